"""Derived predicates compiled away keep their meaning: every axiom of a predicate, bound
variables renamed apart from the action's parameters, and the goal expanded too.

Each problem is solved by Fast Downward on the compiled (axiom-free) domain; the answers
differ exactly when one of those three parts is wrong.
"""

from ssr_compile import syntax as S
from ssr_compile.compile.derived import compile_away
from ssr_compile.parse import parse_domain, parse_problem
from ssr_compile.planners import get_planner

DOMAIN = """
(define (domain reach)
  (:requirements :strips :derived-predicates :existential-preconditions)
  (:predicates (obj ?x) (a ?x) (b ?x ?y) (reach ?x) (done ?x))
  (:derived (reach ?x) (a ?x))
  (:derived (reach ?x) (exists (?y) (b ?x ?y)))
  (:action go :parameters (?y)
    :precondition (and (obj ?y) (reach ?y))
    :effect (done ?y)))
"""


def _problem(init: str, goal: str) -> S.Problem:
    return parse_problem(
        f"(define (problem p) (:domain reach) (:objects o1 o2 o3) (:init {init}) (:goal {goal}))"
    )


def _solvable(init: str, goal: str) -> bool:
    d, p = compile_away(parse_domain(DOMAIN), _problem(init, goal)).task
    assert not d.axioms
    assert not any(isinstance(x, S.Atom) and x.pred == "reach" for x in S.walk(p.goal))
    result = get_planner("fd").solve(d, p, time_limit=20, cost_bound=None)
    assert result.status in ("solved", "unsolvable"), result.message
    return result.status == "solved"


def test_the_second_axiom_is_inlined_too():
    # only the existential axiom makes o1 reachable
    assert _solvable("(obj o1) (b o1 o3)", "(done o1)")


def test_bound_variables_are_renamed_apart_from_action_parameters():
    # the body's ?y must not capture the action's ?y: (b o1 o3) is enough, (b o1 o1) is absent
    assert _solvable("(obj o1) (obj o3) (b o1 o3)", "(done o1)")


def test_derived_atoms_in_the_goal_are_expanded():
    assert _solvable("(b o2 o3)", "(reach o2)")
    assert _solvable("(a o2)", "(reach o2)")
    assert not _solvable("(b o3 o2)", "(reach o2)")


def test_without_support_the_action_is_not_applicable():
    assert not _solvable("(obj o1) (b o2 o3)", "(done o1)")
