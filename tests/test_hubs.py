"""The hubs compile pass (ssr_compile/compile/hubs.py): an action over many pairs written as
two half-steps through a hub -- which actions are split, the smaller task, plans that map
back to the same plans, and pairs the task never had staying out of them."""

from __future__ import annotations

from pathlib import Path

import pytest

from ssr_compile import syntax as S
from ssr_compile.compile import hubs as H
from ssr_compile.compile.lower import lower
from ssr_compile.compile.pipeline import compile_problem
from ssr_compile.errors import SSRError
from ssr_compile.parse import parse_file, parse_text
from ssr_compile.planners import get_planner
from ssr_compile.solver.preimage import plan_preimage

KITCHEN = Path(__file__).resolve().parents[1] / "domains" / "pddl" / "kitchen"

ROADS = """
(define (domain roads)
  (:requirements :strips :action-costs)
  (:predicates (road ?a ?t ?b) (at ?a) (visited ?a) (open ?a))
  (:functions (total-cost) - number)
  (:action drive
    :parameters (?a ?t ?b)
    :precondition (and (road ?a ?t ?b) (at ?a) (open ?a))
    :effect (and (at ?b) (visited ?b) (not (at ?a)) (increase (total-cost) 1)))
  (:action close
    :parameters (?a)
    :precondition (at ?a)
    :effect (not (open ?a))))
"""


def roads_problem(n: int, missing=(), real=(), goal="(visited p1)") -> S.Problem:
    """``n`` places, a shared road object from every place to every place (itself too: a
    product, as the kitchen's base motions; but ``missing``), and one road object of its own
    for each pair of ``real``."""
    places = [f"p{i}" for i in range(n)]
    facts = [f"(road {a} shared {b})" for a in places for b in places if (a, b) not in missing]
    facts += [f"(road {a} own-{a}-{b} {b})" for a, b in real]
    objects = " ".join(places + ["shared"] + [f"own-{a}-{b}" for a, b in real])
    opens = " ".join(f"(open {p})" for p in places)
    text = f"""(define (problem r) (:domain roads) (:objects {objects})
      (:init (at p0) {opens} {" ".join(facts)} (= (total-cost) 0))
      (:goal {goal}) (:metric minimize (total-cost)))"""
    return parse_text(text, "problem.pddl")


def ground_drives(problem: S.Problem) -> int:
    """What a grounder makes of the drives: one per road fact, one per hub's way out and in."""
    return sum(1 for f in problem.init if isinstance(f, S.Atom) and "road" in f.pred) + sum(
        1
        for f in problem.init
        if isinstance(f, S.Atom) and f.pred.endswith(("-hub-from", "-hub-to"))
    )


def test_an_action_over_all_pairs_goes_through_one_hub(monkeypatch):
    monkeypatch.setattr(H, "MIN_PAIRS", 100)
    domain = parse_text(ROADS, "domain.pddl")
    problem = roads_problem(30)
    hubs = H.route_through_hubs(domain, problem)
    out, into, params, xs, ys = hubs.split["drive"]
    assert (params, xs, ys) == (("?a", "?t", "?b"), ("?a",), ("?t", "?b"))
    assert hubs.hubs == 1 and hubs.pairs == 30 * 30
    assert ground_drives(problem) == 900
    assert ground_drives(hubs.problem) == 30 + 30  # 30 ways out of the hub, 30 ways in
    # `close` is not a candidate (no static pair fact), and waits for the hub to be left
    assert "close" not in hubs.split
    close = next(a for a in hubs.domain.actions if a.name == "close")
    assert S.Atom("hub-idle", ()) in S.conjuncts(close.precondition)


def test_plans_through_the_hub_map_back_to_plans_of_the_task(monkeypatch):
    monkeypatch.setattr(H, "MIN_PAIRS", 100)
    domain = parse_text(ROADS, "domain.pddl")
    goal = "(and (visited p1) (visited p2) (at p3))"
    problem = roads_problem(20, goal=goal)
    hubs = H.route_through_hubs(domain, problem)
    result = get_planner("fd").solve(hubs.domain, hubs.problem, time_limit=30)
    assert result.status == "solved", result.message
    names = [n for n, _ in result.actions]
    assert names.count(hubs.split["drive"][0]) == 3 and names.count(hubs.split["drive"][1]) == 3
    plan = hubs.map_plan(result.actions)
    assert [n for n, _ in plan] == ["drive"] * 3
    plan_preimage(domain, problem, plan)  # raises unless the plan is valid on the task
    assert plan[-1][1][2] == "p3"


def test_a_pair_the_task_lacks_stays_out_of_every_plan(monkeypatch):
    monkeypatch.setattr(H, "MIN_PAIRS", 100)
    domain = parse_text(ROADS, "domain.pddl")
    # no road p0 -> p1; p0 has one road of its own to p5
    problem = roads_problem(15, missing={("p0", "p1")}, real={("p0", "p5")})
    hubs = H.route_through_hubs(domain, problem)
    facts = {f for f in hubs.problem.init if isinstance(f, S.Atom)}
    # p0 lacks p1, so it does not take the hub every other place takes; its roads stay as
    # they were, the one of its own among them
    assert S.Atom("road", tuple(map(S.const, ("p0", "own-p0-p5", "p5")))) in facts
    assert not any(f.pred == "road" and f.args[0].name == "p0" and f.args[2].name == "p1"
                   for f in facts)  # fmt: skip
    result = get_planner("fd").solve(hubs.domain, hubs.problem, time_limit=30)
    assert result.status == "solved", result.message
    plan = hubs.map_plan(result.actions)
    plan_preimage(domain, problem, plan)
    assert len(plan) == 2  # p0 -> somewhere -> p1, never straight


@pytest.mark.parametrize(
    "change",
    [
        # the second half read by the precondition: (open ?b) must hold before the move
        ("(at ?a) (open ?a))", "(at ?a) (open ?a) (open ?b))"),
        # the second half deleted: not a plain add after the first half's deletes
        ("(at ?b) (visited ?b) (not (at ?a))", "(at ?b) (not (open ?b)) (not (at ?a))"),
        # the pair's fact changed by an action: not static
        (":effect (not (open ?a))))", ":effect (and (not (open ?a)) (not (road ?a ?a ?a)))))"),
    ],
)
def test_an_action_whose_halves_would_read_or_undo_each_other_is_not_split(monkeypatch, change):
    monkeypatch.setattr(H, "MIN_PAIRS", 100)
    old, new = change
    assert old in ROADS
    domain = parse_text(ROADS.replace(old, new), "domain.pddl")
    hubs = H.route_through_hubs(domain, roads_problem(20))
    assert not hubs.split
    assert hubs.problem is not None and ground_drives(hubs.problem) == 400


def test_small_tasks_are_written_as_they_were():
    domain = parse_text(ROADS, "domain.pddl")
    problem = roads_problem(20)  # 400 pairs, fewer than MIN_PAIRS
    hubs = H.route_through_hubs(domain, problem)
    assert not hubs.split and hubs.problem is problem and hubs.domain is domain


def test_a_plan_that_stops_inside_a_hub_is_an_error(monkeypatch):
    monkeypatch.setattr(H, "MIN_PAIRS", 100)
    hubs = H.route_through_hubs(parse_text(ROADS, "domain.pddl"), roads_problem(20))
    out, into = hubs.split["drive"][:2]
    with pytest.raises(SSRError, match="ends inside hub"):
        hubs.map_plan([(out, ("hub1", "p0"))])
    with pytest.raises(SSRError, match="not where a hub's two halves allow it"):
        hubs.map_plan([(out, ("hub1", "p0")), ("close", ("p0",))])


@pytest.mark.parametrize("level", [4, 5])
def test_the_kitchens_base_motions_plan_the_same_through_a_hub(monkeypatch, level):
    d, s, p = (
        parse_file(KITCHEN / n) for n in ("domain.pddl", "stream.pddl", "problem-inspect.pddl")
    )
    plans = {}
    for on in (False, True):
        monkeypatch.setattr(H, "MIN_PAIRS", 1 if on else 10**9)
        c = compile_problem(d, s, p, level=level, hubs=True)
        split = [x for x in c.passes if isinstance(x, H.Hubs)]
        assert bool(split) == on
        result = get_planner("fd").solve(c.domain, c.problem, time_limit=60)
        assert result.status == "solved", result.message
        plans[on] = c.map_plan(result.actions)
        plan_preimage(c.source_domain, c.source_problem, plans[on])
    assert plans[True] == plans[False]
    assert plans[True][0][0] == "move-base"


def test_a_compile_artifact_keeps_one_step_per_action(monkeypatch):
    """`ssr-compile compile` writes each compiled action's one action of the user's
    (actions.json): the pass runs only where the solver asks for it."""
    monkeypatch.setattr(H, "MIN_PAIRS", 1)
    d, s, p = (
        parse_file(KITCHEN / n) for n in ("domain.pddl", "stream.pddl", "problem-inspect.pddl")
    )
    c = compile_problem(d, s, p, level=4)
    assert not any(isinstance(x, H.Hubs) for x in c.passes)
    assert not any("hub" in a.name for a in c.domain.actions)


@pytest.mark.parametrize("backend", ["fd:lama-first", "up:fast-downward", "pyperplan"])
def test_every_backend_plans_through_a_hub(monkeypatch, backend):
    """The hub's task as each backend reads it (lowered to its capabilities, ground for
    pyperplan): the plan maps back to a valid plan of the task."""
    monkeypatch.setattr(H, "MIN_PAIRS", 100)
    domain = parse_text(ROADS, "domain.pddl")
    problem = roads_problem(12, goal="(and (visited p1) (at p2))")
    hubs = H.route_through_hubs(domain, problem)
    assert hubs.split
    planner = get_planner(backend)
    lowered = lower(hubs.domain, hubs.problem, planner.capabilities)
    result = planner.solve(lowered.domain, lowered.problem, time_limit=60)
    assert result.status == "solved", result.message
    plan = hubs.map_plan(lowered.map_plan(result.actions))
    assert [n for n, _ in plan] == ["drive", "drive"]
    plan_preimage(domain, problem, plan)
