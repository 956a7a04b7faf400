"""``pyperplan``: pyperplan called directly, in a forked child killed at the time limit.

pyperplan reads STRIPS with typing and positive preconditions only and plans with unit costs.
A task with action costs is refused unless the backend was built with ``ignore_costs=True``
(then the plan is found without regard to costs, and its cost is still reported under the
problem's metric).
"""

from __future__ import annotations

import dataclasses
import os
import shutil
import tempfile
from pathlib import Path

from .. import syntax as S
from ..errors import SSRError
from ..printer import to_text
from . import proc
from .base import (
    ERROR,
    TIMEOUT,
    UNSOLVABLE,
    Capabilities,
    Clock,
    PlanResult,
    describe_variants,
)
from .costs import priced
from .features import unsupported
from .rename import rename_task

# search name -> (pyperplan search, heuristic or None); "opt" is optimal under unit costs.
SEARCHES = {"default": ("gbf", "hff"), "opt": ("astar", "lmcut"), "bfs": ("bfs", None)}


def _strip_costs(domain: S.Domain, problem: S.Problem) -> tuple[S.Domain, S.Problem]:
    def effect(f):
        if isinstance(f, S.And):
            return S.And(tuple(e for e in map(effect, f.args) if e is not None))
        return None if isinstance(f, S.NumericEffect) else f

    domain = dataclasses.replace(
        domain,
        functions=(),
        actions=tuple(dataclasses.replace(a, effect=effect(a.effect)) for a in domain.actions),
    )
    init = tuple(f for f in problem.init if not isinstance(f, S.InitValue))
    return domain, dataclasses.replace(problem, init=init, metric=None)


def _search_in_child(domain_path: str, problem_path: str, search: str, heuristic: str | None):
    import logging

    from pyperplan import planner

    logging.disable(logging.CRITICAL)
    found = planner.search_plan(
        domain_path,
        problem_path,
        planner.SEARCHES[search],
        planner.HEURISTICS[heuristic] if heuristic else None,
    )
    if found is None:
        return None
    return [tuple(op.name.strip("()").split()) for op in found]


class Pyperplan:
    """pyperplan in-process (forked): STRIPS with typing, positive preconditions, unit costs."""

    def __init__(self, search: str = "default", *, ignore_costs: bool = False):
        if search not in SEARCHES:
            raise SSRError(
                f"unknown pyperplan search {search!r}; choose one of " + ", ".join(SEARCHES)
            )
        self.search = search
        self.ignore_costs = ignore_costs
        self.name = "pyperplan" if search == "default" else f"pyperplan:{search}"
        self.capabilities = Capabilities(
            costs=ignore_costs,
            axioms=False,
            negative_preconditions=False,
            disjunction=False,
            quantifiers=False,
            conditional_effects=False,
            optimal=search in ("opt", "bfs") and not ignore_costs,
            ground=True,
        )
        import pyperplan.planner  # noqa: F401 - loaded once, before any fork

    def solve(
        self,
        domain: S.Domain,
        problem: S.Problem,
        time_limit: float = 60.0,
        cost_bound: float | None = None,
    ) -> PlanResult:
        clock = Clock(time_limit)

        def result(status, message="", actions=None, cost=None):
            return PlanResult(status, actions, cost, clock.elapsed(), self.name, message)

        missing = unsupported(self.capabilities, domain, problem, equality=False)
        if missing:
            return result(ERROR, f"{self.name} does not support " + ", ".join(missing))
        tmp = tempfile.mkdtemp(prefix="ssr-pyperplan-")
        try:
            dom, prob = _strip_costs(domain, problem) if self.ignore_costs else (domain, problem)
            dom, prob, renaming = rename_task(dom, prob, one_namespace=False)
            d_path, p_path = os.path.join(tmp, "domain.pddl"), os.path.join(tmp, "problem.pddl")
            Path(d_path).write_text(to_text(dom))
            Path(p_path).write_text(to_text(prob))
            status, value = proc.run_forked(
                _search_in_child,
                (d_path, p_path, *SEARCHES[self.search]),
                timeout=clock.remaining(),
                log_path=os.path.join(tmp, "pyperplan.log"),
            )
            if status == proc.TIMED_OUT:
                return result(TIMEOUT, f"exceeded the time limit of {time_limit:g} s")
            if status != proc.OK:
                return result(ERROR, f"pyperplan failed: {value}")
            if value is None:
                return result(UNSOLVABLE, "pyperplan's search found no plan")
            actions = renaming.plan_back([(step[0], tuple(step[1:])) for step in value])
            return priced(result, domain, problem, actions, cost_bound)
        except Exception as e:  # noqa: BLE001 - a backend answers, it never crashes
            return result(ERROR, f"{type(e).__name__}: {e}")
        finally:
            shutil.rmtree(tmp, ignore_errors=True)


def make_planner(variant: str | None = None, **options) -> Pyperplan:
    """Entry-point factory: ``pyperplan`` or ``pyperplan:opt`` / ``pyperplan:bfs``."""
    if variant is not None:
        options.setdefault("search", variant)
    return Pyperplan(**options)


_DESCRIPTIONS = {
    "default": "pyperplan, greedy best-first with hFF (STRIPS, unit costs)",
    "opt": "pyperplan, A* with LM-cut (STRIPS, optimal for unit costs)",
    "bfs": "pyperplan, breadth-first search (STRIPS, shortest plan)",
}


def describe() -> list[dict]:
    return describe_variants(Pyperplan, _DESCRIPTIONS)


make_planner.describe = describe
