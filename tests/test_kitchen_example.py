"""The kitchen example folder runs through `ssr-compile solve FOLDER` like every other one."""

import json
from pathlib import Path

import pytest
from ssr_compile.streams import kitchen_example

from ssr_compile.cli import main

FOLDER = Path(__file__).resolve().parent.parent / "domains" / "pddl" / "kitchen"


@pytest.mark.parametrize("task", kitchen_example.TASKS)
def test_shipped_problem_files_are_the_generated_tasks(task):
    shipped = (FOLDER / f"problem-{task}.pddl").read_text()
    assert shipped == kitchen_example.problem_text(task)


def test_unknown_problem_name_is_refused():
    with pytest.raises(ValueError, match="problem-<task>.pddl"):
        kitchen_example.task_name("problem-dance.pddl")


def test_solve_folder_inspect(capsys):
    code = main(["solve", str(FOLDER), "--problem", "inspect", "--json", "--time-limit", "90"])
    out = json.loads(capsys.readouterr().out)["results"][0]
    assert code == 0, out["message"]
    names = [step["action"] for step in out["plan"]]
    # Inspect (paper appendix): open the bottom drawer, detect the block, close the drawer.
    core = [n for n in names if not n.startswith("move")]
    assert core == ["pull", "detect", "push"]
    # Deferral is on in example.toml: later arm motions stay optimistic.
    assert any(step["deferred"] for step in out["plan"][1:])
    assert not out["plan"][0]["deferred"]


def test_a_copy_of_a_kitchen_problem_under_another_name_is_served(tmp_path):
    """The task comes from the problem's own name (kitchen-<task>-<seed>), not its file name."""
    from ssr_compile.streams.kitchen_example import task_name

    from ssr_compile.resources import domains_dir

    copy = tmp_path / "my-inspect.pddl"
    copy.write_text((domains_dir() / "kitchen" / "problem-swap.pddl").read_text())
    assert task_name(copy) == "swap"
    odd = tmp_path / "problem-cook.pddl"
    odd.write_text("(define (problem other) (:domain kitchen) (:goal (handempty)))")
    assert task_name(odd) == "cook"  # the file name when the problem's name says nothing
    nothing = tmp_path / "whatever.pddl"
    nothing.write_text("(define (problem other) (:domain kitchen) (:goal (handempty)))")
    import pytest

    with pytest.raises(ValueError, match="names its task"):
        task_name(nothing)
