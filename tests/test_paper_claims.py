"""Tests aimed at the paper's claims in the solver: deferral (§VII), stream plans through
derived predicates and domain facts, alternative producers, and the add-after-delete rule of
the plan simulator.  Each builds the smallest task where a wrong implementation gives a
different answer.
"""

from __future__ import annotations

from collections import Counter

import pytest

from ssr_compile.parse import parse_domain, parse_problem, parse_stream_file
from ssr_compile.solver import SolveOptions, solve
from ssr_compile.solver.preimage import PlanInvalid, plan_preimage
from ssr_compile.stream import StreamInfo, StreamsModule

# ---------------------------------------------------------------- a tiny task family

DOMAIN = """
(define (domain claims)
  (:requirements :strips)
  (:predicates (item ?x) (ok ?x) (good ?x) (done ?x) (slot ?s) (fits ?x ?s) (placed ?x ?s))
  (:action finish :parameters (?x)
    :precondition (and (item ?x) (ok ?x) (good ?x))
    :effect (done ?x))
  (:action put :parameters (?x ?s)
    :precondition (and (done ?x) (fits ?x ?s))
    :effect (placed ?x ?s)))
"""


def _streams(text: str):
    return parse_stream_file(f"(define (stream claims) {text})")


def _module(fns: dict, info: dict) -> tuple[StreamsModule, Counter]:
    calls: Counter = Counter()

    def counted(name, fn):
        def wrapper(*args):
            calls[name] += 1
            return fn(*args)

        return wrapper

    module = StreamsModule(
        "claims",
        {k: counted(k, f) for k, f in fns.items()},
        {k: StreamInfo(**v) for k, v in info.items()},
        {},
    )
    return module, calls


def _problem(goal: str, objects: str = "a b s1"):
    return parse_problem(
        f"(define (problem p) (:domain claims) (:objects {objects}) "
        f"(:init (item a) (item b) (slot s1) (good a) (good b)) (:goal {goal}))"
    )


# ---------------------------------------------------------------- deferral (§VII)

TEST_OK = """
  (:stream check :inputs (?x) :domain (item ?x) :certified (ok ?x))
  (:stream fit :inputs (?x ?s) :domain (and (item ?x) (slot ?s)) :certified (fits ?x ?s))
"""


@pytest.mark.parametrize("answer", [True, False])
def test_a_deferrable_test_the_first_step_needs_is_evaluated_now(answer):
    """(ok a) is a precondition of the first action: its test may be deferrable, but it must
    be evaluated before acting; when it fails, there is no plan."""
    module, calls = _module(
        {"check": lambda x: answer, "fit": lambda x, s: True},
        {"check": {"deferrable": True, "kind": "test"}, "fit": {"kind": "test"}},
    )
    sol = solve(
        parse_domain(DOMAIN),
        _streams(TEST_OK),
        _problem("(done a)"),
        module,
        SolveOptions(defer=True, initial_level=2, max_level=2, time_limit=20),
    )
    assert calls["check"] == 1
    assert sol.solved is answer
    if answer:
        assert [s.name for s in sol.plan] == ["finish"] and not sol.deferred


def test_a_deferrable_test_needed_only_later_is_deferred():
    """(fits b s1) is needed by the second action only: with deferral it is not called, and
    the solution says it is deferred; without deferral it is called."""
    for defer, expected_calls in ((True, 0), (False, 1)):
        module, calls = _module(
            {"check": lambda x: True, "fit": lambda x, s: True},
            {"check": {"kind": "test"}, "fit": {"deferrable": True, "kind": "test"}},
        )
        sol = solve(
            parse_domain(DOMAIN),
            _streams(TEST_OK),
            _problem("(placed b s1)"),
            module,
            SolveOptions(defer=defer, initial_level=2, max_level=2, time_limit=20),
        )
        assert sol.solved
        assert [s.name for s in sol.plan] == ["finish", "put"]
        assert calls["fit"] == expected_calls
        assert bool(sol.deferred) is defer


GEN_DOMAIN = """
(define (domain claims2)
  (:requirements :strips)
  (:predicates (item ?x) (conf ?q) (kin ?x ?q) (motion ?q1 ?t ?q2) (at ?q) (holding ?x))
  (:action move :parameters (?q1 ?t ?q2)
    :precondition (and (at ?q1) (motion ?q1 ?t ?q2))
    :effect (and (at ?q2) (not (at ?q1))))
  (:action pick :parameters (?x ?q)
    :precondition (and (item ?x) (kin ?x ?q) (at ?q))
    :effect (holding ?x)))
"""
GEN_STREAMS = """
  (:stream ik :inputs (?x) :domain (item ?x) :outputs (?q) :certified (and (conf ?q) (kin ?x ?q)))
  (:stream motion :inputs (?q1 ?q2) :domain (and (conf ?q1) (conf ?q2)) :outputs (?t)
    :certified (motion ?q1 ?t ?q2))
"""


def test_producers_of_what_the_first_action_needs_are_evaluated_even_if_deferrable():
    """The first move needs a real trajectory to a real configuration: the configuration's
    producer (ik) is evaluated although it is deferrable, so the first step is all real."""
    module, calls = _module(
        {"ik": lambda x: iter([(("q", x),)]), "motion": lambda q1, q2: (("t", q1, q2),)},
        {
            "ik": {"deferrable": True},
            "motion": {"deferrable": True, "kind": "function"},
        },
    )
    module.values = {"q0": ("q", "start")}
    problem = parse_problem(
        "(define (problem p) (:domain claims2) (:objects d q0) "
        "(:init (item d) (conf q0) (at q0)) (:goal (holding d)))"
    )
    sol = solve(
        parse_domain(GEN_DOMAIN),
        _streams(GEN_STREAMS),
        problem,
        module,
        SolveOptions(defer=True, initial_level=2, time_limit=20),
    )
    assert sol.solved
    first = sol.plan[0]
    assert first.name == "move" and not first.deferred
    assert calls["ik"] == 1 and calls["motion"] == 1
    assert first.values[2] == ("q", "d") and first.values[1] == ("t", ("q", "start"), ("q", "d"))


# ---------------------------------------------------------------- stream plans


def test_a_stream_plan_includes_the_producers_of_domain_facts():
    """test-b's domain fact (a-ok x) is certified by test-a: the stream plan must evaluate
    test-a too; when test-a fails the plan is not a solution."""
    domain = parse_domain(
        """(define (domain chain) (:requirements :strips)
          (:predicates (item ?x) (aok ?x) (bok ?x) (done ?x))
          (:action finish :parameters (?x) :precondition (and (item ?x) (bok ?x))
            :effect (done ?x)))"""
    )
    streams = parse_stream_file(
        """(define (stream chain)
          (:stream test-a :inputs (?x) :domain (item ?x) :certified (aok ?x))
          (:stream test-b :inputs (?x) :domain (aok ?x) :certified (bok ?x)))"""
    )
    problem = parse_problem(
        "(define (problem p) (:domain chain) (:objects a) (:init (item a)) (:goal (done a)))"
    )
    for a_answer in (True, False):
        module, calls = _module(
            {"test-a": lambda x, a=a_answer: a, "test-b": lambda x: True},
            {"test-a": {"kind": "test"}, "test-b": {"kind": "test"}},
        )
        options = SolveOptions(initial_level=2, max_level=3, time_limit=20)
        sol = solve(domain, streams, problem, module, options)
        assert calls["test-a"] == 1
        assert sol.solved is a_answer


def test_an_alternative_producer_of_the_same_fact_is_tried():
    """Two streams certify (ok a); the first fails: the solver must use the second."""
    streams = _streams(
        """
        (:stream check-one :inputs (?x) :domain (item ?x) :certified (ok ?x))
        (:stream check-two :inputs (?x) :domain (item ?x) :certified (ok ?x))
        """
    )
    module, calls = _module(
        {"check-one": lambda x: False, "check-two": lambda x: True},
        {"check-one": {"kind": "test", "p_success": 0.1}, "check-two": {"kind": "test"}},
    )
    sol = solve(
        parse_domain(DOMAIN),
        streams,
        _problem("(done a)"),
        module,
        SolveOptions(initial_level=2, max_level=3, time_limit=20),
    )
    assert sol.solved
    assert calls["check-two"] == 1


def test_every_producer_of_a_fact_is_recorded_in_the_instantiation():
    """The provenance (objects.json, stream plans) lists every stream that can certify a
    fact, not only the first one found."""
    from ssr_compile import syntax as S
    from ssr_compile.compile.pipeline import compile_problem

    streams = _streams(
        """
        (:stream check-one :inputs (?x) :domain (item ?x) :certified (ok ?x))
        (:stream check-two :inputs (?x) :domain (item ?x) :certified (ok ?x))
        """
    )
    c = compile_problem(parse_domain(DOMAIN), streams, _problem("(done a)"), level=1)
    producers = c.instantiation.facts[S.Atom("ok", (S.Const("a"),))]
    assert sorted(r.instance.stream for r in producers) == ["check-one", "check-two"]


LOOK_DOMAIN = """
(define (domain claims3)
  (:requirements :strips)
  (:predicates (item ?x) (conf ?q) (kin ?x ?q) (traj ?t) (at ?q) (looked))
  (:action look :parameters (?t)
    :precondition (traj ?t)
    :effect (looked)))
"""
LOOK_STREAMS = """
  (:stream ik :inputs (?x) :domain (item ?x) :outputs (?q) :certified (and (conf ?q) (kin ?x ?q)))
  (:stream motion :inputs (?q1 ?x ?q2) :domain (and (conf ?q1) (kin ?x ?q2)) :outputs (?t)
    :certified (traj ?t))
"""


def test_a_deferrable_producer_of_an_input_the_first_step_needs_is_evaluated():
    """look(?t) needs a real trajectory; the trajectory's input ?q2 comes from a deferrable
    ik that the action itself never names: it must still be evaluated first."""
    module, calls = _module(
        {"ik": lambda x: iter([(("q", x),)]), "motion": lambda q1, x, q2: (("t", q1, q2),)},
        {"ik": {"deferrable": True}, "motion": {"deferrable": True, "kind": "function"}},
    )
    module.values = {"q0": ("q", "start")}
    problem = parse_problem(
        "(define (problem p) (:domain claims3) (:objects d q0) "
        "(:init (item d) (conf q0)) (:goal (looked)))"
    )
    sol = solve(
        parse_domain(LOOK_DOMAIN),
        _streams(LOOK_STREAMS),
        problem,
        module,
        SolveOptions(defer=True, initial_level=2, time_limit=20),
    )
    assert sol.solved and not sol.plan[0].deferred
    assert calls["ik"] == 1
    assert sol.plan[0].values[0] == ("t", ("q", "start"), ("q", "d"))


# ---------------------------------------------------------------- the plan simulator


def test_an_atom_deleted_and_added_by_one_action_holds_afterwards():
    """PDDL applies deletes before adds: moving from q to q leaves the robot at q."""
    domain = parse_domain(
        """(define (domain m) (:requirements :strips)
          (:predicates (at ?q) (seen ?q))
          (:action move :parameters (?a ?b) :precondition (at ?a)
            :effect (and (at ?b) (not (at ?a))))
          (:action look :parameters (?q) :precondition (at ?q) :effect (seen ?q)))"""
    )
    problem = parse_problem(
        "(define (problem p) (:domain m) (:objects x y) (:init (at x)) (:goal (seen x)))"
    )
    plan_preimage(domain, problem, [("move", ("x", "x")), ("look", ("x",))])
    with pytest.raises(PlanInvalid):
        plan_preimage(domain, problem, [("move", ("x", "y")), ("look", ("x",))])
