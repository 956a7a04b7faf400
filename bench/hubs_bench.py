"""Hubs (ssr_compile/compile/hubs.py) on and off on the largest optimistic problem of a kitchen
episode: the planner's ground actions, translation and search time, and the plan's cost.

The episode (a kitchen task or a task file, one seed) runs with the policy of ``ssr-compile
run`` and the hubs pass off for ``--time-limit`` seconds of planning; the task every planner
call was given before lowering is kept when it has more base motions than any before.  That
task is then lowered for Fast Downward twice -- as it is, and through the hubs pass -- and
solved ``--runs`` times each way, interleaved; medians are printed with the ratio off/on.
Counts (pair facts, ground actions, plan cost) do not depend on the machine.

Run: python bench/hubs_bench.py                            # cook, seed 0, 120 s, 3 runs each
     python bench/hubs_bench.py --full                     # 300 s of the episode, 5 runs each
     python bench/hubs_bench.py --task FILE.toml --seed 5 --time-limit 200
     ssr-compile tasks generate --kind cook --objects 8 --hiders 6 -o /tmp/k6.toml
     python bench/hubs_bench.py --task /tmp/k6.toml --seed 1 --time-limit 150
"""

from __future__ import annotations

import argparse
import statistics
import time


def capture(task: str, seed: int, time_limit: float) -> tuple | None:
    """The largest pre-lowering task of an episode with hubs off: ``(domain, problem, caps,
    lowering options, pair facts)``, or None when no planner call was made."""
    from ssr_compile.streams.environments.kitchen import make_episode

    from ssr_compile.compile import hubs, pipeline
    from ssr_compile.policy import PolicySettings, run_policy

    best: list = [None]
    lower = pipeline.lower

    def recording(domain, problem, caps, **kwargs):
        keys = hubs.candidates(domain, problem)
        preds = {k.pred for k, _, _ in keys.values()}
        pairs = sum(1 for f in problem.init if getattr(f, "pred", None) in preds)
        if best[0] is None or pairs > best[0][4]:
            best[0] = (domain, problem, caps, kwargs, pairs)
        return lower(domain, problem, caps, **kwargs)

    pipeline.ROUTE_HUBS = False
    pipeline.lower = recording
    episode = make_episode(task, seed)
    try:
        settings = PolicySettings(variant="both", budget=time_limit)
        result = run_policy(episode, settings)
        print(
            f"episode: {result.reason}, {len(result.cycles)} cycles, "
            f"{result.planning_time:.1f} s of planning"
        )
    finally:
        episode.close()
        pipeline.lower = lower
        pipeline.ROUTE_HUBS = True
    return best[0]


def solve_once(captured: tuple, with_hubs: bool) -> dict:
    from ssr_compile.compile import hubs
    from ssr_compile.compile.lower import lower
    from ssr_compile.planners.fd import make_planner

    domain, problem, caps, kwargs, _ = captured
    began = time.perf_counter()
    split = None
    if with_hubs:
        saved = hubs.MIN_PAIRS
        hubs.MIN_PAIRS = 1
        try:
            split = hubs.route_through_hubs(domain, problem)
        finally:
            hubs.MIN_PAIRS = saved
        domain, problem = split.domain, split.problem
    lowered = lower(domain, problem, caps, **kwargs)
    compile_s = time.perf_counter() - began
    fd = make_planner()
    result = fd.solve(lowered.domain, lowered.problem, time_limit=300)
    cost = None
    if result.actions:
        plan = split.map_plan(result.actions) if split is not None else result.actions
        cost = len(plan)
    return {
        "status": result.status,
        "operators": fd.last_operators,
        "compile": compile_s,
        "translate": result.translate_time,
        "search": result.search_time,
        "total": result.time,
        "steps": cost,
        "hubs": split.hubs if split is not None else 0,
    }


def episode_arguments(description: str, default_time: float, extra=None) -> argparse.Namespace:
    """The arguments of a bench that captures one episode's task and solves it both ways:
    --task, --seed, --time-limit (``default_time``, 300 s with --full), --runs (3, 5 with
    --full); ``extra(ap)`` adds a script's own."""
    ap = argparse.ArgumentParser(description=description)
    ap.add_argument("--task", default="cook", help="kitchen task or task file (default cook)")
    ap.add_argument("--seed", type=int, default=0, help="episode seed (default 0)")
    ap.add_argument(
        "--time-limit", type=float, default=None,
        help=f"planning time of the episode ({default_time:g} s)",
    )  # fmt: skip
    ap.add_argument("--runs", type=int, default=None, help="planner runs each way (default 3)")
    ap.add_argument("--full", action="store_true", help="300 s of the episode and 5 runs each way")
    if extra is not None:
        extra(ap)
    args = ap.parse_args()
    if args.time_limit is None:
        args.time_limit = 300.0 if args.full else default_time
    if args.runs is None:
        args.runs = 5 if args.full else 3
    return args


def main() -> None:
    args = episode_arguments(__doc__.split("\n\n")[0], 120.0)
    captured = capture(args.task, args.seed, args.time_limit)
    if captured is None:
        print("no planner call was made")
        return
    print(f"largest task: {captured[4]} pair facts, {len(captured[1].objects)} objects")
    runs: dict[bool, list[dict]] = {False: [], True: []}
    for i in range(args.runs):
        for on in (False, True):
            r = solve_once(captured, on)
            runs[on].append(r)
            print(
                f"  run {i + 1} hubs {'on ' if on else 'off'}: {r['status']}, "
                f"{r['operators']} ground actions, {r['steps']} steps, translate "
                f"{r['translate']:.2f} s, search {r['search']:.2f} s, planner {r['total']:.2f} s"
            )
    print(f"{'hubs':5s} {'status':9s} {'ground actions':>15s} {'steps':>6s} "
          f"{'compile s':>10s} {'translate s':>12s} {'search s':>9s} {'planner s':>10s}")  # fmt: skip
    med = {}
    for on in (False, True):
        rs = runs[on]
        med[on] = {k: statistics.median(r[k] for r in rs) for k in ("compile", "translate", "search", "total")}  # fmt: skip
        print(
            f"{'on' if on else 'off':5s} {rs[0]['status']:9s} {rs[0]['operators'] or 0:>15d} "
            f"{rs[0]['steps'] or 0:>6d} {med[on]['compile']:>10.2f} {med[on]['translate']:>12.2f} "
            f"{med[on]['search']:>9.2f} {med[on]['total']:>10.2f}"
        )
    if med[True]["total"] > 0:
        print(f"planner time off/on: {med[False]['total'] / med[True]['total']:.2f}")


if __name__ == "__main__":
    main()
