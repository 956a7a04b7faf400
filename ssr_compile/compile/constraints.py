"""Compile pass — plan constraints (paper §VI-A, Algorithm 2 ``ConstrainPlan``).

Given the unexecuted tail of the last plan and which of its argument values are *constants*
(objects, grasps: values still meaningful after new observations), build a domain whose only
actions are one copy per plan step, so the next plan keeps the old plan's structure:

* step ``i`` requires ``(applied-(i-1))``, deletes it and adds ``(applied-i)`` (a chain: each
  step is applied exactly once, in order; ``(applied-0)`` holds initially).  The paper only
  needs the order; deleting the previous marker also forbids repeating a step, which a
  planner's search would otherwise explore: on a kitchen replan with six free base motions
  the search ran past 60 s where the chain takes 23 expansions;
* a constant argument ``v`` at parameter ``?p`` adds ``(= ?p v)``;
* any other value ``v`` becomes a free-variable object ``@v`` (here ``free-k``).  The steps
  are totally ordered, so the first step that uses ``v`` is known when compiling: it binds
  ``v`` (adds ``(assigned v ?p)``; a second parameter of the same step with value ``v`` gets
  ``(= ?q ?p)``), and every later use requires ``(assigned v ?p)``.  Every use of one free
  variable therefore takes the same new value.  The paper's guard ``(imply (bound v)
  (assigned v ?p))`` is equivalent under the total order, but a planner's translator splits
  each such disjunction into two copies of the action, and a step with three of them grounds
  eight times over (the kitchen's constrained replans: 35,632 operators where 676 do);
  a positive precondition also lets the translator ground the step from the bound value only;
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
        pre: list[S.Formula] = [applied(i - 1)]
        eff: list[S.Formula] = [applied(i), S.Not(applied(i - 1))]
        binding_here: dict[str, S.Var] = {}  # free values this step binds -> first parameter
        for value, param in zip(args, schema.parameters):
            p = S.Var(param.name)
            if is_constant(value):
                pre.append(S.Atom("=", (p, S.Const(value))))
            elif value in binding_here:
                pre.append(S.Atom("=", (p, binding_here[value])))
            elif value in free:
                pre.append(S.Atom(ASSIGNED, (S.Const(free[value]), p)))
            else:
                v = S.Const(free.setdefault(value, f"free-{len(free) + 1}"))
                binding_here[value] = p
                eff.append(S.Atom(ASSIGNED, (v, p)))
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
        S.PredicateDecl(ASSIGNED, (S.Typed("?v"), S.Typed("?x"))),
    ]
    predicates += [S.PredicateDecl(applied(i).pred) for i in range(0, n + 1)]
    requirements = domain.requirements
    if requirements is not None:
        extra = [
            r
            for r in (":equality",)
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
        init=problem.init + (applied(0),),
        goal=conj(problem.goal, applied(n)),
    )
    return Constrained(new_domain, new_problem, steps, {v: k for k, v in free.items()})
