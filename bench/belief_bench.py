"""Benchmark of the belief layer: Bayesian update time and BVis (BOccluded) time versus the
number of particles and of occluding objects, plus raw batched ray-cast throughput.

    python bench/belief_bench.py [--full] [--repeats R] [--seed S]

Every time is the median of R runs.  A BOccluded evaluation runs BVis (paper §IV-A, §V-B)
for each occluder: k = 16 poses drawn from its belief, one batched ray cast per pose covering
the 9 test points of every pose in X_i (delta = 0.1 m).
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time

import numpy as np
import pybullet as p

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from ssr_compile.belief.observation import blocking_bodies, sample_obs  # noqa: E402
from ssr_compile.belief.particles import ObservationModel, PoseBelief, Surface, update  # noqa: E402
from ssr_compile.belief.visibility import PyBulletCamera  # noqa: E402

TABLE = Surface("table", (2.0, 0.0), (0.5, 0.6), 0.0)
HALF = (0.04, 0.04, 0.06)


def median_time(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def build_scene(cid: int, n_occluders: int, rng: np.random.Generator) -> dict[int, PoseBelief]:
    """Boxes standing between the camera and the table, each with a 100-particle belief
    spread over a 20 cm square around where it really is."""
    col = p.createCollisionShape(p.GEOM_BOX, halfExtents=[0.05, 0.05, 0.1], physicsClientId=cid)
    beliefs = {}
    for k in range(n_occluders):
        x, y = rng.uniform(1.2, 1.5), rng.uniform(-0.4, 0.4)
        body = p.createMultiBody(0, col, basePosition=[x, y, 0.1], physicsClientId=cid)
        stand = Surface(f"stand{k}", (x, y), (0.1, 0.1), 0.0)
        beliefs[body] = PoseBelief.uniform(f"occ{k}", [stand], 100, rng, z_offset=0.1)
    return beliefs


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument(
        "--full", action="store_true", help="more repeats and occluder counts (default: quick)"
    )
    ap.add_argument("--quick", action="store_true", help="the default (kept for old scripts)")
    ap.add_argument("--repeats", type=int, default=None)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    quick = not args.full
    repeats = args.repeats or (3 if quick else 5)
    occluder_counts = (1, 10) if quick else (1, 2, 5, 10)
    sizes = (100, 1000, 10000)
    rng = np.random.default_rng(args.seed)
    model = ObservationModel()
    started = time.perf_counter()

    print(f"belief layer benchmark (medians of {repeats} runs, seed {args.seed})\n")
    print("Bayesian update (ssr_compile.belief.particles.update), all particles visible")
    print(f"{'N':>7} | {'detect ms':>10} | {'miss ms':>8} | {'reinvig ms':>10}")
    for n in sizes:
        pb = PoseBelief.uniform("o", [TABLE], n, rng, z_offset=HALF[2])
        mask = np.ones(n, bool)
        z_on = pb.poses[0]
        z_off = np.array([2.0, 0.0, HALF[2], 0.0])  # between particles: deprivation
        t_det = median_time(lambda pb=pb, m=mask, z=z_on: update(pb, z, m, model), repeats)
        t_miss = median_time(lambda pb=pb, m=mask: update(pb, None, m, model), repeats)
        t_re = median_time(lambda pb=pb, m=mask, z=z_off: update(pb, z, m, model), repeats)
        print(f"{n:>7} | {1e3 * t_det:>10.2f} | {1e3 * t_miss:>8.2f} | {1e3 * t_re:>10.2f}")

    print("\nBOccluded = BVis for every occluder (k=16 poses each), X_i from sample-obs")
    print(f"{'N':>7} | {'occluders':>9} | {'|X_i|':>5} | {'ms':>9} | {'rays':>8} | {'Mrays/s':>7}")
    for n_occ in occluder_counts:
        cid = p.connect(p.DIRECT)
        try:
            occ = build_scene(cid, n_occ, rng)
            cam = PyBulletCamera([0.0, 0.0, 1.0], client=cid)
            for n in sizes:
                pb = PoseBelief.uniform("o", [TABLE], n, rng, z_offset=HALF[2])
                (obs,) = next(sample_obs("o", pb, rng, delta=0.1, eps=0.1))
                before = cam.rays_cast
                t = median_time(
                    lambda obs=obs, occ=occ, cam=cam: blocking_bodies(
                        obs, occ, cam, half_extents=HALF, k=16
                    ),
                    repeats,
                )
                rays = (cam.rays_cast - before) // repeats
                print(
                    f"{n:>7} | {n_occ:>9} | {len(obs.region.poses):>5} | {1e3 * t:>9.2f} | "
                    f"{rays:>8} | {rays / t / 1e6:>7.2f}"
                )
        finally:
            p.disconnect(cid)

    print("\nRaw PyBulletCamera.visible throughput (10 occluders, 4 batches of 16383 rays)")
    cid = p.connect(p.DIRECT)
    try:
        build_scene(cid, 10, rng)
        pts = np.column_stack(
            [
                rng.uniform(1.5, 2.5, 4 * 16383),
                rng.uniform(-0.6, 0.6, 4 * 16383),
                np.zeros(4 * 16383),
            ]
        )
        for threads in (1, 0):
            cam = PyBulletCamera([0.0, 0.0, 1.0], client=cid, num_threads=threads)
            t = median_time(lambda cam=cam: cam.visible(pts), repeats)
            print(f"  numThreads={threads}: {len(pts) / t / 1e6:.2f} Mrays/s")
    finally:
        p.disconnect(cid)
    print(f"\ntotal bench time {time.perf_counter() - started:.1f} s")


if __name__ == "__main__":
    main()
