"""The compiler: PDDLStream -> plain cost-PDDL, read back and solved by real planners.

Fixtures live in ``tests/fixtures/compile``: ``pp1d`` (1-D pick-and-place with a blocked goal
region, a collision test used through the derived predicate ``unsafe`` and a distance cost
``:function``) and ``blocks`` (classical, no streams).  Compiled text is read back by
unified-planning's PDDL reader and by Fast Downward's translator (the ``fd`` backend), solved,
and the plans are checked with unified-planning's plan validator.
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import pytest
from conftest import require_corpus

from ssr_compile import syntax as S
from ssr_compile.compile.costs import choose_scale, self_loop_cost, to_int
from ssr_compile.compile.derived import compile_away
from ssr_compile.compile.instantiate import DEFAULT_FUNCTION_VALUE, Instance, instantiate
from ssr_compile.compile.leaves import SharedLeaves
from ssr_compile.compile.pipeline import FullCapabilities, compile_problem
from ssr_compile.errors import UnsupportedError
from ssr_compile.parse import parse_domain, parse_problem, parse_stream_file
from ssr_compile.planners import get_planner
from ssr_compile.planners.validate import validate_plan
from ssr_compile.printer import to_text
from ssr_compile.solver.preimage import PlanInvalid, plan_preimage

FIX = Path(__file__).parent / "fixtures" / "compile"
PP = FIX / "pp1d"
BLOCKS = FIX / "blocks"
EMPTY_STREAMS = "(define (stream x))"
NO_AXIOMS = FullCapabilities(axioms=False)


def load(folder: Path, problem: str = "problem.pddl", stream: str = "stream.pddl"):
    d = parse_domain((folder / "domain.pddl").read_text(), str(folder / "domain.pddl"))
    s = parse_stream_file((folder / stream).read_text()) if stream else None
    p = parse_problem((folder / problem).read_text(), str(folder / problem))
    return d, s, p


def up_read(domain: S.Domain, problem: S.Problem):
    from unified_planning.io import PDDLReader

    return PDDLReader().parse_problem_string(to_text(domain), to_text(problem))


def fd_solve(compiled, time_limit: float = 20.0, planner: str = "fd"):
    result = get_planner(planner).solve(compiled.domain, compiled.problem, time_limit=time_limit)
    assert result.status == "solved", result.message
    return result, compiled.map_plan(result.actions)


def with_costs(domain: S.Domain, problem: S.Problem):
    """Axioms compiled away (the validator reads none) and ``(= (total-cost) 0)`` present."""
    if domain.axioms:
        domain, problem = compile_away(domain, problem).task
    uses_cost = any(f.name == "total-cost" for f in domain.functions)
    has_init = any(
        isinstance(f, S.InitValue) and f.fluent.name == "total-cost" for f in problem.init
    )
    if uses_cost and not has_init:
        zero = S.InitValue(S.FuncTerm("total-cost"), S.Num(0))
        problem = replace(problem, init=problem.init + (zero,))
    return domain, problem


def check_valid(domain: S.Domain, problem: S.Problem, plan) -> None:
    domain, problem = with_costs(domain, problem)
    ok, why = validate_plan(domain, problem, plan)
    assert ok, f"{why}: {plan}"


def check_invalid(domain: S.Domain, problem: S.Problem, plan) -> None:
    domain, problem = with_costs(domain, problem)
    ok, _ = validate_plan(domain, problem, plan)
    assert not ok, plan


# ---------------------------------------------------------------- streams: read back, solve


@pytest.mark.parametrize("problem", ["problem.pddl", "problem-blocked.pddl"])
def test_pick_place_compiles_reads_back_and_solves(problem):
    d, s, p = load(PP, problem)
    full = compile_problem(d, s, p, level=3)
    assert full.domain.axioms, "fd keeps derived predicates"
    result, plan = fd_solve(full)  # fd's translator reads the emitted text
    # The optimistic plan is valid for the compiled problem (axioms compiled away for the
    # validator) and its preimage is defined on the domain with axioms.
    check_valid(full.source_domain, full.source_problem, plan)
    plan_preimage(full.source_domain, full.source_problem, plan)
    # Without axioms: unified-planning reads the text and validates the planner's own plan.
    flat = compile_problem(d, s, p, level=3, caps=NO_AXIOMS)
    assert not flat.domain.axioms
    task = up_read(flat.domain, flat.problem)
    assert {a.name for a in task.actions} == {"move", "pick", "place"}
    flat_result, _ = fd_solve(flat)
    check_valid(flat.domain, flat.problem, flat_result.actions)
    names = [n for n, _ in plan]
    assert names[-1] == "place" and plan[-1][1][0] == "a"
    # Optimistically every cfree test holds, so even the blocked region looks free: only
    # evaluating the tests (the Focused solver, tests/test_focused.py) reveals the blocker.
    assert [args[0] for n, args in plan if n == "pick"] == ["a"]
    # Every move's cost comes from the dist function (optimistic value 1) and pick/place
    # cost 1, so the cost is the plan length.
    assert result.cost / full.scale == pytest.approx(len(plan))


def test_cost_function_values_scaled_and_guarded():
    d, s, p = load(PP)
    c = compile_problem(d, s, p, level=3, function_values={"dist": 2.5})
    assert c.scale == 10
    values = {f.fluent: f.value.value for f in c.problem.init if isinstance(f, S.InitValue)}
    dist_values = {v for t, v in values.items() if t.name == "dist"}
    assert dist_values == {25}
    guards = {a for a in c.problem.init if isinstance(a, S.Atom) and a.pred == "has-cost-dist"}
    dist_terms = {t for t in values if t.name == "dist"}
    assert {(g.args) for g in guards} == {t.args for t in dist_terms}
    move = next(a for a in c.domain.actions if a.name == "move")
    assert S.Atom("has-cost-dist", (S.Var("?q1"), S.Var("?q2"))) in S.conjuncts(move.precondition)
    result, plan = fd_solve(c)
    moves = sum(1 for n, _ in plan if n == "move")
    assert result.cost / c.scale == pytest.approx(2.5 * moves + (len(plan) - moves))


ROUTES_DOMAIN = """
(define (domain routes)
  (:requirements :strips :action-costs)
  (:predicates (route ?r) (at-start) (at-end))
  (:functions (len ?r) (total-cost))
  (:action go :parameters (?r)
    :precondition (and (at-start) (route ?r))
    :effect (and (at-end) (not (at-start)) (increase (total-cost) (len ?r)))))
"""
ROUTES_STREAMS = "(define (stream routes) (:function (len ?r) (route ?r)))"
ROUTES_PROBLEM = """
(define (problem two-routes) (:domain routes) (:objects short long)
  (:init (route short) (route long) (at-start)) (:goal (at-end))
  (:metric minimize (total-cost)))
"""


def _routes(real: dict[str, float]):
    d, s, p = (
        parse_domain(ROUTES_DOMAIN),
        parse_stream_file(ROUTES_STREAMS),
        parse_problem(ROUTES_PROBLEM),
    )
    values = {S.FuncTerm("len", (S.Const(k),)): v for k, v in real.items()}
    return compile_problem(d, s, p, real_function_values=values)


def test_undefined_or_infinite_cost_makes_the_action_unusable():
    c = _routes({"short": 1.0, "long": 5.0})
    assert fd_solve(c, planner="fd:opt")[1] == [("go", ("short",))]
    c = _routes({"short": math.inf, "long": 5.0})
    assert S.Atom("has-cost-len", (S.Const("short"),)) not in c.problem.init
    result, plan = fd_solve(c)
    assert plan == [("go", ("long",))] and result.cost == 5
    c = _routes({"short": math.inf, "long": math.inf})
    assert get_planner("fd").solve(c.domain, c.problem, time_limit=10).status == "unsolvable"


# ---------------------------------------------------------------- classical pass-through


def _passthrough(d, p, backends=("fd", "pyperplan")):
    s = parse_stream_file(EMPTY_STREAMS)
    for backend in backends:
        planner = get_planner(backend)
        c = compile_problem(d, s, p, caps=planner.capabilities)
        assert c.instantiation.optimistic_objects() == set()
        up_read(c.domain, c.problem)
        result = planner.solve(c.domain, c.problem, time_limit=20)
        assert result.status == "solved", result.message
        plan = c.map_plan(result.actions)
        check_valid(d, p, plan)  # against the ORIGINAL domain and problem
        # And a plan the original refuses is refused by the compiled problem too.
        if len(plan) > 1:
            check_invalid(d, p, plan[1:])
            with pytest.raises(PlanInvalid):
                plan_preimage(c.source_domain, c.source_problem, plan[1:])


def test_classical_blocksworld_passes_through_unchanged():
    d, _, p = load(BLOCKS, stream=None)
    s = parse_stream_file(EMPTY_STREAMS)
    c = compile_problem(d, s, p)
    # Same actions, same objects and facts; only costs added (unit costs, 0 at start).
    assert [a.name for a in c.domain.actions] == [a.name for a in d.actions]
    assert {o.name for o in c.problem.objects} == {o.name for o in p.objects}
    assert {f for f in c.problem.init if isinstance(f, S.Atom)} == set(p.init)
    assert c.problem.goal == p.goal
    _passthrough(d, p)


def test_corpus_blocksworld_passes_through():
    CORPUS_BW = require_corpus("pddlstream-examples/examples/blocksworld")
    d = parse_domain((CORPUS_BW / "domain.pddl").read_text())
    p = parse_problem((CORPUS_BW / "problem.pddl").read_text())
    _passthrough(d, p)


# ---------------------------------------------------------------- optimistic instantiation

CHAIN_DOMAIN = """
(define (domain chain) (:requirements :strips)
  (:predicates (a ?x) (b ?x) (c ?x) (d ?x) (ok ?x) (good ?x) (done))
  (:functions (weight ?x) (total-cost))
  (:action finish :parameters (?x) :precondition (and (d ?x) (ok ?x))
    :effect (and (done) (increase (total-cost) (weight ?x)))))
"""
CHAIN_STREAMS = """
(define (stream chain)
  (:stream s1 :inputs (?x) :domain (a ?x) :outputs (?y) :certified (b ?y))
  (:stream s2 :inputs (?y) :domain (b ?y) :outputs (?z) :certified (c ?z))
  (:stream s3 :inputs (?z) :domain (c ?z) :outputs (?w) :certified (d ?w))
  (:stream check :inputs (?w) :domain (d ?w) :certified (ok ?w))
  (:function (weight ?w) (d ?w))
  (:rule :inputs (?y) :domain (b ?y) :certified (good ?y)))
"""
CHAIN_PROBLEM = """
(define (problem chain1) (:domain chain) (:objects x0)
  (:init (a x0)) (:goal (done)) (:metric minimize (total-cost)))
"""


def _chain(level: int, **kw):
    d, s, p = (
        parse_domain(CHAIN_DOMAIN),
        parse_stream_file(CHAIN_STREAMS),
        parse_problem(CHAIN_PROBLEM),
    )
    return instantiate(d, s, p, level=level, **kw)


def test_level_bound_gives_the_expected_instances():
    by_level = {}
    for level in (1, 2, 3, 4):
        inst = _chain(level)
        by_level[level] = {(r.instance.stream, r.level) for r in inst.results}
    assert by_level[1] == {("s1", 1)}
    assert by_level[2] == {("s1", 1), ("s2", 2)}
    assert by_level[3] == {("s1", 1), ("s2", 2), ("s3", 3)}
    assert by_level[4] == by_level[3] | {("check", 4)}
    assert not _chain(3).saturated and _chain(4).saturated
    # Inputs of deeper instances are the optimistic outputs of shallower ones.
    inst = _chain(4)
    res = {r.instance.stream: r for r in inst.results}
    assert res["s2"].instance.inputs == res["s1"].outputs
    assert res["s3"].instance.inputs == res["s2"].outputs
    assert res["s1"].instance == Instance("s1", ("x0",), "stream")


def test_every_optimistic_object_and_fact_is_traced():
    inst = _chain(4)
    names = {o.name for o in inst.problem.objects} - {"x0"}
    assert names == inst.optimistic_objects() and len(names) == 3
    for name in names:
        res = inst.objects[name]
        assert name in res.outputs and res.optimistic
    init = {f for f in inst.problem.init if isinstance(f, S.Atom)}
    for fact in init - {S.Atom("a", (S.Const("x0"),))}:
        if fact.pred == "good":  # rule facts come from a rule, not an instance
            continue
        producers = inst.facts[fact]
        assert any(fact in r.certified for r in producers)
    # The test stream is optimistic: its certified fact is in the initial state.
    check = next(r for r in inst.results if r.instance.stream == "check")
    assert check.instance.kind == "test" and check.outputs == ()
    assert check.certified[0] in init and inst.facts[check.certified[0]] == [check]
    # The :rule fact holds wherever its domain holds.
    y = next(r for r in inst.results if r.instance.stream == "s1").outputs[0]
    assert S.Atom("good", (S.Const(y),)) in init


def test_function_values_default_and_from_stream_info():
    for given, expected in ((None, DEFAULT_FUNCTION_VALUE), ({"weight": 7.5}, 7.5)):
        inst = _chain(4, function_values=given)
        values = [f for f in inst.problem.init if isinstance(f, S.InitValue)]
        assert len(values) == 1 and values[0].value.value == expected
        (term,) = inst.functions
        assert inst.functions[term].optimistic and inst.functions[term].value == expected
    assert DEFAULT_FUNCTION_VALUE == 1


def test_chain_plan_solved_and_weight_cost_from_function():
    d, s, p = (
        parse_domain(CHAIN_DOMAIN),
        parse_stream_file(CHAIN_STREAMS),
        parse_problem(CHAIN_PROBLEM),
    )
    assert get_planner("fd").solve(*_compiled(d, s, p, 3)).status == "unsolvable"
    c = compile_problem(d, s, p, level=4, function_values={"weight": 1.25})
    assert c.scale == 100
    result, plan = fd_solve(c)
    assert result.cost == 125 and len(plan) == 1


def _compiled(d, s, p, level):
    c = compile_problem(d, s, p, level=level)
    return c.domain, c.problem


@pytest.mark.parametrize(
    "text, word, line",
    [
        (
            "(define (stream f)\n  (:stream motion :inputs (?q) :domain (conf ?q)\n"
            "    :fluents (atpose) :outputs (?t) :certified (traj ?t)))",
            "fluents",
            2,
        ),
        (
            "(define (stream f)\n\n  (:optimizer planar (:variables (?p) :inputs (?o)\n"
            "    :domain (block ?o)) (:objective dist)))",
            "optimizer",
            3,
        ),
    ],
)
def test_fluents_and_optimizers_are_unsupported_with_a_position(text, word, line):
    d = parse_domain(
        "(define (domain f) (:predicates (conf ?q) (traj ?t) (block ?o)) "
        "(:action noop :parameters () :precondition (and) :effect (and)))"
    )
    p = parse_problem(
        "(define (problem f) (:domain f) (:objects q) (:init (conf q)) (:goal (and)))"
    )
    with pytest.raises(UnsupportedError) as e:
        compile_problem(d, parse_stream_file(text), p)
    assert word in str(e.value) and e.value.line == line and e.value.col is not None
    assert str(e.value).startswith(f"ssr-compile (line {line}, column {e.value.col}):")


# ---------------------------------------------------------------- derived predicates

# A hand-made real problem for pp1d: b is in the goal region; cfree holds only where it should.
PP_REAL = """
(define (problem pp1d-real) (:domain pp1d)
  (:objects a b pa pb pg pt ga gb q0 qa qb qg qt qtb t1 t2 t3 t4 t5 t6 t7 t8 t9 goal table)
  (:init (block a) (block b) (handempty) (atconf q0) (atpose a pa) (atpose b pb)
    (pose a pa) (pose b pb) (pose a pg) (pose b pt) (contained a pg goal) (contained b pt table)
    (kin a pa ga qa) (kin b pb gb qb) (kin a pg ga qg) (kin b pt gb qt)
    (motion q0 t1 qa) (motion q0 t2 qb) (motion qb t3 qt) (motion qt t4 qa) (motion qa t5 qg)
    (motion qb t6 qa) (motion qa t7 qb) (motion qt t8 qb)
    (cfree a pg b pt) (cfree b pt a pa) (cfree a pa b pb) (cfree b pb a pa)
    (= (dist q0 qa) 5) (= (dist q0 qb) 10) (= (dist qb qt) 5) (= (dist qt qa) 2)
    (= (dist qa qg) 5) (= (dist qb qa) 5) (= (dist qa qb) 5) (= (dist qt qb) 5))
  (:goal (exists (?p) (and (contained a ?p goal) (atpose a ?p)))))
"""
GOOD_PLAN = [
    ("move", ("q0", "t2", "qb")),
    ("pick", ("b", "pb", "gb", "qb")),
    ("move", ("qb", "t3", "qt")),
    ("place", ("b", "pt", "gb", "qt")),
    ("move", ("qt", "t4", "qa")),
    ("pick", ("a", "pa", "ga", "qa")),
    ("move", ("qa", "t5", "qg")),
    ("place", ("a", "pg", "ga", "qg")),
]
BAD_PLAN = [  # places a in the goal region while b is still there (no cfree a pg b pb)
    ("move", ("q0", "t1", "qa")),
    ("pick", ("a", "pa", "ga", "qa")),
    ("move", ("qa", "t5", "qg")),
    ("place", ("a", "pg", "ga", "qg")),
]


def _pp_real():
    d = parse_domain((PP / "domain.pddl").read_text())
    p = parse_problem(PP_REAL)
    return d, p


@pytest.mark.parametrize("plan, valid", [(GOOD_PLAN, True), (BAD_PLAN, False)])
def test_derived_kept_and_compiled_away_accept_the_same_plans(plan, valid):
    d, p = _pp_real()
    flat_d, flat_p = compile_away(d, p).task
    assert not flat_d.axioms and "unsafe" not in {x.name for x in flat_d.predicates}
    outcomes = []
    for dom, prob in ((d, p), (flat_d, flat_p)):
        try:
            pre = plan_preimage(dom, prob, plan)
            outcomes.append(True)
            if dom.axioms:  # the placement rests on the cfree test through `unsafe`
                assert S.Atom("cfree", tuple(S.Const(x) for x in ("a", "pg", "b", "pt"))) in (
                    pre.static_facts
                )
        except PlanInvalid:
            outcomes.append(False)
    ok, _ = validate_plan(*with_costs(flat_d, flat_p), plan)
    assert outcomes == [valid, valid] and ok == valid


def test_derived_real_problem_solved_with_axioms_kept_and_compiled_away():
    d, p = _pp_real()
    planner = get_planner("fd")
    for caps in (planner.capabilities, NO_AXIOMS):
        c = compile_problem(d, None, p, caps=caps)
        assert bool(c.domain.axioms) == caps.axioms
        result = planner.solve(c.domain, c.problem, time_limit=20)
        assert result.status == "solved", result.message
        plan = c.map_plan(result.actions)
        check_valid(d, p, plan)
        assert [x[0] for n, x in plan if n == "pick"] == ["b", "a"]
    # pyperplan (no quantifiers, no disjunction, no axioms): the task is ground first, so
    # the negated existential is a conjunction over the objects that really collide.
    pyper = get_planner("pyperplan")
    c = compile_problem(d, None, p, caps=pyper.capabilities)
    assert all(not a.parameters for a in c.domain.actions) and not c.domain.axioms
    result = pyper.solve(c.domain, c.problem, time_limit=20)
    assert result.status == "solved", result.message
    plan = c.map_plan(result.actions)
    check_valid(d, p, plan)
    assert [x[0] for n, x in plan if n == "pick"] == ["b", "a"]


RECURSIVE = """
(define (domain towers) (:requirements :strips :derived-predicates)
  (:predicates (on ?x ?y) (above ?x ?y) (free ?x) (done))
  (:derived (above ?x ?y) (or (on ?x ?y) (exists (?z) (and (on ?x ?z) (above ?z ?y)))))
  (:action finish :parameters (?x ?y) :precondition (above ?x ?y) :effect (done)))
"""


def test_recursive_derived_predicate_needs_axioms():
    d = parse_domain(RECURSIVE)
    p = parse_problem(
        "(define (problem t) (:domain towers) (:objects a b c) (:init (on a b) (on b c)) "
        "(:goal (and (done))))"
    )
    with pytest.raises(UnsupportedError) as e:
        compile_problem(d, None, p, caps=get_planner("pyperplan").capabilities)
    assert "'above'" in str(e.value) and "recursive" in str(e.value)
    assert e.value.line == 4
    c = compile_problem(d, None, p, caps=get_planner("fd").capabilities)
    _, plan = fd_solve(c)
    assert len(plan) == 1 and plan[0][0] == "finish"


# ---------------------------------------------------------------- costs


def test_self_loop_cost_hand_values():
    assert self_loop_cost(3.0, 2.0, 1.0) == 3.0
    assert self_loop_cost(1.0, 2.0, 0.5) == pytest.approx(3.0)
    assert self_loop_cost(1.0, 1.0, 0.25) == pytest.approx(4.0)
    assert self_loop_cost(1.0, 2.0, 0.0) == math.inf
    for bad in ((-1.0, 1.0, 0.5), (1.0, -1.0, 0.5), (1.0, 1.0, 1.5), (1.0, 1.0, -0.1)):
        with pytest.raises(ValueError):
            self_loop_cost(*bad)
    with pytest.raises(ValueError):
        self_loop_cost(1.0, 1.0, math.nan)


def test_scaling_smallest_power_of_ten_rounded_up():
    assert choose_scale([1.0, 2.0]) == 1
    assert choose_scale([1.25]) == 100 and to_int(1.25, 100) == 125
    assert choose_scale([1 / 3]) == 1000 and to_int(1 / 3, 1000) == 334
    assert choose_scale([0.5, 1.25]) == 100
    assert to_int(0.1 + 0.2, 10) == 3  # float noise does not round up
    assert to_int(2.0001, 1) == 3


def test_scale_reported_and_consistent_across_actions_and_values():
    c = _routes({"short": 1 / 3, "long": 1.25})
    assert c.scale == 1000
    values = {
        f.fluent.args[0].name: f.value.value
        for f in c.problem.init
        if isinstance(f, S.InitValue) and f.fluent.args
    }
    assert values["short"] == 334 and values["long"] == 1250
    result, plan = fd_solve(c, planner="fd:opt")
    assert plan == [("go", ("short",))] and result.cost / c.scale == pytest.approx(0.334)


def test_unit_cost_mode_drops_costs():
    d, s, p = load(PP)
    c = compile_problem(d, s, p, level=3, unit_cost=True)
    text = to_text(c.domain) + to_text(c.problem)
    assert "total-cost" not in text and "has-cost" not in text and c.problem.metric is None
    assert c.scale == 1
    _, plan = fd_solve(c)
    assert plan[-1][0] == "place"


# ---------------------------------------------------------------- lowering for pyperplan

SWITCH_DOMAIN = """
(define (domain switches) (:requirements :strips :negative-preconditions :equality
  :disjunctive-preconditions)
  (:constants hall)
  (:predicates (on ?s) (in ?r) (lit ?r) (wired ?s ?r) (door ?r1 ?r2) (key))
  (:action flip-on :parameters (?s ?r)
    :precondition (and (not (on ?s)) (in ?r) (wired ?s ?r))
    :effect (and (on ?s) (lit ?r)))
  (:action walk :parameters (?from ?to)
    :precondition (and (in ?from) (or (door ?from ?to) (and (key) (= ?from hall))))
    :effect (and (in ?to) (not (in ?from))))
  (:action grab-key :parameters (?r)
    :precondition (and (in ?r) (= ?r hall) (not (key)))
    :effect (key)))
"""
SWITCH_PROBLEM = """
(define (problem switches1) (:domain switches) (:objects s1 s2 kitchen cellar)
  (:init (in hall) (wired s1 kitchen) (wired s2 cellar) (door hall kitchen) (door cellar hall))
  (:goal (and (lit kitchen) (lit cellar) (in kitchen))))
"""


def test_lowering_for_pyperplan_negation_equality_disjunction():
    # the lifted lowering (a STRIPS backend that does not ask for a ground task)
    import dataclasses

    d, p = parse_domain(SWITCH_DOMAIN), parse_problem(SWITCH_PROBLEM)
    planner = get_planner("pyperplan")
    lifted = dataclasses.replace(planner.capabilities, ground=False)
    c = compile_problem(d, None, p, caps=lifted)
    for a in c.domain.actions:
        for part in S.conjuncts(a.precondition):
            assert isinstance(part, S.Atom) and part.pred != "=", (a.name, part)
    names = {a.name for a in c.domain.actions}
    assert (
        any(n.startswith("walk") for n in names)
        and len([n for n in names if n.startswith("walk")]) == 2
    )  # the disjunction split in two copies
    grab = next(a for a in c.domain.actions if a.name.startswith("grab-key"))
    assert grab.parameters == ()  # (= ?r hall) substituted: the parameter disappears
    assert any(pred.name.startswith("not-") for pred in c.domain.predicates)
    up_read(c.domain, c.problem)
    result = planner.solve(c.domain, c.problem, time_limit=20)
    assert result.status == "solved", result.message
    plan = c.map_plan(result.actions)
    assert ("grab-key", ("hall",)) in plan  # the substituted constant is mapped back
    check_valid(d, p, plan)
    # The cellar is reached only through the key branch of walk's disjunction.
    assert ("walk", ("hall", "cellar")) in plan


# ---------------------------------------------------------------- names

CLASH_DOMAIN = """
(define (domain clash) (:requirements :strips)
  (:predicates (carry ?b) (at ?b ?r) (robot-at ?r) (free) (link ?r1 ?r2))
  (:action carry :parameters (?b ?r)
    :precondition (and (at ?b ?r) (robot-at ?r) (free))
    :effect (and (carry ?b) (not (at ?b ?r)) (not (free))))
  (:action drop :parameters (?b ?r) :precondition (and (carry ?b) (robot-at ?r))
    :effect (and (at ?b ?r) (free) (not (carry ?b))))
  (:action walk :parameters (?a ?r) :precondition (and (robot-at ?a) (link ?a ?r))
    :effect (and (robot-at ?r) (not (robot-at ?a)))))
"""
CLASH_PROBLEM = """
(define (problem clash1) (:domain clash) (:objects @box room1 room2 drop)
  (:init (at @box room1) (robot-at room1) (free) (link room1 room2) (link room2 drop))
  (:goal (at @box drop)))
"""


@pytest.mark.parametrize("backend", ["fd", "pyperplan", None])
def test_emitted_names_accepted_everywhere(backend):
    d, p = parse_domain(CLASH_DOMAIN), parse_problem(CLASH_PROBLEM)
    caps = get_planner(backend).capabilities if backend else FullCapabilities()
    c = compile_problem(d, parse_stream_file(EMPTY_STREAMS), p, caps=caps)
    up_read(c.domain, c.problem)  # an action and a predicate named carry, an object @box
    planners = [backend] if backend else ["fd"]
    for name in planners:
        result = get_planner(name).solve(c.domain, c.problem, time_limit=20)
        assert result.status == "solved", result.message
        plan = c.map_plan(result.actions)
        assert plan[0] == ("carry", ("@box", "room1"))
        assert plan[-1] == ("drop", ("@box", "drop"))
        check_valid(replace(d), p, plan)


def test_optimistic_names_accepted_by_every_reader():
    d, s, p = load(PP, "problem-blocked.pddl")
    c = compile_problem(d, s, p, level=2, caps=NO_AXIOMS)
    opt = c.instantiation.optimistic_objects()
    assert opt and all(name[0].isalpha() for name in opt)
    emitted = {o.name for o in c.problem.objects}
    shared = next(p for p in c.passes if isinstance(p, SharedLeaves))
    merged = {name for names in shared.merged.values() for name in names}
    assert set(shared.merged) <= emitted and merged and merged.isdisjoint(emitted)
    assert opt - merged <= emitted  # not renamed: already plain identifiers
    up_read(c.domain, c.problem)


def test_ground_atoms_share_one_const_per_name_and_equal_freshly_built_ones():
    from ssr_compile.compile.instantiate import ground_atom

    pattern = S.Atom("kin", (S.Var("?b"), S.Const("q0"), S.Var("?p")))
    a = ground_atom(pattern, {"?b": "b1", "?p": "p-3"})
    b = ground_atom(pattern, {"?b": "b1", "?p": "p-4"})
    assert a.args[0] is b.args[0] and a.args[1] is pattern.args[1]  # interned, or kept
    assert a == S.Atom("kin", (S.Const("b1"), S.Const("q0"), S.Const("p-3")))
    assert hash(a) == hash(S.Atom("kin", (S.Const("b1"), S.Const("q0"), S.Const("p-3"))))
    assert S.const("b1") is a.args[0] and S.const("b1") == S.Const("b1")
