"""``ssr-compile compile`` (and the bare form) and ``ssr-compile plan``: files, output, exit codes."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from ssr_compile.cli import main
from ssr_compile.parse import parse_domain, parse_problem

PP = Path(__file__).parent / "fixtures" / "compile" / "pp1d"
D, S, P = (str(PP / n) for n in ("domain.pddl", "stream.pddl", "problem.pddl"))


@pytest.mark.parametrize("bare", [False, True])
def test_compile_writes_three_files(tmp_path, capsys, bare):
    out = tmp_path / "out"
    argv = ([] if bare else ["compile"]) + [D, S, P, "-o", str(out), "--level", "2"]
    assert main(argv) == 0
    names = ["actions.json", "domain.pddl", "objects.json", "problem.pddl"]
    assert sorted(p.name for p in out.iterdir()) == names
    parse_domain((out / "domain.pddl").read_text())
    problem = parse_problem((out / "problem.pddl").read_text())
    data = json.loads((out / "objects.json").read_text())
    assert data["level"] == 2 and data["scale"] == 1
    objects = data["objects"]
    emitted = {o.name for o in problem.objects}
    assert objects and set(objects) <= emitted
    for inst in objects.values():
        assert inst["stream"] in {"sample-pose", "inverse-kin", "plan-motion"}
        assert all(x in emitted for x in inst["inputs"]) and inst["level"] <= 2
    assert "wrote" in capsys.readouterr().out


def test_domain_level_compile_says_so(tmp_path, capsys):
    out = tmp_path / "dom"
    assert main([D, S, "-o", str(out)]) == 0
    assert [p.name for p in out.iterdir()] == ["domain.pddl"]
    assert "domain only" in capsys.readouterr().out
    text = (out / "domain.pddl").read_text()
    assert "has-cost-dist" in text and ":derived" in text


def test_plan_prints_plan_cost_and_instances(capsys):
    assert main(["plan", D, S, P]) == 0
    out = capsys.readouterr().out
    assert "optimistic plan" in out and "cost" in out and "(place a" in out
    assert "sample-pose(a, goal)" in out


def test_plan_json(capsys):
    assert main(["plan", D, S, P, "--json"]) == 0
    data = json.loads(capsys.readouterr().out)["results"][0]
    assert data["status"] == "solved" and data["plan"][-1]["action"] == "place"
    assert data["cost"] == len(data["plan"])
    streams = {r["stream"] for r in data["stream_plan"]}
    assert {"sample-pose", "inverse-kin", "plan-motion"} <= streams
    outputs = {o for r in data["stream_plan"] for o in r["outputs"]}
    used = {a for step in data["plan"] for a in step["args"] if a.startswith("opt")}
    assert used <= outputs


def test_no_plan_exit_1(capsys):
    assert main(["plan", D, S, P, "--level", "1", "--max-level", "1"]) == 1
    assert "no plan" in capsys.readouterr().out


def test_bad_input_exit_2_nothing_written(tmp_path, capsys):
    bad = tmp_path / "stream.pddl"
    bad.write_text(
        "(define (stream s)\n  (:optimizer opt (:variables (?p) :inputs (?b)\n"
        "    :domain (block ?b))))\n"
    )
    out = tmp_path / "out"
    assert main(["compile", D, str(bad), P, "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert f"{bad}:2:" in err and "optimizer" in err
    assert not out.exists()
    broken = tmp_path / "broken.pddl"
    broken.write_text("(define (domain x) (:action a :parameters (?x)")
    assert main(["compile", str(broken), S, P, "-o", str(out)]) == 2
    assert f"{broken}:" in capsys.readouterr().err and not out.exists()


def test_solve_missing_stream_exit_2(tmp_path, capsys):
    mod = tmp_path / "partial.py"
    mod.write_text("STREAMS = {'sample-pose': lambda b, r: iter(())}\n")
    assert main(["solve", D, S, P, "--streams", str(mod)]) == 2
    err = capsys.readouterr().err
    assert "does not implement" in err and "inverse-kin" in err


def test_solve_fixture_exit_0(capsys):
    assert (
        main(["solve", D, S, P, "--streams", str(PP / "streams.py"), "--level", "3", "--json"]) == 0
    )
    data = json.loads(capsys.readouterr().out)["results"][0]
    assert data["status"] == "solved" and data["stats"]["streams"]["sample-pose"]["calls"] >= 1
