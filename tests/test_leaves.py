"""The shared-leaves compile pass (ssr_compile/compile/leaves.py): which stream outputs are
leaves, the smaller task the planner reads, and plans mapped back to per-instance objects."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest

from ssr_compile import syntax as S
from ssr_compile.compile.leaves import SharedLeaves, leaf_outputs, share_leaves
from ssr_compile.compile.pipeline import compile_problem
from ssr_compile.errors import SSRError
from ssr_compile.parse import parse_file, parse_text
from ssr_compile.planners import get_planner
from ssr_compile.solver.preimage import plan_preimage

PP = Path(__file__).parent / "fixtures" / "compile" / "pp1d"
KITCHEN = Path(__file__).resolve().parents[1] / "domains" / "pddl" / "kitchen"


def load(folder: Path, problem: str = "problem.pddl"):
    return (
        parse_file(folder / "domain.pddl"),
        parse_file(folder / "stream.pddl"),
        parse_file(folder / problem),
    )


def test_motions_are_leaves_and_what_streams_consume_is_not():
    d, s, p = load(KITCHEN, "problem-cook.pddl")
    leaves = leaf_outputs(d, p, s)
    assert ("plan-base-motion", "?t") in leaves
    assert ("plan-arm-motion", "?t") in leaves
    assert [a.pred for a in leaves[("plan-base-motion", "?t")]] == ["motion"]
    # a base configuration is an input of motion streams, an observation of update-belief
    assert ("inv-reach", "?bq") not in leaves
    assert ("sample-obs", "?obs") not in leaves
    assert ("inv-kin", "?aq") not in leaves


def test_an_output_an_action_reads_without_the_inputs_is_not_a_leaf():
    d, s, p = load(PP)
    assert ("plan-motion", "?t") in leaf_outputs(d, p, s)
    # (traj ?t) certified and read by move: the fact cannot tell two instances apart
    stream_text = (PP / "stream.pddl").read_text()
    old = ":certified (motion ?q1 ?t ?q2))"
    assert old in stream_text
    s2 = parse_text(
        stream_text.replace(old, ":certified (and (motion ?q1 ?t ?q2) (traj ?t)))"), "stream.pddl"
    )
    text = (PP / "domain.pddl").read_text()
    old = "(and (atconf ?q1) (motion ?q1 ?t ?q2))"
    assert old in text
    text = text.replace(old, "(and (atconf ?q1) (motion ?q1 ?t ?q2) (traj ?t))")
    text = text.replace("(motion ?q1 ?t ?q2) (cfree", "(motion ?q1 ?t ?q2) (traj ?t) (cfree")
    d2 = parse_text(text, "domain.pddl")
    # certified with the inputs but not read by any action: still a leaf
    assert ("plan-motion", "?t") in leaf_outputs(d, p, s2)
    assert ("plan-motion", "?t") not in leaf_outputs(d2, p, s2)
    # and a leaf predicate read by a derived predicate is not one either
    d3 = replace(
        d,
        axioms=d.axioms
        + (S.Axiom("moving", (), S.Exists((S.Typed("?a"), S.Typed("?t"), S.Typed("?b")),
                                          S.Atom("motion", (S.Var("?a"), S.Var("?t"), S.Var("?b"))))),),
    )  # fmt: skip
    assert ("plan-motion", "?t") not in leaf_outputs(d3, p, s)


@pytest.mark.parametrize("problem", ["problem.pddl", "problem-blocked.pddl"])
def test_the_task_shrinks_and_plans_map_back_per_instance(problem):
    d, s, p = load(PP, problem)
    apart = compile_problem(d, s, p, level=3, leaves=False)
    shared = compile_problem(d, s, p, level=3, leaves=True)
    leaves = next(x for x in shared.passes if isinstance(x, SharedLeaves))
    ((name, originals),) = leaves.merged.items()
    assert name == "opt-plan-motion-t"
    inst = shared.instantiation
    assert all(inst.objects[o].instance.stream == "plan-motion" for o in originals)
    # every optimistic trajectory but one fewer object each
    assert len(shared.problem.objects) == len(apart.problem.objects) - len(originals) + 1
    assert len(originals) > 10
    result = get_planner("fd").solve(shared.domain, shared.problem, time_limit=30)
    assert result.status == "solved", result.message
    assert any(name in args for _, args in result.actions)  # the planner used the shared one
    plan = shared.map_plan(result.actions)
    for step, args in plan:
        assert name not in args
        if step == "move":
            q1, t, q2 = args
            # the trajectory is the one of the instance between these two configurations
            assert inst.objects[t].instance.inputs == (q1, q2)
    # valid on the task before the pass, with per-instance facts
    plan_preimage(shared.source_domain, shared.source_problem, plan)


def test_a_step_no_key_fact_identifies_is_an_error():
    d, s, p = load(PP)
    c = compile_problem(d, s, p, level=3)
    leaves = next(x for x in c.passes if isinstance(x, SharedLeaves))
    with pytest.raises(SSRError, match="no certified fact of the step identifies"):
        leaves.map_plan([("move", ("q0", "opt-plan-motion-t", "nowhere"))])


def test_real_results_keep_their_names():
    d, s, p = load(PP)
    c = compile_problem(d, s, p, level=2)
    inst = c.instantiation
    real = [replace(r, optimistic=False) for r in inst.results[:3]]
    again = share_leaves(c.source_domain, c.source_problem, s, replace(inst, results=real))
    assert not again.merged


def test_verbose_solve_shows_the_planners_task_beside_the_optimistic_problem(capsys):
    import re

    from ssr_compile.cli import main

    d, s, p = (str(PP / n) for n in ("domain.pddl", "stream.pddl", "problem.pddl"))
    assert main(["solve", d, s, p, "--streams", str(PP / "streams.py"), "-v"]) == 0
    out = capsys.readouterr()
    sizes = re.findall(r"problem (\d+) objects \((\d+) in the planner's task\)", out.out + out.err)
    assert sizes and all(int(task) < int(opt) for opt, task in sizes)


def test_verbose_solve_with_a_ground_task_names_no_task_size(capsys):
    """pyperplan's task is ground (no objects at all): "(0 in the planner's task)" said
    nothing true; the line gives the ground actions instead."""
    from ssr_compile.cli import main

    d, s, p = (str(PP / n) for n in ("domain.pddl", "stream.pddl", "problem.pddl"))
    args = ["solve", d, s, p, "--streams", str(PP / "streams.py"), "-v", "--planner", "pyperplan"]
    assert main(args) == 0
    out = capsys.readouterr()
    lines = [ln for ln in (out.out + out.err).splitlines() if ln.startswith("iteration ")]
    assert lines and all("ground actions" in ln for ln in lines)
    assert not any("in the planner's task" in ln for ln in lines)
