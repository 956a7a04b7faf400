"""Lowering pass — quantified preconditions guarded by the action's static atoms.

A lifted planner's translator turns a universal precondition ``(forall (?y) phi)`` of an
action into a derived predicate over the formula's free variables, defined by
``(exists (?y) (not phi))``.  When those variables (action parameters) occur in ``phi`` only
in negative literals -- continuous TAMP's ``(forall (?b2 ?p2) (imply (and (Pose ?b2 ?p2)
(AtPose ?b2 ?p2)) (CFree ?b ?p ?b2 ?p2)))`` -- nothing binds them, and the translator
instantiates the new predicate for every tuple of objects: with the hundreds of optimistic
objects of a compiled problem, most of the planner's time.

The action's precondition already requires its static atoms (facts no action changes, such as
``(Kin ?b ?q ?p ?g)``), so conjoining them to the quantified formula changes nothing where the
action applies: ``(forall (?y) phi)`` becomes ``(forall (?y) (imply G phi))`` and
``(not (exists (?y) psi))`` becomes ``(not (exists (?y) (and G psi)))``, with ``G`` the static
atoms of the precondition's top-level conjunction that share a variable with the formula.
The new predicate is then only instantiated where ``G`` holds.

:func:`guard_quantifiers` returns a :class:`~.result.PassResult`; actions keep their names and
parameters, so plans map back unchanged.
"""

from __future__ import annotations

from dataclasses import replace

from .. import syntax as S
from ..formulas import atoms, free_variables
from .result import PassResult


def changed_predicates(domain: S.Domain) -> set[str]:
    """Predicates some action's effect adds or deletes, and the derived ones."""
    out = {ax.name for ax in domain.axioms}
    for a in domain.actions:
        out.update(x.pred for x in atoms(a.effect))  # a when's condition included
    return out


def guard_quantifiers(domain: S.Domain, problem: S.Problem | None) -> PassResult:
    """Guard the universal (and negated existential) conjuncts of each action's precondition
    with the precondition's static atoms (see the module docstring)."""
    fluent = changed_predicates(domain)
    actions = []
    changed = False
    for action in domain.actions:
        new = _guarded(action, fluent)
        changed |= new is not action
        actions.append(new)
    if not changed:
        return PassResult(domain, problem)
    return PassResult(replace(domain, actions=tuple(actions)), problem)


def _guarded(action: S.Action, fluent: set[str]) -> S.Action:
    parts = S.conjuncts(action.precondition)
    params = {p.name for p in action.parameters}
    static = [
        a
        for a in parts
        if isinstance(a, S.Atom)
        and a.pred != "="
        and a.pred not in fluent
        and any(isinstance(t, S.Var) and t.name in params for t in a.args)
    ]
    if not static:
        return action
    out = []
    changed = False
    for part in parts:
        new = _guard(part, static, params)
        changed |= new is not part
        out.append(new)
    if not changed:
        return action
    precondition = out[0] if len(out) == 1 else S.And(tuple(out), span=action.precondition.span)
    return replace(action, precondition=precondition)


def _guard(part, static: list[S.Atom], params: set[str]):
    if isinstance(part, S.Forall):
        quantified = part
    elif isinstance(part, S.Not) and isinstance(part.arg, S.Exists):
        quantified = part.arg
    else:
        return part
    bound = {p.name for p in quantified.params}  # a guard naming these would be captured
    free = {v.name for v in free_variables(quantified)} & params
    if not free:
        return part
    guard = tuple(
        a
        for a in static
        if not any(isinstance(t, S.Var) and t.name in bound for t in a.args)
        and any(isinstance(t, S.Var) and t.name in free for t in a.args)
    )
    if not guard:
        return part
    g = guard[0] if len(guard) == 1 else S.And(guard)
    if isinstance(part, S.Forall):
        return S.Forall(part.params, S.Imply(g, part.body), span=part.span)
    body = S.And((*guard, *S.conjuncts(quantified.body)))
    return S.Not(S.Exists(quantified.params, body, span=quantified.span), span=part.span)
