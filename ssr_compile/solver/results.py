"""What a call of :func:`~ssr_compile.solver.solve` returns: the solution and its statistics."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from .. import syntax as S
from ..compile.instantiate import Result
from ..stream import ValueTable

SOLVED = "solved"


@dataclass
class StreamStats:
    calls: int = 0
    successes: int = 0
    failures: int = 0
    time: float = 0.0


@dataclass
class Statistics:
    iterations: int = 0
    levels: list[int] = field(default_factory=list)
    planner_calls: int = 0
    planner_time: float = 0.0
    # of planner_time: the backends' translation and search (PlanResult.translate_time...)
    translate_time: float = 0.0
    search_time: float = 0.0
    stream_time: float = 0.0
    total_time: float = 0.0
    streams: dict[str, StreamStats] = field(default_factory=dict)
    # Per iteration: the compiled problem handed to the planner (objects, facts, function
    # values, ground actions when the planner reports them, else None).
    sizes: list[tuple[int, int, int, int | None]] = field(default_factory=list)
    compile_time: float = 0.0
    resamples: int = 0  # generator draws taken again within one stream plan (``resample``)

    def stream(self, name: str) -> StreamStats:
        return self.streams.setdefault(name, StreamStats())

    def as_dict(self) -> dict:
        return {
            "iterations": self.iterations,
            "levels": self.levels,
            "planner_calls": self.planner_calls,
            "planner_time": round(self.planner_time, 4),
            "translate_time": round(self.translate_time, 4),
            "search_time": round(self.search_time, 4),
            "stream_time": round(self.stream_time, 4),
            "total_time": round(self.total_time, 4),
            "compile_time": round(self.compile_time, 4),
            "resamples": self.resamples,
            "sizes": [list(z) for z in self.sizes],
            "streams": {
                k: vars(v) | {"time": round(v.time, 4)} for k, v in sorted(self.streams.items())
            },
        }


@dataclass
class Step:
    """One action of a solution: object names, their Python values, deferred arguments."""

    name: str
    args: tuple[str, ...]
    values: tuple[Any, ...]
    deferred: tuple[str, ...] = ()  # arguments still optimistic (their streams deferred)

    def __str__(self) -> str:
        return "(" + " ".join([self.name, *self.args]) + ")"


@dataclass
class Solution:
    status: str  # "solved", "unsolvable" (no plan within the level / cost bound), "timeout"
    plan: list[Step] | None
    cost: float | None
    certificate: list[S.Atom]
    stats: Statistics
    deferred: list[Result] = field(default_factory=list)
    evaluated: list[Result] = field(default_factory=list)
    values: ValueTable | None = None
    message: str = ""
    # the planner cannot take action costs (pyperplan): it planned with unit costs
    costs_ignored_by: str | None = None
    # instances over the problem's own objects (no drawn value) of tests and of streams of
    # one output at most, that failed in this call: a replanning call evaluates them again
    # before it plans (ReplanState.recheck)
    failed: list = field(default_factory=list)
    # the level the plan was found at (``None``: not recorded), which a level rise for a
    # cheaper plan that found none leaves below the last iteration's
    level: int | None = None

    @property
    def solved(self) -> bool:
        return self.status == SOLVED


def plan_steps(plan, values: ValueTable, deferred_objects: set[str]) -> list[Step]:
    """The steps of ``plan`` (action names and object names) with their arguments' values;
    the arguments in ``deferred_objects`` stay optimistic (no value, marked deferred)."""
    steps = []
    for name, args in plan:
        vals = tuple(None if a in deferred_objects else values.value(a) for a in args)
        steps.append(Step(name, tuple(args), vals, tuple(a for a in args if a in deferred_objects)))
    return steps
