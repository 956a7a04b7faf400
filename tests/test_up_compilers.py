"""Lowering for STRIPS planners: negated equality, and unified-planning's own compilers for
what its PDDL reader still finds unsupported (up:ENGINE backends)."""

import pytest

from ssr_compile.compile.lower import DISTINCT
from ssr_compile.compile.pipeline import compile_problem
from ssr_compile.parse import parse_text
from ssr_compile.planners import get_planner
from ssr_compile.planners.validate import validate_plan
from ssr_compile.printer import to_text

DOMAIN = parse_text(
    """(define (domain eq) (:requirements :strips :equality :negative-preconditions)
 (:predicates (at ?x) (link ?x ?y))
 (:action go :parameters (?a ?b) :precondition (and (at ?a) (link ?a ?b) (not (= ?a ?b)))
   :effect (and (at ?b) (not (at ?a)))))"""
)
# A self-loop x->x is in the map: only (not (= ?a ?b)) stops the planner from using it.
PROBLEM = parse_text(
    """(define (problem e) (:domain eq) (:objects x y z)
 (:init (at x) (link x y) (link y z) (link x x) (link z z)) (:goal (at z)))"""
)


@pytest.mark.parametrize("planner", ["pyperplan", "up:pyperplan", "up:fast-downward"])
def test_negated_equality_reaches_every_planner(planner):
    backend = get_planner(planner)
    compiled = compile_problem(DOMAIN, None, PROBLEM, caps=backend.capabilities)
    result = backend.solve(compiled.domain, compiled.problem, time_limit=30)
    assert result.status == "solved", result.message
    plan = compiled.map_plan(result.actions)
    assert plan == [("go", ("x", "y")), ("go", ("y", "z"))]
    ok, why = validate_plan(DOMAIN, PROBLEM, plan)
    assert ok, why


def test_negated_equality_becomes_a_distinct_relation_for_strips():
    # the lifted lowering (a STRIPS backend that does not ask for a ground task)
    import dataclasses

    caps = dataclasses.replace(get_planner("pyperplan").capabilities, ground=False)
    compiled = compile_problem(DOMAIN, None, PROBLEM, caps=caps)
    text = to_text(compiled.domain) + to_text(compiled.problem)
    assert f"({DISTINCT} ?a ?b)" in text and "(not (= " not in text
    distinct = {
        tuple(t.name for t in f.args)
        for f in compiled.problem.init
        if getattr(f, "pred", None) == DISTINCT
    }
    assert ("x", "y") in distinct and ("y", "x") in distinct
    assert ("x", "x") not in distinct and len(distinct) == 6


def test_unified_planning_compilers_fit_a_task_to_pyperplan():
    from unified_planning.io import PDDLReader

    from ssr_compile.planners.up import _environment, _fit_to_engine, oneshot_engines

    _environment()
    engine = oneshot_engines()["pyperplan"]
    task = PDDLReader().parse_problem_string(to_text(DOMAIN), to_text(PROBLEM))
    assert not engine.supports(task.kind)  # equality and negation: pyperplan reads neither
    fitted, map_backs = _fit_to_engine(task, engine)
    assert engine.supports(fitted.kind) and map_backs
