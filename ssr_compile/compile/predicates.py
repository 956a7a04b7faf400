"""Stream-file predicates (``(:predicate (P ?args) domain)``): a truth value of a predicate the
domain uses, computed by the streams module's Python function over its arguments.

Over real arguments the solver evaluates a predicate before planning (the true instances
become facts).  Over arguments not evaluated yet (optimistic objects), the predicate takes
its *optimistic value*: the value that permits most plans, read from how the domain uses it
(:func:`optimistic_truth`) -- true when the actions, the goal, the derived predicates they
rely on and the stream domains use it only positively, false otherwise (pddlstream's default:
a predicate is mostly used negated, ``(not (BCollision ?l ?o ?d))``).  A plan that relies on
an optimistic value has it checked in its stream plan: an instance that is optimistically
true is a test certifying ``(P args)`` (:func:`predicate_tests`); one that is optimistically
false is checked where the plan's preimage relies on its absence (``Instantiation.negated``).
"""

from __future__ import annotations

from collections import defaultdict

from .. import syntax as S


def optimistic_truth(
    domain: S.Domain, streams: S.StreamFile | None, problem: S.Problem | None
) -> dict[str, bool]:
    """The optimistic value of each predicate ``streams`` declares (see the module doc)."""
    if streams is None or not streams.predicates:
        return {}
    signs = domain_signs(domain, streams, problem)
    return {p.name: signs.get(p.name) == {True} for p in streams.predicates}


def domain_signs(
    domain: S.Domain, streams: S.StreamFile | None, problem: S.Problem | None
) -> dict[str, set[bool]]:
    """For each predicate, the signs it is read with (True: where it being true permits
    plans) by the actions, the goal, the derived predicates they rely on (a derived
    predicate read with a sign passes it on to its body) and the stream domains."""
    signs: dict[str, set[bool]] = defaultdict(set)
    roots: list[S.Formula | None] = [problem.goal if problem is not None else None]
    for a in domain.actions:
        roots.append(a.precondition)
        roots.extend(when_conditions(a.effect))
    for root in roots:
        _signs(root, True, signs)
    if streams is not None:
        for block in (*streams.streams, *streams.rules):
            _signs(block.domain, True, signs)
        for p in streams.predicates:
            _signs(p.domain, True, signs)
    axioms: dict[str, list[S.Axiom]] = defaultdict(list)
    for ax in domain.axioms:
        axioms[ax.name].append(ax)
    done: set[tuple[str, bool]] = set()
    changed = True
    while changed:
        changed = False
        for name, body_of in axioms.items():
            for sign in tuple(signs.get(name, ())):
                if (name, sign) not in done:
                    done.add((name, sign))
                    changed = True
                    for ax in body_of:
                        _signs(ax.body, sign, signs)
    return signs


def when_conditions(effect) -> list:
    """The conditions of the conditional effects in ``effect``."""
    out: list = []
    if isinstance(effect, S.And):
        for e in effect.args:
            out.extend(when_conditions(e))
    elif isinstance(effect, S.Forall | S.Timed):
        out.extend(when_conditions(effect.body))
    elif isinstance(effect, S.When):
        out.append(effect.condition)
        out.extend(when_conditions(effect.effect))
    return out


def _signs(f, positive: bool, signs: dict[str, set[bool]]) -> None:
    """Record the sign (positive or under a negation) of each atom of ``f``."""
    if f is None:
        return
    if isinstance(f, S.Atom):
        signs[f.pred].add(positive)
    elif isinstance(f, S.Not):
        _signs(f.arg, not positive, signs)
    elif isinstance(f, S.Imply):
        _signs(f.left, not positive, signs)
        _signs(f.right, positive, signs)
    elif isinstance(f, S.And | S.Or | S.Exists | S.Forall | S.Timed):
        for part in S.children(f):
            _signs(part, positive, signs)


def predicate_tests(streams: S.StreamFile, certify: bool = True) -> list[S.Stream]:
    """Each stream predicate as a test stream over its parameters, certifying ``(P args)``
    (with ``certify``; else certifying nothing)."""
    return [
        S.Stream(
            p.name,
            p.params,
            p.domain,
            certified=S.Atom(p.name, tuple(S.Var(t.name) for t in p.params)) if certify else None,
            span=p.span,
        )
        for p in streams.predicates
    ]
