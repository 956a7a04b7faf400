"""Plan constraints (paper §VI-A, Algorithm 2): the constrained problem keeps the old plan's
structure and constants, lets the free values change, and binds a repeated free value once.

The domain is the shape of the paper's example: ``[move(arm, @aq1, @at1, @aq2),
pick(D, @p1, gD, @bq1, @aq2)]``; ``arm``, ``D`` and ``gD`` are constants, the rest free.
"""

from __future__ import annotations

from dataclasses import replace

import pytest

from ssr_compile import syntax as S
from ssr_compile.compile.constraints import ASSIGNED, MAY, constrain_plan
from ssr_compile.compile.pipeline import compile_problem
from ssr_compile.parse import parse_domain, parse_problem, parse_stream_file
from ssr_compile.planners import get_planner
from ssr_compile.planners.validate import validate_plan
from ssr_compile.solver.preimage import PlanInvalid, plan_preimage

DOMAIN = """
(define (domain arm-pick) (:requirements :strips)
  (:predicates (arm ?a) (atconf ?a ?q) (motion ?q1 ?t ?q2) (atpose ?o ?p) (grasp ?o ?g)
               (atbase ?bq) (kin ?o ?p ?g ?bq ?aq) (handempty) (holding ?o ?g))
  (:action move :parameters (?a ?q1 ?t ?q2)
    :precondition (and (arm ?a) (atconf ?a ?q1) (motion ?q1 ?t ?q2))
    :effect (and (atconf ?a ?q2) (not (atconf ?a ?q1))))
  (:action pick :parameters (?o ?p ?g ?bq ?aq)
    :precondition (and (atpose ?o ?p) (grasp ?o ?g) (atbase ?bq) (kin ?o ?p ?g ?bq ?aq)
                       (handempty))
    :effect (and (holding ?o ?g) (not (handempty)) (not (atpose ?o ?p)))))
"""
# After replanning: D was re-observed at p9; the old values aq1, at1, aq2, p1 are gone.
# kin also holds for aq8 (no motion reaches it) and for another object E.
PROBLEM = """
(define (problem arm-pick-new) (:domain arm-pick)
  (:objects arm d e gd ge p9 pe bq1 aq0 aq7 aq8 at5)
  (:init (arm arm) (atconf arm aq0) (motion aq0 at5 aq7) (atpose d p9) (atpose e pe)
         (grasp d gd) (grasp e ge) (atbase bq1) (handempty)
         (kin d p9 gd bq1 aq7) (kin d p9 gd bq1 aq8) (kin e pe ge bq1 aq0))
  (:goal (or (exists (?g) (holding d ?g)) (exists (?g) (holding e ?g)))))
"""
TAIL = [("move", ("arm", "aq1", "at1", "aq2")), ("pick", ("d", "p1", "gd", "bq1", "aq2"))]
CONSTANTS = {"arm", "d", "gd"}


def _task():
    return parse_domain(DOMAIN), parse_problem(PROBLEM)


# A second motion from aq0 (to aq8, which kin also admits): the tail's trajectory and its
# arm configuration aq2 can each take two values.  In PROBLEM every free value can take one.
WIDE = (S.Atom("motion", (S.Const("aq0"), S.Const("at6"), S.Const("aq8"))),)


def _constrained(wide: bool = True):
    d, p = _task()
    if wide:
        p = replace(p, objects=p.objects + (S.Typed("at6"),), init=p.init + WIDE)
    return d, p, constrain_plan(d, p, TAIL, lambda v: v in CONSTANTS)


def test_structure_of_the_constrained_problem():
    _, _, c = _constrained()
    assert [a.name for a in c.domain.actions] == ["move-step1", "pick-step2"]
    assert c.steps == {"move-step1": ("move", 1), "pick-step2": ("pick", 2)}
    # Free values become free-variable objects; aq2 (used twice) is one object.
    assert set(c.free.values()) == {"aq1", "at1", "aq2", "p1", "bq1"}
    assert len(c.free) == 5
    pick = c.domain.actions[1]
    pre = S.conjuncts(pick.precondition)
    assert S.Atom("ssr-applied-1") in pre
    # The constants d and gd are substituted: the step no longer takes ?o and ?g, and no
    # equality is left for a translator to explore over every object.  So are the free values
    # that can take one value only: p1 (p9, where d is), bq1 (the one base) and, in the move,
    # aq1 (aq0, where the arm is).
    assert [p.name for p in pick.parameters] == ["?aq"]
    assert S.Atom("kin", tuple(map(S.Const, ("d", "p9", "gd", "bq1"))) + (S.Var("?aq"),)) in pre
    assert not any(isinstance(f, S.Atom) and f.pred == "=" for f in pre)
    assert [p.name for p in c.domain.actions[0].parameters] == ["?t", "?q2"]  # not ?a, ?q1
    # The map back puts the constants in again, in the schema's order.
    assert c.map_plan([("move-step1", ("at5", "aq7")), ("pick-step2", ("aq7",))]) == [
        ("move", ("arm", "aq0", "at5", "aq7")),
        ("pick", ("d", "p9", "gd", "bq1", "aq7")),
    ]
    # Without the second motion every free value has one value: the steps take nothing.
    _, _, narrow = _constrained(wide=False)
    assert [a.parameters for a in narrow.domain.actions] == [(), ()]
    assert narrow.map_plan([("move-step1", ()), ("pick-step2", ())]) == [
        ("move", ("arm", "aq0", "at5", "aq7")),
        ("pick", ("d", "p9", "gd", "bq1", "aq7")),
    ]
    aq2 = next(k for k, v in c.free.items() if v == "aq2")
    # aq2 is first used by step 1, which binds it; step 2 requires the bound value.
    move = c.domain.actions[0]
    assert S.Atom(ASSIGNED, (S.Const(aq2), S.Var("?q2"))) in S.conjuncts(move.effect)
    assert S.Atom(ASSIGNED, (S.Const(aq2), S.Var("?aq"))) in pre
    assert not any(isinstance(f, (S.Or, S.Imply)) for f in pre)  # no disjunction to split
    assert S.Atom("ssr-applied-2") in S.conjuncts(c.problem.goal)


def test_free_values_are_narrowed_to_what_the_tail_admits():
    _, p, c = _constrained()
    may = {}
    for f in c.problem.init:
        if isinstance(f, S.Atom) and f.pred == MAY:
            may.setdefault(c.free[f.args[0].name], set()).add(f.args[1].name)
    # at1, aq2: the two motions from aq0 (both ends have kin).  One value each, substituted,
    # so with no ssr-may of their own: aq1, the arm's configuration before any step moved it
    # (fluent, in the initial state); p1, where d is now; bq1, the one base.
    assert may == {"at1": {"at5", "at6"}, "aq2": {"aq7", "aq8"}}
    # Each binding step requires its values; a later use only the bound one.
    aq2 = next(k for k, v in c.free.items() if v == "aq2")
    move, pick = c.domain.actions
    assert S.Atom(MAY, (S.Const(aq2), S.Var("?q2"))) in S.conjuncts(move.precondition)
    assert not any(
        a.pred == MAY and a.args[0] == S.Const(aq2)
        for a in S.conjuncts(pick.precondition)
        if isinstance(a, S.Atom)
    )
    # A value another step adds stays possible: after a motion to aq8, the pick may use it.
    d, _ = _task()
    p2 = replace(p, init=p.init + (S.Atom("motion", tuple(map(S.Const, ("aq7", "at5", "aq8")))),))
    two = [
        ("move", ("arm", "aq1", "at1", "aq2")),
        ("move", ("arm", "aq2", "at2", "aq3")),
        ("pick", ("d", "p1", "gd", "bq1", "aq3")),
    ]
    c2 = constrain_plan(d, p2, two, lambda v: v in CONSTANTS)
    # (aq3: aq8 only, from aq7; nothing moves on from aq8): the pick takes no argument
    assert c2.domain.actions[2].parameters == ()
    assert c2.map_plan([("pick-step3", ())]) == [("pick", ("d", "p9", "gd", "bq1", "aq8"))]
    fd = get_planner("fd")
    lowered = compile_problem(
        d, None, p2, caps=fd.capabilities, plan_tail=two, is_constant=CONSTANTS.__contains__
    )
    result = fd.solve(lowered.domain, lowered.problem, time_limit=20)
    assert lowered.map_plan(result.actions) == [
        ("move", ("arm", "aq0", "at5", "aq7")),
        ("move", ("arm", "aq7", "at5", "aq8")),
        ("pick", ("d", "p9", "gd", "bq1", "aq8")),
    ]
    # A static fact the tail needs and nothing states: no value is left, and no plan.
    gone = replace(
        p,
        init=tuple(
            f
            for f in p.init
            if not (isinstance(f, S.Atom) and f.pred == "kin" and f.args[0].name == "d")
        ),
    )
    c3 = constrain_plan(d, gone, TAIL, lambda v: v in CONSTANTS)
    assert not any(
        isinstance(f, S.Atom) and f.pred == MAY and c3.free[f.args[0].name] == "aq2"
        for f in c3.problem.init
    )
    lowered = compile_problem(
        d, None, gone, caps=fd.capabilities, plan_tail=TAIL, is_constant=CONSTANTS.__contains__
    )
    assert fd.solve(lowered.domain, lowered.problem, time_limit=20).status != "solved"


def test_constrained_plan_forces_sequence_and_constants_and_maps_back():
    d, p = _task()
    fd = get_planner("fd")
    # Unconstrained, picking e needs no motion at all.
    free = compile_problem(d, None, p, caps=fd.capabilities)
    result = fd.solve(free.domain, free.problem, time_limit=20)
    assert free.map_plan(result.actions) == [("pick", ("e", "pe", "ge", "bq1", "aq0"))]
    c = compile_problem(
        d, None, p, caps=fd.capabilities, plan_tail=TAIL, is_constant=CONSTANTS.__contains__
    )
    result = fd.solve(c.domain, c.problem, time_limit=20)
    assert result.status == "solved", result.message
    plan = c.map_plan(result.actions)
    # Same actions, same constants; free values replaced; aq2 bound once (aq7, not aq8).
    assert plan == [
        ("move", ("arm", "aq0", "at5", "aq7")),
        ("pick", ("d", "p9", "gd", "bq1", "aq7")),
    ]
    ok, why = validate_plan(d, p, plan)
    assert ok, why


def test_repeated_free_variable_binds_consistently():
    d, p, c = _constrained()
    # Valid in the original domain (pick does not look at the arm conf)...
    inconsistent = [
        ("move", ("arm", "aq0", "at5", "aq7")),
        ("pick", ("d", "p9", "gd", "bq1", "aq8")),
    ]
    assert validate_plan(d, p, inconsistent)[0]
    # ...but the constrained problem refuses aq8 for the aq2 already bound to aq7.
    # (The steps take the free parameters with more than one value only: the move ?t and ?q2,
    # the pick ?aq.)
    steps = [("move-step1", ("at5", "aq7")), ("pick-step2", ("aq8",))]
    with pytest.raises(PlanInvalid):
        plan_preimage(c.domain, c.problem, steps)
    good = [("move-step1", ("at5", "aq7")), ("pick-step2", ("aq7",))]
    plan_preimage(c.domain, c.problem, good)
    assert c.map_plan(good) == [inconsistent[0], ("pick", ("d", "p9", "gd", "bq1", "aq7"))]


def test_a_value_used_twice_in_one_step_is_one_parameter():
    d = parse_domain("""(define (domain links) (:requirements :strips)
      (:predicates (edge ?x ?y) (linked ?x ?y))
      (:action link :parameters (?x ?y) :precondition (edge ?x ?y) :effect (linked ?x ?y)))""")
    p = parse_problem("""(define (problem l) (:domain links) (:objects a b)
      (:init (edge a a) (edge b b) (edge a b)) (:goal (linked b b)))""")
    # The old plan linked v to itself: v can be a or b, and the step takes ?x for both.
    c = constrain_plan(d, p, [("link", ("v", "v"))], lambda v: False)
    step = c.domain.actions[0]
    assert [x.name for x in step.parameters] == ["?x"]
    assert S.Atom("edge", (S.Var("?x"), S.Var("?x"))) in S.conjuncts(step.precondition)
    fd = get_planner("fd")
    lowered = compile_problem(d, None, p, caps=fd.capabilities, plan_tail=[("link", ("v", "v"))])
    result = fd.solve(lowered.domain, lowered.problem, time_limit=20)
    assert lowered.map_plan(result.actions) == [("link", ("b", "b"))]


def test_constants_and_order_and_last_step_are_required():
    d, p, c = _constrained()
    with pytest.raises(
        PlanInvalid
    ):  # the step picks d, the constant (not e, which kin admits at aq0)
        plan_preimage(c.domain, c.problem, [("pick-step2", ("aq0",))])
    # A step applied twice: the chain consumed its marker (the motion back exists here).
    back = replace(
        c.problem,
        init=c.problem.init + (S.Atom("motion", tuple(map(S.Const, ("aq7", "at5", "aq0")))),),
    )
    twice = [("move-step1", ("at5", "aq7")), ("move-step1", ("at5", "aq0"))]
    with pytest.raises(PlanInvalid, match="goal"):  # one application: applicable
        plan_preimage(c.domain, back, twice[:1])
    with pytest.raises(PlanInvalid, match="step 2"):
        plan_preimage(c.domain, back, twice)
    with pytest.raises(PlanInvalid):  # step 2 without step 1 (ssr-applied-1)
        plan_preimage(c.domain, c.problem, [("pick-step2", ("aq8",))])
    # Holding d some other way does not reach the goal without ssr-applied-2.
    p2 = replace(
        c.problem, init=c.problem.init + (S.Atom("holding", (S.Const("d"), S.Const("gd"))),)
    )
    with pytest.raises(PlanInvalid):
        plan_preimage(c.domain, p2, [])
    with pytest.raises(PlanInvalid):
        plan_preimage(c.domain, p2, [("move-step1", ("at5", "aq7"))])


def test_changed_constant_makes_it_unsolvable():
    d, p = _task()
    tail = [("move", ("arm", "aq1", "at1", "aq2")), ("pick", ("d", "p1", "gx", "bq1", "aq2"))]
    fd = get_planner("fd")
    c = compile_problem(
        d,
        None,
        p,
        caps=fd.capabilities,
        plan_tail=tail,
        is_constant={"arm", "d", "gx"}.__contains__,
    )
    assert fd.solve(c.domain, c.problem, time_limit=20).status == "unsolvable"


def test_pyperplan_solves_the_constrained_problem_too():
    d, p = _task()
    pp = get_planner("pyperplan")
    c = compile_problem(
        d, None, p, caps=pp.capabilities, plan_tail=TAIL, is_constant=CONSTANTS.__contains__
    )
    result = pp.solve(c.domain, c.problem, time_limit=20)
    assert result.status == "solved", result.message
    assert c.map_plan(result.actions) == [
        ("move", ("arm", "aq0", "at5", "aq7")),
        ("pick", ("d", "p9", "gd", "bq1", "aq7")),
    ]


def test_bad_tails_are_refused():
    d, p = _task()
    from ssr_compile.errors import UnsupportedError

    with pytest.raises(ValueError):
        constrain_plan(d, p, [], lambda v: False)
    with pytest.raises(UnsupportedError, match="fly"):
        constrain_plan(d, p, [("fly", ("x",))], lambda v: False)
    with pytest.raises(UnsupportedError, match="takes 4"):
        constrain_plan(d, p, [("move", ("arm",))], lambda v: False)


def _ranges(sas_text: str) -> list[int]:
    lines = sas_text.splitlines()
    return [int(lines[i + 3]) for i, ln in enumerate(lines) if ln == "begin_variable"]


def test_fd_skips_invariant_synthesis_for_a_constrained_task_only(tmp_path):
    import contextlib
    import io

    from ssr_compile.compile.constraints import is_chained
    from ssr_compile.errors import SSRError
    from ssr_compile.planners.fd import FastDownward, _translate
    from ssr_compile.printer import to_text

    d, p = _task()
    fd = get_planner("fd")
    # (a second motion: the arm's configuration takes three values, a multi-valued variable)
    p3 = replace(
        p,
        init=p.init + (S.Atom("motion", tuple(map(S.Const, ("aq7", "at5", "aq8")))),),
        goal=S.Atom("atconf", (S.Const("arm"), S.Const("aq8"))),
    )
    free = compile_problem(d, None, p3, caps=fd.capabilities)
    c = compile_problem(
        d, None, p, caps=fd.capabilities, plan_tail=TAIL, is_constant=CONSTANTS.__contains__
    )
    assert is_chained(c.domain) and not is_chained(free.domain)
    (tmp_path / "d.pddl").write_text(to_text(c.domain))
    (tmp_path / "p.pddl").write_text(to_text(c.problem))
    ranges = {}
    for invariants in (True, False):
        sas = tmp_path / f"{invariants}.sas"
        with contextlib.redirect_stdout(io.StringIO()):
            _translate(str(tmp_path / "d.pddl"), str(tmp_path / "p.pddl"), str(sas), invariants)
        ranges[invariants] = _ranges(sas.read_text())
    # With invariants, the chain's markers (one true at a time) form multi-valued variables;
    # without, every variable is binary.
    assert max(ranges[True]) > 2 and set(ranges[False]) == {2}
    # Either way the same plan; "auto" (the default) skips them here.
    import shutil

    plans, binary = {}, {}
    for setting, task in (("on", c), ("auto", c), ("off", c), ("auto-free", free)):
        planner = FastDownward(invariants=setting.split("-")[0], keep_files=True)
        result = planner.solve(task.domain, task.problem, time_limit=20)
        folder = result.message.rsplit("[files in ", 1)[1].rstrip("]")
        binary[setting] = set(_ranges(open(f"{folder}/output.sas").read())) == {2}
        shutil.rmtree(folder)
        plans[setting] = task.map_plan(result.actions)
    assert binary == {"on": False, "auto": True, "off": True, "auto-free": False}
    assert (
        plans["on"]
        == plans["auto"]
        == plans["off"]
        == [
            ("move", ("arm", "aq0", "at5", "aq7")),
            ("pick", ("d", "p9", "gd", "bq1", "aq7")),
        ]
    )
    with pytest.raises(SSRError, match="auto, on or off"):
        FastDownward(invariants="sometimes")


def test_up_fast_downward_skips_invariant_synthesis_on_a_constrained_ground_task():
    """unified-planning's engines get the task ground; Fast Downward's invariant synthesis
    took 14.5 of 15 s on one such constrained Swap replan.  The engine's public translator
    options turn it off there, and the plan is the same."""
    from ssr_compile.compile.constraints import is_chained
    from ssr_compile.errors import SSRError

    d, p = _task()
    up = get_planner("up:fast-downward")
    c = compile_problem(
        d, None, p, caps=up.capabilities, plan_tail=TAIL, is_constant=CONSTANTS.__contains__
    )
    free = compile_problem(d, None, p, caps=up.capabilities)
    assert all(not decl.params for decl in c.domain.predicates)  # the grounding pass ran
    assert is_chained(c.domain) and not is_chained(free.domain)
    off = ["--invariant-generation-max-candidates", "0"]
    assert up.engine_params(c.domain)["fast_downward_translate_options"] == off
    assert "fast_downward_translate_options" not in up.engine_params(free.domain)
    always = get_planner("up:fast-downward", invariants="on")
    assert "fast_downward_translate_options" not in always.engine_params(c.domain)
    assert (
        get_planner("up:fast-downward", invariants="off").engine_params(free.domain)[
            "fast_downward_translate_options"
        ]
        == off
    )
    result = up.solve(c.domain, c.problem, time_limit=60)
    assert result.status == "solved", result.message
    assert c.map_plan(result.actions) == [
        ("move", ("arm", "aq0", "at5", "aq7")),
        ("pick", ("d", "p9", "gd", "bq1", "aq7")),
    ]
    with pytest.raises(SSRError, match="takes no translator options"):
        get_planner("up:fast-downward-opt", invariants="off")


DRAWER = """
(define (domain drawer) (:requirements :strips)
  (:predicates (atconf ?q) (motion ?q1 ?t ?q2) (pullkin ?d ?q1 ?q2) (pushkin ?d ?q1 ?q2)
               (closed ?d) (open ?d) (seen ?d))
  (:action move :parameters (?q1 ?t ?q2)
    :precondition (and (atconf ?q1) (motion ?q1 ?t ?q2))
    :effect (and (atconf ?q2) (not (atconf ?q1))))
  (:action pull :parameters (?d ?q1 ?q2)
    :precondition (and (atconf ?q1) (closed ?d) (pullkin ?d ?q1 ?q2))
    :effect (and (atconf ?q2) (not (atconf ?q1)) (open ?d) (seen ?d) (not (closed ?d))))
  (:action push :parameters (?d ?q1 ?q2)
    :precondition (and (atconf ?q1) (open ?d) (pushkin ?d ?q1 ?q2))
    :effect (and (atconf ?q2) (not (atconf ?q1)) (closed ?d) (not (open ?d)))))
"""
# The old plan pushed d shut, ending at q2, then: move from q2, pull d open, move, and push d
# shut again with the same push -- ending at q2 once more.  After the first push the arm is
# observed at aq0, where no push ends: q2, one free variable for both uses, fits no value
# (Swap's constrained attempts that fell back, one cycle in three).
DRAWER_PROBLEM = """
(define (problem drawer-replan) (:domain drawer)
  (:objects d aq0 qa qb qc qd t1 t2)
  (:init (atconf aq0) (closed d) (motion aq0 t1 qa) (pullkin d qa qb) (motion qb t2 qc)
         (pushkin d qc qd))
  (:goal (and (seen d) (closed d))))
"""
DRAWER_TAIL = [
    ("move", ("q2", "t7", "q3")),
    ("pull", ("d", "q3", "q4")),
    ("move", ("q4", "t8", "q1")),
    ("push", ("d", "q1", "q2")),
]


def test_a_tail_no_value_fits_is_unsolvable_without_asking_the_planner():
    from ssr_compile.solver import ReplanState, SolveOptions, solve
    from ssr_compile.stream import StreamsModule

    d, p = parse_domain(DRAWER), parse_problem(DRAWER_PROBLEM)
    constant = {"d"}.__contains__
    c = constrain_plan(d, p, DRAWER_TAIL, constant)
    assert "q2" in c.unfit  # (and the values tied to it through the steps)
    # what the planner would say about it
    fd = get_planner("fd")
    lowered = compile_problem(
        d, None, p, caps=fd.capabilities, plan_tail=DRAWER_TAIL, is_constant=constant
    )
    assert fd.solve(lowered.domain, lowered.problem, time_limit=20).status == "unsolvable"
    # the tail without its last push fits (aq0 for q2, qa for q3, ...)
    assert constrain_plan(d, p, DRAWER_TAIL[:3], constant).unfit == ()
    streams = parse_stream_file("(define (stream drawer))")
    module = StreamsModule("drawer")
    options = SolveOptions(max_level=2)
    tied = solve(d, streams, p, module, options, ReplanState(DRAWER_TAIL, frozenset({"d"})))
    assert tied.status == "unsolvable"
    assert tied.stats.planner_calls == 0 and tied.stats.iterations >= 1
    # the same problem without the tail: the planner is asked, and plans
    free = solve(d, streams, p, module, options)
    assert free.solved and free.stats.planner_calls == 1
