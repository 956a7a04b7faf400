"""The optimistic instantiation's cap is checked while the instances are built, not after a
whole depth's join (which took 9 s and 600 MB on tamp2d with 1000 blocks before refusing)."""

from __future__ import annotations

import pytest

from ssr_compile.compile import instantiate as inst_mod
from ssr_compile.compile.pipeline import compile_problem
from ssr_compile.errors import UnsupportedError
from ssr_compile.examples import load_example
from ssr_compile.parse import parse_problem


def _blocks(n: int):
    objs = " ".join(f"b{i} p{i}" for i in range(n))
    init = " ".join(
        f"(Block b{i}) (Pose b{i} p{i}) (AtPose b{i} p{i}) (Contained b{i} p{i} rtable)"
        for i in range(n)
    )
    return parse_problem(
        f"(define (problem t) (:domain tamp2d) (:objects {objs} q0 rtable rgoal) (:init "
        f"(Region rtable) (Region rgoal) (Conf q0) (AtConf q0) (HandEmpty) {init} "
        f"(= (total-cost) 0)) (:goal (In b0 rgoal)) (:metric minimize (total-cost)))"
    )


def test_the_cap_stops_the_join_as_soon_as_it_is_passed(monkeypatch):
    ex = load_example("tamp2d")
    problem = _blocks(60)
    monkeypatch.setattr(inst_mod, "MAX_INSTANCES", 50)
    drawn = 0
    real = inst_mod._matches

    def counting(*args, **kwargs):
        nonlocal drawn
        for m in real(*args, **kwargs):
            drawn += 1
            yield m

    monkeypatch.setattr(inst_mod, "_matches", counting)
    with pytest.raises(UnsupportedError, match="more than 50 stream instances at level 1"):
        compile_problem(ex.domain, ex.streams, problem, level=1)
    # 60 blocks x 60 poses x ... candidate bindings exist; the join stopped right after 51
    assert drawn <= 52


def test_the_focused_solver_stops_raising_the_level_at_the_cap(monkeypatch):
    # A resource limit, like the last level: "no plan up to the level before", not a crash of
    # the whole solve (a kitchen episode ended on it); at the first level it is still an error.
    from pathlib import Path

    from ssr_compile.streams import tamp2d

    from ssr_compile.parse import parse_file
    from ssr_compile.solver import SolveOptions, solve
    from ssr_compile.stream import from_module

    folder = Path(__file__).resolve().parents[1] / "domains" / "pddl" / "tamp2d"
    domain, streams = parse_file(folder / "domain.pddl"), parse_file(folder / "stream.pddl")
    problem = parse_file(folder / "problem-blocked.pddl")
    first = compile_problem(domain, streams, problem, level=1)
    cap = len(first.instantiation.results) + 1  # level 1 fits, a higher level does not
    monkeypatch.setattr(inst_mod, "MAX_INSTANCES", cap)
    sol = solve(domain, streams, problem, from_module(tamp2d), SolveOptions(time_limit=60))
    assert sol.status == "unsolvable", sol.message
    assert "would pass the cap" in sol.message and "up to level 1 " in sol.message
    monkeypatch.setattr(inst_mod, "MAX_INSTANCES", 1)
    with pytest.raises(UnsupportedError, match="more than 1 stream instances at level 1"):
        solve(domain, streams, problem, from_module(tamp2d), SolveOptions(time_limit=60))


# Leaf tests (issue 40): tests whose facts no stream domain reads are counted apart.


def _tamp2d_counts(problem, level):
    ex = load_example("tamp2d")
    out = inst_mod.instantiate(ex.domain, ex.streams, problem, level=level)
    counts: dict[str, int] = {}
    for r in out.results:
        counts[r.instance.stream] = counts.get(r.instance.stream, 0) + 1
    return counts


def test_leaf_tests_are_the_tests_no_domain_reads():
    from ssr_compile.parse import parse_stream_file

    ex = load_example("tamp2d")
    assert inst_mod.leaf_tests(ex.streams, ex.streams.streams) == {"test-cfree"}
    streams = parse_stream_file(
        "(define (stream s)"
        " (:stream near :inputs (?a ?b) :domain (and (P ?a) (P ?b)) :certified (Near ?a ?b))"
        " (:stream far :inputs (?a ?b) :domain (and (P ?a) (P ?b)) :certified (Far ?a ?b))"
        " (:stream gen :inputs (?a ?b) :domain (Near ?a ?b) :outputs (?c) :certified (P ?c))"
        " (:function (Cost ?a ?b) (Far ?a ?b)))"
    )
    # near feeds gen's domain, far a function's: neither is a leaf; gen has outputs
    assert inst_mod.leaf_tests(streams, streams.streams) == frozenset()


def test_leaf_streams_are_the_generators_no_domain_reads_either():
    """A generator whose certified facts no stream, rule or function domain reads (its
    outputs are typed only by them, so no stream takes one as an input) is a leaf stream:
    tamp2d's motion, the kitchen's base motion (one per pair of base configurations); not a
    generator whose output another stream reads (the kitchen's inv-kin, tamp2d's ik)."""
    ex = load_example("tamp2d")
    assert inst_mod.leaf_streams(ex.streams, ex.streams.streams) == {"test-cfree", "motion"}
    kitchen = load_example("kitchen")
    leaves = inst_mod.leaf_streams(kitchen.streams, kitchen.streams.streams)
    assert "plan-base-motion" in leaves
    assert "inv-kin" not in leaves and "sample-placement" not in leaves


def test_pairwise_tests_do_not_count_against_the_instance_cap(monkeypatch):
    # 3 blocks, 2 regions, level 2: 18 instances whose objects or facts streams join over (6
    # placements, 3 grasps, 9 ik), 1 motion (a leaf stream: its trajectory only actions read)
    # and 54 test-cfree instances: the pairs of the 9 poses (3 a block) of two different
    # blocks (Unsafe reads CFree only with (not (= ?b ?b2)))
    problem = _blocks(3)
    counts = _tamp2d_counts(problem, 2)
    assert counts == {"sample-placement": 6, "sample-grasp": 3, "ik": 9, "motion": 1,
                      "test-cfree": 54}  # fmt: skip
    ex = load_example("tamp2d")
    monkeypatch.setattr(inst_mod, "MAX_INSTANCES", 18)
    out = inst_mod.instantiate(ex.domain, ex.streams, problem, level=2)
    assert len(out.results) == 73
    monkeypatch.setattr(inst_mod, "MAX_INSTANCES", 17)
    with pytest.raises(UnsupportedError, match=r"more than 17 stream instances at level 2.*ik 9"):
        inst_mod.instantiate(ex.domain, ex.streams, problem, level=2)


def test_leaf_tests_have_a_cap_of_their_own(monkeypatch):
    ex = load_example("tamp2d")
    problem = _blocks(3)
    monkeypatch.setattr(inst_mod, "MAX_LEAF_TESTS", 55)
    assert len(inst_mod.instantiate(ex.domain, ex.streams, problem, level=2).results) == 73
    monkeypatch.setattr(inst_mod, "MAX_LEAF_TESTS", 54)
    with pytest.raises(
        UnsupportedError,
        match=r"more than 54 instances of tests and streams no stream domain uses at level 2;"
        r".*test-cfree 54, motion 1",
    ):
        inst_mod.instantiate(ex.domain, ex.streams, problem, level=2)


def test_a_test_is_not_instantiated_where_the_domain_cannot_read_its_fact():
    from ssr_compile.compile.relevance import distinct_inputs
    from ssr_compile.parse import parse_domain, parse_stream_file

    ex = load_example("tamp2d")
    problem = _blocks(2)
    assert distinct_inputs(ex.domain, problem, ex.streams.streams) == {
        "test-cfree": (("?b", "?b2"),)
    }
    out = inst_mod.instantiate(ex.domain, ex.streams, problem, level=1)
    pairs = [r.instance.inputs for r in out.results if r.instance.stream == "test-cfree"]
    assert sorted(pairs) == [("b0", "p0", "b1", "p1"), ("b1", "p1", "b0", "p0")]
    # one occurrence without the inequality (here: in the goal) and every pair is read
    text = (
        "(define (domain d) (:predicates (P ?x) (Far ?x ?y) (G))"
        " (:derived (G) (exists (?x ?y) (and (P ?x) (P ?y) (not (= ?x ?y)) (Far ?x ?y))))"
        " (:action a :parameters (?x ?y) :precondition (and (not (= ?y ?x)) (Far ?x ?y))"
        " :effect (G)))"
    )
    domain = parse_domain(text)
    streams = parse_stream_file(
        "(define (stream s) (:stream far :inputs (?a ?b) :domain (and (P ?a) (P ?b))"
        " :certified (Far ?a ?b)))"
    )
    goal = parse_problem("(define (problem p) (:domain d) (:init) (:goal (G)))")
    assert distinct_inputs(domain, goal, streams.streams) == {"far": (("?a", "?b"),)}
    read = parse_problem("(define (problem p) (:domain d) (:init) (:goal (Far x x)))")
    assert distinct_inputs(domain, read, streams.streams) == {}


def test_a_stream_that_never_succeeds_optimistically_is_instantiated_over_real_inputs_only():
    # StreamInfo.p_success 0 (pddlstream's infinite effort): no instance over an optimistic
    # input, every instance over real inputs as before
    ex = load_example("tamp2d")
    problem = _blocks(2)
    full = inst_mod.instantiate(ex.domain, ex.streams, problem, level=2)
    real = inst_mod.instantiate(ex.domain, ex.streams, problem, level=2, real_only={"test-cfree"})

    def cfree(out):
        return {r.instance.inputs for r in out.results if r.instance.stream == "test-cfree"}

    optimistic = {i for i in cfree(full) if any(x in full.objects for x in i)}
    assert optimistic  # placements drawn for a plan are tested optimistically by default
    assert cfree(real) == cfree(full) - optimistic
    assert cfree(real) == {("b0", "p0", "b1", "p1"), ("b1", "p1", "b0", "p0")}
    # the other streams are untouched
    others = {r.instance for r in full.results if r.instance.stream != "test-cfree"}
    assert others == {r.instance for r in real.results if r.instance.stream != "test-cfree"}
