"""Lowering pass — derived predicates (paper §IV-A: ``BOccluded``).

Backends with axiom support (Fast Downward) keep ``:derived`` as it is.  For the others,
non-recursive derived predicates are compiled away (:func:`compile_away`): every use is
replaced by the disjunction of its axioms' bodies with the arguments substituted and the bound
variables renamed apart.  A negated use such as ``(not (BOccluded ?o ?obs))`` becomes
``(not (exists ...))``, which the later lowering passes turn into what the backend supports.
A recursive derived predicate cannot be compiled this way: that is a clear
:class:`UnsupportedError`.  No action is renamed, so the pass's :class:`~.result.PassResult`
maps plans back unchanged.
"""

from __future__ import annotations

import itertools
from dataclasses import replace

from .. import syntax as S
from ..errors import UnsupportedError
from ..formulas import atoms, free_variables, variable_names
from .formulas import conj, map_atoms, substitute
from .result import PassResult


def dependencies(domain: S.Domain) -> dict[str, set[str]]:
    """Derived predicate -> the derived predicates its axioms' bodies use."""
    derived = {ax.name for ax in domain.axioms}
    graph: dict[str, set[str]] = {name: set() for name in derived}
    for ax in domain.axioms:
        for atom in atoms(ax.body):
            if atom.pred in derived:
                graph[ax.name].add(atom.pred)
    return graph


def recursive_predicates(domain: S.Domain) -> set[str]:
    """Derived predicates that depend on themselves (directly or through others)."""
    graph = dependencies(domain)
    out = set()
    for start in graph:
        stack, seen = list(graph[start]), set()
        while stack:
            p = stack.pop()
            if p == start:
                out.add(start)
                break
            if p not in seen:
                seen.add(p)
                stack.extend(graph.get(p, ()))
    return out


def normalise_axiom_bodies(domain: S.Domain) -> S.Domain:
    """Existentially quantify body variables that are not head parameters.

    Real files (and Fast Downward) read them so; making it explicit lets every later pass and
    backend see a closed formula.
    """
    axioms = []
    for ax in domain.axioms:
        head = {p.name for p in ax.parameters}
        free = [v.name for v in free_variables(ax.body) if v.name not in head]
        body = ax.body
        if free:
            body = S.Exists(tuple(S.Typed(v) for v in dict.fromkeys(free)), body)
        axioms.append(replace(ax, body=body))
    return replace(domain, axioms=tuple(axioms))


def compile_away(domain: S.Domain, problem: S.Problem | None = None) -> PassResult:
    """Remove every derived predicate by inlining its definition.

    Returns the :class:`~.result.PassResult` of the task without axioms; its plans are the
    input's plans (no action is renamed).
    """
    if not domain.axioms:
        return PassResult(domain, problem)
    rec = recursive_predicates(domain)
    if rec:
        ax = next(a for a in domain.axioms if a.name in rec)
        raise UnsupportedError(
            f"derived predicate '{ax.name}' is recursive; it can only be used with a planner "
            "that supports axioms (such as fd)",
            line=ax.span.line if ax.span else None,
            col=ax.span.col if ax.span else None,
        )
    domain = normalise_axiom_bodies(domain)
    definitions: dict[str, list[S.Axiom]] = {}
    for ax in domain.axioms:
        definitions.setdefault(ax.name, []).append(ax)
    counter = itertools.count(1)

    def expand(atom: S.Atom):
        axioms = definitions.get(atom.pred)
        if axioms is None:
            return atom
        options = []
        for ax in axioms:
            n = next(counter)
            # Rename every variable of the body apart, then bind the head to the arguments.
            renaming = {v: S.Var(f"{v}-d{n}") for v in variable_names(ax.body)}
            body = _rename_bound(ax.body, renaming)
            mapping = {p.name: arg for p, arg in zip(ax.parameters, atom.args)}
            mapping = {renaming.get(k, S.Var(k)).name: v for k, v in mapping.items()}
            options.append(map_atoms(substitute(body, mapping), expand))
        return options[0] if len(options) == 1 else S.Or(tuple(options))

    derived = set(definitions)
    actions = tuple(
        replace(
            a,
            precondition=map_atoms(a.precondition, expand) if a.precondition is not None else None,
            effect=_expand_effect(a.effect, expand),
        )
        for a in domain.actions
    )
    requirements = domain.requirements
    if requirements is not None:
        # Readers such as unified-planning's refuse the flag once no axiom is left.
        requirements = tuple(r for r in requirements if r != ":derived-predicates")
    new_domain = replace(
        domain,
        requirements=requirements,
        axioms=(),
        actions=actions,
        predicates=tuple(p for p in domain.predicates if p.name not in derived),
    )
    if problem is not None and problem.goal is not None:
        problem = replace(problem, goal=map_atoms(problem.goal, expand))
    return PassResult(new_domain, problem)


def _expand_effect(effect, expand):
    """Expand derived predicates inside the conditions of conditional effects."""
    if effect is None:
        return None
    if isinstance(effect, S.And):
        return S.And(tuple(_expand_effect(e, expand) for e in effect.args))
    if isinstance(effect, S.When):
        return S.When(map_atoms(effect.condition, expand), _expand_effect(effect.effect, expand))
    if isinstance(effect, S.Forall):
        return S.Forall(effect.params, _expand_effect(effect.body, expand))
    return effect


def _rename_bound(f, renaming: dict[str, S.Var]):
    """Rename all variables (free and bound) according to ``renaming``."""
    if isinstance(f, S.Exists | S.Forall):
        params = tuple(S.Typed(renaming[p.name].name, p.type) for p in f.params)
        return type(f)(params, _rename_bound(f.body, renaming))
    if isinstance(f, S.And | S.Or):
        return type(f)(tuple(_rename_bound(a, renaming) for a in f.args))
    if isinstance(f, S.Not):
        return S.Not(_rename_bound(f.arg, renaming))
    if isinstance(f, S.Imply):
        return S.Imply(_rename_bound(f.left, renaming), _rename_bound(f.right, renaming))
    # Atoms, comparisons: free substitution reaches every variable (no binders inside).
    return substitute(f, renaming)


__all__ = ["compile_away", "conj", "dependencies", "normalise_axiom_bodies", "recursive_predicates"]
