"""One definition of an action's cost effects, used by the compiler and the plan pricer."""

from ssr_compile.compile.costs import cost_effects
from ssr_compile.parse import parse_domain, parse_problem
from ssr_compile.planners.costs import plan_cost

DOMAIN = """
(define (domain d) (:requirements :strips :action-costs)
  (:predicates (p) (q))
  (:functions (total-cost) (refund))
  (:action a :parameters () :precondition (p)
    :effect (and (q) (increase (total-cost) 3) (decrease (total-cost) 1)
                 (increase (refund) 5))))
"""
PROBLEM = """
(define (problem pr) (:domain d) (:init (p) (= (total-cost) 0) (= (refund) 0))
  (:goal (q)) (:metric minimize (total-cost)))
"""


def test_only_increases_of_total_cost_are_costs():
    d = parse_domain(DOMAIN)
    effects = cost_effects(d.actions[0].effect)
    assert [(e.op, e.fluent.name) for e in effects] == [("increase", "total-cost")]


def test_plan_cost_ignores_decreases_and_other_fluents():
    d, p = parse_domain(DOMAIN), parse_problem(PROBLEM)
    assert plan_cost(d, p, [("a", ())]) == 3
