"""Focused solver scaling: generated tamp2d problems with 1..8 blocks to move into one goal
region, printing solve time, stream calls, planner calls, plan length and cost, and the
largest compiled problem per size (issue 13: the growth must stay polynomial for problems whose
plans grow linearly).  Figures, no assertions.

The problems use ``domains/pddl/tamp2d`` (domain and streams, ``ssr_compile.streams.tamp2d``)
with generated values: N blocks of width 0.5 in a row on the table, a goal region of 0.8 per
block (placements there may collide: test-cfree fails and the solver samples again), and with
``--blockers`` one more block standing in the middle of the goal region, to move aside.

Run: python bench/scaling_bench.py               # sizes 1..8, one run each (about a minute)
     python bench/scaling_bench.py --full        # 3 runs per size (medians), longer limits
     python bench/scaling_bench.py --sizes 1 2 3 --runs 3 --planner fd:opt
     python bench/scaling_bench.py --redraws 4 --accept-drawn   # see the solver's keywords
     python bench/scaling_bench.py --resample 0                 # without drawing again at once
     python bench/scaling_bench.py --algorithm focused adaptive # both, interleaved, a row each
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from dataclasses import replace
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from ssr_compile.errors import SSRError  # noqa: E402
from ssr_compile.parse import parse_domain, parse_problem, parse_stream_file  # noqa: E402
from ssr_compile.solver import RESAMPLE, SolveOptions, solve  # noqa: E402

FOLDER = ROOT / "domains/pddl/tamp2d"
WIDTH, HEIGHT = 0.5, 0.8


def generate(n: int, blockers: bool = False, room: float = 0.8):
    """Problem text and VALUES for ``n`` blocks (plus a blocker in the goal region), with a goal
    region ``room`` long per block."""
    import ssr_compile.streams.tamp2d as T

    goal_lo = 3.0
    goal_hi = goal_lo + room * n + (room if blockers else 0.0)
    values = {
        "q0": T.Conf(-5.0, 3.0),
        "rtable": T.Region(-5.5, 2.5),
        "rgoal": T.Region(goal_lo, round(goal_hi, 3)),
    }
    objects = ["q0", "rtable", "rgoal"]
    init = ["(Region rtable)", "(Region rgoal)", "(Conf q0)", "(AtConf q0)", "(HandEmpty)"]
    goal = []
    blocks = [(f"b{i}", -5.0 + 0.9 * i) for i in range(n)]
    if blockers:
        blocks.append(("c0", round((goal_lo + goal_hi) / 2, 3)))
    for i, (b, x) in enumerate(blocks):
        p = f"p{i}"
        region = "rgoal" if b.startswith("c") else "rtable"
        values[b] = T.Block(b, WIDTH, HEIGHT)
        values[p] = T.Pose(round(x, 3))
        objects += [b, p]
        init += [
            f"(Block {b})",
            f"(Pose {b} {p})",
            f"(AtPose {b} {p})",
            f"(Contained {b} {p} {region})",
        ]
        if b.startswith("b"):
            goal.append(f"(In {b} rgoal)")
    text = (
        f"(define (problem tamp2d-scaling-{n})\n  (:domain tamp2d)\n"
        f"  (:objects {' '.join(objects)})\n"
        f"  (:init {' '.join(init)} (= (total-cost) 0))\n"
        f"  (:goal (and {' '.join(goal)}))\n  (:metric minimize (total-cost)))\n"
    )
    return text, values


def run_once(n: int, args, algorithm: str = "focused") -> tuple:
    text, values = generate(n, args.blockers, args.room)
    d = parse_domain((FOLDER / "domain.pddl").read_text())
    s = parse_stream_file((FOLDER / "stream.pddl").read_text())
    p = parse_problem(text)
    from ssr_compile.streams import tamp2d

    module = replace(tamp2d.make_module(args.seed), values=values)
    start = time.perf_counter()
    sol = solve(
        d,
        s,
        p,
        module,
        SolveOptions(
            planner=args.planner,
            time_limit=args.time_limit,
            initial_level=args.level,
            max_level=args.max_level,
            redraws=args.redraws,
            resample=args.resample,
            accept_drawn=args.accept_drawn or None,
            algorithm=algorithm,
        ),
    )
    elapsed = time.perf_counter() - start
    calls = sum(st.calls for st in sol.stats.streams.values())
    sizes = getattr(sol.stats, "sizes", None) or [(0, 0)]
    big = max(sizes, key=lambda z: (z[1], z[0]))
    length = len(sol.plan) if sol.plan else 0
    cost = sol.cost if sol.cost is not None else float("nan")
    return sol.status, elapsed, calls, sol.stats.planner_calls, length, cost, big[0], big[1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=None, help="numbers of blocks")
    ap.add_argument("--runs", type=int, default=None, help="runs per size (medians)")
    ap.add_argument("--time-limit", type=float, default=None, help="per solve, seconds")
    ap.add_argument("--full", action="store_true", help="3 runs per size, 120 s limits")
    ap.add_argument("--blockers", action="store_true", help="a block to move out of the goal")
    ap.add_argument(
        "--room",
        type=float,
        default=0.8,
        help="length of the goal region per block (blocks are 0.5 wide; default 0.8: the "
        "placements must pack to 62%% of the region, which random placements rarely do)",
    )
    ap.add_argument("--planner", default="fd")
    ap.add_argument("--level", type=int, default=3)
    ap.add_argument("--max-level", type=int, default=8)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument(
        "--redraws",
        type=int,
        default=0,
        help="rejected draws a generator may redraw per level (the solver's redraws keyword)",
    )
    ap.add_argument(
        "--resample",
        type=int,
        default=RESAMPLE,
        help="draws again at once of a generator whose draw failed or was rejected, per stream "
        f"plan (the solver's resample keyword; default {RESAMPLE}, 0: off)",
    )
    ap.add_argument(
        "--accept-drawn",
        action="store_true",
        help="a plan whose stream plan all succeeds is the solution, also with a suboptimal "
        "planner (the solver's accept_drawn keyword)",
    )
    ap.add_argument(
        "--algorithm",
        nargs="+",
        default=["focused"],
        metavar="NAME",
        help="the solver's algorithm(s): focused, adaptive; several: interleaved runs, a row each",
    )
    args = ap.parse_args()
    args.sizes = args.sizes or list(range(1, 9))
    args.runs = args.runs or (3 if args.full else 1)
    args.time_limit = args.time_limit or (120.0 if args.full else 15.0)
    head = (
        f"{'blocks':>6s} {'algorithm':9s} {'status':8s} {'time s':>8s} {'streams':>8s} {'planner':>8s} "
        f"{'length':>6s} {'cost':>8s} {'objects':>8s} {'facts':>7s}"
    )
    print(
        f"planner {args.planner}, {args.runs} run(s) per size, medians"
        + (", with a blocker" if args.blockers else "")
        + (f", redraws {args.redraws}" if args.redraws else "")
        + f", resample {args.resample}"
        + (", accept_drawn" if args.accept_drawn else "")
    )
    print(head)
    print("-" * len(head))
    for n in args.sizes:
        runs: dict[str, list] = {a: [] for a in args.algorithm}
        failed: dict[str, str] = {}
        for _ in range(args.runs):
            for algorithm in args.algorithm:
                if algorithm in failed:
                    continue
                try:
                    runs[algorithm].append(run_once(n, args, algorithm))
                except SSRError as e:  # a size past a limit (the instance cap) is a row
                    failed[algorithm] = str(e)
        for algorithm, rows in runs.items():
            if algorithm in failed:
                print(f"{n:6d} {algorithm:9s} error: {failed[algorithm]}", flush=True)
            else:
                print_row(n, algorithm, rows)


def print_row(n: int, algorithm: str, rows: list) -> None:
    med = [statistics.median(r[i] for r in rows) for i in range(1, 8)]
    status = "/".join(sorted({r[0] for r in rows}))
    print(
        f"{n:6d} {algorithm:9s} {status:8s} {med[0]:8.2f} {med[1]:8.0f} {med[2]:8.0f} "
        f"{med[3]:6.0f} {med[4]:8.2f} {med[5]:8.0f} {med[6]:7.0f}",
        flush=True,
    )


if __name__ == "__main__":
    main()
