"""The planner backend protocol (docs/design.md §4 "Planner backend").

A backend takes a plain cost-PDDL domain and problem (syntax trees, no streams) and returns a
:class:`PlanResult`.  It states what it supports in :class:`Capabilities`, so that the compiler
can lower a problem to fit it before calling :meth:`Planner.solve`; a backend handed something
outside its capabilities answers with status ``"error"`` and a message instead of crashing.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

from ..compile.capabilities import Capabilities  # noqa: F401 (the backends' type)
from ..syntax import Domain, Problem

SOLVED = "solved"
UNSOLVABLE = "unsolvable"
TIMEOUT = "timeout"
ERROR = "error"
STATUSES = (SOLVED, UNSOLVABLE, TIMEOUT, ERROR)

GroundAction = tuple[str, tuple[str, ...]]


@dataclass
class PlanResult:
    """The answer of one planner call.

    ``actions`` are ground actions ``(name, args)`` in the input's (lower-case) names, present
    only when ``status == "solved"``; ``cost`` is the plan's cost under the problem's metric
    (the sum of action costs), or the number of actions when the problem has no metric.
    ``message`` says why there is no plan in one line.
    """

    status: str
    actions: list[GroundAction] | None
    cost: float | None
    time: float
    planner: str
    message: str = ""
    # What a failed backend left behind (its child's traceback, a log's tail): shown by the
    # CLI's --debug, never in the one-line message.
    detail: str = ""
    # Seconds of ``time`` spent translating the task (Fast Downward's translator) and
    # searching (its search binary); 0 for a backend that does not tell its stages apart.
    translate_time: float = 0.0
    search_time: float = 0.0

    @property
    def solved(self) -> bool:
        return self.status == SOLVED

    def plan_text(self) -> str:
        """The plan in the usual ``(name arg ...)`` one-action-per-line form."""
        return "".join("(" + " ".join([n, *args]) + ")\n" for n, args in self.actions or ())


@runtime_checkable
class Planner(Protocol):
    name: str
    capabilities: Capabilities

    def solve(
        self,
        domain: Domain,
        problem: Problem,
        time_limit: float = 60.0,
        cost_bound: float | None = None,
    ) -> PlanResult: ...


class Clock:
    """Wall-clock time since construction and what remains of a limit."""

    def __init__(self, limit: float):
        self.start = time.monotonic()
        self.limit = limit

    def elapsed(self) -> float:
        return time.monotonic() - self.start

    def remaining(self) -> float:
        return max(0.0, self.limit - self.elapsed())


def describe_variants(make, descriptions: dict[str, str]) -> list[dict]:
    """Rows for ``ssr-compile planners``: one per variant, built with ``make(variant)``."""
    rows = []
    for variant, text in descriptions.items():
        planner = make(variant)
        rows.append(
            {
                "name": planner.name,
                "planner": planner.name,
                "capabilities": planner.capabilities.as_dict(),
                "description": text,
            }
        )
    return rows


def over_bound(cost: float, cost_bound: float | None) -> str | None:
    """Why a plan of ``cost`` is refused under ``cost_bound`` (plans must cost strictly less)."""
    if cost_bound is not None and cost >= cost_bound:
        return f"the plan found costs {cost:g}, not below the bound {cost_bound:g}"
    return None
