"""One contract for every compile pass: each returns a ``PassResult`` (its output task and the
map from the output's plans back to the input's), and chaining the map-backs takes a
planner's plan back to the input task."""

from __future__ import annotations

from dataclasses import replace

import pytest

from ssr_compile import syntax as S
from ssr_compile.compile.capabilities import Capabilities
from ssr_compile.compile.constraints import Constrained, constrain_plan
from ssr_compile.compile.costs import Costed, compile_costs
from ssr_compile.compile.derived import compile_away
from ssr_compile.compile.disjunctions import Split, split_disjunctions
from ssr_compile.compile.ground import Grounded, ground
from ssr_compile.compile.instantiate import Instantiation, instantiate
from ssr_compile.compile.lower import Lowered, lower
from ssr_compile.compile.negations import Negated, remove_negations
from ssr_compile.compile.pipeline import Compiled, compile_problem, objects_as_constants
from ssr_compile.compile.quantifiers import expand_quantifiers
from ssr_compile.compile.rename import Renamed, rename_task
from ssr_compile.compile.result import PassResult, map_back
from ssr_compile.parse import parse_domain, parse_problem, parse_stream_file
from ssr_compile.planners import get_planner
from ssr_compile.solver.preimage import plan_preimage

# Every feature a lowering step removes: a derived predicate, a quantifier, a disjunction,
# negation, equality with a constant (``?to`` disappears from ``go-hall``), costs, and an
# action named like a predicate (renamed for unified-planning's reader).
DOMAIN = """
(define (domain rooms)
  (:requirements :strips :typing :negative-preconditions :disjunctive-preconditions
                 :equality :existential-preconditions :derived-predicates :action-costs)
  (:types room)
  (:constants hall - room)
  (:predicates (at ?r - room) (link ?a ?b - room) (open ?r - room) (dark ?r - room)
               (near ?r - room) (lit))
  (:functions (total-cost) - number)
  (:derived (near ?r - room) (exists (?s - room) (and (at ?s) (link ?s ?r))))
  (:action go
    :parameters (?from ?to - room)
    :precondition (and (at ?from) (link ?from ?to) (not (= ?from ?to))
                       (or (open ?to) (near ?to)) (not (dark ?to)))
    :effect (and (at ?to) (not (at ?from)) (increase (total-cost) 2.5)))
  (:action go-hall
    :parameters (?from ?to - room)
    :precondition (and (at ?from) (link ?from ?to) (= ?to hall))
    :effect (and (at ?to) (not (at ?from)) (increase (total-cost) 1)))
  (:action lit
    :parameters (?r - room)
    :precondition (and (near ?r) (dark ?r))
    :effect (and (not (dark ?r)) (lit) (increase (total-cost) 1))))
"""
PROBLEM = """
(define (problem tour) (:domain rooms)
  (:objects kitchen cellar attic - room)
  (:init (at kitchen) (link kitchen hall) (link hall cellar) (link cellar attic)
         (link hall kitchen) (dark cellar) (= (total-cost) 0))
  (:goal (and (at attic) (lit)))
  (:metric minimize (total-cost)))
"""
STREAMS = """
(define (stream rooms)
  (:stream find-door
    :inputs (?r)
    :domain (at ?r)
    :outputs (?d)
    :certified (doorof ?r ?d)))
"""
STRIPS = Capabilities(**dict.fromkeys(Capabilities().as_dict(), False))  # every feature off


def _task():
    domain = parse_domain(DOMAIN)
    return domain, parse_problem(PROBLEM)


def _dummy_plan(domain: S.Domain) -> list[tuple[str, tuple[str, ...]]]:
    """One step per action of ``domain``, its arguments named after its parameters."""
    return [(a.name, tuple(p.name.lstrip("?") for p in a.parameters)) for a in domain.actions]


def test_every_pass_returns_a_pass_result():
    domain, problem = _task()
    results = {
        "objects_as_constants": (objects_as_constants(domain, problem), PassResult),
        "instantiate": (
            instantiate(domain, parse_stream_file(STREAMS), problem, level=1),
            Instantiation,
        ),
        "constraints": (
            constrain_plan(
                domain, problem, [("go-hall", ("kitchen", "hall"))], {"hall"}.__contains__
            ),
            Constrained,
        ),
        "ground": (ground(domain, problem), Grounded),
        "derived": (compile_away(domain, problem), PassResult),
        "quantifiers": (expand_quantifiers(*compile_away(domain, problem).task), PassResult),
        "disjunctions": (
            split_disjunctions(*expand_quantifiers(*compile_away(domain, problem).task).task),
            Split,
        ),
        "negations": (remove_negations(domain, problem), Negated),
        "costs": (compile_costs(domain, problem), Costed),
        "rename": (rename_task(domain, problem), Renamed),
        "lower": (lower(domain, problem, STRIPS), Lowered),
        "compile_problem": (compile_problem(domain, None, problem, caps=STRIPS), Compiled),
    }
    arity = {a.name: len(a.parameters) for a in domain.actions}
    for name, (result, kind) in results.items():
        assert isinstance(result, PassResult) and isinstance(result, kind), name
        assert isinstance(result.domain, S.Domain) and isinstance(result.problem, S.Problem), name
        assert result.task == (result.domain, result.problem), name
        # every action of the output maps back to an action of the input, with its arity
        for back, args in result.map_plan(_dummy_plan(result.domain)):
            assert back in arity and len(args) == arity[back], (name, back, args)
    # the extras the later steps need
    assert results["costs"][0].scale == 10  # 2.5 -> 25
    assert results["instantiate"][0].objects  # provenance of the optimistic objects
    assert "doorof" in {p.name for p in results["instantiate"][0].domain.predicates}


def test_each_pass_maps_its_own_changes_back():
    domain, problem = _task()
    flat = compile_away(domain, problem)
    split = split_disjunctions(*expand_quantifiers(*flat.task).task)
    copies = [a.name for a in split.domain.actions if a.name.startswith("go--")]
    # (open ?to), or (near ?to) through one of the four rooms: a copy each
    assert len(copies) == 5 and "go" not in {a.name for a in split.domain.actions}
    assert split.map_plan([(copies[-1], ("a", "b"))]) == [("go", ("a", "b"))]
    negated = remove_negations(*split.task)
    hall = next(a for a in negated.domain.actions if a.name == "go-hall")
    assert [p.name for p in hall.parameters] == ["?from"]  # (= ?to hall) substituted
    assert negated.map_plan([("go-hall", ("kitchen",))]) == [("go-hall", ("kitchen", "hall"))]
    renamed = rename_task(domain, problem)
    new = renamed.renaming.actions["lit"]  # the action shares the predicate's name
    assert renamed.map_plan([(new, ())]) == [("lit", ())]
    grounded = ground(domain, problem)
    name, lifted = next(iter(grounded.actions.items()))
    assert grounded.map_plan([(name, ())]) == [lifted]
    constrained = constrain_plan(
        domain, problem, [("go-hall", ("kitchen", "hall"))], {"hall"}.__contains__
    )
    assert constrained.map_plan([("go-hall-step1", ("kitchen", "hall"))]) == [
        ("go-hall", ("kitchen", "hall"))
    ]


def test_lowered_chains_the_map_backs_of_its_steps():
    domain, problem = _task()
    lowered = lower(domain, problem, replace(STRIPS, ground=True))
    kinds = [type(s) for s in lowered.steps]
    assert Grounded in kinds and Split in kinds and Negated in kinds and Costed in kinds
    assert kinds[-1] is Renamed and lowered.grounded is lowered.steps[kinds.index(Grounded)]
    plan = _dummy_plan(lowered.domain)
    assert lowered.map_plan(plan) == map_back(lowered.steps, plan)


@pytest.mark.parametrize(
    "caps",
    [
        Capabilities(),
        Capabilities(axioms=False),
        Capabilities(disjunction=False, negative_preconditions=False),
        replace(STRIPS, ground=True),
        replace(STRIPS, ground=True, costs=True),
    ],
    ids=["all", "no-axioms", "split-and-complement", "ground", "ground-costs"],
)
def test_a_planners_plan_maps_back_to_a_valid_plan_of_the_input(caps):
    domain, problem = _task()
    compiled = compile_problem(domain, None, problem, caps=caps)
    result = get_planner("fd").solve(compiled.domain, compiled.problem, time_limit=30)
    assert result.status == "solved", result.message
    plan = compiled.map_plan(result.actions)
    assert plan == map_back(compiled.passes, result.actions)
    assert {name for name, _ in plan} <= {a.name for a in domain.actions}
    plan_preimage(*objects_as_constants(domain, problem).task, plan)  # raises if invalid
    assert ("lit", ("cellar",)) in plan and plan[-1] == ("go", ("cellar", "attic"))
