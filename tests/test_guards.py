"""Quantified preconditions guarded by the action's static atoms (compile/guards.py), and the
plan preimage's quantifier bindings: both keep the meaning of the task, so plans and their
preimages are the same as without them."""

from __future__ import annotations

from ssr_compile import syntax as S
from ssr_compile.compile.capabilities import Capabilities
from ssr_compile.compile.guards import guard_quantifiers
from ssr_compile.compile.lower import lower
from ssr_compile.parse import parse_domain, parse_problem
from ssr_compile.planners import get_planner
from ssr_compile.solver.preimage import plan_preimage

DOMAIN = """
(define (domain line)
  (:requirements :strips :negative-preconditions :disjunctive-preconditions
                 :universal-preconditions :existential-preconditions)
  (:predicates (block ?b) (spot ?p) (kin ?b ?p) (free ?b ?p ?c ?q) (at ?b ?p) (holding ?b)
               (marked ?p))
  (:action place
    :parameters (?b ?p)
    :precondition (and (holding ?b) (kin ?b ?p)
                       (forall (?c ?q) (imply (at ?c ?q) (free ?b ?p ?c ?q)))
                       (not (exists (?q) (and (at ?b ?q) (marked ?p)))))
    :effect (and (at ?b ?p) (not (holding ?b))))
  (:action pick
    :parameters (?b ?p)
    :precondition (and (at ?b ?p) (kin ?b ?p))
    :effect (and (holding ?b) (not (at ?b ?p)))))
"""

PROBLEM = """
(define (problem two) (:domain line)
  (:objects a b p1 p2 p3)
  (:init (block a) (block b) (spot p1) (spot p2) (spot p3)
         (kin a p1) (kin a p2) (kin a p3) (kin b p1) (kin b p2) (kin b p3)
         (at a p1) (holding b)
         (free b p3 a p1) (free a p2 b p3) (free b p1 a p2))
  (:goal (and (at b p3) (at a p2))))
"""


def test_quantified_preconditions_get_the_static_atoms_as_a_guard():
    d = parse_domain(DOMAIN)
    out = guard_quantifiers(d, parse_problem(PROBLEM))
    place = next(a for a in out.domain.actions if a.name == "place")
    forall = next(x for x in S.conjuncts(place.precondition) if isinstance(x, S.Forall))
    assert isinstance(forall.body, S.Imply)
    assert forall.body.left == S.Atom("kin", (S.Var("?b"), S.Var("?p")))
    negated = next(x for x in S.conjuncts(place.precondition) if isinstance(x, S.Not))
    assert S.Atom("kin", (S.Var("?b"), S.Var("?p"))) in S.conjuncts(negated.arg.body)
    # an action without quantifiers is the same object
    pick = next(a for a in out.domain.actions if a.name == "pick")
    assert pick is next(a for a in d.actions if a.name == "pick")
    # ``holding`` changes: it is no guard
    assert "holding" not in str(forall.body.left)


def test_a_guard_naming_a_quantified_variable_is_left_out():
    # (kin ?b ?p) would be captured by (forall (?p) ...): no guard
    d = parse_domain(
        DOMAIN.replace(
            "forall (?c ?q) (imply (at ?c ?q) (free ?b ?p ?c ?q))",
            "forall (?p) (imply (at ?b ?p) (spot ?p))",
        )
    )
    place = next(a for a in guard_quantifiers(d, None).domain.actions if a.name == "place")
    before = next(a for a in d.actions if a.name == "place")
    forall = [x for x in S.conjuncts(place.precondition) if isinstance(x, S.Forall)]
    assert forall == [x for x in S.conjuncts(before.precondition) if isinstance(x, S.Forall)]


def test_the_guarded_task_plans_the_same_and_the_preimage_names_the_tests():
    d, p = parse_domain(DOMAIN), parse_problem(PROBLEM)
    low = lower(d, p, Capabilities())
    plan = get_planner("fd").solve(low.domain, low.problem, time_limit=30)
    assert plan.status == "solved"
    steps = low.map_plan(plan.actions)
    pre = plan_preimage(d, p, steps)
    # placing b at p3 rests on the free test against a at p1, placing a at p2 on b at p3
    assert S.Atom("free", tuple(S.Const(x) for x in ("b", "p3", "a", "p1"))) in pre.static_facts
    assert S.Atom("free", tuple(S.Const(x) for x in ("a", "p2", "b", "p3"))) in pre.static_facts
    assert not any(f.pred == "free" and f.args[0].name == f.args[2].name for f in pre.static_facts)
