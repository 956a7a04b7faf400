"""Every planner backend on every shipped example problem: the optimistic plan (one compile
at a fixed level, as `ssr-compile plan`), time, plan length, plan cost, compiled and ground
sizes.  Each plan is checked against the optimistic problem by the project's own simulator.

    python bench/backends_bench.py                  # one run per cell (about a minute)
    python bench/backends_bench.py --full           # medians of 3 runs
    python bench/backends_bench.py --planners fd,pyperplan --problems kitchen/stow
    python bench/backends_bench.py --planners 'up:fast-downward[invariants=on]','up:fast-downward[invariants=off]'

A planner may carry backend options in brackets (one each: the list is comma-separated).
"""

from __future__ import annotations

import argparse
import statistics
import time

from planner_overhead import make as get_planner  # NAME or NAME[key=value]

from ssr_compile.compile.pipeline import compile_problem
from ssr_compile.examples import SHIPPED_PROBLEMS, load_example
from ssr_compile.parse import parse_file
from ssr_compile.solver.preimage import PlanInvalid, plan_preimage

PROBLEMS = SHIPPED_PROBLEMS  # (example, problem file, level at which it has a plan)
PLANNERS = ["fd", "pyperplan", "up:fast-downward", "up:pyperplan"]


def plan_once(example: str, problem_file: str, level: int, planner: str, time_limit: float):
    ex = load_example(example)
    problem = parse_file(ex.folder / problem_file)
    backend = get_planner(planner)
    start = time.perf_counter()
    compiled = compile_problem(
        ex.domain, ex.streams, problem, caps=backend.capabilities, level=level
    )
    result = backend.solve(compiled.domain, compiled.problem, time_limit=time_limit)
    elapsed = time.perf_counter() - start
    row = {
        "status": result.status,
        "time": elapsed,
        "length": None,
        "cost": None,
        "objects": len(compiled.source_problem.objects),
        "facts": sum(1 for x in compiled.source_problem.init if hasattr(x, "pred")),
        "ground_actions": len(compiled.domain.actions) if compiled.lowered.grounded else None,
        "valid": None,
        "message": result.message,
    }
    if result.status == "solved":
        plan = compiled.map_plan(result.actions or [])
        row["length"] = len(plan)
        row["cost"] = (result.cost or 0) / compiled.scale
        try:
            plan_preimage(compiled.source_domain, compiled.source_problem, plan)
            row["valid"] = True
        except PlanInvalid as e:
            row["valid"] = False
            row["message"] = str(e)
    return row


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=None, help="runs per cell (default 1)")
    ap.add_argument("--full", action="store_true", help="medians of 3 runs")
    ap.add_argument("--planners", default=",".join(PLANNERS))
    ap.add_argument("--problems", default="", help="comma-separated example/problem filters")
    ap.add_argument("--time-limit", type=float, default=60.0)
    args = ap.parse_args()
    args.runs = args.runs or (3 if args.full else 1)
    wanted = [w for w in args.problems.split(",") if w]
    print(
        f"{'problem':32s} {'planner':34s} {'status':9s} {'time s':>7s} {'len':>4s} "
        f"{'cost':>7s} {'objects':>7s} {'facts':>6s} {'ground':>7s} valid"
    )
    for example, pfile, level in PROBLEMS:
        label = f"{example}/{pfile.removesuffix('.pddl')}"
        if wanted and not any(w in label for w in wanted):
            continue
        for planner in args.planners.split(","):
            rows = [
                plan_once(example, pfile, level, planner, args.time_limit) for _ in range(args.runs)
            ]
            r = rows[-1]
            t = statistics.median(x["time"] for x in rows)
            cost = "-" if r["cost"] is None else f"{r['cost']:.4g}"
            ground = "-" if r["ground_actions"] is None else str(r["ground_actions"])
            print(
                f"{label:32s} {planner:34s} {r['status']:9s} {t:7.2f} {r['length'] or '-':>4} "
                f"{cost:>7s} {r['objects']:7d} {r['facts']:6d} {ground:>7s} {r['valid']}"
                + (f"  ({r['message'][:60]})" if r["status"] != "solved" else "")
            )


if __name__ == "__main__":
    main()
