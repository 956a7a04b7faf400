"""Walks over formulas and effects, shared by the checker, the compile passes and the planners.

The one place that knows how to read a formula of :mod:`.syntax`:

* walkers -- :func:`atoms`, :func:`changed_atoms` (what an effect adds or deletes),
  :func:`free_variables` (quantifiers bind), :func:`variable_names` (bound or free);
* the atom matcher -- :func:`match` (an atom against a row of object names) and
  :func:`unify` (against a ground atom), used by grounding and stream instantiation;
* feature detection -- :func:`formula_features` reads the PDDL constructs one formula uses,
  and three views of a task are built from it: :func:`planner_features` (what a planner
  backend must support), :func:`requirements_of` (the ``:requirements`` flags a compiled task
  declares) and :func:`domain_requirements` (the flags the checker expects a domain to
  declare).

Walkers dispatch on the node's class (``functools.singledispatch`` or a table keyed by class),
so a new kind of node is added in one place.  This module imports only :mod:`.syntax`: it is
the bottom layer the rest of the package builds on.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from functools import singledispatch

from . import syntax as S

COST = "total-cost"

# ---------------------------------------------------------------- walkers


def atoms(f) -> list[S.Atom]:
    """Every atom in a formula or effect (in order; ``None`` gives none)."""
    return [x for x in S.walk(f) if isinstance(x, S.Atom)]


# What an effect node changes: its sub-effects (a ``when``'s condition only reads).
_EFFECT_PARTS = {
    S.And: lambda e: e.args,
    S.Forall: lambda e: (e.body,),
    S.When: lambda e: (e.effect,),
    S.Not: lambda e: (e.arg,),
    S.Timed: lambda e: (e.body,),
}


def changed_atoms(effect) -> list[S.Atom]:
    """The atoms an effect adds or deletes (in order)."""
    if isinstance(effect, S.Atom):
        return [effect]
    parts = _EFFECT_PARTS.get(type(effect))
    return [a for e in parts(effect) for a in changed_atoms(e)] if parts else []


@singledispatch
def _free(node, bound: frozenset[str], out: list[S.Var]) -> None:
    for child in S.children(node):
        _free(child, bound, out)


@_free.register
def _(node: S.Var, bound: frozenset[str], out: list[S.Var]) -> None:
    if node.name not in bound:
        out.append(node)


@_free.register(S.Exists)
@_free.register(S.Forall)
def _(node, bound: frozenset[str], out: list[S.Var]) -> None:
    _free(node.body, bound | {p.name for p in node.params}, out)


def free_variables(f) -> list[S.Var]:
    """The free variables of a formula, effect or expression, each occurrence in order of
    appearance (variables a quantifier binds are left out; ``None`` gives none)."""
    out: list[S.Var] = []
    if f is not None:
        _free(f, frozenset(), out)
    return out


def variable_names(f) -> set[str]:
    """Every variable name in a formula, bound or free (quantified parameters included)."""
    out: set[str] = set()
    for x in S.walk(f):
        if isinstance(x, S.Var):
            out.add(x.name)
        elif isinstance(x, S.Exists | S.Forall):
            out.update(p.name for p in x.params)
    return out


# ---------------------------------------------------------------- matching atoms


def match(
    pattern: S.Atom, values: Sequence[str], binding: Mapping[str, str]
) -> Mapping[str, str] | None:
    """``binding`` extended so that the arguments of ``pattern`` name ``values`` in order, or
    None when they cannot.  The result is a new dict only when a variable was added, so a
    caller must not change it in place."""
    if len(pattern.args) != len(values):
        return None
    new = binding
    for term, value in zip(pattern.args, values):
        if isinstance(term, S.Var):
            seen = new.get(term.name)
            if seen is None:
                if new is binding:
                    new = dict(binding)
                new[term.name] = value
            elif seen != value:
                return None
        elif term.name != value:
            return None
    return new


def unify(pattern: S.Atom, fact: S.Atom, binding: Mapping[str, str]) -> Mapping[str, str] | None:
    """:func:`match` of ``pattern`` against the ground atom ``fact`` (predicates not compared)."""
    return match(pattern, [t.name for t in fact.args], binding)


# ---------------------------------------------------------------- features

# A feature of a formula is a pair (construct, place): the construct is the kind of node (as
# named in _CONSTRUCT, or "=", "negative" for an atom under an odd number of negations, and
# "cost-increase" / "cost-change" / "numeric-effect" for numeric effects, "total-cost" for a
# numeric expression that mentions it) and the place says
# whether it stands where a condition or an effect is expected.
CONDITION, EFFECT = "condition", "effect"
_CONSTRUCT = {
    S.Not: "not",
    S.Or: "or",
    S.Imply: "imply",
    S.Exists: "exists",
    S.Forall: "forall",
    S.Compare: "compare",
    S.When: "when",
    S.Timed: "timed",
}


def _numeric_effect(e: S.NumericEffect) -> str:
    if e.fluent.name != COST:
        return "numeric-effect"
    return "cost-increase" if e.op == "increase" and not e.fluent.args else "cost-change"


def _scan(f, place: str, negated: bool, out: set[tuple[str, str]]) -> None:
    kind = type(f)
    if kind is S.Atom:
        if f.pred == "=":
            out.add(("=", place))
        if negated and place == CONDITION:
            out.add(("negative", place))
        return
    if kind is S.NumericEffect:
        out.add((_numeric_effect(f), place))
    if kind is S.NumericEffect or kind is S.Compare:
        if any(isinstance(x, S.FuncTerm | S.Const) and x.name == COST for x in S.walk(f)):
            out.add(("total-cost", place))  # read or written in a numeric expression
        if kind is S.NumericEffect:
            return
    if kind in _CONSTRUCT:
        out.add((_CONSTRUCT[kind], place))
    if kind is S.Not:
        _scan(f.arg, place, not negated, out)
    elif kind is S.Imply:  # the sides of an implication are conditions wherever it stands
        _scan(f.left, CONDITION, not negated, out)
        _scan(f.right, CONDITION, negated, out)
    elif kind is S.When:
        _scan(f.condition, CONDITION, False, out)
        _scan(f.effect, EFFECT, False, out)
    elif kind is not S.Compare:
        for child in S.children(f):
            _scan(child, place, negated, out)


def formula_features(f, *, effect: bool = False) -> set[tuple[str, str]]:
    """The ``(construct, place)`` pairs a condition (or, with ``effect``, an effect) uses."""
    out: set[tuple[str, str]] = set()
    if f is not None:
        _scan(f, EFFECT if effect else CONDITION, False, out)
    return out


def _task_features(domain: S.Domain, problem: S.Problem | None):
    """The features of the conditions (preconditions, axiom bodies, the goal) and of the
    effects of a classical task (durative actions are not read)."""
    conditions: set[tuple[str, str]] = set()
    for c in (
        *(a.precondition for a in domain.actions),
        *(ax.body for ax in domain.axioms),
        problem.goal if problem is not None else None,
    ):
        conditions |= formula_features(c)
    effects: set[tuple[str, str]] = set()
    for a in domain.actions:
        effects |= formula_features(a.effect, effect=True)
    return conditions, effects


def _constructs(features: Iterable[tuple[str, str]], place: str | None = None) -> set[str]:
    return {c for c, p in features if place is None or p == place}


def planner_features(domain: S.Domain, problem: S.Problem) -> set[str]:
    """The features a planner backend must support to take the task: names of the fields of
    :class:`~ssr_compile.compile.capabilities.Capabilities`, plus ``equality``, ``numeric``
    (other than ``total-cost``) and ``durative``."""
    conditions, effects = _task_features(domain, problem)
    both = conditions | effects
    read = _constructs(both, CONDITION)  # constructs standing where a condition is read
    written = _constructs(effects, EFFECT)
    found = set()
    table = {
        "equality": "=" in read,
        "negative_preconditions": "negative" in read,
        "disjunction": bool(read & {"or", "imply"}),
        "quantifiers": bool(read & {"exists", "forall"}) or "forall" in written,
        "numeric": bool(read & {"compare", "numeric-effect", "cost-increase", "cost-change"})
        or bool(written & {"numeric-effect", "cost-change"}),
        "durative": bool(domain.durative_actions)
        or bool(read & {"when", "timed"})
        or bool(written & {"or", "exists", "imply", "compare", "timed"}),
        "conditional_effects": "when" in written,
        "costs": "cost-increase" in written or problem.metric is not None,
        "axioms": bool(domain.axioms),
    }
    found.update(name for name, used in table.items() if used)
    return found


def requirements_of(domain: S.Domain, problem: S.Problem) -> tuple[str, ...]:
    """The requirement flags a (compiled) classical task uses, in the usual order: what its
    ``(:requirements ...)`` line declares.  A ``when``'s condition is not read."""
    conditions, effects = _task_features(domain, problem)
    read = _constructs(conditions)
    flags = {
        ":strips": True,
        ":typing": bool(domain.types) or any(o.type for o in problem.objects),
        ":negative-preconditions": "not" in read,
        ":disjunctive-preconditions": bool(read & {"or", "imply"}),
        ":equality": "=" in read,
        ":existential-preconditions": "exists" in read,
        ":universal-preconditions": "forall" in read,
        ":conditional-effects": bool(_constructs(effects) & {"when", "forall"}),
        ":derived-predicates": bool(domain.axioms),
        ":action-costs": problem.metric is not None,
    }
    return tuple(flag for flag, used in flags.items() if used)


def domain_requirements(domain: S.Domain) -> set[str]:
    """The requirement flags the formulas of a domain (durative actions included) need, as
    the checker reads them: any ``(not ...)`` in a condition, quantifiers, ``=`` anywhere.
    ``:typing`` and the sections (``:derived-predicates``, ``:durative-actions``) are the
    checker's to add."""
    used: set[tuple[str, str]] = set()
    for a in domain.actions:
        used |= formula_features(a.precondition) | formula_features(a.effect, effect=True)
    for ax in domain.axioms:
        used |= formula_features(ax.body)
    for da in domain.durative_actions:
        duration = formula_features(da.duration)
        if isinstance(da.duration, S.Compare):  # (= ?duration 5) is not a numeric condition
            duration = {f for f in duration if f[0] == "total-cost"}
        used |= duration
        used |= formula_features(da.condition) | formula_features(da.effect, effect=True)
    every = _constructs(used)
    # A (total-cost) the domain reads without declaring it needs the flag that declares it.
    declared_cost = any(f.name == COST for f in domain.functions) or any(
        c.name == COST for c in domain.constants
    )
    flags = {
        ":disjunctive-preconditions": bool(every & {"or", "imply"}),
        ":negative-preconditions": ("not", CONDITION) in used,
        ":existential-preconditions": "exists" in every,
        ":universal-preconditions": ("forall", CONDITION) in used,
        ":conditional-effects": ("forall", EFFECT) in used or "when" in every,
        ":numeric-fluents": bool(every & {"compare", "numeric-effect"}),
        ":action-costs": bool(every & {"cost-increase", "cost-change"})
        or ("total-cost" in every and not declared_cost),
        ":equality": "=" in every,
    }
    return {flag for flag, needed in flags.items() if needed}


# What a declared requirement flag implies (PDDL 3.1).
IMPLIED = {
    ":adl": (
        ":strips",
        ":typing",
        ":negative-preconditions",
        ":disjunctive-preconditions",
        ":equality",
        ":existential-preconditions",
        ":universal-preconditions",
        ":conditional-effects",
    ),
    ":quantified-preconditions": (":existential-preconditions", ":universal-preconditions"),
    ":fluents": (":numeric-fluents",),
}


def undeclared_requirements(declared: Iterable[str], used: Iterable[str]) -> list[str]:
    """The flags of ``used`` that ``declared`` neither names nor implies (sorted)."""
    implied = set(declared)
    for flag in tuple(implied):
        implied.update(IMPLIED.get(flag, ()))
    return sorted(set(used) - implied)
