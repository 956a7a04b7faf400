"""The Focused solver on the pp1d fixture (1-D pick-and-place, Python streams).

Solutions are checked by an independent simulator over the geometric values (written here,
not taken from the solver), certificates and per-stream statistics against the streams
module's own call counts, deferral by counting motion-planner calls.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import pytest

from ssr_compile import syntax as S
from ssr_compile.errors import StreamError
from ssr_compile.parse import parse_domain, parse_problem, parse_stream_file
from ssr_compile.solver import SolveOptions, solve
from ssr_compile.solver.plan_evaluation import PAIR_DRAWS
from ssr_compile.stream import load_streams_module

PP = Path(__file__).parent / "fixtures" / "compile" / "pp1d"
GOAL = (4.5, 5.5)


def task(problem: str = "problem-blocked.pddl"):
    d = parse_domain((PP / "domain.pddl").read_text())
    s = parse_stream_file((PP / "stream.pddl").read_text())
    p = parse_problem((PP / problem).read_text())
    return d, s, p


def fresh_module():
    return load_streams_module(str(PP / "streams.py"))


def run(problem="problem-blocked.pddl", module=None, state=None, **kw):
    d, s, p = task(problem)
    module = module or fresh_module()
    kw.setdefault("initial_level", 3)
    kw.setdefault("time_limit", 30)
    return module, solve(d, s, p, module, SolveOptions(**kw), state)


def _values_with_b(module, problem):
    values = dict(module.values)
    return values, ("pb-goal" if "blocked" in problem else "pb-far")


@pytest.mark.parametrize("problem", ["problem.pddl", "problem-blocked.pddl"])
def test_solves_and_the_plan_simulates(problem):
    module, sol = run(problem)
    assert sol.status == "solved", sol.message
    assert all(not step.deferred for step in sol.plan)
    values, b_pose = _values_with_b(module, problem)
    plan = sol.plan
    _simulate(plan, values, {"a": values["pa"], "b": values[b_pose]})  # b where the problem puts it
    picks = [s.args[0] for s in plan if s.name == "pick"]
    assert picks == (["b", "a"] if "blocked" in problem else ["a"])
    # Certificate: the facts the plan relies on, with real names.
    cert = set(sol.certificate)
    for step in plan:
        if step.name in ("pick", "place"):
            assert S.Atom("kin", tuple(S.Const(x) for x in step.args)) in cert
        if step.name == "move":
            assert S.Atom("motion", tuple(S.Const(x) for x in step.args)) in cert
    last = plan[-1]
    assert S.Atom("contained", (S.Const("a"), S.Const(last.args[1]), S.Const("goal"))) in cert
    if "blocked" in problem:
        b_place = next(s for s in plan if s.name == "place" and s.args[0] == "b")
        cfree = S.Atom(
            "cfree", tuple(S.Const(x) for x in ("a", last.args[1], "b", b_place.args[1]))
        )
        assert cfree in cert
    # Statistics count the calls the module saw (functions and tests are called once each).
    calls = module.module.CALLS
    for name in ("test-cfree", "plan-motion", "dist"):
        assert sol.stats.streams[name].calls == calls[name], name
    assert sol.stats.planner_calls == sol.stats.iterations >= 1
    assert sol.cost == pytest.approx(
        sum(abs(s.values[0][1] - s.values[2][1]) for s in plan if s.name == "move")
        + sum(1 for s in plan if s.name != "move"),
        abs=0.1 * len(plan),
    )


def _simulate(plan, values, blocks):
    """An independent check of a real plan in 1-D: kinematics, motions, collisions, goal."""
    blocks = dict(blocks)
    q = values["q0"][1]
    holding = None
    for step in plan:
        v = dict(zip(step.args, step.values))
        if step.name == "move":
            q1, t, q2 = step.values
            assert q1[1] == pytest.approx(q) and t[0] == "traj", step
            assert (t[1], t[2]) == pytest.approx((q1[1], q2[1])), step
            q = q2[1]
        elif step.name == "pick":
            b, p, g, conf = step.args
            assert holding is None and blocks[b] == pytest.approx(v[p]), step
            assert v[conf][1] == pytest.approx(v[p] + v[g][1]) and v[conf][1] == pytest.approx(q)
            holding, blocks[b] = b, None
        else:
            assert step.name == "place", step
            b, p, g, conf = step.args
            assert holding == b and v[conf][1] == pytest.approx(v[p] + v[g][1])
            assert v[conf][1] == pytest.approx(q), step
            for other, x in blocks.items():
                assert other == b or x is None or abs(x - v[p]) >= 1.0, f"collision: {step}"
            holding, blocks[b] = None, v[p]
    assert holding is None and GOAL[0] <= blocks["a"] <= GOAL[1], blocks


def test_simulator_catches_a_collision():
    module, sol = run()
    plan = list(sol.plan)
    with pytest.raises(AssertionError):  # b never moved out of the way
        _simulate(
            [s for s in plan if s.args[0] != "b" and s.name != "move"],
            module.values,
            {"a": 0.3, "b": 5.2},
        )


def test_failing_generator_and_test_are_recovered_from():
    module = fresh_module()
    module.module.FAIL_FIRST_IK = {0.3}  # a at its start
    _, sol = run(module=module)
    assert sol.status == "solved", sol.message
    ik = sol.stats.streams["inverse-kin"]
    cfree = sol.stats.streams["test-cfree"]
    assert ik.failures >= 1 and ik.successes >= 1
    assert cfree.failures >= 1 and cfree.successes >= 1  # b's first table pose hits a
    _simulate(sol.plan, module.values, {"a": 0.3, "b": 5.2})


def test_deferral_skips_motions_beyond_the_first_action():
    on, off = fresh_module(), fresh_module()
    _, sol_on = run("problem.pddl", module=on, defer=True)
    _, sol_off = run("problem.pddl", module=off, defer=False)
    assert sol_on.solved and sol_off.solved
    # Off: every move has a real trajectory.
    assert all(not s.deferred for s in sol_off.plan)
    # On: the first action is real, later moves keep an optimistic trajectory...
    assert sol_on.plan[0].name == "move" and not sol_on.plan[0].deferred
    later_moves = [s for s in sol_on.plan[1:] if s.name == "move"]
    assert later_moves and all(s.deferred == (s.args[1],) for s in later_moves)
    assert all(s.values[1] is None for s in later_moves)
    assert {r.instance.stream for r in sol_on.deferred} == {"plan-motion"}
    # ...and the motion planner was called only for first actions (once per iteration at
    # most), far less than without deferral.
    motion_on, motion_off = on.module.CALLS["plan-motion"], off.module.CALLS["plan-motion"]
    assert motion_on <= sol_on.stats.iterations
    assert motion_off > motion_on
    assert motion_off >= len([s for s in sol_off.plan if s.name == "move"])


def test_time_limit_honoured():
    module = fresh_module()
    module.module.SLEEP = 0.4
    start = time.monotonic()
    _, sol = run(module=module, time_limit=0.5)
    elapsed = time.monotonic() - start
    assert sol.status == "timeout" and "time" in sol.message
    assert elapsed < 2.0


def test_max_cost_below_the_optimum_is_unsolvable():
    _, sol = run("problem.pddl", max_cost=2.0, max_level=3)
    assert sol.status == "unsolvable" and sol.plan is None
    assert "cost bound" in sol.message


def test_max_cost_above_the_plan_is_solved():
    # A bound just above the unbounded plan's cost keeps that very plan; one just below it
    # excludes it (the bound is on the plan's real cost, in the user's units).
    _, free = run("problem.pddl")
    assert free.solved
    _, bounded = run("problem.pddl", max_cost=free.cost + 1e-3)
    assert bounded.solved and bounded.cost == pytest.approx(free.cost)
    assert [str(s) for s in bounded.plan] == [str(s) for s in free.plan]
    _, below = run("problem.pddl", max_cost=free.cost - 1e-3, max_level=4)
    assert not below.solved or below.cost < free.cost - 1e-3


def test_stream_missing_from_module_is_a_stream_error():
    module = fresh_module()
    del module.streams["test-cfree"]
    with pytest.raises(StreamError) as e:
        run(module=module)
    assert "test-cfree" in str(e.value) and e.value.line is not None


def test_module_that_fails_to_import(tmp_path):
    bad = tmp_path / "broken_streams.py"
    bad.write_text("import math\nSTREAMS = {}\nraise RuntimeError('no robot attached')\n")
    with pytest.raises(StreamError, match="no robot attached"):
        load_streams_module(str(bad))
    with pytest.raises(StreamError, match="does not exist"):
        load_streams_module(str(tmp_path / "nothing.py"))
    with pytest.raises(StreamError, match="cannot import"):
        load_streams_module("no_such_streams_package_xyz")


def test_solution_is_unsolvable_when_no_goal_pose_is_free():
    # Goal region narrower than a block and b inside it forever: every placement collides.
    module = fresh_module()
    module.module.REGIONS = {"table": (5.2, 5.2), "goal": (4.9, 5.1)}
    _, sol = run(module=module, max_level=4, time_limit=20)
    assert sol.status == "unsolvable" and sol.plan is None
    assert "up to level 4" in sol.message
    assert sol.stats.levels[-1] == 4  # it did try every level up to the maximum
    # the placements were sampled and each was refused by the collision test
    assert sol.stats.streams["sample-pose"].successes > 0
    assert sol.stats.streams["test-cfree"].failures > 0
    assert math.isfinite(sol.stats.total_time)


@pytest.mark.parametrize("problem", ["problem.pddl", "problem-blocked.pddl"])
def test_shared_optimistic_outputs_solve_and_the_plan_simulates(problem):
    module, sol = run(problem, share=True)
    assert sol.status == "solved", sol.message
    values, b_pose = _values_with_b(module, problem)
    _simulate(sol.plan, values, {"a": values["pa"], "b": values[b_pose]})
    assert (
        all(len(z) == 4 for z in sol.stats.sizes) and len(sol.stats.sizes) == sol.stats.iterations
    )


def test_cheap_functions_are_evaluated_eagerly_and_the_plan_is_as_cheap():
    _, lazy = run("problem.pddl", eager_cost=-1)
    _, eager = run("problem.pddl")
    assert lazy.status == eager.status == "solved"
    assert eager.cost <= lazy.cost + 1e-9
    assert eager.stats.planner_calls <= lazy.stats.planner_calls


@pytest.mark.parametrize("problem", ["problem.pddl", "problem-blocked.pddl"])
def test_cheap_tests_are_evaluated_before_planning_and_no_plan_rests_on_a_failed_one(problem):
    module, eager = run(problem, progress=(said := []).append)
    _, lazy = run(problem, eager_tests=False)
    assert lazy.status == eager.status == "solved"
    assert eager.cost <= lazy.cost + 1e-9
    values, b_pose = _values_with_b(module, problem)
    _simulate(eager.plan, values, {"a": values["pa"], "b": values[b_pose]})
    # a test over real inputs is evaluated before any plan can count on it: a stream plan's
    # test failing on real inputs would have been found eagerly
    assert not any(
        "test-cfree" in line and line.endswith("failed") for line in said if "opt" not in line
    )


def test_a_test_over_real_values_that_fails_a_stream_plan_is_evaluated_over_their_siblings(
    monkeypatch,
):
    # Lazy tests (none evaluated before planning): the blocked problem's stream plans fail on
    # test-cfree over real placements.  The same test over the same blocks' other real
    # placements is then evaluated at once, so the planner is not asked once per pair.  (The
    # draws again are seen from the first level, as levels climbed from 1: complexity_base.)
    from ssr_compile.solver import focused

    kw = dict(eager_tests=False, complexity_base=1)
    _, with_siblings = run("problem-blocked.pddl", **kw, progress=(said := []).append)
    monkeypatch.setattr(focused, "SIBLINGS", 0)
    _, without = run("problem-blocked.pddl", **kw)
    assert with_siblings.status == without.status == "solved"
    assert any("more test-cfree over the same objects' other values" in x for x in said)
    assert with_siblings.stats.planner_calls < without.stats.planner_calls
    assert with_siblings.cost <= without.cost + 1e-9


def test_a_test_declared_p_success_zero_is_never_planned_over_values_drawn_for_the_plan():
    # pp1d's blocked problem needs CFree over a placement drawn for the plan: declared never
    # to succeed optimistically (pddlstream's p_success=0), the test is instantiated over
    # real placements only, so no plan exists -- and the solver says so at once
    from ssr_compile.stream import StreamInfo

    module = fresh_module()
    module.info["test-cfree"] = StreamInfo(kind="test", p_success=0)
    _, sol = run("problem-blocked.pddl", module=module)
    assert sol.status == "unsolvable"
    assert "no higher level adds a stream instance" in sol.message
    _, default = run("problem-blocked.pddl")
    assert default.status == "solved"


def test_a_plan_whose_stream_plan_all_succeeds_is_the_solution_with_the_values_drawn():
    # the progress example: its last stream plan succeeds, and (accept_drawn) the plan with
    # the values drawn is returned without another planner call; unified-planning's validator checks it
    # against the problem with the certified facts of the evaluated streams
    from dataclasses import replace

    from ssr_compile.compile.instantiate import declare_stream_predicates
    from ssr_compile.planners.validate import validate_plan
    from ssr_compile.stream import module_for_problem

    folder = Path(__file__).parent.parent / "domains" / "pddl" / "progress"
    d = parse_domain((folder / "domain.pddl").read_text())
    s = parse_stream_file((folder / "stream.pddl").read_text())
    p = parse_problem((folder / "problem.pddl").read_text())
    module = module_for_problem("ssr_compile.streams.progress", folder / "problem.pddl", 0)
    sol = solve(d, s, p, module, SolveOptions(progress=(said := []).append, accept_drawn=True))
    assert sol.status == "solved", sol.message
    assert said[-1].strip() == "the plan holds with the values drawn"
    assert sol.stats.planner_calls == sol.stats.iterations
    assert not any(a.startswith("opt") for step in sol.plan for a in step.args)
    facts = [f for r in sol.evaluated for f in r.certified]
    names = {o.name for o in p.objects} | {c.name for c in d.constants}
    extra = sorted({a.name for f in facts for a in f.args} - names)
    real = replace(
        p, objects=p.objects + tuple(S.Typed(n) for n in extra), init=p.init + tuple(facts)
    )
    ok, why = validate_plan(
        declare_stream_predicates(d, s), real, [(x.name, x.args) for x in sol.plan]
    )
    assert ok, why
    again = solve(
        d,
        s,
        p,
        module_for_problem("ssr_compile.streams.progress", folder / "problem.pddl", 0),
        SolveOptions(accept_drawn=True),
    )
    assert [str(x) for x in again.plan] == [str(x) for x in sol.plan] and again.cost == sol.cost
    # by default only a cost-optimal planner's plan is taken as drawn at once (fd's is not): it
    # is kept, the solver plans again, and takes it when the next plan is no cheaper
    said.clear()
    module = module_for_problem("ssr_compile.streams.progress", folder / "problem.pddl", 0)
    default = solve(d, s, p, module, SolveOptions(progress=said.append))
    lines = [line.strip() for line in said]
    kept = lines.index("the plan holds with the values drawn (cost 6; kept, planning again)")
    assert lines[kept + 1].startswith("iteration ")
    assert lines[-1] == "no cheaper than the plan drawn before: taken"
    assert default.stats.planner_calls == sol.stats.planner_calls + 1
    assert [str(x) for x in default.plan] == [str(x) for x in sol.plan]
    assert default.cost == sol.cost


def test_out_of_time_after_a_plan_was_drawn_the_solver_returns_that_plan():
    # the progress example's third plan holds with its values drawn and is kept (fd is not
    # cost-optimal); the planner then runs out of time: the kept plan is the answer, not
    # "timeout"
    from ssr_compile.planners import get_planner
    from ssr_compile.planners.base import PlanResult
    from ssr_compile.stream import module_for_problem

    folder = Path(__file__).parent.parent / "domains" / "pddl" / "progress"
    d = parse_domain((folder / "domain.pddl").read_text())
    s = parse_stream_file((folder / "stream.pddl").read_text())
    p = parse_problem((folder / "problem.pddl").read_text())

    class ThreeCalls:
        def __init__(self):
            self.fd = get_planner("fd")
            self.name, self.capabilities, self.calls = "fd", self.fd.capabilities, 0

        def solve(self, domain, problem, time_limit=None, cost_bound=None):
            self.calls += 1
            if self.calls > 3:
                return PlanResult("timeout", None, None, time_limit or 0.0, self.name)
            return self.fd.solve(domain, problem, time_limit=time_limit, cost_bound=cost_bound)

    said: list[str] = []
    module = module_for_problem("ssr_compile.streams.progress", folder / "problem.pddl", 0)
    sol = solve(d, s, p, module, SolveOptions(planner=ThreeCalls(), progress=said.append))
    assert sol.status == "solved", sol.message
    # the 4th call, on a level with instances held back, had a slice of the time: cut there,
    # the level rose; the 5th call ran out of time
    assert sol.stats.planner_calls == 5
    assert sol.stats.levels == [1, 2, 2, 2, 3]
    assert said[-1].strip().endswith("the cheapest plan drawn so far")
    assert [x.name for x in sol.plan] == ["move-base", "pick"]
    assert sol.plan[0].args[2] == sol.plan[1].args[3]  # picks where it moved to
    assert sol.cost == 6
    # without a plan drawn before, running out of time stays a timeout
    module = module_for_problem("ssr_compile.streams.progress", folder / "problem.pddl", 0)
    planner = ThreeCalls()
    planner.calls = 2
    assert solve(d, s, p, module, SolveOptions(planner=planner)).status == "timeout"


def test_rejected_draws_are_redrawn_at_their_level_and_the_plan_simulates():
    module, sol = run("problem-blocked.pddl", redraws=2)
    assert sol.status == "solved", sol.message
    values, b_pose = _values_with_b(module, "problem-blocked.pddl")
    _simulate(sol.plan, values, {"a": values["pa"], "b": values[b_pose]})
    _, again = run("problem-blocked.pddl", redraws=2)
    assert [str(s) for s in again.plan] == [str(s) for s in sol.plan]
    assert again.stats.planner_calls == sol.stats.planner_calls


def test_a_failed_or_rejected_draw_is_drawn_again_at_once_instead_of_planning_again():
    # a's first inverse kinematics fails and b's first table pose hits a: drawn again within
    # the same stream plan, no planner call is spent on either, and the plan still simulates.
    sols = {}
    for resample in (0, 1):
        module = fresh_module()
        module.module.FAIL_FIRST_IK = {0.3}
        _, sols[resample] = run(module=module, resample=resample)
        assert sols[resample].status == "solved", sols[resample].message
        _simulate(sols[resample].plan, module.values, {"a": 0.3, "b": 5.2})
    off, on = sols[0], sols[1]
    assert off.stats.resamples == 0 and on.stats.resamples >= 1
    assert on.stats.planner_calls < off.stats.planner_calls
    assert on.cost <= off.cost + 1e-9  # equal costs may differ in the last bit


def test_a_sampler_that_finds_nothing_draws_again_once_per_solve():
    # No inverse kinematics for a at its start, ever: after one draw again that gave nothing,
    # a failed draw of inverse-kin is left to the next level, as without resample.
    module = fresh_module()
    module.module.NO_IK = {0.3}
    said: list[str] = []
    _, sol = run(module=module, progress=said.append, max_level=5, time_limit=20)
    assert sol.status == "unsolvable", sol.message
    failed = [line for line in said if line.startswith("  inverse-kin") and "failed" in line]
    again = [line for line in said if line.startswith("  drawing again:") and "inverse-kin" in line]
    assert len(failed) >= 3 and len(again) == 1, (failed, again)


def test_draws_again_stop_at_the_limit_and_at_an_exhausted_generator():
    # Every pose of b on the table hits a (test-cfree fails): the first stream plan draws a
    # rejected generator again at most ``resample`` times, then plans again; each stream plan
    # the tests rejected before adds ``resample`` more draws to the next one's budget (drawing
    # costs stream calls, planning again a planner call on a larger problem).  A draw tested
    # against another draw of its plan (b against a placement of a drawn for the same plan,
    # from the second stream plan on) has PAIR_DRAWS times the budget.
    for resample in (1, 3):
        module = fresh_module()
        module.module.CFREE_NEVER = True
        said: list[str] = []
        run(module=module, resample=resample, progress=said.append, max_level=4, time_limit=20)
        per_plan: list[int] = []
        for line in said:
            if line.startswith("  stream plan:"):
                per_plan.append(0)
            elif line.startswith("  drawing again:") and per_plan:
                per_plan[-1] += 1
        assert per_plan and per_plan[0] == resample, (resample, per_plan)
        assert all(n <= resample * (1 + i) * PAIR_DRAWS for i, n in enumerate(per_plan)), (
            resample,
            per_plan,
        )
        assert max(per_plan) > resample, (resample, per_plan)  # the budget grew
        # past the lone draw's budget: b drawn against a's placement of the same plan
        assert any(n > resample * (1 + i) for i, n in enumerate(per_plan)), (resample, per_plan)


def test_no_level_is_tried_once_instantiation_has_reached_its_fixed_point(tmp_path):
    # Holding both blocks at once is impossible whatever the streams give: once the optimistic
    # problem stops growing and the planner proves it unsolvable, a higher level would plan
    # the same problem again (the policy's constrained attempts spent levels 5-8 so).
    d, s, p = task("problem.pddl")
    text = (PP / "problem.pddl").read_text()
    goal = "(:goal (exists (?p) (and (contained a ?p goal) (atpose a ?p))))"
    assert goal in text
    impossible = parse_problem(text.replace(goal, "(:goal (and (holding a ga) (holding b gb)))"))
    options = SolveOptions(initial_level=1, max_level=8, time_limit=30)
    sol = solve(d, s, impossible, fresh_module(), options)
    assert sol.status == "unsolvable" and sol.plan is None
    assert "no higher level adds a stream instance" in sol.message
    assert sol.stats.levels[-1] < 8
    assert sol.stats.planner_calls == len(sol.stats.levels)  # one call per level tried
    # while instantiation still grows, levels go on (the goal pose test above: to level 4)
    assert sol.stats.levels == sorted(set(sol.stats.levels))


def _logged_fd(events: list[str]):
    """An ``fd`` backend that appends "plan" to ``events`` at each planner call."""
    from ssr_compile.planners import get_planner

    backend = get_planner("fd")
    plan_once = backend.solve

    def logged_solve(*a, **k):
        events.append("plan")
        return plan_once(*a, **k)

    backend.solve = logged_solve
    return backend


def test_eager_streams_are_drawn_before_planning_and_a_failure_is_never_planned_with():
    """StreamInfo.eager: an instance whose domain holds in the real facts is drawn before the
    first planner call; one that found nothing (b's pose out of reach) is in no stream plan;
    the plan costs what the lazy one does."""
    from ssr_compile.stream import StreamInfo

    outcome = {}
    for eager in (False, True):
        module = fresh_module()
        module.info["inverse-kin"] = StreamInfo(kind="function", eager=eager)
        fixture = module.streams["inverse-kin"].__globals__
        events: list[str] = []
        kin = module.streams["inverse-kin"]

        def logged_kin(block, pose, grasp, _kin=kin, _events=events):
            _events.append(f"kin {block} {pose}")
            return next(_kin(block, pose, grasp))  # a function: its first answer

        module.streams["inverse-kin"] = logged_kin
        backend = _logged_fd(events)
        fixture["NO_IK"].add(9.0)  # pb-far: b is never in reach (and never needed)
        said: list[str] = []
        try:
            _, sol = run("problem.pddl", module=module, planner=backend, progress=said.append)
        finally:
            fixture["NO_IK"].clear()
        outcome[eager] = (sol, events, said)
    (lazy, lazy_events, _), (eager_sol, events, said) = outcome[False], outcome[True]
    assert lazy.status == eager_sol.status == "solved"
    assert eager_sol.cost == pytest.approx(lazy.cost)
    values = dict(module.values)
    _simulate(eager_sol.plan, values, {"a": values["pa"], "b": values["pb-far"]})
    # the lazy solver draws it only once a plan asked for it
    assert "kin b 9.0" not in lazy_events or lazy_events.index("kin b 9.0") > lazy_events.index(
        "plan"
    )
    assert events.index("kin b 9.0") < events.index("plan")  # drawn before planning
    assert events.count("kin b 9.0") == 1  # a function: one draw, then exhausted
    plans = [line for line in said if "stream plan:" in line]
    assert not any("inverse-kin(b, pb-far" in line for line in plans)


def test_what_failed_over_the_problems_objects_is_rechecked_before_the_next_call_plans():
    """Solution.failed names the instances over the problem's own objects that failed (a grasp
    of a out of reach at its pose); a replanning call handed them (ReplanState.recheck)
    evaluates them before its first planner call, and no plan of it counts on them; an
    instance whose inputs are not the problem's objects is not called."""
    from dataclasses import replace

    from ssr_compile.compile.instantiate import Instance
    from ssr_compile.solver import ReplanState
    from ssr_compile.stream import StreamInfo

    d, s, p = task("problem.pddl")
    # a second grasp of a; the first one (ga) never reaches a at pa
    p = replace(
        p,
        objects=p.objects + (S.Typed("ga2"),),
        init=p.init + (S.Atom("grasp", (S.Const("a"), S.Const("ga2"))),),
    )
    bad = Instance("inverse-kin", ("a", "pa", "ga"), "stream")
    outcome = {}
    for recheck in ((), (bad, Instance("inverse-kin", ("zz", "pa", "ga"), "stream"))):
        module = fresh_module()
        module.values["ga2"] = ("g", 1e-9)  # as ga, for the kinematics
        module.info["inverse-kin"] = StreamInfo(kind="function")
        kin = module.streams["inverse-kin"]
        events: list[str] = []

        def one_kin(block, pose, grasp, _kin=kin, _events=events):
            _events.append(f"kin {block} {pose} {grasp[1]}")
            if block == "a" and grasp == ("g", 0.0):
                return None
            return next(_kin(block, pose, grasp))

        module.streams["inverse-kin"] = one_kin
        backend = _logged_fd(events)
        said: list[str] = []
        sol = solve(
            d, s, p, module,
            SolveOptions(
                initial_level=3, time_limit=30, planner=backend, progress=said.append,
                accept_drawn=True,
            ),
            ReplanState(recheck=recheck),
        )  # fmt: skip
        outcome[bool(recheck)] = (sol, events, said)
    (first, first_events, first_said), (again, events, said) = outcome[False], outcome[True]
    assert first.status == again.status == "solved"
    # the first call planned with ga, found it failing, and says so
    assert any("inverse-kin(a, pa, ga) failed" in line for line in first_said)
    assert first_events.index("plan") < first_events.index("kin a 0.3 0.0")
    assert bad in first.failed
    assert all(x in {"a", "b", "pa", "pb-far", "ga", "ga2", "gb", "q0"} for i in first.failed
               for x in i.inputs)  # fmt: skip
    # the second evaluates it before planning, once, and never plans with it
    assert events.index("kin a 0.3 0.0") < events.index("plan")
    assert events.count("kin a 0.3 0.0") == 1
    assert not any("inverse-kin(a, pa, ga)" in line for line in said if "stream plan:" in line)
    assert bad in again.failed  # it failed again: carried on


@pytest.mark.parametrize("max_level", [3, 4])
def test_a_kept_plan_is_returned_when_no_cheaper_plan_is_found(monkeypatch, max_level):
    # A plan that held with its values drawn but cost more than planned is kept while the
    # planner is asked for a cheaper one.  When the planner then finds none up to the last
    # level, the kept plan is the answer, not "unsolvable" (Cook seed 23 looked again instead
    # of acting, after 105,529 stream calls).
    from dataclasses import replace

    from ssr_compile.planners.base import UNSOLVABLE
    from ssr_compile.solver import focused

    original = focused.FocusedLoop.plan
    refused = []

    def plan(self, compiled):
        result, bound = original(self, compiled)
        if self.incumbent is not None:  # nothing cheaper from here on
            refused.append(self.level)
            result = replace(result, status=UNSOLVABLE, actions=None, cost=None)
        return result, bound

    monkeypatch.setattr(focused.FocusedLoop, "plan", plan)
    module, sol = run("problem-blocked.pddl", max_level=max_level, progress=(said := []).append)
    assert refused and refused[-1] == max_level  # a plan was kept, then none found to the last
    assert sol.status == "solved", sol.message
    assert any("the cheapest plan drawn so far" in x for x in said)
    values, b_pose = _values_with_b(module, "problem-blocked.pddl")
    _simulate(sol.plan, values, {"a": values["pa"], "b": values[b_pose]})


def test_retry_levels_bounds_the_level_rises_that_only_draw_again_what_failed():
    # Every placement in the goal region collides: once instantiation is saturated, each
    # level rise only gives back the failed samples to be drawn again.  ``retry_levels`` caps
    # those rises (the policy's constrained attempts, which have a fallback); unbounded, the
    # loop climbs until the planner proves the problem unsolvable with nothing held back.
    levels = {}
    for retries in (None, 0, 1):
        module = fresh_module()
        module.module.REGIONS = {"table": (5.2, 5.2), "goal": (4.9, 5.1)}
        _, sol = run(module=module, max_level=6, time_limit=20, retry_levels=retries)
        assert sol.status == "unsolvable" and sol.plan is None
        levels[retries] = sol.stats.levels
        if retries is not None:
            assert f"retry_levels={retries}" in sol.message
    first = levels[0][0]
    assert set(levels[0]) == {first}  # no rise at all
    assert set(levels[1]) == {first, first + 1}  # one rise
    assert max(levels[None]) > first + 1
    assert levels[None][: len(levels[1])] == levels[1]  # the same iterations until the cap
