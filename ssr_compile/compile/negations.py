"""Lowering pass — negative preconditions as complement predicates ``not-p`` kept in step by
the effects; negated equality as the ``ssr-distinct`` relation; equality with constants
substituted into the action (its parameter disappears).

:func:`remove_negations` returns a :class:`Negated`, whose map back puts the substituted
arguments back into the steps of the actions that lost parameters."""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field, replace

from .. import syntax as S
from ..errors import UnsupportedError
from .formulas import substitute
from .quantifiers import MAX_EXPANSION, objects_by_type
from .result import PassResult, Plan

DISTINCT = "ssr-distinct"


# ---------------------------------------------------------------- negation and equality


@dataclass
class Negated(PassResult):
    """The negations pass's result.  ``templates``: for each action whose equalities were
    substituted, its input parameters in order, each the position of the argument that now
    stands for it (int) or the constant substituted for it (str)."""

    templates: dict[str, tuple[int | str, ...]] = field(default_factory=dict)

    def map_plan(self, plan) -> Plan:
        out: Plan = []
        for name, args in plan:
            template = self.templates.get(name)
            if template is None:
                out.append((name, tuple(args)))
            else:
                out.append((name, tuple(args[t] if isinstance(t, int) else t for t in template)))
        return out


def remove_negations(domain: S.Domain, problem: S.Problem) -> Negated:
    """Complement predicates for negated atoms; equalities substituted away (STRIPS targets)."""
    templates: dict[str, tuple[int | str, ...]] = {}
    actions: list[S.Action] = []
    for a in domain.actions:
        new, template = _substitute_equalities(a)
        if new is None:
            continue  # an equality that can never hold
        if template is not None:
            templates[new.name] = template
        actions.append(new)
    negated: set[str] = set()
    for a in actions:
        for lit in S.conjuncts(a.precondition):
            if isinstance(lit, S.Not) and isinstance(lit.arg, S.Atom):
                negated.add(lit.arg.pred)
    for lit in S.conjuncts(problem.goal):
        if isinstance(lit, S.Not) and isinstance(lit.arg, S.Atom):
            negated.add(lit.arg.pred)
    if not negated:
        return Negated(replace(domain, actions=tuple(actions)), problem, templates)

    def neg_name(pred: str) -> str:
        # (not (= ?a ?b)) reads (ssr-distinct ?a ?b), true of every pair of distinct objects.
        return DISTINCT if pred == "=" else f"not-{pred}"

    def neg(atom: S.Atom) -> S.Atom:
        return S.Atom(neg_name(atom.pred), atom.args)

    def positive_pre(f):
        parts = []
        for lit in S.conjuncts(f):
            if isinstance(lit, S.Not) and isinstance(lit.arg, S.Atom) and lit.arg.pred in negated:
                parts.append(neg(lit.arg))
            else:
                parts.append(lit)
        return S.And(tuple(parts))

    def mirrored(effect):
        parts = []
        for e in S.conjuncts(effect):
            parts.append(e)
            if isinstance(e, S.Atom) and e.pred in negated:
                parts.append(S.Not(neg(e)))
            elif isinstance(e, S.Not) and isinstance(e.arg, S.Atom) and e.arg.pred in negated:
                parts.append(neg(e.arg))
        return S.And(tuple(parts))

    actions = [
        replace(a, precondition=positive_pre(a.precondition), effect=mirrored(a.effect))
        for a in actions
    ]
    decls = {p.name: p for p in domain.predicates}
    of_type = objects_by_type(domain, problem)
    init_true = {f for f in problem.init if isinstance(f, S.Atom)}
    extra_init: list[S.Atom] = []
    for pred in sorted(negated):
        decl = decls.get(pred)
        arity = 2 if pred == "=" else len(decl.params) if decl else _arity(pred, init_true, actions)
        types = [p.type for p in decl.params] if decl else [None] * arity
        combos = itertools.product(*(of_type(t) for t in types))
        count = 0
        for combo in combos:
            count += 1
            if count > MAX_EXPANSION:
                raise UnsupportedError(
                    f"the complement of '{pred}' has more than {MAX_EXPANSION} facts; use a planner "
                    "with negative preconditions"
                )
            atom = S.Atom(pred, tuple(S.Const(c) for c in combo))
            if pred == "=":
                if combo[0] != combo[1]:
                    extra_init.append(neg(atom))
            elif atom not in init_true:
                extra_init.append(neg(atom))
    predicates = list(domain.predicates) + [
        S.PredicateDecl(
            neg_name(p),
            (S.Typed("?a"), S.Typed("?b")) if p == "=" else decls[p].params if p in decls else (),
        )
        for p in sorted(negated)
    ]
    goal = positive_pre(problem.goal) if problem.goal is not None else None
    return Negated(
        replace(domain, actions=tuple(actions), predicates=tuple(predicates)),
        replace(problem, init=problem.init + tuple(extra_init), goal=goal),
        templates,
    )


def _arity(pred, facts, actions) -> int:
    for f in facts:
        if f.pred == pred:
            return len(f.args)
    for a in actions:
        for lit in S.conjuncts(a.precondition):
            atom = lit.arg if isinstance(lit, S.Not) else lit
            if isinstance(atom, S.Atom) and atom.pred == pred:
                return len(atom.args)
    return 0


def _substitute_equalities(a: S.Action):
    """Substitute ``(= ?p c)`` and ``(= ?p ?q)`` into an action.

    Returns ``(action, template)``: ``template`` maps the *original* parameters to the new
    action's argument positions (int) or to constants (str); ``None`` when nothing changed.
    ``(None, None)`` when the precondition can never hold.
    """
    lits = list(S.conjuncts(a.precondition))
    eqs = [lit for lit in lits if isinstance(lit, S.Atom) and lit.pred == "="]
    if not eqs:
        return a, None
    mapping: dict[str, S.Term] = {}

    def resolve(t):
        while isinstance(t, S.Var) and t.name in mapping:
            t = mapping[t.name]
        return t

    for eq in eqs:
        left, right = (resolve(t) for t in eq.args)
        if isinstance(left, S.Const) and isinstance(right, S.Const):
            if left.name != right.name:
                return None, None
        elif isinstance(left, S.Var):
            if left != right:
                mapping[left.name] = right
        else:
            mapping[right.name] = left
    full = {name: resolve(S.Var(name)) for name in mapping}
    rest = [substitute(lit, full) for lit in lits if lit not in eqs]
    params = tuple(p for p in a.parameters if p.name not in full)
    position = {p.name: i for i, p in enumerate(params)}
    template = []
    for p in a.parameters:
        t = full.get(p.name, S.Var(p.name))
        template.append(position[t.name] if isinstance(t, S.Var) else t.name)
    new = replace(
        a, parameters=params, precondition=S.And(tuple(rest)), effect=substitute(a.effect, full)
    )
    return new, tuple(template)
