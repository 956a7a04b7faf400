"""Compile pass — lowering to what a planner backend supports (one module per step: ground,
derived, quantifiers, disjunctions, negations, costs, rename; this one orders them).

A backend states its :class:`~ssr_compile.compile.capabilities.Capabilities` (costs, axioms,
negative preconditions, disjunction, quantifiers, conditional effects, a ground task); this pass
rewrites the plain domain and problem to fit, running the steps it needs in this order, each a
pass with the common contract (:class:`~.result.PassResult`):

* ground task -> the relaxed-reachable ground actions (:mod:`.ground`); a lifted task keeps
  its quantifiers, guarded by each action's static atoms (:mod:`.guards`);
* axioms  -> derived predicates inlined (:mod:`.derived`);
* quantifiers -> expanded over the problem's objects (respecting types) (:mod:`.quantifiers`);
* disjunction / ``imply`` -> each action split into one copy per disjunct of its precondition's
  DNF (``a--1``, ``a--2``...); a disjunctive goal gets one ``ssr-goal--k`` action per disjunct
  (:mod:`.disjunctions`);
* negative preconditions -> complement predicates ``not-p`` kept in step by the effects, and
  equality with constants substituted into the action (its parameter disappears)
  (:mod:`.negations`);
* costs -> unit costs (else integer costs, scaled and rounded up) (:mod:`.costs`);
* requirements -> the flags the task really uses (:func:`~ssr_compile.formulas.requirements_of`);
* names -> renamed where a reader would refuse them (an action named like a predicate, ``@x``)
  (:mod:`.rename`).

:class:`Lowered` keeps each step's result; its :meth:`~Lowered.map_plan` chains their map-backs.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from .. import syntax as S
from ..errors import UnsupportedError
from ..formulas import requirements_of
from .costs import compile_costs
from .derived import compile_away, normalise_axiom_bodies
from .disjunctions import GOAL_ACTION, GOAL_REACHED, split_disjunctions  # noqa: F401
from .formulas import has
from .ground import Grounded, ground
from .guards import guard_quantifiers
from .negations import DISTINCT, remove_negations  # noqa: F401
from .quantifiers import MAX_EXPANSION, expand_quantifiers, objects_by_type  # noqa: F401
from .rename import Renamed, Renaming, rename_task
from .result import PassResult, Plan, map_back


@dataclass
class Lowered(PassResult):
    """The lowering's result: the task for the backend, the scale of its costs (planner units
    per unit of the input's costs) and the result of each step that ran, in order."""

    scale: int = 1
    steps: tuple[PassResult, ...] = ()

    @property
    def grounded(self) -> Grounded | None:
        """The grounding step's result, when the task was grounded."""
        return next((s for s in self.steps if isinstance(s, Grounded)), None)

    @property
    def renaming(self) -> Renaming | None:
        """The names changed so that every reader accepts them (``None``: none changed)."""
        renamed = next((s for s in self.steps if isinstance(s, Renamed)), None)
        return renamed.renaming if renamed is not None and renamed.renaming else None

    def map_plan(self, plan) -> Plan:
        return map_back(self.steps, plan)


def lower(
    domain: S.Domain,
    problem: S.Problem,
    caps,
    *,
    cost_functions: set[str] = frozenset(),
    scale: int | None = None,
    unit_cost: bool = False,
) -> Lowered:
    """Rewrite ``domain`` and ``problem`` for a backend with capabilities ``caps``."""
    if domain.durative_actions:
        a = domain.durative_actions[0]
        raise UnsupportedError(
            f"durative action '{a.name}': temporal planning is not supported by the classical backends",
            line=a.span.line if a.span else None,
            col=a.span.col if a.span else None,
        )
    steps: list[PassResult] = [PassResult(normalise_axiom_bodies(domain), problem)]
    if getattr(caps, "ground", False):
        steps.append(ground(*steps[-1].task, conditional_effects=caps.conditional_effects))
    elif caps.quantifiers:
        steps.append(guard_quantifiers(*steps[-1].task))
    if not caps.axioms:
        steps.append(compile_away(*steps[-1].task))
    if not caps.quantifiers:
        steps.append(expand_quantifiers(*steps[-1].task))
    if not caps.disjunction:
        steps.append(split_disjunctions(*steps[-1].task))
    if not caps.negative_preconditions:
        steps.append(remove_negations(*steps[-1].task))
    if not caps.conditional_effects:
        for a in steps[-1].domain.actions:
            if has(a.effect, S.When):
                raise UnsupportedError(
                    f"action '{a.name}' has conditional effects, which this planner does not support",
                    line=a.span.line if a.span else None,
                    col=a.span.col if a.span else None,
                )
    costed = compile_costs(
        *steps[-1].task,
        cost_functions=set(cost_functions),
        scale=scale,
        unit_cost=unit_cost or not caps.costs,
    )
    steps.append(costed)
    # The requirement flags the task really uses, now that no later step changes them.
    domain, problem = costed.task
    domain = replace(domain, requirements=requirements_of(domain, problem))
    steps.append(PassResult(domain, replace(problem, requirements=None)))
    # unified-planning's reader keeps every kind of name in one namespace (an action and a
    # predicate may not share a name) and wants plain identifiers: rename what offends it.
    steps.append(rename_task(*steps[-1].task))
    return Lowered(*steps[-1].task, costed.scale, tuple(steps))
