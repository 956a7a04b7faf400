"""pddlstream's own examples with stream implementations of ours (nobody tuned the solver for
them): per problem and seed, solved or not, solve time, plan cost, planner calls, stream calls
and the largest optimistic problem (objects, ground actions), then the medians per problem.

Problems: continuous_tamp's ``tight(N)`` for N = 1, 2, 3, 4, 6, 8 (two goal blocks into the
5-wide red region) and ``blocked``; discrete_tamp's ``shift_one(N)`` and ``shift_all(N)``
(blocks on a row of 9 cells); discrete_belief's ``noisy`` (run.py's problem), ``observable``,
``deterministic`` and ``det-obs`` (its other settings; nothing is sampled, every seed gives the
same run, so only the first seed is run); advanced/defer's ``defer(1)`` (run.py's) and
``defer(3)``.  The generators and streams are in ``tests/fixtures/pddlstream/``; the domain and
stream files are read in place from the shared corpus (``../shared/corpus`` or ``$SSR_CORPUS``,
then ``pddlstream-examples/examples``), and the script stops with a message when it is absent.
Figures, no assertions; each solve runs in this process, one at a time.

Run: python bench/pddlstream_examples.py [--seeds 0-9 | --full] [--only NAME ...] [--time-limit S]
     [--algorithm NAME] [--option KEY=VALUE ...] [--json OUT]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests" / "fixtures" / "pddlstream"))

import continuous_tamp as ctamp  # noqa: E402
import defer  # noqa: E402
import discrete_belief as dbelief  # noqa: E402
import discrete_tamp as dtamp  # noqa: E402

from ssr_compile.cli.options import seed_list  # noqa: E402
from ssr_compile.parse import parse_domain, parse_problem, parse_stream_file  # noqa: E402
from ssr_compile.solver import SolveOptions, solve  # noqa: E402

# the shared corpus beside the checkout, or $SSR_CORPUS (as the tests find it)
CORPUS = Path(os.environ.get("SSR_CORPUS") or ROOT.parent / "shared/corpus")
CORPUS = CORPUS / "pddlstream-examples/examples"

# example -> (its corpus folder, its problems, make(problem, seed) -> (PDDL text, module),
# check(problem, plan, None) raising AssertionError on a plan that breaks the world's rules;
# problem names are unique across examples)
EXAMPLES = {
    "continuous_tamp": ("continuous_tamp", list(ctamp.PROBLEMS), ctamp.make, ctamp.check_plan),
    "discrete_tamp": ("discrete_tamp", list(dtamp.PROBLEMS), dtamp.make, dtamp.check_plan),
    "discrete_belief": (
        "discrete_belief",
        list(dbelief.PROBLEMS),
        dbelief.make,
        dbelief.check_plan,
    ),
    "defer": ("advanced/defer", list(defer.PROBLEMS), defer.make, defer.check_plan),
}
# examples that sample nothing (every seed gives the same run): only the first seed is run
SEEDLESS = {"discrete_belief"}


def parse_option(text: str) -> tuple[str, object]:
    key, _, raw = text.partition("=")
    for cast in (int, float):
        try:
            return key, cast(raw)
        except ValueError:
            pass
    return key, raw


def run_one(folder: Path, make, check, problem: str, seed: int, time_limit: float, options: dict):
    domain = parse_domain((folder / "domain.pddl").read_text())
    streams = parse_stream_file((folder / "stream.pddl").read_text())
    text, module = make(problem, seed)
    parsed = parse_problem(text)
    start = time.perf_counter()
    sol = solve(domain, streams, parsed, module, SolveOptions(time_limit=time_limit, **options))
    elapsed = time.perf_counter() - start
    calls = sum(st.calls for st in sol.stats.streams.values())
    valid = None
    if sol.solved and check is not None:
        try:
            check(problem, sol.plan, None)
            valid = True
        except AssertionError as e:
            valid = False
            print(f"  {problem} seed {seed}: the plan breaks the example's rules: {e}", flush=True)
    sizes = sol.stats.sizes or []
    largest = max(sizes, key=lambda z: ((z[3] or 0), z[0]), default=(0, 0, 0, None))
    return {
        "problem": problem,
        "seed": seed,
        "solved": sol.solved,
        "valid": valid,
        "status": sol.status,
        "time": round(elapsed, 3),
        "cost": sol.cost,
        "planner_calls": sol.stats.planner_calls,
        "stream_calls": calls,
        "objects": largest[0],
        "ground_actions": largest[3],
        "plan": sol.plan,
    }


def row_text(r: dict) -> str:
    cost = f"{r['cost']:.1f}" if r["cost"] is not None else "-"
    solved = ("yes" if r["valid"] is not False else "INVALID") if r["solved"] else r["status"]
    ga = r["ground_actions"] if r["ground_actions"] is not None else "?"
    return (
        f"{r['problem']:<13} {r['seed']:>4} {solved:>8} "
        f"{r['time']:>7.2f} {cost:>7} {r['planner_calls']:>7} {r['stream_calls']:>7} "
        f"{r['objects']:>7} {ga:>7}"
    )


HEADER = (
    f"{'problem':<13} {'seed':>4} {'solved':>8} {'time s':>7} {'cost':>7} {'planner':>7} "
    f"{'streams':>7} {'objects':>7} {'actions':>7}"
)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", default=None, help="seeds, e.g. 0-9 (default 0-9; --full: 0-24)")
    ap.add_argument("--full", action="store_true", help="the long version: seeds 0-24")
    ap.add_argument("--only", action="append", default=[], help="a problem name, e.g. tight(2)")
    ap.add_argument("--time-limit", type=float, default=60.0)
    ap.add_argument("--algorithm", default=None)
    ap.add_argument("--option", action="append", default=[], help="KEY=VALUE for SolveOptions")
    ap.add_argument("--json", default=None, help="write the rows to this file")
    args = ap.parse_args(argv)
    if not CORPUS.is_dir():
        print(f"skipped: the pddlstream examples corpus is not at {CORPUS}")
        return 0
    options = dict(parse_option(o) for o in args.option)
    if args.algorithm:
        options["algorithm"] = args.algorithm
    seeds = seed_list(args.seeds or ("0-24" if args.full else "0-9"))
    rows = []
    print(HEADER, flush=True)
    for example, (sub, problems, make, check) in EXAMPLES.items():
        folder = CORPUS / sub
        for problem in problems:
            if args.only and problem not in args.only:
                continue
            mine = []
            for seed in seeds[:1] if example in SEEDLESS else seeds:
                r = run_one(folder, make, check, problem, seed, args.time_limit, options)
                print(row_text(r), flush=True)
                mine.append(r)
            rows += mine
            solved = sum(r["solved"] and r["valid"] is not False for r in mine)
            invalid = sum(r["valid"] is False for r in mine)
            worst = max(r["time"] for r in mine)

            def med(key: str, mine=mine) -> float:
                return statistics.median(r[key] for r in mine)

            print(
                f"{problem:<13} median: solved {solved}/{len(mine)}"
                + (f" ({invalid} invalid)" if invalid else "")
                + f", time {med('time'):.2f} s "
                f"(worst {worst:.2f}), planner calls {med('planner_calls'):g}, stream calls "
                f"{med('stream_calls'):g}, objects {med('objects'):g}",
                flush=True,
            )
    if args.json:
        for r in rows:
            r.pop("plan", None)
        Path(args.json).write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
