"""Lazy tests (``ssr_compile/compile/lazy_tests.py``): a cheap test the domain reads only where
it holding permits plans, beside its own domain's atoms, becomes an optimistically false
complement (``ssr-fails-<test>``) stated only where the test failed and checked where a plan
relies on it.  Which tests qualify, what the rewrite reads, and that plans stay right: a plan
never relies on a pair the test rejects, on tamp2d and on a small domain written here."""

from __future__ import annotations

from pathlib import Path

import pytest
from ssr_compile.streams import tamp2d as T

from ssr_compile import syntax as S
from ssr_compile.compile.lazy_tests import PREFIX, lazy_tests
from ssr_compile.parse import parse_domain, parse_problem, parse_stream_file
from ssr_compile.solver import SolveOptions, solve

ROOT = Path(__file__).resolve().parents[1]
TAMP2D = ROOT / "domains" / "pddl" / "tamp2d"

# A shelf with slots: a box goes on a free slot (a slot some other box occupies is taken).
# ``clear`` tests a slot against another box's slot; the domain reads it under (not (taken)).
SHELF = """
(define (domain shelf)
  (:predicates (Box ?b) (Slot ?s) (At ?b ?s) (Held ?b) (HandEmpty) (Clear ?s ?s2)
               (Taken ?b ?s) (Reach ?s))
  (:derived (Taken ?b ?s)
    (exists (?b2 ?s2) (and {guard} (At ?b2 ?s2) (not (= ?b ?b2)) (not (Clear ?s ?s2)))))
  (:action pick :parameters (?b ?s)
    :precondition (and (Box ?b) (At ?b ?s) (HandEmpty))
    :effect (and (Held ?b) (not (At ?b ?s)) (not (HandEmpty))))
  (:action put :parameters (?b ?s)
    :precondition (and (Held ?b) (Reach ?s) (not (Taken ?b ?s)))
    :effect (and (At ?b ?s) (HandEmpty) (not (Held ?b)))))
"""

SHELF_STREAMS = """
(define (stream shelf)
  (:stream find-slot :inputs (?b) :domain (Box ?b) :outputs (?s)
    :certified (and (Slot ?s) (Reach ?s)))
  (:stream clear :inputs (?s ?s2) :domain (and (Slot ?s) (Slot ?s2))
    :certified (Clear ?s ?s2)))
"""

SHELF_PROBLEM = """
(define (problem p) (:domain shelf) (:objects a b s0 s1)
  (:init (Box a) (Box b) (Slot s0) (Slot s1) (Reach s0) (Reach s1) (At a s0) (At b s1)
         (HandEmpty))
  (:goal (and (At a s1) (HandEmpty))))
"""

GUARDED = "(Slot ?s) (Slot ?s2)"
UNGUARDED = "(Slot ?s)"


def _shelf(guard: str = GUARDED, streams: str = SHELF_STREAMS):
    return (
        parse_domain(SHELF.format(guard=guard)),
        parse_stream_file(streams),
        parse_problem(SHELF_PROBLEM),
    )


def _atoms(f) -> list[S.Atom]:
    out, stack = [], [f]
    while stack:
        n = stack.pop()
        if isinstance(n, S.Atom):
            out.append(n)
        elif n is not None and not isinstance(n, S.Var | S.Const):
            stack.extend(S.children(n))
    return out


def test_a_test_read_under_a_negation_beside_its_domain_becomes_its_complement():
    domain, streams, problem = _shelf()
    out = lazy_tests(domain, streams, problem, {"clear"})
    assert out.tests == {PREFIX + "clear": "clear"}
    # the test is gone from the streams; its complement is a predicate over its inputs,
    # with its domain
    assert [s.name for s in out.streams.streams] == ["find-slot"]
    (pred,) = out.streams.predicates
    assert pred.name == PREFIX + "clear" and [p.name for p in pred.params] == ["?s", "?s2"]
    assert pred.domain == streams.streams[1].domain
    # (not (Clear ?s ?s2)) reads (ssr-fails-clear ?s ?s2); Clear is read nowhere any more
    (taken,) = out.domain.axioms
    preds = [a.pred for a in _atoms(taken.body)]
    assert "clear" not in preds and preds.count(PREFIX + "clear") == 1
    fails = next(a for a in _atoms(taken.body) if a.pred == PREFIX + "clear")
    assert [t.name for t in fails.args] == ["?s", "?s2"]
    assert not isinstance(taken.body.body, S.Not)  # a positive atom inside the conjunction
    assert PREFIX + "clear" in {p.name for p in out.domain.predicates}


def test_a_test_whose_domain_is_not_beside_it_stays_as_it_is():
    # (Slot ?s2) is not stated beside (not (Clear ?s ?s2)): outside the test's domain Clear
    # is false and Taken true, which the complement (false until evaluated) would not say
    domain, streams, problem = _shelf(UNGUARDED)
    out = lazy_tests(domain, streams, problem, {"clear"})
    assert out.tests == {}
    assert out.domain is domain and out.streams is streams


@pytest.mark.parametrize(
    "change",
    ["not a candidate", "stated by the problem", "changed by an action", "read positively"],
)
def test_the_conditions_under_which_a_test_is_not_turned(change):
    domain, streams, problem = _shelf()
    candidates = {"clear"}
    if change == "not a candidate":  # not cheap, or eager tests off: the caller says
        candidates = set()
    elif change == "stated by the problem":
        problem = parse_problem(SHELF_PROBLEM.replace("(HandEmpty))", "(HandEmpty) (Clear s0 s1))"))
    elif change == "changed by an action":
        domain = parse_domain(
            SHELF.format(guard=GUARDED).replace(
                "(not (HandEmpty))))", "(not (HandEmpty)) (Clear ?s ?s)))"
            )
        )
    elif change == "read positively":  # Clear true forbids a plan: its permissive value is false
        domain = parse_domain(
            SHELF.format(guard=GUARDED).replace("(not (Clear ?s ?s2))", "(Clear ?s ?s2)")
        )
    assert lazy_tests(domain, streams, problem, candidates).tests == {}


def test_an_atom_that_only_streams_certify_brings_what_they_require():
    # continuous_tamp's place: (Kin ?b ?q ?p ?g) comes only from the stream that requires
    # (Pose ?b ?p), so (Pose ?b ?p) holds beside it; the quantified pair states its own
    domain = parse_domain(
        """
(define (domain t)
  (:predicates (Pose ?b ?p) (Grasp ?b ?g) (Kin ?b ?q ?p ?g) (AtPose ?b ?p) (AtGrasp ?b ?g)
               (AtConf ?q) (CFree ?b ?p ?b2 ?p2))
  (:action place :parameters (?b ?p ?g ?q)
    :precondition (and (Kin ?b ?q ?p ?g) (AtConf ?q) (AtGrasp ?b ?g)
                       (forall (?b2 ?p2) (imply (and (Pose ?b2 ?p2) (AtPose ?b2 ?p2))
                                                (CFree ?b ?p ?b2 ?p2))))
    :effect (and (AtPose ?b ?p) (not (AtGrasp ?b ?g)))))
"""
    )
    streams = parse_stream_file(
        """
(define (stream t)
  (:stream ik :inputs (?b ?p ?g) :domain (and (Pose ?b ?p) (Grasp ?b ?g)) :outputs (?q)
    :certified (Kin ?b ?q ?p ?g))
  (:stream t-cfree :inputs (?b ?p ?b2 ?p2) :domain (and (Pose ?b ?p) (Pose ?b2 ?p2))
    :certified (CFree ?b ?p ?b2 ?p2)))
"""
    )
    problem = parse_problem(
        "(define (problem p) (:domain t) (:objects b p0 g) "
        "(:init (Pose b p0) (AtPose b p0) (Grasp b g)) (:goal (AtPose b p0)))"
    )
    assert lazy_tests(domain, streams, problem, {"t-cfree"}).tests == {
        PREFIX + "t-cfree": "t-cfree"
    }
    # a Kin fact the problem states without its Pose: Kin no longer brings Pose
    stated = parse_problem(
        "(define (problem p) (:domain t) (:objects b p0 p1 g q) "
        "(:init (Pose b p0) (AtPose b p0) (Grasp b g) (Kin b q p1 g)) (:goal (AtPose b p0)))"
    )
    assert lazy_tests(domain, streams, stated, {"t-cfree"}).tests == {}


def _solve_shelf(clear, lazy: bool):
    domain, streams, problem = _shelf()
    calls = []

    def recorded(s, s2):
        calls.append((s, s2))
        return clear(s, s2)

    def find_slot(b):
        for i in range(2, 6):
            yield (f"n{i}",)

    from ssr_compile.stream import StreamInfo, StreamsModule

    module = StreamsModule(
        "shelf",
        {"find-slot": find_slot, "clear": recorded},
        {"clear": StreamInfo(kind="test", cost=0.1)},
    )
    sol = solve(domain, streams, problem, module, SolveOptions(time_limit=30, lazy_tests=lazy))
    return sol, calls


@pytest.mark.parametrize("lazy", [True, False])
def test_a_plan_never_relies_on_a_pair_the_test_rejects(lazy):
    # a goes to s1, where b stands: b must move first, to a drawn slot that is not too close
    # to s0 (n2 is: rejected), so to n3
    def clear(s, s2):
        return s != s2 and {s, s2} != {"n2", "s0"}

    sol, calls = _solve_shelf(clear, lazy)
    assert sol.solved, sol.message
    steps = [(step.name, tuple(step.args)) for step in sol.plan]
    puts = [args for name, args in steps if name == "put"]
    assert ("b", "n2") not in puts and ("a", "s1") in puts
    # every put is clear of where the other box stands then (the real geometry)
    at = {"a": "s0", "b": "s1"}
    for name, (box, slot) in steps:
        if name == "put":
            other = "b" if box == "a" else "a"
            if at[other] is not None:
                assert clear(slot, at[other]), (box, slot, at)
            at[box] = slot
        else:
            at[box] = None
    assert sol.stats.streams["clear"].failures >= (1 if lazy else 0)


def test_tamp2d_blocked_plans_over_fewer_facts_and_moves_the_blocker():
    domain = parse_domain((TAMP2D / "domain.pddl").read_text())
    streams = parse_stream_file((TAMP2D / "stream.pddl").read_text())
    problem = parse_problem((TAMP2D / "problem-blocked.pddl").read_text())
    sizes = {}
    for lazy in (True, False):
        sol = solve(
            domain,
            streams,
            problem,
            T.make_module(0),
            SolveOptions(time_limit=30, planner="fd:opt", initial_level=3, lazy_tests=lazy),
        )
        assert sol.solved, sol.message
        plan = [(step.name, step.args) for step in sol.plan]
        T.check_plan(domain, problem, sol.values.value, plan)  # the real geometry
        picks = [args[0] for name, args in plan if name == "pick"]
        assert picks[0] == "b1", picks  # the blocker first
        sizes[lazy] = max(facts for _objects, facts, _values, _actions in sol.stats.sizes)
    # no CFree fact per pair of poses: the lazy problems are smaller
    assert sizes[True] < sizes[False]
