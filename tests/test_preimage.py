"""A plan's preimage (the solver's check of a plan over the real facts): quantifiers and
derived predicates evaluated under the step's binding, with a quantified variable shadowing
an action parameter of the same name."""

import pytest

from ssr_compile import syntax as S
from ssr_compile.parse import parse_domain, parse_problem
from ssr_compile.solver.preimage import PlanInvalid, plan_preimage

DOMAIN = """
(define (domain lift)
  (:requirements :strips :negative-preconditions :derived-predicates
                 :existential-preconditions :universal-preconditions)
  (:predicates (on ?a ?b) (heavy ?a) (near ?a ?b) (clear ?a))
  (:derived (blocked ?x) (exists (?y) (and (on ?y ?x) (heavy ?y))))
  (:action lift
    :parameters (?y ?x)
    :precondition (and (on ?y ?x) (not (blocked ?y))
                       (exists (?y) (and (near ?y ?x) (heavy ?y)))
                       (forall (?z) (imply (near ?z ?x) (not (blocked ?z)))))
    :effect (and (not (on ?y ?x)) (clear ?x))))
"""


def problem(*init: str) -> S.Problem:
    return parse_problem(
        f"""(define (problem p) (:domain lift) (:objects a b c d)
        (:init {" ".join(init)}) (:goal (clear b)))"""
    )


def atom(text: str) -> S.Atom:
    pred, *args = text.strip("()").split()
    return S.Atom(pred, tuple(S.Const(a) for a in args))


def test_the_inner_quantifier_ranges_over_its_own_variable_and_its_facts_are_the_support():
    # (exists (?y) ...) shadows the parameter ?y (bound to a): c is near b and heavy
    pre = plan_preimage(
        parse_domain(DOMAIN), problem("(on a b)", "(heavy c)", "(near c b)"), [("lift", ("a", "b"))]
    )
    assert pre.static_facts == {atom("(near c b)"), atom("(heavy c)")}
    assert pre.per_step == [{atom("(near c b)"), atom("(heavy c)")}]


def test_the_parameter_is_not_what_the_inner_quantifier_binds():
    # a is near b but not heavy, and nothing else is near b: read as the parameter, the
    # inner ?y would look at (near a b) and (heavy a) only
    with pytest.raises(PlanInvalid, match="precondition"):
        plan_preimage(
            parse_domain(DOMAIN),
            problem("(on a b)", "(near a b)", "(heavy d)"),
            [("lift", ("a", "b"))],
        )


def test_a_derived_predicate_under_a_universal_refuses_the_step():
    # c is near b and a heavy d stands on c: (blocked c), so the forall fails
    with pytest.raises(PlanInvalid, match="step 1"):
        plan_preimage(
            parse_domain(DOMAIN),
            problem("(on a b)", "(heavy c)", "(near c b)", "(on d c)", "(heavy d)"),
            [("lift", ("a", "b"))],
        )


def test_the_state_each_step_leaves_is_the_next_steps():
    # after lifting a off b, (on a b) is gone: lifting it again is refused at step 2
    with pytest.raises(PlanInvalid, match="step 2"):
        plan_preimage(
            parse_domain(DOMAIN),
            problem("(on a b)", "(heavy c)", "(near c b)"),
            [("lift", ("a", "b")), ("lift", ("a", "b"))],
        )
