"""Renaming a task for a backend that restricts names, and mapping its plan back.

unified-planning keeps types, predicates, functions, actions and objects in one namespace
(an action and a predicate may not share a name), and some readers accept only plain
identifiers (no ``@``).  :func:`rename_task`, the last lowering pass, gives every offending
name a fresh safe name and returns a :class:`Renamed` result: the renamed task, the
:class:`Renaming` it used, and the map back to the input's names
(:meth:`Renaming.plan_back`).
"""

from __future__ import annotations

import dataclasses
import re
from dataclasses import dataclass, field

from .. import syntax as S
from .result import PassResult, Plan

GroundAction = tuple[str, tuple[str, ...]]

SAFE = re.compile(r"^[a-z][a-z0-9_-]*$")
_KEEP = {"object", "number", "total-cost", "="}


@dataclass
class Renaming:
    """Old name -> new name, per kind of symbol (only names that changed are stored)."""

    types: dict[str, str] = field(default_factory=dict)
    predicates: dict[str, str] = field(default_factory=dict)
    functions: dict[str, str] = field(default_factory=dict)
    actions: dict[str, str] = field(default_factory=dict)
    objects: dict[str, str] = field(default_factory=dict)
    # the domain's and the problem's own names (unified-planning's reader refuses a problem
    # named ``37``)
    names: dict[str, str] = field(default_factory=dict)

    def __bool__(self) -> bool:
        return any(
            (self.types, self.predicates, self.functions, self.actions, self.objects, self.names)
        )

    def plan_back(self, actions: list[GroundAction]) -> list[GroundAction]:
        """A plan over the renamed task, in the input's names."""
        act = {v: k for k, v in self.actions.items()}
        obj = {v: k for k, v in self.objects.items()}
        return [
            (act.get(n.lower(), n.lower()), tuple(obj.get(a.lower(), a.lower()) for a in args))
            for n, args in actions
        ]


@dataclass
class Renamed(PassResult):
    """The renaming pass's result: the renamed task and its :class:`Renaming` (empty when no
    name had to change)."""

    renaming: Renaming = field(default_factory=Renaming)

    def map_plan(self, plan) -> Plan:
        if not self.renaming:
            return super().map_plan(plan)
        return self.renaming.plan_back(list(plan))


def _safe(name: str) -> str:
    text = re.sub(r"[^a-z0-9_-]", "_", name.lower())
    return text if text[:1].isalpha() else "x" + text


def rename_task(domain: S.Domain, problem: S.Problem, *, one_namespace: bool = True) -> Renamed:
    """Rename unsafe names (and, with ``one_namespace``, names shared between kinds); the
    domain's and the problem's names too when a reader would refuse them."""
    kinds = {
        "types": [t.name for t in domain.types]
        + [t for t in _type_names(domain.types) if t not in {x.name for x in domain.types}],
        "predicates": [p.name for p in domain.predicates] + [a.name for a in domain.axioms],
        "functions": [f.name for f in domain.functions],
        "actions": [a.name for a in domain.actions],
        "objects": [o.name for o in (*domain.constants, *problem.objects)],
    }
    renaming = Renaming()
    taken: set[str] = set()
    per_kind: dict[str, set[str]] = {k: set() for k in kinds}
    all_names = {n for names in kinds.values() for n in names}
    for kind, names in kinds.items():  # earlier kinds keep their names first
        mapping = getattr(renaming, kind)
        for name in dict.fromkeys(names):
            clash = name in taken if one_namespace else name in per_kind[kind]
            if name in _KEEP or (SAFE.match(name) and not clash):
                new = name
            else:
                base = _safe(name)
                new, i = base, 1
                while new in taken or new in all_names or new in _KEEP:
                    new, i = f"{base}-{kind[:3]}{i if i > 1 else ''}", i + 1
                mapping[name] = new
            taken.add(new)
            per_kind[kind].add(new)
    for name in (domain.name, problem.name, problem.domain_name):
        if name and not SAFE.match(name) and name not in renaming.names:
            renaming.names[name] = _safe(name)
    if not renaming:
        return Renamed(domain, problem, renaming)
    return Renamed(_domain(domain, renaming), _problem(problem, renaming), renaming)


def _type_names(types: tuple[S.Typed, ...]) -> list[str]:
    out: list[str] = []
    for t in types:
        if isinstance(t.type, S.Either):
            out.extend(t.type.types)
        elif t.type is not None:
            out.append(t.type)
    return out


# ---------------------------------------------------------------- rewriting


def _type(t: S.TypeRef, r: Renaming) -> S.TypeRef:
    if isinstance(t, S.Either):
        return S.Either(tuple(r.types.get(x, x) for x in t.types))
    return r.types.get(t, t) if t is not None else None


def _typed(items: tuple[S.Typed, ...], r: Renaming, names: dict[str, str]) -> tuple:
    return tuple(S.Typed(names.get(t.name, t.name), _type(t.type, r)) for t in items)


def _term(t, r: Renaming):
    if isinstance(t, S.Const):
        return S.Const(r.objects.get(t.name, t.name))
    return t


def _map(node, r: Renaming):
    """Rename the symbols inside a formula, term or numeric expression."""
    if node is None or isinstance(node, (str, int, float, S.Var, S.Num)):
        return node
    if isinstance(node, S.Const):
        return _term(node, r)
    if isinstance(node, S.Atom):
        return S.Atom(r.predicates.get(node.pred, node.pred), tuple(_term(a, r) for a in node.args))
    if isinstance(node, S.FuncTerm):
        return S.FuncTerm(
            r.functions.get(node.name, node.name), tuple(_term(a, r) for a in node.args)
        )
    if isinstance(node, (S.Exists, S.Forall)):
        return type(node)(_typed(node.params, r, {}), _map(node.body, r))
    if isinstance(node, tuple):
        return tuple(_map(x, r) for x in node)
    if dataclasses.is_dataclass(node):
        changes = {
            f.name: _map(getattr(node, f.name), r) for f in dataclasses.fields(node) if f.compare
        }
        return dataclasses.replace(node, **changes)
    return node


def _domain(d: S.Domain, r: Renaming) -> S.Domain:
    return dataclasses.replace(
        d,
        name=r.names.get(d.name, d.name),
        types=_typed(d.types, r, r.types),
        constants=_typed(d.constants, r, r.objects),
        predicates=tuple(
            S.PredicateDecl(r.predicates.get(p.name, p.name), _typed(p.params, r, {}))
            for p in d.predicates
        ),
        functions=tuple(
            S.FunctionDecl(r.functions.get(f.name, f.name), _typed(f.params, r, {}), f.type)
            for f in d.functions
        ),
        axioms=tuple(
            S.Axiom(r.predicates.get(a.name, a.name), _typed(a.parameters, r, {}), _map(a.body, r))
            for a in d.axioms
        ),
        actions=tuple(
            S.Action(
                r.actions.get(a.name, a.name),
                _typed(a.parameters, r, {}),
                _map(a.precondition, r),
                _map(a.effect, r),
            )
            for a in d.actions
        ),
    )


def _problem(p: S.Problem, r: Renaming) -> S.Problem:
    return dataclasses.replace(
        p,
        name=r.names.get(p.name, p.name),
        domain_name=r.names.get(p.domain_name, p.domain_name),
        objects=_typed(p.objects, r, r.objects),
        init=tuple(_map(f, r) for f in p.init),
        goal=_map(p.goal, r),
        metric=_map(p.metric, r),
    )
