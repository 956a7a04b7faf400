"""Compile pass — plan constraints (paper §VI-A, Algorithm 2 ``ConstrainPlan``).

Given the unexecuted tail of the last plan and which of its argument values are *constants*
(objects, grasps: values still meaningful after new observations), build a domain whose only
actions are one copy per plan step, so the next plan keeps the old plan's structure:

* step ``i >= 2`` requires ``(applied-(i-1))`` and adds ``(applied-i)`` (total order);
* a constant argument ``v`` at parameter ``?p`` adds ``(= ?p v)``;
* any other value ``v`` becomes a free-variable object ``@v`` (here ``free-k``): the step
  requires ``(imply (bound v) (assigned v ?p))`` and adds ``(bound v)`` and ``(assigned v ?p)``,
  so every use of one free variable binds the same new value;
* the goal gains ``(applied-|a|)``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

from .. import syntax as S
from ..errors import UnsupportedError
from .formulas import conj
from .result import PassResult

Plan = list[tuple[str, tuple[str, ...]]]

BOUND = "ssr-bound"
ASSIGNED = "ssr-assigned"


def applied(i: int) -> S.Atom:
    return S.Atom(f"ssr-applied-{i}")


@dataclass
class Constrained(PassResult):
    """The constraints pass's result (:func:`constrain_plan`): its map back names each step
    copy by its action."""

    # new action name -> (original action name, step index)
    steps: dict[str, tuple[str, int]] = field(default_factory=dict)
    # free-variable object -> the value it stood for in the old plan
    free: dict[str, str] = field(default_factory=dict)

    def map_plan(self, plan: Plan) -> Plan:
        """A plan of the constrained problem in the original action names."""
        return [(self.steps.get(name, (name, 0))[0], args) for name, args in plan]


def constrain_plan(
    domain: S.Domain,
    problem: S.Problem,
    tail: Sequence[tuple[str, Sequence[str]]],
    is_constant: Callable[[str], bool],
) -> Constrained:
    """Algorithm 2: the constrained domain and problem for the plan ``tail``."""
    if not tail:
        raise ValueError("constrain_plan needs a non-empty plan tail")
    schemas = {a.name: a for a in domain.actions}
    free: dict[str, str] = {}  # old value -> free-variable object
    actions: list[S.Action] = []
    steps: dict[str, tuple[str, int]] = {}
    for i, (name, args) in enumerate(tail, start=1):
        schema = schemas.get(name)
        if schema is None:
            raise UnsupportedError(
                f"plan step {i} uses action '{name}', which the domain does not define"
            )
        if len(args) != len(schema.parameters):
            raise UnsupportedError(
                f"plan step {i}: '{name}' takes {len(schema.parameters)} arguments, got {len(args)}"
            )
        pre: list[S.Formula] = []
        eff: list[S.Formula] = [applied(i)]
        if i >= 2:
            pre.append(applied(i - 1))
        for value, param in zip(args, schema.parameters):
            p = S.Var(param.name)
            if is_constant(value):
                pre.append(S.Atom("=", (p, S.Const(value))))
            else:
                v = S.Const(free.setdefault(value, f"free-{len(free) + 1}"))
                pre.append(S.Imply(S.Atom(BOUND, (v,)), S.Atom(ASSIGNED, (v, p))))
                eff.extend([S.Atom(BOUND, (v,)), S.Atom(ASSIGNED, (v, p))])
        new_name = f"{name}-step{i}"
        steps[new_name] = (name, i)
        actions.append(
            replace(
                schema,
                name=new_name,
                precondition=conj(schema.precondition, *pre),
                effect=conj(schema.effect, *eff),
            )
        )
    n = len(tail)
    predicates = list(domain.predicates) + [
        S.PredicateDecl(BOUND, (S.Typed("?v"),)),
        S.PredicateDecl(ASSIGNED, (S.Typed("?v"), S.Typed("?x"))),
    ]
    predicates += [S.PredicateDecl(applied(i).pred) for i in range(1, n + 1)]
    requirements = domain.requirements
    if requirements is not None:
        extra = [
            r
            for r in (":equality", ":disjunctive-preconditions", ":negative-preconditions")
            if r not in requirements
        ]
        requirements = requirements + tuple(extra)
    new_domain = replace(
        domain, actions=tuple(actions), predicates=tuple(predicates), requirements=requirements
    )
    # The constants the new preconditions name must be domain constants: a domain may only
    # mention objects it declares (Fast Downward's translator refuses others).
    used = {value for name, args in tail for value in args if is_constant(value)}
    known = {c.name for c in domain.constants}
    moved = tuple(o for o in problem.objects if o.name in used and o.name not in known)
    missing = used - known - {o.name for o in moved}
    # The free-variable objects appear in the actions too.
    free_objects = tuple(S.Typed(name) for name in free.values())
    constants = domain.constants + moved + tuple(S.Typed(v) for v in sorted(missing)) + free_objects
    new_domain = replace(new_domain, constants=constants)
    kept = tuple(o for o in problem.objects if o.name not in used)
    new_problem = replace(
        problem,
        objects=kept,
        goal=conj(problem.goal, applied(n)),
    )
    return Constrained(new_domain, new_problem, steps, {v: k for k, v in free.items()})
