"""Formula utilities shared by the passes: substitution, negation normal form, DNF."""

from __future__ import annotations

import itertools
from collections.abc import Callable, Mapping

from .. import syntax as S


def substitute(f, mapping: Mapping[str, S.Term]):
    """Replace variables (by name) in a formula, effect or numeric expression.

    Quantified variables shadow the mapping inside their scope.
    """
    if not mapping:
        return f
    if isinstance(f, S.Var):
        return mapping.get(f.name, f)
    if isinstance(f, S.Const | S.Num) or f is None:
        return f
    if isinstance(f, S.Atom):
        return S.Atom(f.pred, tuple(substitute(a, mapping) for a in f.args), span=f.span)
    if isinstance(f, S.FuncTerm):
        return S.FuncTerm(f.name, tuple(substitute(a, mapping) for a in f.args), span=f.span)
    if isinstance(f, S.Arith):
        return S.Arith(f.op, tuple(substitute(a, mapping) for a in f.args), span=f.span)
    if isinstance(f, S.Not):
        return S.Not(substitute(f.arg, mapping), span=f.span)
    if isinstance(f, S.And):
        return S.And(tuple(substitute(a, mapping) for a in f.args), span=f.span)
    if isinstance(f, S.Or):
        return S.Or(tuple(substitute(a, mapping) for a in f.args), span=f.span)
    if isinstance(f, S.Imply):
        return S.Imply(substitute(f.left, mapping), substitute(f.right, mapping), span=f.span)
    if isinstance(f, S.Exists | S.Forall):
        inner = {k: v for k, v in mapping.items() if k not in {p.name for p in f.params}}
        return type(f)(f.params, substitute(f.body, inner), span=f.span)
    if isinstance(f, S.Compare):
        return S.Compare(
            f.op, substitute(f.left, mapping), substitute(f.right, mapping), span=f.span
        )
    if isinstance(f, S.When):
        return S.When(substitute(f.condition, mapping), substitute(f.effect, mapping), span=f.span)
    if isinstance(f, S.NumericEffect):
        return S.NumericEffect(
            f.op, substitute(f.fluent, mapping), substitute(f.value, mapping), span=f.span
        )
    if isinstance(f, S.Timed):
        return S.Timed(f.when, substitute(f.body, mapping), span=f.span)
    raise TypeError(f"cannot substitute into {type(f).__name__}")


def map_atoms(f, fn: Callable[[S.Atom], object]):
    """Rebuild a formula with every atom replaced by ``fn(atom)`` (a formula)."""
    if isinstance(f, S.Atom):
        return fn(f)
    if isinstance(f, S.Not):
        return S.Not(map_atoms(f.arg, fn), span=f.span)
    if isinstance(f, S.And):
        return S.And(tuple(map_atoms(a, fn) for a in f.args), span=f.span)
    if isinstance(f, S.Or):
        return S.Or(tuple(map_atoms(a, fn) for a in f.args), span=f.span)
    if isinstance(f, S.Imply):
        return S.Imply(map_atoms(f.left, fn), map_atoms(f.right, fn), span=f.span)
    if isinstance(f, S.Exists | S.Forall):
        return type(f)(f.params, map_atoms(f.body, fn), span=f.span)
    if isinstance(f, S.When):
        return S.When(map_atoms(f.condition, fn), map_atoms(f.effect, fn), span=f.span)
    return f


def conj(*parts) -> S.Formula:
    """A flattened conjunction (``None`` parts dropped; one part is returned as itself)."""
    out = []
    for p in parts:
        if p is None:
            continue
        if isinstance(p, S.And):
            out.extend(p.args)
        else:
            out.append(p)
    return out[0] if len(out) == 1 else S.And(tuple(out))


def nnf(f, negate: bool = False):
    """Negation normal form: ``not`` only on atoms; ``imply`` removed."""
    if isinstance(f, S.Atom | S.Compare):
        return S.Not(f) if negate else f
    if isinstance(f, S.Not):
        return nnf(f.arg, not negate)
    if isinstance(f, S.And):
        parts = tuple(nnf(a, negate) for a in f.args)
        return S.Or(parts) if negate else S.And(parts)
    if isinstance(f, S.Or):
        parts = tuple(nnf(a, negate) for a in f.args)
        return S.And(parts) if negate else S.Or(parts)
    if isinstance(f, S.Imply):
        return nnf(S.Or((S.Not(f.left), f.right)), negate)
    if isinstance(f, S.Exists):
        body = nnf(f.body, negate)
        return S.Forall(f.params, body) if negate else S.Exists(f.params, body)
    if isinstance(f, S.Forall):
        body = nnf(f.body, negate)
        return S.Exists(f.params, body) if negate else S.Forall(f.params, body)
    raise TypeError(f"not a condition: {type(f).__name__}")


class TooLarge(ValueError):
    """A normal form would have more clauses than allowed."""


def dnf(f, limit: int = 4096) -> list[list]:
    """Disjunctive normal form of a quantifier-free NNF condition: a list of literal lists.

    Raises :class:`TooLarge` beyond ``limit`` clauses (DNF can grow exponentially).
    """
    if f is None:
        return [[]]
    if isinstance(f, S.And):
        result: list[list] = [[]]
        for part in f.args:
            options = dnf(part, limit)
            if len(result) * len(options) > limit:
                raise TooLarge(f"more than {limit} disjuncts")
            result = [a + b for a, b in itertools.product(result, options)]
        return result
    if isinstance(f, S.Or):
        out = [clause for part in f.args for clause in dnf(part, limit)]
        if len(out) > limit:
            raise TooLarge(f"more than {limit} disjuncts")
        return out
    if isinstance(f, S.Exists | S.Forall):
        raise ValueError("quantifiers must be removed before DNF")
    return [[f]]


def has(f, *types) -> bool:
    """Does the formula contain a node of one of ``types``?"""
    return any(isinstance(x, types) for x in S.walk(f))
