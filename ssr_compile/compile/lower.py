"""Pass 5 — lowering to what a planner backend supports.

A backend states its :class:`~ssr_compile.planners.base.Capabilities` (costs, axioms, negative
preconditions, disjunction, quantifiers, conditional effects); this pass rewrites the plain
domain and problem to fit, and returns a map from a plan of its output back to its input:

* axioms  -> derived predicates inlined (:mod:`.derived`);
* quantifiers -> expanded over the problem's objects (respecting types);
* disjunction / ``imply`` -> each action split into one copy per disjunct of its precondition's
  DNF (``a--1``, ``a--2``...); a disjunctive goal gets one ``ssr-goal--k`` action per disjunct;
* negative preconditions -> complement predicates ``not-p`` kept in step by the effects, and
  equality with constants substituted into the action (its parameter disappears);
* costs -> unit costs (else integer costs, scaled and rounded up, by :mod:`.costs`);
* names -> renamed where a reader would refuse them (an action named like a predicate, ``@x``),
  mapped back by :meth:`Lowered.map_plan`.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass, replace

from .. import syntax as S
from ..errors import UnsupportedError
from .costs import compile_costs
from .derived import compile_away, normalise_axiom_bodies
from .formulas import TooLarge, conj, dnf, has, map_atoms, nnf, substitute
from .ground import Grounded, ground
from .rename import Renaming, rename_task

Plan = list[tuple[str, tuple[str, ...]]]
MAX_EXPANSION = 200_000
GOAL_ACTION = "ssr-goal"
GOAL_REACHED = S.Atom("ssr-goal-reached")
DISTINCT = "ssr-distinct"


@dataclass
class Lowered:
    domain: S.Domain
    problem: S.Problem
    scale: int
    # lowered action name -> (original name, argument template); a template entry is an int
    # (index into the lowered action's arguments) or a str (a constant substituted in).
    templates: dict[str, tuple[str, tuple[int | str, ...]]]
    # names changed so that every reader accepts them (see :func:`lower`)
    renaming: Renaming | None = None
    # ground action name -> (lifted action, arguments), when the task was grounded
    grounded: Grounded | None = None

    def map_plan(self, plan: Plan) -> Plan:
        out: Plan = []
        if self.renaming:
            plan = self.renaming.plan_back(list(plan))
        for name, args in plan:
            if name.startswith(GOAL_ACTION):
                continue
            original, template = self.templates.get(name, (name, None))
            if template is None:
                out.append((original, tuple(args)))
            else:
                out.append(
                    (original, tuple(args[t] if isinstance(t, int) else t for t in template))
                )
        if self.grounded is not None:
            out = self.grounded.map_plan(out)
        return out


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
    domain = normalise_axiom_bodies(domain)
    grounded = None
    if getattr(caps, "ground", False):
        grounded = ground(domain, problem, conditional_effects=caps.conditional_effects)
        domain, problem = grounded.domain, grounded.problem
    if not caps.axioms:
        domain, problem = compile_away(domain, problem)
    if not caps.quantifiers:
        domain, problem = expand_quantifiers(domain, problem)
    templates: dict[str, tuple[str, tuple[int | str, ...]]] = {}
    if not caps.disjunction:
        domain, problem, templates = split_disjunctions(domain, problem)
    if not caps.negative_preconditions:
        domain, problem, templates = remove_negations(domain, problem, templates)
    if not caps.conditional_effects:
        for a in domain.actions:
            if has(a.effect, S.When):
                raise UnsupportedError(
                    f"action '{a.name}' has conditional effects, which this planner does not support",
                    line=a.span.line if a.span else None,
                    col=a.span.col if a.span else None,
                )
    domain, problem, scale = compile_costs(
        domain,
        problem,
        cost_functions=set(cost_functions),
        scale=scale,
        unit_cost=unit_cost or not caps.costs,
    )
    domain = replace(domain, requirements=requirements_of(domain, problem))
    problem = replace(problem, requirements=None)
    # unified-planning's reader keeps every kind of name in one namespace (an action and a
    # predicate may not share a name) and wants plain identifiers: rename what offends it,
    # and map plans back.
    domain, problem, renaming = rename_task(domain, problem)
    return Lowered(domain, problem, scale, templates, renaming or None, grounded)


def requirements_of(domain: S.Domain, problem: S.Problem) -> tuple[str, ...]:
    """The requirement flags the (lowered) domain and problem really use."""
    used = [":strips"]
    conds = (
        [a.precondition for a in domain.actions]
        + [ax.body for ax in domain.axioms]
        + [problem.goal]
    )
    conds = [c for c in conds if c is not None]
    effects = [a.effect for a in domain.actions if a.effect is not None]
    found: list[S.Atom] = []
    for c in conds:
        map_atoms(c, lambda a: found.append(a) or a)
    if domain.types or any(o.type for o in problem.objects):
        used.append(":typing")
    if any(has(c, S.Not) for c in conds):
        used.append(":negative-preconditions")
    if any(has(c, S.Or, S.Imply) for c in conds):
        used.append(":disjunctive-preconditions")
    if any(a.pred == "=" for a in found):
        used.append(":equality")
    if any(has(c, S.Exists) for c in conds):
        used.append(":existential-preconditions")
    if any(has(c, S.Forall) for c in conds):
        used.append(":universal-preconditions")
    if any(has(e, S.When, S.Forall) for e in effects):
        used.append(":conditional-effects")
    if domain.axioms:
        used.append(":derived-predicates")
    if problem.metric is not None:
        used.append(":action-costs")
    return tuple(used)


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


def expand_quantifiers(domain: S.Domain, problem: S.Problem):
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
    return replace(domain, actions=actions, axioms=axioms), replace(problem, goal=goal)


# ---------------------------------------------------------------- disjunction


def split_disjunctions(domain: S.Domain, problem: S.Problem):
    templates: dict[str, tuple[str, tuple[int | str, ...]]] = {}
    actions: list[S.Action] = []
    for a in domain.actions:
        if a.precondition is None or not has(
            a.precondition, S.Or, S.Imply, S.Exists, S.Forall, S.Not
        ):
            actions.append(a)
            continue
        pre = nnf(a.precondition)
        if has(pre, S.Exists, S.Forall):
            raise UnsupportedError(
                f"action '{a.name}': quantified preconditions need a planner with quantifiers"
            )
        try:
            clauses = [c for c in dnf(pre) if not _contradictory(c)]
        except TooLarge:
            raise UnsupportedError(
                f"action '{a.name}': its precondition has too many disjuncts to split for a "
                "planner without disjunction; use a planner that supports it (such as fd)",
                line=a.span.line if a.span else None,
                col=a.span.col if a.span else None,
            ) from None
        if len(clauses) == 1:
            actions.append(replace(a, precondition=conj(*clauses[0]) if clauses[0] else S.And(())))
            continue
        identity = tuple(range(len(a.parameters)))
        for k, clause in enumerate(clauses, start=1):
            name = f"{a.name}--{k}"
            templates[name] = (a.name, identity)
            actions.append(
                replace(a, name=name, precondition=conj(*clause) if clause else S.And(()))
            )
    goal = problem.goal
    predicates = list(domain.predicates)
    if goal is not None and has(goal, S.Or, S.Imply, S.Not, S.Exists, S.Forall):
        try:
            clauses = [c for c in dnf(nnf(goal)) if not _contradictory(c)]
        except TooLarge:
            raise UnsupportedError(
                "the goal has too many disjuncts for a planner without disjunction"
            ) from None
        if len(clauses) == 1:
            goal = conj(*clauses[0]) if clauses[0] else S.And(())
        else:
            for k, clause in enumerate(clauses, start=1):
                actions.append(
                    S.Action(
                        f"{GOAL_ACTION}--{k}",
                        (),
                        conj(*clause) if clause else S.And(()),
                        GOAL_REACHED,
                    )
                )
            predicates.append(S.PredicateDecl(GOAL_REACHED.pred))
            goal = GOAL_REACHED
    return (
        replace(domain, actions=tuple(actions), predicates=tuple(predicates)),
        replace(problem, goal=goal),
        templates,
    )


def _contradictory(clause) -> bool:
    pos = {x for x in clause if isinstance(x, S.Atom)}
    return any(isinstance(x, S.Not) and x.arg in pos for x in clause)


# ---------------------------------------------------------------- negation and equality


def remove_negations(domain: S.Domain, problem: S.Problem, templates):
    """Complement predicates for negated atoms; equalities substituted away (STRIPS targets)."""
    templates = dict(templates)
    actions: list[S.Action] = []
    for a in domain.actions:
        new, template = _substitute_equalities(a)
        if new is None:
            continue  # an equality that can never hold
        if template is not None:
            base_name, base_template = templates.get(
                a.name, (a.name, tuple(range(len(a.parameters))))
            )
            # base_template maps the original parameters to a's; template maps a's to new's.
            composed = tuple(template[t] if isinstance(t, int) else t for t in base_template)
            templates[new.name] = (base_name, composed)
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
        return replace(domain, actions=tuple(actions)), problem, templates

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
    return (
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
