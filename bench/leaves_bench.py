"""Shared leaf outputs (ssr_compile/compile/leaves.py) on and off: the first plan of each
kitchen task (the Focused solver with deferred motions, as the policy's first cycle), runs
interleaved, medians printed with the ratio off/on.  "opt. objects" is the largest optimistic
problem of the solve (as ``-v`` reports it: before the leaves are shared); the planner's task
has one object per shared leaf instead of one per instance.

Run: python bench/leaves_bench.py                # Cook's first plan, one run each way (~30 s)
     python bench/leaves_bench.py --full         # 3 runs each way, every kitchen task
     python bench/leaves_bench.py --runs 3 --tasks cook,stow,swap --seed 1
"""

from __future__ import annotations

import argparse
import statistics
import time


def first_plan(task: str, seed: int, leaves: bool) -> dict:
    from ssr_compile.streams.environments.kitchen import make_episode

    from ssr_compile.solver import SolveOptions, solve

    episode = make_episode(task, seed)
    try:
        agent = episode.agent
        agent.update(None, episode.environment.observe())
        problem, module = agent.problem()
        began = time.perf_counter()
        sol = solve(
            agent.domain, agent.streams, problem, module,
            SolveOptions(planner="fd", time_limit=300, defer=True, leaves=leaves),
        )  # fmt: skip
        took = time.perf_counter() - began
        st = sol.stats
        return {
            "status": sol.status,
            "time": took,
            "planner": st.planner_time,
            "calls": st.planner_calls,
            "objects": max((s[0] for s in st.sizes), default=0),
            "cost": sol.cost,
        }
    finally:
        episode.close()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=None, help="runs each way (default 1)")
    ap.add_argument("--tasks", default=None, help="kitchen tasks, comma-separated (default cook)")
    ap.add_argument("--seed", type=int, default=1, help="episode seed (default 1)")
    ap.add_argument("--full", action="store_true", help="3 runs each way, every kitchen task")
    args = ap.parse_args()
    if args.runs is None:
        args.runs = 3 if args.full else 1
    if args.tasks is None:
        args.tasks = "inspect,stow,swap,cook" if args.full else "cook"
    print(
        f"{'task':8s} {'leaves':6s} {'status':8s} {'median s':>9s} {'planner s':>10s} "
        f"{'calls':>5s} {'opt. objects':>12s} {'cost':>8s}"
    )
    for task in args.tasks.split(","):
        rows: dict[bool, list[dict]] = {True: [], False: []}
        for _ in range(args.runs):
            for leaves in (False, True):
                rows[leaves].append(first_plan(task, args.seed, leaves))
        med = {}
        for leaves in (False, True):
            r = rows[leaves]
            med[leaves] = statistics.median(x["time"] for x in r)
            cost = r[0]["cost"]
            print(
                f"{task:8s} {'on' if leaves else 'off':6s} {r[0]['status']:8s} "
                f"{med[leaves]:9.2f} {statistics.median(x['planner'] for x in r):10.2f} "
                f"{r[0]['calls']:5d} {r[0]['objects']:12d} "
                f"{'-' if cost is None else f'{cost:.2f}':>8s}"
            )
        print(f"{task:8s} ratio off/on {med[False] / med[True]:.2f}")


if __name__ == "__main__":
    main()
