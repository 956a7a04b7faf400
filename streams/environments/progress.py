"""The closed loop of the progress example ``domains/pddl/progress`` (paper §VI): the true
world (:class:`ProgressWorld`: noisy base motions) and what the robot knows
(:class:`ProgressAgent`); the streams are those of :mod:`ssr_compile.streams.progress`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ssr_compile import syntax as S
from ssr_compile.stream import StreamsModule

from ..progress import BASE_NOISE, OBJECT, Q0, make_module, within_reach


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
