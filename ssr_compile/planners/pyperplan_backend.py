"""``pyperplan``: pyperplan called directly, in a forked child killed at the time limit.

pyperplan reads STRIPS with typing and positive preconditions only and plans with unit costs.
A task with action costs is refused unless the backend was built with ``ignore_costs=True``
(then the plan is found without regard to costs, and its cost is still reported under the
problem's metric).
"""

from __future__ import annotations

import dataclasses

from .. import syntax as S
from ..errors import SSRError
from .base import UNSOLVABLE, Capabilities, describe_variants
from .external import ExternalPlanner, Job, Stop

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


class Pyperplan(ExternalPlanner):
    """pyperplan in-process (forked): STRIPS with typing, positive preconditions, unit costs."""

    def __init__(self, search: str = "default", *, ignore_costs: bool = False):
        if search not in SEARCHES:
            raise SSRError(
                f"unknown pyperplan search {search!r}; choose one of " + ", ".join(SEARCHES)
            )
        self.search = search
        self.ignore_costs = ignore_costs
        self.equality = False  # pyperplan does not read (= ?x ?y)
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

    def prepare(self, domain: S.Domain, problem: S.Problem) -> tuple[S.Domain, S.Problem]:
        return _strip_costs(domain, problem) if self.ignore_costs else (domain, problem)

    def run(self, job: Job) -> list | None:
        found = self.run_forked(
            job,
            _search_in_child,
            (job.domain, job.problem, *SEARCHES[self.search]),
            what="pyperplan",
        )
        if found is None:
            raise Stop(UNSOLVABLE, "pyperplan's search found no plan")
        return [(step[0], tuple(step[1:])) for step in found]


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
