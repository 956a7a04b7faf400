"""Tests the domain relies on only where they hold, checked where a plan relies on them.

A collision test such as ``test-cfree`` certifies ``(CFree ?b ?p ?b2 ?p2)``, and the domain
reads it under a negation: ``(Unsafe ?b ?p)`` holds where some other block rests at a pose
not known to be free.  Optimistic instantiation then certifies ``CFree`` for every pair of a
pose and a pose of another object, real or optimistic: the pairs are most of the optimistic
problem (the inspect family's N = 8 kitchen: 19,000 of 22,000 stream instances, 20,000 of
the 26,000 facts of the planner's task), and each compile and each translation pays for
them.

:func:`lazy_tests` turns such a test into its complement, a stream predicate
``(ssr-fails-<test> args)`` that is optimistically false: the optimistic problem states it
only for pairs evaluated and found to fail, and a plan that relies on its absence has the
test evaluated in its stream plan (``Instantiation.negated``, the machinery of stream-file
predicates).  Over real arguments it is evaluated before planning, as a cheap test is.

The rewrite ``P(args) -> (not (ssr-fails-T args))`` is exact only where the test's domain
holds: outside it the test is never evaluated and ``P`` is false.  So a test is turned only
when, at each place the domain mentions ``P``, the atoms of the test's domain (over the same
arguments) are conjoined with it, in an enclosing ``and`` or the antecedent of an enclosing
``imply``, or follow from an atom conjoined so: a static atom that only streams certify
brings the facts every one of them certifies or requires with it (continuous_tamp's
``(Kin ?b ?q ?p ?g)`` brings ``(Pose ?b ?p)``, which the stream that certifies it requires).
There ``P`` and the negated complement agree.  Otherwise the test stays as it is.
Other conditions: the test has no fluents, its domain is a conjunction of atoms, it
certifies exactly ``P`` over its inputs; ``P`` is no other stream's or rule's, no action
changes it, no derived predicate is named so, the problem states none and its goal does not
mention it; and the domain reads it only where it being true permits plans (so that the
complement, false until evaluated, is the permissive value).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, replace

from .. import syntax as S
from ..formulas import atoms, changed_atoms
from .formulas import substitute
from .predicates import domain_signs, when_conditions

PREFIX = "ssr-fails-"


@dataclass(frozen=True)
class LazyTests:
    """The domain and stream file with the tests turned (:func:`lazy_tests`), and for each
    complement predicate the test it stands for."""

    domain: S.Domain
    streams: S.StreamFile
    tests: dict[str, str]  # complement predicate -> test stream


def lazy_tests(
    domain: S.Domain, streams: S.StreamFile, problem: S.Problem, candidates: Iterable[str]
) -> LazyTests:
    """Turn each test of ``candidates`` that qualifies (module doc) into its complement."""
    wanted = set(candidates)
    turned: dict[str, tuple[S.Stream, str]] = {}  # certified predicate -> (test, complement)
    taken = {p.name for p in domain.predicates} | {p.name for p in streams.predicates}
    signs = None
    implied = None
    for t in streams.streams:
        if t.name not in wanted or not t.is_test:
            continue
        pred = _certified_predicate(t)
        if pred is None or PREFIX + t.name in taken:
            continue
        if signs is None:
            signs = domain_signs(domain, streams, problem)
        if signs.get(pred) != {True} or not _only_here(pred, t, domain, streams, problem):
            continue
        if implied is None:
            implied = _implications(domain, streams, problem)
        if not all(_guarded(pred, t, root, implied) for root in _roots(domain)):
            continue
        turned[pred] = (t, PREFIX + t.name)
    if not turned:
        return LazyTests(domain, streams, {})
    out_domain = replace(
        domain,
        predicates=domain.predicates
        + tuple(S.PredicateDecl(c, t.inputs) for t, c in turned.values()),
        axioms=tuple(replace(a, body=_rewrite(a.body, turned)) for a in domain.axioms),
        actions=tuple(
            replace(
                a,
                precondition=_rewrite(a.precondition, turned),
                effect=_rewrite_conditions(a.effect, turned),
            )
            for a in domain.actions
        ),
    )
    names = {t.name for t, _c in turned.values()}
    out_streams = replace(
        streams,
        streams=tuple(s for s in streams.streams if s.name not in names),
        predicates=streams.predicates
        + tuple(S.StreamPredicate(c, t.inputs, t.domain) for t, c in turned.values()),
    )
    return LazyTests(out_domain, out_streams, {c: t.name for t, c in turned.values()})


def _certified_predicate(t: S.Stream) -> str | None:
    """``P`` when ``t`` qualifies by its own declaration (module doc), else None."""
    if t.fluents:
        return None
    dom = S.conjuncts(t.domain)
    if not all(isinstance(a, S.Atom) and a.pred != "=" for a in dom):
        return None
    cert = S.conjuncts(t.certified)
    if len(cert) != 1 or not isinstance(cert[0], S.Atom):
        return None
    args = cert[0].args
    inputs = [p.name for p in t.inputs]
    if not all(isinstance(a, S.Var) for a in args):
        return None
    names = [a.name for a in args]
    if len(set(names)) != len(names) or set(names) != set(inputs):
        return None
    return cert[0].pred


def _only_here(pred: str, t: S.Stream, domain, streams, problem) -> bool:
    """No other stream or rule certifies ``pred``, no stream domain, action effect or
    derived predicate's head mentions it, the problem states none and its goal does not
    mention it."""
    for s in (*streams.streams, *streams.rules):
        if s is not t and pred in _read(s.certified):
            return False
    for s in (*streams.streams, *streams.rules, *streams.functions, *streams.predicates):
        if pred in _read(s.domain):
            return False
    if any(a.name == pred for a in domain.axioms):
        return False
    if any(x.pred == pred for a in domain.actions for x in changed_atoms(a.effect)):
        return False
    if any(isinstance(f, S.Atom) and f.pred == pred for f in problem.init):
        return False
    return pred not in _read(problem.goal)


def _roots(domain: S.Domain) -> list:
    """Every formula of the domain that reads predicates: preconditions, conditions of
    conditional effects, bodies of derived predicates."""
    out: list = [a.body for a in domain.axioms]
    for a in domain.actions:
        out.append(a.precondition)
        out.extend(when_conditions(a.effect))
    return out


def _implications(domain: S.Domain, streams: S.StreamFile, problem: S.Problem) -> dict:
    """For each static predicate that streams and rules certify: ``(pattern, implied)``, the
    atoms (over the pattern's variables) that hold wherever an atom of it does -- those every
    stream or rule certifying it requires or certifies with it, and that every fact of it
    the problem states comes with."""
    changed = {ax.name for ax in domain.axioms}
    changed |= {x.pred for a in domain.actions for x in changed_atoms(a.effect)}
    found: dict[str, tuple[S.Atom, set[S.Atom]]] = {}
    refused: set[str] = set()
    for block in (*streams.streams, *streams.rules):
        certified = [a for a in S.conjuncts(block.certified) if isinstance(a, S.Atom)]
        around = [a for a in S.conjuncts(block.domain) if isinstance(a, S.Atom)] + certified
        for c in certified:
            if c.pred in changed or c.pred in refused or c.pred == "=":
                continue
            if not all(isinstance(x, S.Var) for x in c.args):
                refused.add(c.pred)
                continue
            names = [x.name for x in c.args]
            if len(set(names)) != len(names):
                refused.add(c.pred)
                continue
            pattern = S.Atom(c.pred, tuple(S.Var(f"?{i}") for i in range(len(names))))
            rename = {n: S.Var(f"?{i}") for i, n in enumerate(names)}
            here = {
                substitute(a, rename)
                for a in around
                if a is not c
                and a.pred != "="
                and all(not isinstance(x, S.Var) or x.name in rename for x in a.args)
            }
            if c.pred in found:
                found[c.pred][1].intersection_update(here)
            else:
                found[c.pred] = (pattern, here)
    init = {f for f in problem.init if isinstance(f, S.Atom)}
    for fact in init:
        if fact.pred in found:
            pattern, implied = found[fact.pred]
            env = {v.name: x for v, x in zip(pattern.args, fact.args)}
            implied.intersection_update({a for a in implied if substitute(a, env) in init})
    return {p: v for p, v in found.items() if p not in refused and v[1]}


def _closure(atoms, implied: dict) -> set[S.Atom]:
    """``atoms`` and what follows from them (:func:`_implications`), to a fixpoint."""
    out = set(atoms)
    todo = list(out)
    while todo:
        a = todo.pop()
        if a.pred not in implied:
            continue
        pattern, more = implied[a.pred]
        if len(pattern.args) != len(a.args):
            continue
        env = {v.name: x for v, x in zip(pattern.args, a.args)}
        for b in more:
            b = substitute(b, env)
            if b not in out:
                out.add(b)
                todo.append(b)
    return out


def _guarded(pred: str, t: S.Stream, f, implied: dict, context: frozenset = frozenset()) -> bool:
    """Each atom of ``pred`` in ``f`` has ``t``'s domain among the atoms conjoined with it
    (``context``: those of the enclosing ``and``s and ``imply`` antecedents, and what follows
    from them)."""
    if f is None:
        return True
    if isinstance(f, S.Atom):
        if f.pred != pred:
            return True
        cert = S.conjuncts(t.certified)[0]
        env = {v.name: a for v, a in zip(cert.args, f.args, strict=True)}
        needed = [substitute(a, env) for a in S.conjuncts(t.domain)]
        return all(a in context for a in needed)
    if isinstance(f, S.And):
        here = frozenset(
            _closure(context | {a for a in S.conjuncts(f) if isinstance(a, S.Atom)}, implied)
        )
        return all(_guarded(pred, t, a, implied, here) for a in f.args)
    if isinstance(f, S.Imply):
        left = {a for a in S.conjuncts(f.left) if isinstance(a, S.Atom)}
        here = frozenset(_closure(context | left, implied))
        return _guarded(pred, t, f.left, implied, context) and _guarded(
            pred, t, f.right, implied, here
        )
    if isinstance(f, S.Exists | S.Forall):
        bound = {p.name for p in f.params}
        kept = frozenset(a for a in context if not _mentions(a, bound))
        return _guarded(pred, t, f.body, implied, kept)
    if isinstance(f, S.Not | S.Or | S.Timed):
        return all(_guarded(pred, t, a, implied, context) for a in S.children(f))
    return pred not in _read(f)


def _mentions(atom: S.Atom, names: set[str]) -> bool:
    return any(isinstance(x, S.Var) and x.name in names for x in atom.args)


def _rewrite(f, turned: dict[str, tuple[S.Stream, str]]):
    """``f`` with each ``(P args)`` of a turned test replaced by ``(not (C args'))`` (and
    ``(not (P args))`` by ``(C args')``), ``args'`` in the order of the test's inputs."""
    if f is None:
        return None
    if isinstance(f, S.Atom):
        return S.Not(_complement(f, turned)) if f.pred in turned else f
    if isinstance(f, S.Not):
        if isinstance(f.arg, S.Atom) and f.arg.pred in turned:
            return _complement(f.arg, turned)
        return replace(f, arg=_rewrite(f.arg, turned))
    if isinstance(f, S.And | S.Or):
        return replace(f, args=tuple(_rewrite(a, turned) for a in f.args))
    if isinstance(f, S.Imply):
        return replace(f, left=_rewrite(f.left, turned), right=_rewrite(f.right, turned))
    if isinstance(f, S.Exists | S.Forall | S.Timed):
        return replace(f, body=_rewrite(f.body, turned))
    return f


def _rewrite_conditions(effect, turned):
    """``effect`` with the conditions of its conditional effects rewritten."""
    if isinstance(effect, S.And):
        return replace(effect, args=tuple(_rewrite_conditions(e, turned) for e in effect.args))
    if isinstance(effect, S.Forall | S.Timed):
        return replace(effect, body=_rewrite_conditions(effect.body, turned))
    if isinstance(effect, S.When):
        return replace(
            effect,
            condition=_rewrite(effect.condition, turned),
            effect=_rewrite_conditions(effect.effect, turned),
        )
    return effect


def _complement(atom: S.Atom, turned) -> S.Atom:
    t, c = turned[atom.pred]
    cert = S.conjuncts(t.certified)[0]
    by_var = {v.name: a for v, a in zip(cert.args, atom.args, strict=True)}
    return S.Atom(c, tuple(by_var[p.name] for p in t.inputs), span=atom.span)


def _read(f) -> set[str]:
    """The predicates of the atoms in ``f``."""
    return {a.pred for a in atoms(f)}
