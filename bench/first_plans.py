"""The first plan of kitchen episodes: its cost, planner calls, stream calls and solve time,
per task and seed, planned as the policy's first cycle plans it (its unconstrained attempt:
the policy's solver options, deferred motions, levels up to 12): the same world and belief
at every commit, so the costs compare across commits.

Run: python bench/first_plans.py                          # Table I's four tasks, seeds 0-4
     python bench/first_plans.py --tasks cook --seeds 5-9
     python bench/first_plans.py --set cheaper_rises=0    # a SolveOptions field changed
     python bench/first_plans.py --jsonl F                # also one JSON line per plan
     python bench/first_plans.py --full                   # the four tasks, seeds 0-24

Runs from a checkout of an older commit too (``PYTHONPATH=CHECKOUT python bench/...``): it
uses only the options every commit since the kitchen's deferral has.
"""

from __future__ import annotations

import argparse
import ast
import json
import sys
import time


def first_plan(task: str, seed: int, limit: float, changes: dict) -> dict:
    try:
        from ssr_compile.streams.environments.kitchen import make_episode

        from ssr_compile.policy_settings import PolicySettings
        from ssr_compile.solver import solve

        settings = PolicySettings()

        def SolveOptions(**kw):  # noqa: N802 (the policy's options, changed)
            return settings.solve_options(**kw)

    except ImportError:  # a commit before the solver package (3881689 and older)
        from ssr_compile.focused import solve as solve_kw
        from ssr_compile.streams.kitchen_env import make_episode

        def SolveOptions(**kw):  # noqa: N802 (the old solve took keywords)
            return kw

        def solve(domain, streams, problem, module, options):
            return solve_kw(domain, streams, problem, module, **options)

    episode = make_episode(task, seed)
    try:
        agent = episode.agent
        agent.update(None, episode.environment.observe())
        problem, module = agent.problem()
        options = SolveOptions(planner="fd", time_limit=limit, defer=True, max_level=12, **changes)
        began = time.perf_counter()
        sol = solve(agent.domain, agent.streams, problem, module, options)
        took = time.perf_counter() - began
        st = sol.stats
        return {
            "task": task,
            "seed": seed,
            "status": sol.status,
            "cost": sol.cost,
            "steps": len(sol.plan or []),
            "planner_calls": st.planner_calls,
            "stream_calls": sum(s.calls for s in st.streams.values()),
            "time": round(took, 3),
        }
    finally:
        episode.close()


def seeds_of(text: str) -> list[int]:
    out: list[int] = []
    for part in text.split(","):
        lo, _, hi = part.partition("-")
        out.extend(range(int(lo), int(hi or lo) + 1))
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--tasks", default="inspect,stow,swap,cook", help="kitchen tasks or files")
    ap.add_argument("--seeds", default=None, help="seeds: 0-4, or 1,3,8 (default 0-4)")
    ap.add_argument("--full", action="store_true", help="the long version: seeds 0-24")
    ap.add_argument("--time-limit", type=float, default=300.0, help="per solve (default 300)")
    ap.add_argument(
        "--set", action="append", default=[], metavar="FIELD=VALUE",
        help="a SolveOptions field (a Python literal), e.g. cheaper_rises=0",
    )  # fmt: skip
    ap.add_argument("--jsonl", default=None, help="also write one JSON line per plan here")
    args = ap.parse_args()
    if args.seeds is None:
        args.seeds = "0-24" if args.full else "0-4"
    changes = {}
    for item in args.set:
        name, sep, value = item.partition("=")
        if not sep:
            ap.error(f"--set takes FIELD=VALUE, got {item!r}")
        try:
            changes[name] = ast.literal_eval(value)
        except (ValueError, SyntaxError):
            ap.error(f"--set {name}: {value!r} is not a Python literal")
    out = open(args.jsonl, "w") if args.jsonl else None
    print(f"{'task':8s} {'seed':>4s} {'status':8s} {'cost':>8s} {'steps':>5s} "
          f"{'planner':>7s} {'streams':>7s} {'s':>7s}")  # fmt: skip
    total = {"cost": 0.0, "planner_calls": 0, "stream_calls": 0, "time": 0.0}
    for task in args.tasks.split(","):
        for seed in seeds_of(args.seeds):
            row = first_plan(task, seed, args.time_limit, changes)
            cost = "-" if row["cost"] is None else f"{row['cost']:.2f}"
            print(
                f"{task:8s} {seed:4d} {row['status']:8s} {cost:>8s} {row['steps']:5d} "
                f"{row['planner_calls']:7d} {row['stream_calls']:7d} {row['time']:7.2f}",
                flush=True,
            )
            for k in total:
                total[k] += row[k] or 0
            if out:
                out.write(json.dumps(row) + "\n")
                out.flush()
    print(
        f"total: cost {total['cost']:.2f}, planner calls {total['planner_calls']}, "
        f"stream calls {total['stream_calls']}, solve {total['time']:.1f} s"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
