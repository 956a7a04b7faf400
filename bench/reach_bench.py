"""inv-reach into the kitchen's drawers, with and without the hand check (figures, no assertions).

The block's top grasps at placements drawn over each open drawer (seeded), one batch of
``inv-reach`` each (the first base it finds, or none after its IK attempts), in the world of
Swap seed 0 with the movable objects out (the planning state).  Prints, per side, the pairs
tried, those reached, those the hand check refused without an IK call, the IK calls and the
seconds; the two sides run one after the other in one process, on the same pairs, each from
its own seeded generator, with the robot's IK attempts and the world's collision answers
forgotten before each.

Run: python bench/reach_bench.py [--full] [--placements N] [--seed S]   (--full: 50 placements)
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from ssr_compile.sim.samplers import KitchenStreams, ObjPose
from ssr_compile.sim.tasks import make_task
from ssr_compile.sim.world import DRAWER_TRAVEL, DRAWERS


def pairs_of(w, ks, n: int, rng) -> list[tuple[str, ObjPose, object]]:
    """(drawer, placement, grasp) for ``n`` valid placements of the block per drawer."""
    out = []
    for s in DRAWERS:
        w.set_drawer(s, DRAWER_TRAVEL)
        sf, found = w.surfaces[s], 0
        while found < n:
            x, y = rng.uniform(sf.lo[0], sf.hi[0]), rng.uniform(sf.lo[1], sf.hi[1])
            p = ObjPose("block", s, w.rest_pose("block", s, x, y, rng.uniform(-np.pi, np.pi)))
            if not ks.placement_valid(p):
                continue
            found += 1
            out += [(s, p, g) for g in ks.grasps("block") if g.kind == "top"]
        w.set_drawer(s, 0.0)
    return out


def run(w, pairs, seed: int, check: bool) -> dict:
    w.robot._ik_attempts.clear()  # nothing kept from the other side
    w._collisions.clear()
    ks = KitchenStreams(w, np.random.default_rng(seed), hand_check=check)
    calls = [0]
    real = w.robot.inverse_kinematics

    def counted(*a, **k):
        calls[0] += 1
        return real(*a, **k)

    w.robot.inverse_kinematics = counted
    reached = refused = 0
    began = time.perf_counter()
    try:
        for s, p, g in pairs:
            w.set_drawer(s, DRAWER_TRAVEL)
            if check and ks.hand_blocked("block", p, g):
                refused += 1
            reached += next(iter(ks.inv_reach("block", p, g)), None) is not None
            w.set_drawer(s, 0.0)
    finally:
        w.robot.inverse_kinematics = real
    took = time.perf_counter() - began
    return {"pairs": len(pairs), "reached": reached, "refused": refused, "ik": calls[0], "s": took}


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--placements", type=int, default=15, help="placements per drawer (15)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the placements and the bases")
    ap.add_argument("--rounds", type=int, default=2, help="times each side runs, in turn (2)")
    ap.add_argument("--full", action="store_true", help="50 placements per drawer")
    args = ap.parse_args(argv)
    if args.full:
        args.placements = 50
    task = make_task("swap", 0)
    try:
        w = task.world
        for o in list(w.objects):
            if w.support.get(o) is not None:
                w.remove_object(o)
        pairs = pairs_of(w, KitchenStreams(w, np.random.default_rng(args.seed)), args.placements,
                         np.random.default_rng(args.seed))  # fmt: skip
        print(
            f"{'side':14s} {'pairs':>5s} {'reached':>7s} {'refused':>7s} {'IK calls':>8s} {'s':>6s}"
        )
        for name, check in (("without check", False), ("with check", True)) * args.rounds:
            r = run(w, pairs, args.seed, check)
            print(f"{name:14s} {r['pairs']:5d} {r['reached']:7d} {r['refused']:7d} {r['ik']:8d} "
                  f"{r['s']:6.2f}")  # fmt: skip
    finally:
        task.close()


if __name__ == "__main__":
    main()
