"""Lowering pass — disjunctive preconditions split into one action copy per DNF clause
(``a--1``, ``a--2``...); a disjunctive goal gets one ``ssr-goal--k`` action per clause.

:func:`split_disjunctions` returns a :class:`Split`, whose map back names each copy by its
action and leaves out the goal actions."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from .. import syntax as S
from ..errors import UnsupportedError
from .formulas import TooLarge, conj, dnf, has, nnf
from .result import PassResult, Plan

GOAL_ACTION = "ssr-goal"
GOAL_REACHED = S.Atom("ssr-goal-reached")


# ---------------------------------------------------------------- disjunction


@dataclass
class Split(PassResult):
    """The disjunctions pass's result: ``copies`` maps an action copy to the action it splits."""

    copies: dict[str, str] = field(default_factory=dict)

    def map_plan(self, plan) -> Plan:
        return [
            (self.copies.get(name, name), tuple(args))
            for name, args in plan
            if not name.startswith(GOAL_ACTION)
        ]


def split_disjunctions(domain: S.Domain, problem: S.Problem) -> Split:
    copies: dict[str, str] = {}
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
        for k, clause in enumerate(clauses, start=1):
            name = f"{a.name}--{k}"
            copies[name] = a.name
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
    return Split(
        replace(domain, actions=tuple(actions), predicates=tuple(predicates)),
        replace(problem, goal=goal),
        copies,
    )


def _contradictory(clause) -> bool:
    pos = {x for x in clause if isinstance(x, S.Atom)}
    return any(isinstance(x, S.Not) and x.arg in pos for x in clause)
