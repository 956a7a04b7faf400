"""Stream-file predicates (``(:predicate (P ?args) domain)``) evaluated by the solver: a car
parks on a spot a generator draws (``s1``, then ``s2``, ...).  Used negated (through a
derived predicate), the spot the plan takes must not be near an obstacle; used positively,
it must be free.  The first spot drawn fails the predicate: the plan must take the second."""

from __future__ import annotations

import pytest

from ssr_compile.compile.predicates import optimistic_truth
from ssr_compile.errors import StreamFailure
from ssr_compile.parse import parse_domain, parse_problem, parse_stream_file
from ssr_compile.solver import SolveOptions, solve
from ssr_compile.stream import StreamsModule

NEGATED = """
(define (domain park)
  (:predicates (Car ?c) (Spot ?s) (Obstacle ?o) (Near ?o ?s) (Unsafe ?s) (Parked ?c))
  (:derived (Unsafe ?s) (exists (?o) (and (Obstacle ?o) (Near ?o ?s))))
  (:action park :parameters (?c ?s)
    :precondition (and (Car ?c) (Spot ?s) (not (Unsafe ?s)))
    :effect (Parked ?c)))
"""

POSITIVE = """
(define (domain park)
  (:predicates (Car ?c) (Spot ?s) (Free ?s) (Parked ?c))
  (:action park :parameters (?c ?s)
    :precondition (and (Car ?c) (Spot ?s) (Free ?s))
    :effect (Parked ?c)))
"""

STREAMS = """
(define (stream park)
  (:stream find-spot :inputs (?c) :domain (Car ?c) :outputs (?s) :certified (Spot ?s))
  {predicate})
"""

PROBLEM = """
(define (problem p) (:domain park) (:objects c1 {objects})
  (:init (Car c1) {init}) (:goal (Parked c1)))
"""


def spots(c):
    for i in range(1, 6):
        yield (f"s{i}",)


def run(domain: str, predicate: str, fn, objects="", init="", algorithm="focused"):
    calls = []

    def recorded(*args):
        calls.append(args)
        return fn(*args)

    name = predicate.split()[1].lstrip("(").lower()
    module = StreamsModule("park", {"find-spot": spots, name: recorded}, {})
    sol = solve(
        parse_domain(domain),
        parse_stream_file(STREAMS.format(predicate=predicate)),
        parse_problem(PROBLEM.format(objects=objects, init=init)),
        module,
        SolveOptions(time_limit=30, algorithm=algorithm),
    )
    return sol, calls


@pytest.mark.parametrize("algorithm", ["focused", "adaptive"])
def test_a_predicate_used_negated_is_checked_before_the_plan_relies_on_it(algorithm):
    # the obstacle o1 is near s1 only: parking on s1 (the first spot drawn) is unsafe
    sol, calls = run(
        NEGATED,
        "(:predicate (Near ?o ?s) (and (Obstacle ?o) (Spot ?s)))",
        lambda o, s: s == "s1",
        objects="o1",
        init="(Obstacle o1)",
        algorithm=algorithm,
    )
    assert sol.solved, sol.message
    assert [(s.name, s.values) for s in sol.plan] == [("park", ("c1", "s2"))]
    assert ("o1", "s1") in calls and ("o1", "s2") in calls
    assert len(calls) == len(set(calls))  # each instance evaluated once


@pytest.mark.parametrize("algorithm", ["focused", "adaptive"])
def test_a_predicate_used_positively_is_assumed_true_then_checked(algorithm):
    free = lambda s: s != "s1"  # noqa: E731
    sol, calls = run(POSITIVE, "(:predicate (Free ?s) (Spot ?s))", free, algorithm=algorithm)
    assert sol.solved, sol.message
    assert [(s.name, s.values) for s in sol.plan] == [("park", ("c1", "s2"))]
    assert calls[:2] == [("s1",), ("s2",)]


def test_a_predicate_over_real_arguments_is_evaluated_before_planning():
    # s1 is an object of the problem: Free(s1) is known false before the first plan, so the
    # plan draws a spot instead
    sol, calls = run(
        POSITIVE,
        "(:predicate (Free ?s) (Spot ?s))",
        lambda s: s not in ("s1", "s0"),
        objects="s0",
        init="(Spot s0)",
    )
    assert sol.solved, sol.message
    assert [(s.name, s.values) for s in sol.plan] == [("park", ("c1", "s2"))]
    assert calls[0] == ("s0",)
    assert sol.stats.planner_calls >= 2  # s1 drawn and rejected, then s2


def test_a_predicate_returning_no_truth_value_is_the_streams_fault():
    with pytest.raises(StreamFailure, match="predicate 'free' returned 'yes'"):
        run(POSITIVE, "(:predicate (Free ?s) (Spot ?s))", lambda s: "yes")


def test_the_optimistic_value_follows_the_signs_the_domain_uses():
    streams = parse_stream_file(
        STREAMS.format(predicate="(:predicate (Near ?o ?s) (and (Obstacle ?o) (Spot ?s)))")
    )
    problem = parse_problem(PROBLEM.format(objects="", init=""))
    assert optimistic_truth(parse_domain(NEGATED), streams, problem) == {"near": False}
    positive = NEGATED.replace("(not (Unsafe ?s))", "(Unsafe ?s)")
    assert optimistic_truth(parse_domain(positive), streams, problem) == {"near": True}
    both = positive.replace("(Spot ?s) (Unsafe ?s)", "(Spot ?s) (Unsafe ?s) (not (Near ?c ?s))")
    assert optimistic_truth(parse_domain(both), streams, problem) == {"near": False}
