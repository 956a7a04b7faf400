"""The adaptive algorithm (ssr_compile/solver/adaptive.py): a queue of plan skeletons sampled between
planner calls.  Its plans pass the examples' own checkers, cost no more than the Focused
loop's on the shipped examples, are the same run after run, and it keeps to the time limit,
retries a failed draw within its skeleton (no planner call) and abandons a skeleton whose
generator has no more values.  A few seconds in all."""

from __future__ import annotations

import time
from pathlib import Path

import pytest
from conftest import require_corpus
from ssr_compile.streams import belief_detect as bd
from ssr_compile.streams import tamp2d as T
from test_focused import _simulate
from test_focused import run as run_pp1d

from ssr_compile.errors import UnsupportedError
from ssr_compile.parse import parse_file
from ssr_compile.solver import ReplanState, SolveOptions, solve
from ssr_compile.stream import from_module, load_streams_module

ROOT = Path(__file__).resolve().parents[1]
PDDL = ROOT / "domains" / "pddl"


def load(folder: Path, name: str):
    return (
        parse_file(folder / "domain.pddl"),
        parse_file(folder / "stream.pddl"),
        parse_file(folder / name),
    )


def solve_tamp2d(folder: str, name: str, **options):
    domain, streams, problem = load(PDDL / folder, name)
    options.setdefault("planner", "fd:opt")  # as example.toml
    options.setdefault("initial_level", 3)
    sol = solve(
        domain,
        streams,
        problem,
        from_module(T),
        SolveOptions(time_limit=20, algorithm="adaptive", **options),
    )
    assert sol.solved, sol.message
    plan = [(step.name, step.args) for step in sol.plan]
    cost = T.check_plan(domain, problem, sol.values.value, plan)
    return sol, plan, cost


# The Focused loop's plan costs on these problems (same planner and level): no worse.
@pytest.mark.parametrize(
    ("folder", "name", "focused_cost"),
    [
        ("tamp2d", "problem.pddl", 13.303),
        ("tamp2d", "problem-blocked.pddl", 29.703),
        ("tamp2d-routes", "problem.pddl", 12.01),
    ],
)
def test_tamp2d_plans_pass_the_checker_and_cost_no_more(folder, name, focused_cost):
    sol, plan, cost = solve_tamp2d(folder, name)
    assert sol.cost == pytest.approx(cost, rel=0.01, abs=0.01)
    assert sol.cost <= focused_cost + 0.01
    if "blocked" in name:
        assert [args[0] for n, args in plan if n == "pick"] == ["b1", "b0"]
    assert all(not step.deferred for step in sol.plan)


def test_same_plan_and_same_stream_calls_every_run():
    runs = [solve_tamp2d("tamp2d", "problem-blocked.pddl")[0] for _ in range(2)]
    a, b = runs
    assert [str(s) for s in a.plan] == [str(s) for s in b.plan]
    assert a.cost == b.cost
    assert {k: v.calls for k, v in a.stats.streams.items()} == {
        k: v.calls for k, v in b.stats.streams.items()
    }
    assert a.stats.planner_calls == b.stats.planner_calls


def test_deferred_motions_wait_and_the_plan_passes_the_checker():
    sol, plan, _ = solve_tamp2d("tamp2d", "problem-blocked.pddl", defer=True)
    deferred = {x for step in sol.plan for x in step.deferred}
    assert deferred and not sol.plan[0].deferred
    assert all(name == "move" for name, args in plan if set(args) & deferred)
    # the deferred results name the real configurations they join
    assert sol.deferred and all(
        not x.startswith("opt") for r in sol.deferred for x in r.instance.inputs
    )


@pytest.mark.parametrize(("which", "cost"), [("occluded", 6.05), ("clear", 4.05)])
def test_belief_detect(which, cost):
    folder = PDDL / "belief-detect"
    domain, streams, problem = load(folder, f"problem-{which}.pddl")
    sol = solve(
        domain,
        streams,
        problem,
        bd.make_module(0),
        SolveOptions(planner="fd:opt", initial_level=3, time_limit=20, algorithm="adaptive"),
    )
    assert sol.solved, sol.message
    names = [s.name for s in sol.plan]
    assert names.count("detect") == 1 and names[-1] == "pick"
    if which == "occluded":
        assert names.index("move-aside") < names.index("detect")
    assert bd.localized_test("target", sol.plan[-1].values[1])
    assert sol.cost == pytest.approx(cost, abs=0.01)


def test_continuous_tamp_two_blocks_into_the_goal_region():
    corpus = require_corpus("pddlstream-examples/examples/continuous_tamp")
    fixture = ROOT / "tests" / "fixtures" / "ctamp"
    domain = parse_file(corpus / "domain.pddl")
    streams = parse_file(corpus / "stream.pddl")
    problem = parse_file(fixture / "problem.pddl")
    module = load_streams_module(str(fixture / "streams.py"))
    start = time.monotonic()
    options = SolveOptions(planner="fd", time_limit=20, algorithm="adaptive")
    sol = solve(domain, streams, problem, module, options)
    assert sol.solved, sol.message
    assert time.monotonic() - start < 10
    lo, hi = module.module.REGIONS["goal"]
    placed = {s.args[1]: s.values[2] for s in sol.plan if s.name == "place"}
    assert set(placed) == {"a", "b"}
    assert all(lo + 0.5 <= p <= hi - 0.5 for p in placed.values())
    assert abs(placed["a"] - placed["b"]) >= 1.0


def test_time_limit_honoured():
    module = load_streams_module(str(ROOT / "tests/fixtures/compile/pp1d/streams.py"))
    module.module.SLEEP = 0.4
    start = time.monotonic()
    _, sol = run_pp1d(module=module, time_limit=0.5, algorithm="adaptive")
    assert sol.status == "timeout" and "time" in sol.message
    assert time.monotonic() - start < 2.0


def test_rejected_draws_are_retried_in_the_skeleton_and_a_spent_one_is_abandoned():
    module = load_streams_module(str(ROOT / "tests/fixtures/compile/pp1d/streams.py"))
    module.module.FAIL_FIRST_IK = {0.3}  # inverse-kin of a at its start fails at first
    said: list[str] = []
    _, sol = run_pp1d(module=module, algorithm="adaptive", progress=said.append)
    assert sol.status == "solved", sol.message
    _simulate(sol.plan, module.values, {"a": 0.3, "b": 5.2})
    cfree = sol.stats.streams["test-cfree"]
    # the goal pose drawn for a hits b, again and again: each rejection draws anew from the
    # queue, not after a planner call
    assert cfree.failures > sol.stats.planner_calls
    # sample-pose(a, goal) is finite: its skeleton is dropped when it has no more values
    assert any("abandoned: sample-pose(a, goal) has no more values" in line for line in said)
    ik = sol.stats.streams["inverse-kin"]
    assert ik.failures >= 1 and ik.successes >= 1


def test_replanning_state_is_taken():
    module = load_streams_module(str(ROOT / "tests/fixtures/compile/pp1d/streams.py"))
    # a cost-optimal planner: the incumbent is returned when no cheaper plan is left
    _, first = run_pp1d("problem.pddl", module=module, algorithm="adaptive", planner="fd:opt")
    assert first.solved
    state = ReplanState(evaluated=first.evaluated, values=first.values)
    _, again = run_pp1d(
        "problem.pddl", module=module, algorithm="adaptive", planner="fd:opt", state=state
    )
    assert again.solved and again.cost <= first.cost + 1e-6
    _simulate(again.plan, module.values, {"a": 0.3, "b": 9.0})
    calls = lambda s: sum(x.calls for x in s.stats.streams.values())  # noqa: E731
    assert calls(again) < calls(first)


def test_shared_outputs_and_unknown_algorithms_are_refused():
    with pytest.raises(UnsupportedError, match="share"):
        run_pp1d("problem.pddl", algorithm="adaptive", share=True)
    with pytest.raises(ValueError, match="unknown algorithm"):
        run_pp1d("problem.pddl", algorithm="sideways")


def test_cli_solve_algorithm_adaptive(capsys):
    from ssr_compile.cli import main

    code = main(["solve", "tamp2d", "--problem", "problem", "--algorithm", "adaptive", "-v"])
    assert code == 0
    out, err = capsys.readouterr()
    assert "algorithm   adaptive  (flag --algorithm)" in err
    line = next(x for x in err.splitlines() if x.startswith("iteration 1:"))
    assert "objects" in line and "facts" in line and "queue" in line
    assert "plan (4 actions, cost 13.303)" in out
    with pytest.raises(SystemExit):
        main(["solve", "--help"])
    assert "adaptive" in capsys.readouterr().out
