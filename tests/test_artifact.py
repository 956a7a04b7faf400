"""Issue 41: the output of ``compile --for`` taken to a planner outside ``ssr-compile``; its
plan mapped back with the documented map (``actions.json``) and with ``map-plan``, and
validated against the original domain and problem."""

from __future__ import annotations

import json
import logging
from pathlib import Path

import pytest

from ssr_compile.cli import main
from ssr_compile.parse import parse_domain, parse_problem
from ssr_compile.planners.validate import validate_plan

FIXTURES = Path(__file__).parent / "fixtures" / "compile"
COURIER = FIXTURES / "courier"  # typed, negative preconditions, equality with a constant
PP1D = FIXTURES / "pp1d"  # streams and derived predicates


def _compile(tmp_path, folder: Path, target: str, *extra) -> Path:
    out = tmp_path / f"out-{target.replace(':', '-')}-{'-'.join(extra) or 'auto'}"
    files = [str(folder / n) for n in ("domain.pddl", "stream.pddl", "problem.pddl")]
    assert main(["compile", *files, "-o", str(out), "--for", target, *extra]) == 0
    return out


def _solve_with_up(out: Path) -> Path:
    """unified-planning's reader and one-shot planner on the written files."""
    up = pytest.importorskip("unified_planning.shortcuts")
    from unified_planning.io import PDDLReader

    up.get_environment().credits_stream = None
    task = PDDLReader().parse_problem(str(out / "domain.pddl"), str(out / "problem.pddl"))
    try:
        planner = up.OneshotPlanner(name="fast-downward")
    except Exception as e:  # noqa: BLE001
        pytest.skip(f"unified-planning's fast-downward engine is not installed: {e}")
    with planner:
        result = planner.solve(task)
    assert result.plan is not None, result.status
    path = out / "plan.txt"
    path.write_text(str(result.plan) + "\n")  # "SequentialPlan:\n    name(a, b)" lines
    return path


def _solve_with_pyperplan(out: Path) -> Path:
    planner = pytest.importorskip("pyperplan.planner")
    logging.disable(logging.CRITICAL)
    try:
        found = planner.search_plan(
            str(out / "domain.pddl"),
            str(out / "problem.pddl"),
            planner.SEARCHES["gbf"],
            planner.HEURISTICS["hff"],
        )
    finally:
        logging.disable(logging.NOTSET)
    assert found
    path = out / "problem.pddl.soln"  # pyperplan's own plan file: "(name a b)" lines
    path.write_text("".join(op.name + "\n" for op in found) + "; cost = 7 (unit cost)\n")
    return path


def _plan_lines(path: Path) -> list[tuple[str, list[str]]]:
    steps = []
    for line in path.read_text().splitlines():
        line = line.split(";")[0].strip()
        if not line or line.endswith(":"):
            continue
        if line.startswith("("):
            name, *args = line.strip("()").split()
        else:
            name, _, rest = line.partition("(")
            args = [a.strip() for a in rest.rstrip(")").split(",") if a.strip()]
        steps.append((name, args))
    return steps


def _map_by_hand(out: Path, plan_file: Path) -> list[tuple[str, tuple[str, ...]]]:
    """The README's rule, applied to actions.json by hand."""
    doc = json.loads((out / "actions.json").read_text())
    lifted = []
    for name, values in _plan_lines(plan_file):
        entry = doc["actions"][name]
        value = dict(zip(entry.get("parameters", []), values))
        if entry["action"] is None:
            continue
        args = [value.get(a, a) for a in entry["args"]]
        lifted.append((entry["action"], tuple(doc["objects"].get(a, a) for a in args)))
    return lifted


def _schema_valid(doc: dict) -> None:
    jsonschema = pytest.importorskip("jsonschema")
    from ssr_compile.json_output import SCHEMA

    jsonschema.validate(doc, SCHEMA)
    assert doc["command"] == "map-plan"


def _original(folder: Path):
    return (
        parse_domain((folder / "domain.pddl").read_text()),
        parse_problem((folder / "problem.pddl").read_text()),
    )


@pytest.mark.parametrize("task", ["auto", "ground"])
@pytest.mark.parametrize("target, solve", [("up:fast-downward", "up"), ("pyperplan", "pp")])
def test_plan_of_compiled_files_maps_back_and_validates(tmp_path, capsys, target, solve, task):
    out = _compile(tmp_path, COURIER, target, "--task", task)
    doc = json.loads((out / "actions.json").read_text())
    assert doc["task"] == ("lifted" if task == "auto" else "ground")
    plan_file = (_solve_with_up if solve == "up" else _solve_with_pyperplan)(out)
    by_hand = _map_by_hand(out, plan_file)
    assert {name for name, _ in by_hand} <= {"drive", "load", "seal", "unload"}
    assert ("seal", ("p1", "depot")) in by_hand  # the constant the lowering substituted
    ok, reason = validate_plan(*_original(COURIER), by_hand)
    assert ok, reason
    capsys.readouterr()
    assert main(["map-plan", str(out), str(plan_file), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    _schema_valid(data)
    assert data["valid"] is True and data["validator"] == "unified-planning"
    assert [(s["action"], tuple(s["args"])) for s in data["plan"]] == by_hand


def test_lifted_output_is_the_small_one(tmp_path):
    lifted = _compile(tmp_path, COURIER, "up:fast-downward")
    ground = _compile(tmp_path, COURIER, "up:fast-downward", "--task", "ground")
    assert "?from" in (lifted / "domain.pddl").read_text()
    assert len(json.loads((lifted / "actions.json").read_text())["actions"]) == 4
    assert "drive-g1" in json.loads((ground / "actions.json").read_text())["actions"]


def test_stream_problem_maps_optimistic_objects_to_instances(tmp_path, capsys):
    # derived predicates: the ground task, and the project's own checker validates
    out = _compile(tmp_path, PP1D, "up:fast-downward")
    assert json.loads((out / "actions.json").read_text())["task"] == "ground"
    plan_file = _solve_with_up(out)
    capsys.readouterr()
    assert main(["map-plan", str(out), str(plan_file), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["valid"] is True and data["validator"] == "ssr-compile"
    assert data["plan"][-1]["action"] == "place"
    named = {a for s in data["plan"] for a in s["args"] if a.startswith("opt")}
    assert named and set(data["stream_instances"]) == named
    assert any(v.startswith("sample-pose(") for v in data["stream_instances"].values())
    assert main(["map-plan", str(out), str(plan_file)]) == 0
    text = capsys.readouterr().out
    assert "valid for the optimistic problem" in text and " <- " in text


def test_bad_plans_exit_2_with_their_position(tmp_path, capsys):
    out = _compile(tmp_path, COURIER, "pyperplan")
    bad = tmp_path / "plan.txt"
    bad.write_text("(drive depot north)\n; a comment\n  (fly north east)\n")
    assert main(["map-plan", str(out), str(bad)]) == 2
    assert f"{bad}:3:4: error: unknown action 'fly'" in capsys.readouterr().err
    bad.write_text("(drive depot north\n")
    assert main(["map-plan", str(out), str(bad)]) == 2
    assert f"{bad}:1:1: error: malformed plan step" in capsys.readouterr().err
    bad.write_text("0: (drive depot) [1]\n")
    assert main(["map-plan", str(out), str(bad)]) == 2
    assert f"{bad}:1:5: error: 'drive' takes 2 arguments" in capsys.readouterr().err


def test_invalid_plan_exit_1(tmp_path, capsys):
    out = _compile(tmp_path, COURIER, "up:fast-downward")
    plan = tmp_path / "plan.txt"
    plan.write_text("(drive depot south)\n(drive south east)\n")
    assert main(["map-plan", str(out), str(plan)]) == 1
    assert "INVALID" in capsys.readouterr().out
    capsys.readouterr()
    assert main(["map-plan", str(out), str(plan), "--no-validate", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    _schema_valid(data)
    assert data["valid"] is None and len(data["plan"]) == 2
