"""Compile pass — a derived predicate's existential split at the object its one fluent atom is
about, for backends that read axioms (Fast Downward).

The kitchen's ``(unsafe ?o ?pb)`` holds when some other object ``?o2`` stands at some pose
``?pb2`` that collides with ``?o`` at ``?pb``: ``(exists (?o2 ?pb2) (and (atposeb ?o2 ?pb2)
...statics...))``.  Its ground rules, one per colliding pair ``(o2, pb2)``, each have one fluent
condition, ``atposeb(o2, pb2)``; in Fast Downward's multi-valued task that is one value of
``o2``'s pose variable.  A heuristic that needs ``(not (unsafe o pb))`` (the ``place`` action's
precondition) asks Fast Downward for the negated rules, the conjunction of the rules' negations
as a disjunction of conjunctions: every value of every other object's pose variable that is not
one of its colliding poses, multiplied out over the objects.  With six boxes around the block
that was 2.9 million unary operators; the search binary spent 45 s building its heuristics and
0.1 s per state evaluated on a task of 1,900 ground actions (a cluttered kitchen's replan).

Written with the existential split, ``(unsafe ?o ?pb)`` becomes ``(exists (?o2) (unsafe-per-o2
?o ?pb ?o2))`` and ``(unsafe-per-o2 ?o ?pb ?o2)`` keeps the rest, ``(exists (?pb2) ...)``: the
negation of ``unsafe`` is then one rule over the helper's binary variables, and the negation of
each helper is over one pose variable only (its other values).  The same task: 7,500 unary
operators, 0.1 s in all.

The rewrite is logical identity (``exists x, y: C`` is ``exists x: (exists y: C)``); it applies
to a disjunct of a derived predicate's body that is a conjunction of literals with exactly one
fluent literal (a positive atom of a predicate some action changes) naming at least two of the
disjunct's quantified variables; the split is at the first of them (PDDL's habit: the object
first, then what it is at).  Only predicates whose false value a heuristic may need are split:
those read negatively by an action, the goal or another axiom, and what their bodies read
positively.  No action changes, so plans map back as they are.
"""

from __future__ import annotations

from dataclasses import replace

from .. import syntax as S
from ..formulas import changed_atoms, free_variables
from .formulas import nnf
from .result import PassResult


def _literals(f) -> list | None:
    """The conjunction ``f`` as a list of literals, or None when it is not one."""
    if isinstance(f, S.And):
        out = []
        for part in f.args:
            sub = _literals(part)
            if sub is None:
                return None
            out.extend(sub)
        return out
    if isinstance(f, S.Atom | S.Compare) or (
        isinstance(f, S.Not) and isinstance(f.arg, S.Atom | S.Compare)
    ):
        return [f]
    return None


def _disjuncts(f, bound: tuple[S.Typed, ...] = ()) -> list[tuple[tuple[S.Typed, ...], object]]:
    """``f`` (in NNF) as a disjunction of existentially quantified parts: (variables, body)."""
    if isinstance(f, S.Or):
        return [d for part in f.args for d in _disjuncts(part, bound)]
    if isinstance(f, S.Exists):
        names = {p.name for p in bound}
        if any(p.name in names for p in f.params):  # shadowing: leave the formula whole
            return [(bound, f)]
        return _disjuncts(f.body, bound + tuple(f.params))
    return [(bound, f)]


def _polarities(f, positive: bool, out: dict[str, set[bool]], derived: set[str]) -> None:
    if f is None:
        return
    if isinstance(f, S.Atom):
        if f.pred in derived:
            out.setdefault(f.pred, set()).add(positive)
    elif isinstance(f, S.Not):
        _polarities(f.arg, not positive, out, derived)
    elif isinstance(f, S.Imply):
        _polarities(f.left, not positive, out, derived)
        _polarities(f.right, positive, out, derived)
    elif isinstance(f, S.When):
        _polarities(f.condition, positive, out, derived)
    else:
        for child in S.children(f):
            _polarities(child, positive, out, derived)


def negatively_needed(domain: S.Domain, problem: S.Problem | None) -> set[str]:
    """Derived predicates whose false value some condition reads, directly or through the body
    of another such predicate (where they are read positively)."""
    derived = {ax.name for ax in domain.axioms}
    uses: dict[str, set[bool]] = {}
    for action in domain.actions:
        _polarities(action.precondition, True, uses, derived)
        _polarities(action.effect, True, uses, derived)
    if problem is not None and problem.goal is not None:
        _polarities(problem.goal, True, uses, derived)
    body_uses = {}
    for ax in domain.axioms:
        inner: dict[str, set[bool]] = {}
        _polarities(ax.body, True, inner, derived)
        body_uses[ax.name] = inner
        for name, signs in inner.items():
            if False in signs:
                uses.setdefault(name, set()).add(False)
    needed = {name for name, signs in uses.items() if False in signs}
    todo = list(needed)
    while todo:
        for name, signs in body_uses.get(todo.pop(), {}).items():
            if True in signs and name not in needed:
                needed.add(name)
                todo.append(name)
    return needed


def split_axioms(domain: S.Domain, problem: S.Problem | None) -> PassResult:
    """The task with the existentials of negatively needed derived predicates split (module
    docstring); the same task when nothing fits."""
    if not domain.axioms:
        return PassResult(domain, problem)
    needed = negatively_needed(domain, problem)
    fluent = {a.pred for action in domain.actions for a in changed_atoms(action.effect)}
    derived = {ax.name for ax in domain.axioms}
    taken = {p.name for p in domain.predicates} | derived
    new_axioms: list[S.Axiom] = []
    new_preds: list[S.PredicateDecl] = []
    changed = False
    for ax in domain.axioms:
        if ax.name not in needed:
            new_axioms.append(ax)
            continue
        head_types = {p.name: p for p in ax.parameters}
        parts, split_any = [], False
        for bound, body in _disjuncts(nnf(ax.body)):
            split = _split(ax, bound, body, fluent, derived, head_types, taken)
            if split is None:
                parts.append(S.Exists(bound, body) if bound else body)
                continue
            disjunct, helper = split
            parts.append(disjunct)
            new_axioms.append(helper)
            new_preds.append(S.PredicateDecl(helper.name, helper.parameters))
            taken.add(helper.name)
            split_any = True
        if split_any:
            changed = True
            new_axioms.append(replace(ax, body=parts[0] if len(parts) == 1 else S.Or(tuple(parts))))
        else:
            new_axioms.append(ax)
    if not changed:
        return PassResult(domain, problem)
    return PassResult(
        replace(domain, axioms=tuple(new_axioms), predicates=domain.predicates + tuple(new_preds)),
        problem,
    )


def _split(ax: S.Axiom, bound, body, fluent, derived, head_types, taken):
    """One disjunct ``exists bound: body`` of ``ax`` as ``exists key: helper(...)`` and the
    helper's axiom, or None when it does not fit (module docstring)."""
    literals = _literals(body)
    if literals is None or len(bound) < 2:
        return None
    moving = [
        lit
        for lit in literals
        if (
            isinstance(lit, S.Not)
            and isinstance(lit.arg, S.Atom)
            and lit.arg.pred in fluent | derived
        )
        or (isinstance(lit, S.Atom) and lit.pred in fluent | derived)
    ]
    if len(moving) != 1 or not isinstance(moving[0], S.Atom) or moving[0].pred in derived:
        return None
    names = {p.name: p for p in bound}
    inside = list(
        dict.fromkeys(a.name for a in moving[0].args if isinstance(a, S.Var) and a.name in names)
    )
    if len(inside) < 2:
        return None
    key = names[inside[0]]
    rest = tuple(p for p in bound if p.name != key.name)
    free = [v.name for v in free_variables(body) if v.name not in names]
    if any(n not in head_types for n in free):
        return None
    head = [head_types[n] for n in dict.fromkeys(free)]
    stem = f"{ax.name}-per-{key.name.lstrip('?')}"
    name, i = stem, 1
    while name in taken:
        i += 1
        name = f"{stem}-{i}"
    helper = S.Axiom(name, (*head, key), S.Exists(rest, body) if rest else body)
    atom = S.Atom(name, tuple(S.Var(p.name) for p in (*head, key)))
    return S.Exists((key,), atom), helper
