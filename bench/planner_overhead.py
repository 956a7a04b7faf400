"""Per-call time of each planner backend on three small problems (median of N calls).

Prints one row per backend and problem, with the ratio of each backend's median to ``fd``'s
in the same run, and the CPU time per call (this process and its children: forked workers,
planner binaries), which varies less than wall-clock time on a busy machine.  The CPU time of
``fd``'s persistent translator worker is not in that column (a child's CPU time is counted
only once it has been reaped), so read ``fd``'s CPU as the search binary's and this process's.  Usage: ``python bench/planner_overhead.py [--calls 10] [--full] [SPEC ...]`` (``--full``: 30 calls).
A SPEC may give the backend's options in brackets, e.g. ``'fd[prestart=0]'`` (``fd`` without its
search binary started during translation); the calls of a problem are interleaved across the
specs, so that the machine's load falls on all of them alike.
"""

from __future__ import annotations

import argparse
import resource
import statistics
import time
from pathlib import Path

from ssr_compile.parse import parse_text
from ssr_compile.planners import get_planner

FIXTURES = Path(__file__).resolve().parent.parent / "tests" / "fixtures" / "planners"
PROBLEMS = [("blocks", "blocks"), ("travel", "travel"), ("clash", "clash")]
DEFAULT_SPECS = ["fd", "fd:opt", "pyperplan", "up:fast-downward", "up:pyperplan"]


def load(domain: str, problem: str):
    d = FIXTURES / f"{domain}-domain.pddl"
    p = FIXTURES / f"{problem}-problem.pddl"
    return parse_text(d.read_text(), d.name), parse_text(p.read_text(), p.name)


def _cpu() -> float:
    total = 0.0
    for who in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN):
        r = resource.getrusage(who)
        total += r.ru_utime + r.ru_stime
    return total


def make(spec: str):
    """``get_planner`` for ``NAME`` or ``NAME[key=value,...]`` (values read as int if they can)."""
    name, _, rest = spec.partition("[")
    options = {}
    for item in filter(None, rest.rstrip("]").split(",")):
        key, _, value = item.partition("=")
        options[key.strip()] = int(value) if value.strip().lstrip("-").isdigit() else value.strip()
    return get_planner(name, **options)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("specs", nargs="*", default=DEFAULT_SPECS)
    ap.add_argument("--calls", type=int, default=None, help="calls per cell (default 10)")
    ap.add_argument("--full", action="store_true", help="30 calls per cell")
    args = ap.parse_args()
    args.calls = args.calls or (30 if args.full else 10)
    specs = ["fd", *(s for s in args.specs if s != "fd")]
    planners = {s: make(s) for s in specs}
    rows = []
    for domain, problem in PROBLEMS:
        task = load(domain, problem)
        first = {s: pl.solve(*task, time_limit=60) for s, pl in planners.items()}  # warm-up
        times: dict[str, list[float]] = {s: [] for s in planners}
        cpu = dict.fromkeys(planners, 0.0)
        for _ in range(args.calls):
            for spec, planner in planners.items():
                before, start = _cpu(), time.perf_counter()
                planner.solve(*task, time_limit=60)
                times[spec].append(time.perf_counter() - start)
                cpu[spec] += _cpu() - before
        base = statistics.median(times["fd"])
        for spec in planners:
            med = statistics.median(times[spec])
            rows.append(
                (
                    problem,
                    spec,
                    first[spec].status,
                    med,
                    min(times[spec]),
                    cpu[spec] / args.calls,
                    med / base,
                )
            )
    head = (
        f"{'problem':<8} {'planner':<22} {'status':<11} {'median ms':>9} {'min ms':>7}"
        f" {'cpu ms':>7} {'x fd':>6}"
    )
    print(f"{args.calls} calls per cell")
    print(head)
    print("-" * len(head))
    for p, s, st, med, lo, cpu, ratio in rows:
        print(
            f"{p:<8} {s:<22} {st:<11} {med * 1e3:9.1f} {lo * 1e3:7.1f} {cpu * 1e3:7.1f}"
            f" {ratio:6.1f}"
        )


if __name__ == "__main__":
    main()
