"""The Focused solver on the kitchen's other tasks (Inspect is in test_kitchen_example): each
plan is checked against the optimistic problem by the preimage simulator and has the shape
the paper's appendix describes."""

from __future__ import annotations

import json

import pytest

from ssr_compile.cli import main


def _solve(task: str, capsys, time_limit: int = 120) -> list[tuple[str, list[str]]]:
    code = main(["solve", "kitchen", "--problem", task, "--json", "--time-limit", str(time_limit)])
    out = json.loads(capsys.readouterr().out)
    assert code == 0, out
    (result,) = out["results"]
    assert result["status"] == "solved"
    return [(s["action"], s["args"]) for s in result["plan"]]


def test_cook_places_the_block_on_the_stove_turns_it_on_and_off(capsys):
    plan = _solve("cook", capsys)
    names = [n for n, _ in plan]
    assert "detect" in names and names.index("detect") < names.index("pick")
    place = next(i for i, (n, a) in enumerate(plan) if n == "place" and a[0] == "block")
    on, off = names.index("press-on"), names.index("press-off")
    assert place < on < off  # the appendix's trace; the goal has the stove off


def test_swap_opens_the_bottom_drawer_and_detects(capsys):
    plan = _solve("swap", capsys)
    names = [n for n, _ in plan]
    pull = next(i for i, (n, a) in enumerate(plan) if n == "pull")
    assert plan[pull][1][0] == "bottom_drawer"
    assert pull < names.index("detect")


@pytest.mark.slow
def test_stow_moves_the_sugar_box_before_closing_the_top_drawer(capsys):
    plan = _solve("stow", capsys, time_limit=300)
    picks = [a[0] for n, a in plan if n == "pick"]
    assert "sugar_box" in picks and "block" in picks  # the tall box must leave the drawer
    push = max(i for i, (n, a) in enumerate(plan) if n == "push" and a[0] == "top_drawer")
    sugar_pick = next(i for i, (n, a) in enumerate(plan) if n == "pick" and a[0] == "sugar_box")
    assert sugar_pick < push
