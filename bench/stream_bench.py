"""Median time of the kitchen streams over 20 calls each (figures, no assertions).

Run: python bench/stream_bench.py [--full]   (--full: 100 calls each)

Each call starts with nothing kept: the robot's IK attempts and the world's collision answers
are forgotten before it (else a repeated call would time lookups).
"""

from __future__ import annotations

import time

import numpy as np
from ssr_compile.sim.perception import visible_fraction
from ssr_compile.sim.robot import ARM_TUCK, STALL, STALL_GAIN
from ssr_compile.sim.samplers import KitchenStreams
from ssr_compile.sim.world import PARK_BASE, World

N = 20


def _median_ms(fn, forget) -> tuple[float, int]:
    times, ok = [], 0
    for _ in range(N):
        forget()
        t = time.perf_counter()
        ok += fn() is not None
        times.append(time.perf_counter() - t)
    return 1000 * float(np.median(times)), ok


def main(argv: list[str] | None = None) -> None:
    import argparse

    global N
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--full", action="store_true", help="100 calls per stream (default 20)")
    N = 100 if ap.parse_args(argv).full else N
    w = World()
    rng = np.random.default_rng(0)
    w.robot.stall = (STALL, STALL_GAIN)  # IK as the planner's streams run it
    ks = KitchenStreams(w, rng)
    w.set_object("block", "counter", 1.0, 0.8, 0.0)
    w.set_object("sugar_box", "counter", 1.15, 1.05, 0.0)
    w.set_object("cracker_box", "counter", 1.15, 0.55, 0.0)
    p = ks.current_pose("block")
    g = ks.grasps("block")[0]
    base = next(iter(ks.inv_reach("block", p, g)))[0]
    pre = ks.inv_kin("block", p, g, base)[0]
    tool = w.robot.forward_kinematics(base, pre)
    far = ((tool[0][0] + 0.6, tool[0][1], tool[0][2] + 0.6), tool[1])
    rows = [
        ("IK (tool pose, restarts)", lambda: w.robot.inverse_kinematics(base, tool, rng)),
        # 0.85 m beyond a pose the arm reaches: every attempt fails (all the restarts spent)
        ("IK (out of reach, restarts)", lambda: w.robot.inverse_kinematics(base, far, rng)),
        (
            "inv-kin (grasp + approach)",
            lambda: ks._kin_cache.clear() or ks.inv_kin("block", p, g, base),
        ),
        ("inv-reach (first base)", lambda: next(iter(ks.inv_reach("block", p, g)), None)),
        ("arm motion (RRT-Connect)", lambda: ks.plan_arm_motion(base, ARM_TUCK, pre)),
        ("base motion (RRT-Connect)", lambda: ks.plan_base_motion(PARK_BASE, base)),
        ("grasp sampling (all)", lambda: list(ks.sample_grasps("sugar_box"))),
        (
            "placement sampling (first)",
            lambda: next(iter(ks.sample_placements("block", "counter")), None),
        ),
        ("visibility (10 rays)", lambda: visible_fraction(w, "block")),
    ]

    def forget() -> None:
        w.robot._ik_attempts.clear()
        w._collisions.clear()

    print(f"{'stream':32s} {'median ms':>10s} {'ok/' + str(N):>7s}")
    for name, fn in rows:
        ms, ok = _median_ms(fn, forget)
        print(f"{name:32s} {ms:10.2f} {ok:7d}")
    w.close()


if __name__ == "__main__":
    main()
