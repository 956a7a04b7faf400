"""The progress example of paper §VI (``domains/pddl/progress``): streams and a closed loop.

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

The true world (:class:`ProgressWorld`): a base motion lands at the aimed pose plus Gaussian
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
from dataclasses import dataclass

import numpy as np

from ssr_compile import syntax as S
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


# ---------------------------------------------------------------- the closed loop


class ProgressWorld:
    """The true world: the robot's real base pose and whether it holds ``d``."""

    def __init__(self, seed: int, noise: float = BASE_NOISE):
        self.rng = np.random.default_rng([seed, 7])
        self.noise = noise
        self.base = Q0
        self.holding = False
        self.base_motions = 0

    def observe(self) -> dict:
        return {"base": self.base, "holding": self.holding, "ok": True}

    def execute(self, step) -> dict:
        if step.name == "move-base":
            aim = step.values[2]
            dx, dy = self.rng.normal(0.0, self.noise, 2)
            self.base = (round(aim[0] + dx, 4), round(aim[1] + dy, 4))
            self.base_motions += 1
            return self.observe()
        if step.name == "pick":
            planned_from = step.values[3]
            ok = (
                not self.holding
                and math.dist(planned_from, self.base) < 1e-6
                and within_reach(self.base, OBJECT)
            )
            self.holding = self.holding or ok
            return {**self.observe(), "ok": ok}
        return {**self.observe(), "ok": False}

    def goal_holds(self) -> bool:
        return self.holding

    def close(self) -> None:
        pass


@dataclass
class ProgressAgent:
    """What the robot knows: its base pose (it localizes after every motion) and its hand."""

    domain: S.Domain
    streams: S.StreamFile
    seed: int
    base: tuple = Q0
    holding: bool = False
    _poses: int = 0

    def update(self, step, observation) -> None:
        if observation is None:
            return
        if observation["base"] != self.base:
            self._poses += 1
        self.base = observation["base"]
        self.holding = observation["holding"]

    def _base_name(self) -> str:
        return "q0" if self._poses == 0 else f"q-reached-{self._poses}"

    def problem(self) -> tuple[S.Problem, StreamsModule]:
        q = self._base_name()
        a = S.Atom
        init: list = [
            a("graspable", (S.Const("d"),)),
            a("pose", (S.Const("d"), S.Const("p-d"))),
            a("baseconf", (S.Const(q),)),
            a("atbase", (S.Const(q),)),
        ]
        if self.holding:
            init.append(a("holding", (S.Const("d"),)))
        else:
            init += [a("atpose", (S.Const("d"), S.Const("p-d"))), a("handempty")]
        init.append(S.InitValue(S.FuncTerm("total-cost"), S.Num(0)))
        problem = S.Problem(
            "progress-now",
            "progress",
            None,
            tuple(S.Typed(n) for n in ("d", "p-d", q)),
            tuple(init),
            a("holding", (S.Const("d"),)),
            S.Metric("minimize", S.FuncTerm("total-cost")),
        )
        return problem, make_module(self.seed, {"p-d": OBJECT, q: self.base})

    def is_constant(self, name: str) -> bool:
        return name == "d"

    def summary(self) -> str:
        d = math.dist(self.base, OBJECT)
        hand = "holding d" if self.holding else "hand empty"
        return f"base ({self.base[0]:.2f}, {self.base[1]:.2f}), {d:.2f} m from d; {hand}"


def make_episode(problem: str | None = None, seed: int = 0, *, noise: float = BASE_NOISE):
    """The environment and agent of one episode (``example.toml``'s ``environment``)."""
    from ssr_compile.examples import load_example
    from ssr_compile.policy import Episode

    ex = load_example("progress")
    return Episode(
        ProgressWorld(seed, noise), ProgressAgent(ex.domain, ex.streams, seed), "progress"
    )
