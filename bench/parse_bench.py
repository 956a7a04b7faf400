"""Parse throughput: ssr-compile's parser against the Lark-based `pddl` package.

Usage: python bench/parse_bench.py [DIR] [--runs N] [--full]

Parses every .pddl file under DIR (default: the repository's own files; with ``--full``, the
pddlstream example corpus at ``$SSR_CORPUS`` or ``shared/corpus`` beside the repository) and
prints files/s and MB/s, the median of N runs (default 5).  Both parsers are
built once before timing and read texts already in memory, so only parsing is timed.

The `pddl` package (AI-Planning/pddl) reads plain domain and problem files only; it is timed
in the same run over the files it accepts, and ssr-compile is timed over that same subset for
the ratio.  Its ``parse_domain(path)`` builds a new Lark parser on every call, so its
``DomainParser``/``ProblemParser`` objects are built once and reused instead, as ours is.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path

from ssr_compile.errors import SSRError
from ssr_compile.parse import parse_text, parser

ROOT = Path(__file__).resolve().parent.parent
DEFAULT = ROOT  # the repository's own .pddl files


def corpus() -> Path:
    """The pddlstream example corpus (``--full``): $SSR_CORPUS, or shared/corpus beside the
    repository."""
    import os

    base = os.environ.get("SSR_CORPUS") or ROOT.parent / "shared" / "corpus"
    return Path(base) / "pddlstream-examples"


def median_time(fn: Callable[[], object], runs: int) -> float:
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def pddl_parsers() -> dict[str, Callable[[str], object]] | None:
    """The `pddl` package's domain and problem parsers, built once (None if not installed)."""
    try:
        from pddl.parser.domain import DomainParser
        from pddl.parser.problem import ProblemParser
    except ImportError:
        return None
    return {"domain": DomainParser(), "problem": ProblemParser()}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("dir", nargs="?", type=Path, default=None)
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--full", action="store_true", help="the pddlstream example corpus")
    args = ap.parse_args(argv)
    if args.dir is None:
        args.dir = corpus() if args.full else DEFAULT
    files = sorted(args.dir.rglob("*.pddl")) if args.dir.is_dir() else []
    if not files:
        print(f"no .pddl files under {args.dir}", file=sys.stderr)
        return 2
    texts = {p: p.read_text(encoding="utf-8", errors="replace") for p in files}

    parser()  # build (or load) the parse tables before timing
    ours: dict[Path, str] = {}  # path -> kind, for the files we parse
    for p, t in texts.items():
        try:
            ours[p] = parse_text(t, str(p)).kind
        except SSRError as e:
            print(f"ssr-compile refuses {p}: {e.location}: {e.message}", file=sys.stderr)

    theirs = pddl_parsers()
    subset: dict[Path, Callable[[str], object]] = {}
    if theirs is not None:
        for p, kind in ours.items():
            if kind in theirs:
                try:
                    theirs[kind](texts[p])
                except Exception:  # any failure means the file is outside its dialect
                    continue
                subset[p] = theirs[kind]

    def run_ours(paths):
        return lambda: [parse_text(texts[p], str(p)) for p in paths]

    def run_theirs():
        return [fn(texts[p]) for p, fn in subset.items()]

    def mb(paths) -> float:
        return sum(len(texts[p].encode("utf-8")) for p in paths) / 1e6

    rows = []
    t_all = median_time(run_ours(list(ours)), args.runs)
    rows.append(("ssr-compile, all files", len(ours), mb(ours), t_all))
    if subset:
        t_ours = median_time(run_ours(list(subset)), args.runs)
        t_theirs = median_time(run_theirs, args.runs)
        rows.append(("ssr-compile, pddl's subset", len(subset), mb(subset), t_ours))
        import pddl

        rows.append(
            (f"pddl {pddl.__version__}, prebuilt parsers", len(subset), mb(subset), t_theirs)
        )
        # As users call it: pddl.parse_domain / parse_problem build a new parser per file.
        from pddl import parse_domain, parse_problem

        as_called = {p: parse_domain if ours[p] == "domain" else parse_problem for p in subset}
        t_called = median_time(lambda: [fn(str(p)) for p, fn in as_called.items()], args.runs)
        rows.append((f"pddl {pddl.__version__}, parse_domain()", len(subset), mb(subset), t_called))

    print(f"{len(files)} .pddl files under {args.dir}; median of {args.runs} runs")
    print(f"{'parser':<30} {'files':>5} {'MB':>7} {'seconds':>8} {'files/s':>8} {'MB/s':>6}")
    for name, n, size, t in rows:
        print(f"{name:<30} {n:>5} {size:>7.3f} {t:>8.4f} {n / t:>8.1f} {size / t:>6.2f}")
    if subset:
        print(
            f"ssr-compile / pddl speed on the same {len(subset)} files: {t_theirs / t_ours:.2f}x "
            f"against its prebuilt parsers, {t_called / t_ours:.2f}x against parse_domain/parse_problem"
        )
    elif theirs is None:
        print("(the pddl package is not installed: no baseline)")
    else:
        print("(the pddl package parsed none of these files: no baseline)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
