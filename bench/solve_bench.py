"""Focused solver: median solve time over N runs, planner calls, stream calls and plan cost,
with and without deferred evaluation (paper §VII), for every example folder in
``domains/pddl/`` and the compiler test fixture ``tests/fixtures/compile/pp1d`` (figures, no
assertions).  By default one run of each small example (under a minute); ``--full``: 5 runs,
and the kitchen's tasks too.  ``size`` is the largest compiled problem of a run (objects/facts of
the optimistic problem), when the solver reports it.

Also pddlstream's continuous_tamp (its domain and stream files, read in place from the shared
corpus when present, with the streams of ``tests/fixtures/ctamp``).  ``--option KEY=VALUE``
passes a keyword to the solver (``share=1``, ``eager_tests=0``, ``eager_cost=-1``...).
``--algorithm focused adaptive`` runs each cell with each algorithm, interleaved run by run
(one row per algorithm, the same runs' conditions: before/after in one table).

Run: python bench/solve_bench.py [--full] [--runs N] [--time-limit S] [--only NAME[:PROBLEM]] [--no-defer] [--option KEY=VALUE] [--algorithm NAME...]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

try:
    import tomllib
except ModuleNotFoundError:  # pragma: no cover - Python 3.10
    import tomli as tomllib  # type: ignore[no-redef]

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from ssr_compile.focused import solve  # noqa: E402
from ssr_compile.parse import parse_domain, parse_problem, parse_stream_file  # noqa: E402
from ssr_compile.stream import module_for_problem  # noqa: E402

FIXTURES = {
    "pp1d (fixture)": (
        ROOT / "tests/fixtures/compile/pp1d",
        {
            "streams": str(ROOT / "tests/fixtures/compile/pp1d/streams.py"),
            "problems": ["problem.pddl", "problem-blocked.pddl"],
            "level": 3,
        },
    ),
}
# pddlstream's continuous_tamp (domain and stream files from the shared corpus) with the
# streams of tests/fixtures/ctamp; only when the corpus is there.
CORPUS_CTAMP = ROOT.parent / "shared/corpus/pddlstream-examples/examples/continuous_tamp"
if CORPUS_CTAMP.is_dir():
    FIXTURES["continuous_tamp"] = (
        ROOT / "tests/fixtures/ctamp",
        {
            "streams": str(ROOT / "tests/fixtures/ctamp/streams.py"),
            "problems": ["problem.pddl"],
            "domain_file": str(CORPUS_CTAMP / "domain.pddl"),
            "stream_file": str(CORPUS_CTAMP / "stream.pddl"),
        },
    )


LONG = {"kitchen"}  # examples only --full (or --only) runs


def examples():
    for folder in sorted((ROOT / "domains/pddl").iterdir()):
        config_file = folder / "example.toml"
        if config_file.exists():
            yield folder.name, (folder, tomllib.loads(config_file.read_text()))
    yield from FIXTURES.items()


def run_once(
    folder: Path, config: dict, problem: str, defer: bool, time_limit: float, options: dict
):
    d = parse_domain(Path(config.get("domain_file", folder / "domain.pddl")).read_text())
    s = parse_stream_file(Path(config.get("stream_file", folder / "stream.pddl")).read_text())
    p = parse_problem((folder / problem).read_text())
    module = module_for_problem(config["streams"], folder / problem, 0, search=[ROOT])
    start = time.perf_counter()
    sol = solve(
        d,
        s,
        p,
        module,
        planner=config.get("planner", "fd"),
        time_limit=time_limit,
        defer=defer,
        initial_level=int(config.get("level", 1)),
        max_level=int(config.get("max_level", 8)),
        **options,
    )
    elapsed = time.perf_counter() - start
    calls = sum(st.calls for st in sol.stats.streams.values())
    sizes = getattr(sol.stats, "sizes", None) or []
    size = max(sizes, key=lambda z: (z[1], z[0]), default=None)
    cost = sol.cost if sol.cost is not None else float("nan")
    return sol.status, elapsed, sol.stats.planner_calls, calls, cost, size


def selected(name: str, problem: str, only: list[str]) -> bool:
    if not only:
        return True
    for o in only:
        ex, _, pr = o.partition(":")
        if ex == name and (not pr or pr == problem or pr + ".pddl" == problem):
            return True
    return False


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=None, help="runs per cell (default 1)")
    ap.add_argument(
        "--full", action="store_true", help="5 runs per cell, and the kitchen's tasks too"
    )
    ap.add_argument("--time-limit", type=float, default=60.0)
    ap.add_argument(
        "--only",
        action="append",
        default=[],
        metavar="NAME[:PROBLEM]",
        help="only this example (and problem); repeatable, e.g. --only tamp2d:problem-blocked",
    )
    ap.add_argument("--no-defer", action="store_true", help="only the runs without deferral")
    ap.add_argument(
        "--algorithm",
        nargs="+",
        default=["focused"],
        metavar="NAME",
        help="the solver's algorithm(s): focused, adaptive; several: interleaved runs, a row each",
    )
    ap.add_argument(
        "--option",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="a keyword of the solver, e.g. --option share=1 --option eager_tests=0",
    )
    args = ap.parse_args()
    options = {}
    for o in args.option:
        key, _, value = o.partition("=")
        options[key] = float(value) if "." in value else int(value) if value.isdigit() else value
    options = {k: bool(v) if k in ("share", "eager_tests", "leaves") else v for k, v in options.items()}
    args.runs = args.runs or (5 if args.full else 1)
    head = (
        f"{'example':16s} {'problem':22s} {'defer':5s} {'algorithm':9s} {'status':8s} {'median s':>9s} "
        f"{'planner':>7s} {'streams':>7s} {'cost':>8s} {'size obj/facts':>14s}"
    )
    print(head)
    print("-" * len(head))
    for name, (folder, config) in examples():
        if name in LONG and not args.full and not any(o.startswith(name) for o in args.only):
            continue
        problems = config.get("problems") or sorted(x.name for x in folder.glob("problem*.pddl"))
        for problem in problems:
            if not selected(name, problem, args.only):
                continue
            for defer in (False,) if args.no_defer else (False, True):
                rows: dict[str, list] = {a: [] for a in args.algorithm}
                try:
                    for _ in range(args.runs):
                        for algorithm in args.algorithm:
                            rows[algorithm].append(
                                run_once(
                                    folder,
                                    config,
                                    problem,
                                    defer,
                                    args.time_limit,
                                    {**options, "algorithm": algorithm},
                                )
                            )
                except Exception as e:  # noqa: BLE001 - a broken example is a row, not a crash
                    print(f"{name:16s} {problem:22s} {str(defer):5s} error: {e}")
                    continue
                for algorithm, runs in rows.items():
                    print_row(name, problem, defer, algorithm, runs)


def print_row(name, problem, defer, algorithm, rows) -> None:
    statuses = {r[0] for r in rows}
    sizes = [r[5] for r in rows if r[5] is not None]
    size = (
        f"{statistics.median(z[0] for z in sizes):.0f}/"
        f"{statistics.median(z[1] for z in sizes):.0f}"
        if sizes
        else "-"
    )
    print(
        f"{name:16s} {problem:22s} {str(defer):5s} {algorithm:9s} {'/'.join(sorted(statuses)):8s} "
        f"{statistics.median(r[1] for r in rows):9.3f} "
        f"{statistics.median(r[2] for r in rows):7.0f} "
        f"{statistics.median(r[3] for r in rows):7.0f} "
        f"{statistics.median(r[4] for r in rows):8.2f} {size:>14s}",
        flush=True,
    )

if __name__ == "__main__":
    main()
