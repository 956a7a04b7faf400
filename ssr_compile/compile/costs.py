"""Lowering pass — costs (paper §V-A): plain integer action costs, scaled from the stream
functions' values (the self-loop determinization itself is in :mod:`ssr_compile.belief`).

:func:`compile_costs` returns a :class:`Costed` result: the task with integer costs and the
``scale`` that turns a planner's cost back into the input's units; no action is renamed, so
plans map back unchanged.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from .. import syntax as S
from ..belief.determinize import self_loop_cost  # noqa: F401  (re-exported)
from .result import PassResult

TOTAL_COST = S.FuncTerm("total-cost")
MAX_SCALE = 1000


def choose_scale(values: list[float]) -> int:
    """The smallest power of ten (up to :data:`MAX_SCALE`) that makes every cost an integer."""
    scale = 1
    while scale < MAX_SCALE:
        if all(abs(v * scale - round(v * scale)) < 1e-9 for v in values):
            return scale
        scale *= 10
    return MAX_SCALE


def to_int(value: float, scale: int) -> int:
    """A cost in planner units: scaled and rounded *up*, so no plan looks cheaper than it is."""
    return max(0, math.ceil(value * scale - 1e-9))


def cost_effects(effect) -> list[S.NumericEffect]:
    """The action-cost effects ``(increase (total-cost) X)`` of an effect (top-level
    conjuncts); a ``decrease`` of total-cost is not a cost."""
    out = []
    for e in S.conjuncts(effect):
        if (
            isinstance(e, S.NumericEffect)
            and e.op == "increase"
            and e.fluent.name == TOTAL_COST.name
            and not e.fluent.args
        ):
            out.append(e)
    return out


@dataclass
class Costed(PassResult):
    """The costs pass's result: ``scale`` planner units make one unit of the input's costs."""

    scale: int = 1


def compile_costs(
    domain: S.Domain,
    problem: S.Problem,
    *,
    cost_functions: set[str] = frozenset(),
    scale: int | None = None,
    unit_cost: bool = False,
) -> Costed:
    """Make costs plain integer action costs (paper §V-A; docs/design.md §4 "Costs").

    ``(increase (total-cost) (F args))`` with ``F`` a stream function stays a static numeric
    fluent whose values (given in the problem's init by instantiation) are scaled to integers
    and rounded up; each such action gets a guard ``(has-cost-F args)`` true exactly where a
    finite value exists, so a planner never grounds an action whose cost is undefined.
    Constant increments are scaled likewise.  ``unit_cost`` drops all costs instead (scale 1).
    """
    if unit_cost:
        actions = tuple(replace(a, effect=_drop_costs(a.effect)) for a in domain.actions)
        init = tuple(f for f in problem.init if not isinstance(f, S.InitValue))
        # Functions that only priced actions are gone with the costs; declared without values
        # they would read as undefined numeric fluents.
        used = _function_names(actions)
        functions = tuple(
            f for f in domain.functions if f.name != TOTAL_COST.name and f.name in used
        )
        return Costed(
            replace(domain, actions=actions, functions=functions),
            replace(problem, init=init, metric=None),
            1,
        )
    values = [
        float(v.value.value)
        for v in problem.init
        if isinstance(v, S.InitValue) and math.isfinite(v.value.value)
    ]
    for a in domain.actions:
        for e in cost_effects(a.effect):
            if isinstance(e.value, S.Num):
                values.append(float(e.value.value))
    if scale is None:
        scale = choose_scale(values)
    used = {
        e.value.name
        for a in domain.actions
        for e in cost_effects(a.effect)
        if isinstance(e.value, S.FuncTerm)
    }
    guarded = used & set(cost_functions)
    actions = []
    for a in domain.actions:
        guards = []
        for e in cost_effects(a.effect):
            if isinstance(e.value, S.FuncTerm) and e.value.name in guarded:
                guards.append(S.Atom(_guard(e.value.name), e.value.args))
        pre = a.precondition
        if guards:
            pre = S.And(tuple(S.conjuncts(pre)) + tuple(guards))
        actions.append(replace(a, precondition=pre, effect=_scale_effect(a.effect, scale)))
    init = []
    for fact in problem.init:
        if isinstance(fact, S.InitValue):
            if fact.fluent.name == TOTAL_COST.name:
                continue
            if not math.isfinite(fact.value.value):
                continue
            init.append(S.InitValue(fact.fluent, S.Num(to_int(fact.value.value, scale))))
            if fact.fluent.name in guarded:
                init.append(S.Atom(_guard(fact.fluent.name), fact.fluent.args))
        else:
            init.append(fact)
    init.append(S.InitValue(TOTAL_COST, S.Num(0)))
    declared = {f.name for f in domain.functions}
    functions = list(domain.functions)
    if TOTAL_COST.name not in declared:
        functions.insert(0, S.FunctionDecl(TOTAL_COST.name, (), "number"))
    arities = {}
    for fact in problem.init:
        if isinstance(fact, S.InitValue):
            arities.setdefault(fact.fluent.name, len(fact.fluent.args))
    for a in domain.actions:
        for e in cost_effects(a.effect):
            if isinstance(e.value, S.FuncTerm):
                arities.setdefault(e.value.name, len(e.value.args))
    for name, arity in arities.items():
        if name not in declared and name != TOTAL_COST.name:
            functions.append(S.FunctionDecl(name, _params(arity), "number"))
    # One type for all: untyped declarations printed after typed ones would read back typed.
    functions = [S.FunctionDecl(f.name, f.params, "number") for f in functions]
    predicates = list(domain.predicates) + [
        S.PredicateDecl(_guard(n), _params(arities.get(n, 0))) for n in sorted(guarded)
    ]
    requirements = domain.requirements
    if requirements is not None and ":action-costs" not in requirements:
        requirements = requirements + (":action-costs",)
    new_domain = replace(
        domain,
        actions=tuple(actions),
        functions=tuple(functions),
        predicates=tuple(predicates),
        requirements=requirements,
    )
    new_problem = replace(problem, init=tuple(init), metric=S.Metric("minimize", TOTAL_COST))
    return Costed(new_domain, new_problem, scale)


def _function_names(actions) -> set[str]:
    """Functions mentioned by numeric conditions or effects of ``actions``."""
    return {
        x.name
        for a in actions
        for part in (a.precondition, a.effect)
        for x in S.walk(part)
        if isinstance(x, S.FuncTerm)
    }


def _guard(name: str) -> str:
    return f"has-cost-{name}"


def _params(arity: int) -> tuple[S.Typed, ...]:
    return tuple(S.Typed(f"?a{i}") for i in range(arity))


def _drop_costs(effect):
    if effect is None:
        return None
    parts = [
        e
        for e in S.conjuncts(effect)
        if not (isinstance(e, S.NumericEffect) and e.fluent.name == TOTAL_COST.name)
    ]
    return S.And(tuple(parts))


def _scale_effect(effect, scale: int):
    if effect is None:
        return None
    parts = []
    for e in S.conjuncts(effect):
        if (
            isinstance(e, S.NumericEffect)
            and e.fluent.name == TOTAL_COST.name
            and isinstance(e.value, S.Num)
        ):
            e = S.NumericEffect(e.op, TOTAL_COST, S.Num(to_int(e.value.value, scale)))
        parts.append(e)
    return S.And(tuple(parts))
