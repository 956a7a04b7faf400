"""Optimistic stand-ins (``StreamInfo(optimistic=...)``, pddlstream's ``opt_gen_fn``): a
number line walked from 1 by ``inc`` (+1) and ``dbl`` (x2) to a number at least 6.  With
stand-ins, optimistic instantiation computes the numbers a plan would reach, ``big`` rejects
the optimistic ones below 6, and equal numbers are one optimistic object, so the first
optimistic plan that passes ``big`` is one the real streams confirm; without them, the
optimistic plans are "one step, then big" until the real numbers say otherwise."""

from __future__ import annotations

import pytest

from ssr_compile.compile.instantiate import instantiate
from ssr_compile.compile.standins import StandIns
from ssr_compile.errors import StreamError, StreamFailure
from ssr_compile.parse import parse_domain, parse_problem, parse_stream_file
from ssr_compile.solver import SolveOptions, solve
from ssr_compile.stream import StreamInfo, StreamsModule

DOMAIN = """
(define (domain line)
  (:predicates (Num ?x) (At ?x) (Inc ?x ?y) (Dbl ?x ?y) (Big ?x) (Reached))
  (:functions (StepCost ?x ?y))
  (:action inc :parameters (?x ?y) :precondition (and (At ?x) (Inc ?x ?y))
    :effect (and (At ?y) (not (At ?x)) (increase (total-cost) (StepCost ?x ?y))))
  (:action dbl :parameters (?x ?y) :precondition (and (At ?x) (Dbl ?x ?y))
    :effect (and (At ?y) (not (At ?x)) (increase (total-cost) (StepCost ?x ?y))))
  (:action finish :parameters (?x) :precondition (and (At ?x) (Big ?x)) :effect (Reached)))
"""

STREAMS = """
(define (stream line)
  (:stream inc :inputs (?x) :domain (Num ?x) :outputs (?y) :certified (and (Num ?y) (Inc ?x ?y)))
  (:stream dbl :inputs (?x) :domain (Num ?x) :outputs (?y) :certified (and (Num ?y) (Dbl ?x ?y)))
  (:stream big :inputs (?x) :domain (Num ?x) :certified (Big ?x))
  (:function (StepCost ?x ?y) (and (Num ?x) (Num ?y))))
"""

PROBLEM = """
(define (problem p) (:domain line) (:objects one)
  (:init (Num one) (At one) (= (total-cost) 0)) (:goal (Reached))
  (:metric minimize (total-cost)))
"""


def inc(x):
    return (x + 1,)


def dbl(x):
    return (2 * x,)


def big(x):
    return x >= 6


def step_cost(x, y):
    return 1


def module(standins: bool, calls: list | None = None, **extra) -> StreamsModule:
    def recorded(name, fn):
        def call(*args):
            if calls is not None:
                calls.append((name, args))
            return fn(*args)

        return call

    fns = {"inc": inc, "dbl": dbl, "big": big, "stepcost": step_cost}
    streams = {n: recorded(n, f) for n, f in fns.items()}
    info = {n: StreamInfo(kind="function") for n in ("inc", "dbl")}
    info["big"] = StreamInfo(kind="test")
    if standins:
        info = {n: StreamInfo(kind=i.kind, optimistic=fns[n]) for n, i in info.items()}
        info["stepcost"] = StreamInfo(optimistic=step_cost)
    for name, value in extra.items():
        info[name] = value
    return StreamsModule("line", streams, info, {"one": 1})


def run(mod: StreamsModule):
    return solve(
        parse_domain(DOMAIN),
        parse_stream_file(STREAMS),
        parse_problem(PROBLEM),
        mod,
        SolveOptions(time_limit=60),
    )


def numbers(sol) -> list:
    return [sol.plan[0].values[0]] + [s.values[1] for s in sol.plan if s.name != "finish"]


def test_stand_ins_make_the_first_optimistic_plan_the_real_one():
    calls: list = []
    with_standins = run(module(True, calls))
    assert with_standins.solved, with_standins.message
    reached = numbers(with_standins)
    assert reached[0] == 1 and reached[-1] >= 6 and len(reached) == 4  # three steps
    # the real streams were called on the plan's chain only: no "one step, then big" plans
    drawn = [(n, a) for n, a in calls if n in ("inc", "dbl")]
    assert len(drawn) == 3
    assert [a[0] for _n, a in drawn] == reached[:-1]
    without = run(module(False))
    assert without.solved, without.message
    assert numbers(without)[-1] >= 6
    assert with_standins.stats.planner_calls < without.stats.planner_calls


def instantiation(mod: StreamsModule, level: int = 3):
    domain, streams = parse_domain(DOMAIN), parse_stream_file(STREAMS)
    mod.check_against(streams)
    values = {"one": 1}
    return instantiate(
        domain,
        streams,
        parse_problem(PROBLEM),
        level=level,
        standins=StandIns.of(mod, lambda name: values.get(name, name)),
    )


def test_equal_stand_in_values_are_one_optimistic_object():
    inst = instantiation(module(True), level=4)
    # inc(1) = dbl(1) = 2: one object, made by both instances
    two = [o for o, v in inst.standins.items() if v == 2]
    assert len(two) == 1
    assert sorted(r.instance.stream for r in inst.merged[two[0]]) == ["dbl", "inc"]
    assert sorted(set(inst.standins.values())) == [2, 3, 4, 5, 6, 7, 8, 9, 10, 12, 16]
    # big holds optimistically only where its stand-in does
    big_of = {r.instance.inputs[0] for r in inst.results if r.instance.stream == "big"}
    assert {inst.standins[o] for o in big_of} == {6, 8}


def test_a_cost_stand_in_gives_the_planned_value_and_none_rules_the_term_out():
    def cost(x, y):
        return None if y == 3 else float(abs(y - x))

    inst = instantiation(module(True, stepcost=StreamInfo(optimistic=cost)))
    planned = {
        tuple(inst.standins.get(a.name, 1) for a in t.args): r.value
        for t, r in inst.functions.items()
    }
    assert planned[(1, 2)] == 1.0 and planned[(2, 4)] == 2.0
    assert planned[(2, 3)] == float("inf")  # not applicable: no action uses it


def test_without_stand_in_values_the_defaults_hold():
    """``inc`` has no stand-in: its outputs have no value, so ``big`` (which has one) is
    optimistically true over them and ``dbl``'s stand-in is not called on them."""
    seen: list = []

    def opt_dbl(x):
        seen.append(x)
        return (2 * x,)

    mod = module(False, dbl=StreamInfo(kind="function", optimistic=opt_dbl))
    mod.info["big"] = StreamInfo(kind="test", optimistic=big)
    inst = instantiation(mod, level=3)
    assert set(seen) == {1, 2, 4}  # dbl(1) = 2, dbl(2), dbl(4); never an output of inc
    inc_out = [r.outputs[0] for r in inst.results if r.instance.stream == "inc" and r.level < 3]
    big_of = {r.instance.inputs[0] for r in inst.results if r.instance.stream == "big"}
    assert inc_out and set(inc_out) <= big_of
    assert not any(inst.standins.get(o) == 2 for o in big_of)  # big(2) is false


def test_stand_in_errors_name_the_stream():
    streams = parse_stream_file(STREAMS)
    mod = module(False, inc=StreamInfo(kind="function", optimistic=5))
    with pytest.raises(StreamError, match="optimistic stand-in is 5"):
        mod.check_against(streams)

    def broken(x):
        raise ValueError("no stand-in today")

    with pytest.raises(StreamFailure, match="inc.*raised ValueError: no stand-in today"):
        run(module(False, inc=StreamInfo(kind="function", optimistic=broken)))
    with pytest.raises(StreamFailure, match="dbl.*returned 2 output"):
        run(module(False, dbl=StreamInfo(kind="function", optimistic=lambda x: (x, x))))
    with pytest.raises(StreamFailure, match="big.*must return True or False"):
        run(module(False, big=StreamInfo(kind="test", optimistic=lambda x: "yes")))


def test_a_predicate_takes_no_stand_in():
    streams = parse_stream_file(STREAMS.replace(
        "(:stream big", "(:predicate (Odd ?x) (Num ?x))\n  (:stream big"
    ))  # fmt: skip
    mod = module(False, odd=StreamInfo(optimistic=lambda x: x % 2 == 1))
    mod.streams["odd"] = lambda x: x % 2 == 1
    with pytest.raises(StreamError, match="to the :predicate 'odd'"):
        mod.check_against(streams)
