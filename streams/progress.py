"""The progress example of paper §VI (``domains/pddl/progress``): its streams.

A mobile robot at ``q0`` must pick object ``d`` two metres away.  Positions are planar
``(x, y)`` in metres.  The arm reaches ``d`` from a base pose whose distance to ``d`` lies in
``[REACH_MIN, REACH_MAX]``.

Streams (``make_module``):

* ``sample-grasp`` — two grasps of ``d`` (top, side); its outputs are *constants* (§VI-A);
* ``inv-reach`` — endless: base poses at distance ``[0.45, 0.65]`` from ``d``, seeded from the
  inputs;
* ``inv-kin`` — endless, from **any** base pose (the reached one included): each random restart
  of the arm's IK succeeds with probability ``P_IK`` when the base is within reach; never
  when it is not (then the generator ends);
* ``plan-base-motion`` — deferrable (§VII): a straight base trajectory.

The true world (:class:`~ssr_compile.streams.environments.progress.ProgressWorld`): a base motion lands at the aimed pose plus Gaussian
noise ``BASE_NOISE`` per axis (seeded); the robot then observes where it is (localization).
A pick succeeds in the true world when the base really is within reach and the pick was planned
from the pose the robot is at.

Why it oscillates without plan constraints (paper §VI): after a noisy motion the replanning
planner sees two optimistic plans, pick from here (cost 1) and move again then pick (cost 6);
it tries the first, and when the IK's first restart from here fails, the Focused solver turns,
within the same level, to a fresh base pose -- another noisy motion, and the story repeats.
With the last plan's structure enforced (Algorithm 2) the only plan is ``pick`` from the
reached pose, so the solver raises the level and retries the IK instead.
"""

from __future__ import annotations

import math
import zlib
from collections.abc import Iterator

import numpy as np

from ssr_compile.stream import StreamInfo, StreamsModule

OBJECT = (2.0, 0.0)  # where d stands
Q0 = (0.0, 0.0)  # where the robot starts
REACH_MIN, REACH_MAX = 0.35, 0.75  # the arm's reach: base-to-object distance
SAMPLE_MIN, SAMPLE_MAX = 0.45, 0.65  # where inv-reach samples
P_IK = 0.3  # success probability of one IK restart within reach
BASE_NOISE = 0.06  # standard deviation of a base motion's landing error per axis, metres
GRASPS = ("top", "side")


def _rng(seed: int, *parts: object) -> np.random.Generator:
    """A generator seeded from the episode seed and a stable digest of ``parts``."""
    text = repr(tuple(round(x, 9) if isinstance(x, float) else x for x in _flat(parts)))
    return np.random.default_rng([seed, zlib.crc32(text.encode())])


def _flat(parts):
    for p in parts:
        if isinstance(p, tuple):
            yield from _flat(p)
        else:
            yield p


def within_reach(q, p) -> bool:
    d = math.dist(q, p)
    return REACH_MIN - 1e-9 <= d <= REACH_MAX + 1e-9


def make_module(seed: int = 0, values: dict | None = None) -> StreamsModule:
    """The streams of the progress domain for one episode (``seed``) and problem values."""

    def sample_grasp(o: str) -> Iterator[tuple]:
        for g in GRASPS:
            yield ((o, g),)

    def inv_reach(o: str, p, g) -> Iterator[tuple]:
        rng = _rng(seed, "inv-reach", o, p, g)
        while True:
            angle = rng.uniform(-math.pi, math.pi)
            r = rng.uniform(SAMPLE_MIN, SAMPLE_MAX)
            yield ((round(p[0] + r * math.cos(angle), 4), round(p[1] + r * math.sin(angle), 4)),)

    def inv_kin(o: str, p, g, q) -> Iterator[tuple]:
        if not within_reach(q, p):
            return
        k = 0
        while True:
            k += 1
            if _rng(seed, "inv-kin", o, p, g, q, k).random() < P_IK:
                bearing = math.atan2(p[1] - q[1], p[0] - q[0])
                yield (("arm", round(bearing, 4), g[1], k),)
            else:
                yield None  # this restart failed; another may succeed

    def plan_base_motion(q1, q2) -> tuple:
        return (("base-path", q1, q2),)

    return StreamsModule(
        "ssr_compile.streams.progress",
        {
            "sample-grasp": sample_grasp,
            "inv-reach": inv_reach,
            "inv-kin": inv_kin,
            "plan-base-motion": plan_base_motion,
        },
        {
            "sample-grasp": StreamInfo(constant_outputs=True, cost=0.1),
            "inv-reach": StreamInfo(cost=0.1),
            "inv-kin": StreamInfo(p_success=P_IK, cost=0.5),
            "plan-base-motion": StreamInfo(
                deferrable=True, kind="function", p_success=0.99, cost=5
            ),
        },
        dict(values or {"p-d": OBJECT, "q0": Q0}),
    )


# The plain module form, for `ssr-compile solve progress` (seed 0) ...
_default = make_module(0)
STREAMS = _default.streams
STREAM_INFO = _default.info
VALUES = _default.values


def for_problem(path, seed: int) -> StreamsModule:
    """... and the seeded module for `solve --seed N`."""
    return make_module(seed)
