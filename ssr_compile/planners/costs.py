"""The cost of a plan under a problem's metric, computed from the syntax tree.

Backends report costs in different ways (Fast Downward prints one, unified-planning and
pyperplan do not), so every backend computes :attr:`PlanResult.cost` here: the sum of the
``(increase (total-cost) v)`` effects of the plan's actions, where ``v`` is a number or a static
function looked up in the initial state, or the plan's length when the problem has no metric.
"""

from __future__ import annotations

from .. import syntax as S
from ..compile.costs import cost_effects
from ..errors import UnsupportedError
from .base import SOLVED, UNSOLVABLE, GroundAction, over_bound


def plan_cost(
    domain: S.Domain, problem: S.Problem, actions: list[GroundAction], values: dict | None = None
) -> float:
    """``values``: the problem's numeric values when the caller has them already
    (:func:`value_table`), instead of reading them from ``problem.init``."""
    if problem.metric is None:
        return len(actions)
    if values is None:
        values = problem_values(problem)
    by_name = {a.name: a for a in domain.actions}
    total: float = 0
    for name, args in actions:
        action = by_name.get(name)
        if action is None:
            raise UnsupportedError(f"plan uses unknown action {name!r}")
        binding = {p.name: a for p, a in zip(action.parameters, args)}
        for e in cost_effects(action.effect):
            total += _value(e.value, binding, values)
    return total


def value_table(values) -> dict:
    """Numeric values (``S.InitValue``s, or ``(FuncTerm, number)`` pairs) as
    :func:`plan_cost` reads them: by function name and argument names."""
    table = {}
    for v in values:
        term, x = (v.fluent, v.value.value) if isinstance(v, S.InitValue) else v
        table[(term.name, tuple(a.name for a in term.args))] = x
    return table


def problem_values(problem: S.Problem) -> dict:
    """The numeric values of ``problem``'s initial state, as :func:`plan_cost` reads them."""
    return value_table(v for v in problem.init if isinstance(v, S.InitValue))


def fractional_costs(domain: S.Domain, problem: S.Problem) -> list[str]:
    """Cost values that are not integers (Fast Downward accepts integer costs only)."""
    out = []
    for a in domain.actions:
        for e in cost_effects(a.effect):
            if isinstance(e.value, S.Num) and not float(e.value.value).is_integer():
                out.append(f"{a.name}: {e.value.value}")
    for v in problem.init:
        if isinstance(v, S.InitValue) and not float(v.value.value).is_integer():
            args = " ".join(a.name for a in v.fluent.args)
            out.append(f"({v.fluent.name}{' ' + args if args else ''}) = {v.value.value}")
    return out


def _value(e, binding: dict[str, str], values: dict) -> float:
    if isinstance(e, S.Num):
        return e.value
    if isinstance(e, S.FuncTerm):
        key = (e.name, tuple(binding.get(a.name, a.name) for a in e.args))
        if key not in values:
            raise UnsupportedError(f"no initial value for ({' '.join([key[0], *key[1]])})")
        return values[key]
    if isinstance(e, S.Arith):
        xs = [_value(a, binding, values) for a in e.args]
        if e.op == "-" and len(xs) == 1:
            return -xs[0]
        out = xs[0]
        for x in xs[1:]:
            out = {"+": out + x, "-": out - x, "*": out * x, "/": out / x}[e.op]
        return out
    raise UnsupportedError(f"cannot evaluate cost expression {e!r}")


def priced(result, domain: S.Domain, problem: S.Problem, actions: list[GroundAction], cost_bound):
    """The answer for a plan a backend found: its cost, refused when not below ``cost_bound``.

    ``result(status, message, actions, cost)`` builds the backend's :class:`PlanResult`.
    """
    cost = plan_cost(domain, problem, actions)
    refused = over_bound(cost, cost_bound)
    if refused:
        return result(UNSOLVABLE, refused)
    return result(SOLVED, "", actions, cost)
