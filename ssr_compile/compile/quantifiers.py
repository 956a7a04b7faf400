"""Lowering pass — quantifiers expanded over the problem's objects (respecting types).

:func:`expand_quantifiers` returns a :class:`~.result.PassResult`; no action is renamed, so
plans map back unchanged."""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import replace

from .. import syntax as S
from ..errors import UnsupportedError
from .formulas import substitute
from .result import PassResult

MAX_EXPANSION = 200_000


# ---------------------------------------------------------------- quantifiers


def objects_by_type(domain: S.Domain, problem: S.Problem) -> Callable[[S.TypeRef], list[str]]:
    parents: dict[str, set[str]] = {}
    for t in domain.types:
        if isinstance(t.type, S.Either):
            parents.setdefault(t.name, set()).update(t.type.types)
        elif t.type is not None:
            parents.setdefault(t.name, set()).add(t.type)

    def ancestors(t: str | None) -> set[str]:
        out = {"object"}
        stack = [t] if t else []
        while stack:
            x = stack.pop()
            if x not in out:
                out.add(x)
                stack.extend(parents.get(x, ()))
        return out

    everything = [
        (o.name, ancestors(o.type if isinstance(o.type, str) else None))
        for o in (*domain.constants, *problem.objects)
    ]

    def of(t: S.TypeRef) -> list[str]:
        if t is None:
            return [n for n, _ in everything]
        wanted = set(t.types) if isinstance(t, S.Either) else {t}
        return [n for n, anc in everything if anc & wanted]

    return of


def expand_quantifiers(domain: S.Domain, problem: S.Problem) -> PassResult:
    of_type = objects_by_type(domain, problem)
    budget = [MAX_EXPANSION]

    def groundings(params):
        choices = [of_type(p.type) for p in params]
        size = 1
        for c in choices:
            size *= len(c)
        budget[0] -= size
        if budget[0] < 0:
            raise UnsupportedError(
                f"expanding quantifiers needs more than {MAX_EXPANSION} copies; use a planner with "
                "quantifier support (such as fd)"
            )
        for combo in itertools.product(*choices):
            yield {p.name: S.Const(v) for p, v in zip(params, combo)}

    def cond(f):
        if isinstance(f, S.Exists | S.Forall):
            parts = tuple(cond(substitute(f.body, m)) for m in groundings(f.params))
            return S.Or(parts) if isinstance(f, S.Exists) else S.And(parts)
        if isinstance(f, S.And | S.Or):
            return type(f)(tuple(cond(a) for a in f.args))
        if isinstance(f, S.Not):
            return S.Not(cond(f.arg))
        if isinstance(f, S.Imply):
            return S.Imply(cond(f.left), cond(f.right))
        return f

    def eff(f):
        if f is None:
            return None
        if isinstance(f, S.Forall):
            return S.And(tuple(eff(substitute(f.body, m)) for m in groundings(f.params)))
        if isinstance(f, S.And):
            return S.And(tuple(eff(a) for a in f.args))
        if isinstance(f, S.When):
            return S.When(cond(f.condition), eff(f.effect))
        return f

    actions = tuple(
        replace(
            a,
            precondition=cond(a.precondition) if a.precondition is not None else None,
            effect=eff(a.effect),
        )
        for a in domain.actions
    )
    axioms = tuple(replace(ax, body=cond(ax.body)) for ax in domain.axioms)
    goal = cond(problem.goal) if problem.goal is not None else None
    return PassResult(replace(domain, actions=actions, axioms=axioms), replace(problem, goal=goal))
