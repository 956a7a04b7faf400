"""Issue 17 row 8: every ``--json`` output follows one documented schema (schema_version;
numbers as numbers, null as null, arrays as lists; the same shape for one or many problems;
long paths summarised unless --full)."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from ssr_compile.cli import main
from ssr_compile.json_output import SCHEMA, SCHEMA_VERSION, to_json

jsonschema = pytest.importorskip("jsonschema")

ROOT = Path(__file__).resolve().parent.parent


def _validated(capsys, argv: list[str], code: int | None = 0) -> dict:
    got = main(argv)
    if code is not None:
        assert got == code
    doc = json.loads(capsys.readouterr().out)
    jsonschema.validate(doc, SCHEMA)
    assert doc["schema_version"] == SCHEMA_VERSION and doc["command"] == argv[0]
    return doc


def test_the_schema_is_a_valid_json_schema():
    jsonschema.Draft202012Validator.check_schema(SCHEMA)


def test_solve_one_and_many_problems_have_the_same_shape(capsys):
    one = _validated(capsys, ["solve", "tamp2d", "--problem", "problem", "--json"])
    many = _validated(capsys, ["solve", "tamp2d", "--json"])
    assert len(one["results"]) == 1 and len(many["results"]) == 2
    assert set(one) == set(many) and set(one["results"][0]) == set(many["results"][1])
    step = one["results"][0]["plan"][0]
    assert isinstance(one["results"][0]["cost"], float)
    assert all(not (isinstance(v, str) and v in ("None", "True")) for v in step["values"])


def test_solve_deferred_values_are_null(capsys):
    doc = _validated(capsys, ["solve", "kitchen", "--problem", "inspect", "--json"])
    plan = doc["results"][0]["plan"]
    deferred = [s for s in plan if s["deferred"]]
    assert deferred and any(v is None for s in deferred for v in s["values"])
    # Trajectories are summarised: the whole document is small, and --full has them all
    text = json.dumps(doc)
    assert len(text) < 12_000
    summaries = [v for s in plan for v in s["values"] if isinstance(v, dict) and "summary" in v]
    assert summaries and all(x["length"] > 4 for x in summaries)
    full = _validated(capsys, ["solve", "kitchen", "--problem", "inspect", "--json", "--full"])
    assert len(json.dumps(full)) > len(text)
    assert "summary" not in json.dumps(full)


def test_solve_timeout_and_unsolved_validate(capsys, tmp_path):
    doc = _validated(
        capsys, ["solve", "tamp2d", "--problem", "problem", "--max-level", "1", "--json"], 1
    )
    assert doc["results"][0]["status"] == "unsolvable" and doc["results"][0]["cost"] is None
    hang = tmp_path / "hang.py"
    hang.write_text(
        "import time\nfrom ssr_compile.streams.tamp2d import STREAMS as S0, STREAM_INFO, VALUES\n"
        "STREAMS = dict(S0)\n"
        "def slow(*a):\n    time.sleep(30)\n    yield\n"
        "STREAMS['sample-placement'] = slow\n"
    )
    t = ROOT / "domains" / "pddl" / "tamp2d"
    argv = ["solve", str(t / "domain.pddl"), str(t / "stream.pddl"), str(t / "problem.pddl")]
    doc = _validated(capsys, argv + ["--streams", str(hang), "--time-limit", "1", "--json"], 1)
    assert doc["results"][0]["status"] == "timeout"


def test_plan_json_validates(capsys):
    doc = _validated(capsys, ["plan", "tamp2d", "--problem", "problem", "--json"])
    assert doc["results"][0]["status"] == "solved" and isinstance(doc["results"][0]["cost"], float)
    doc = _validated(
        capsys,
        ["plan", "tamp2d", "--problem", "problem", "--level", "1", "--max-level", "1", "--json"],
        1,
    )
    assert doc["results"][0]["status"] == "level_limit" and doc["results"][0]["plan"] == []


def test_plan_timeout_validates(capsys, monkeypatch):
    import time

    import ssr_compile.compile.pipeline as pipeline

    def slow(*a, **k):
        time.sleep(30)

    monkeypatch.setattr(pipeline, "compile_problem", slow)
    doc = _validated(
        capsys, ["plan", "tamp2d", "--problem", "problem", "--time-limit", "0.5", "--json"], 1
    )
    assert doc["results"][0]["status"] == "timeout"


def test_planners_json_validates(capsys):
    doc = _validated(capsys, ["planners", "--json"])
    assert any(p["name"] == "fd" for p in doc["planners"])


def test_run_json_validates(capsys):
    doc = _validated(capsys, ["run", "progress", "--seed", "1", "--json"], None)
    assert doc["example"] == "progress" and isinstance(doc["success"], bool)


@dataclasses.dataclass
class _Motion:
    name: str
    path: tuple


def test_to_json_rules():
    path = np.linspace(0, 1, 20).reshape(10, 2)
    assert to_json(None) is None and to_json(np.float64(1.5)) == 1.5
    assert to_json((1, (2, 3))) == [1, [2, 3]]
    assert to_json(float("inf")) == "inf"
    short = to_json(path)
    assert short == {
        "summary": "sequence",
        "length": 10,
        "first": [0.0, path[0, 1]],
        "last": [path[-1, 0], 1.0],
    }
    assert to_json(path, full=True) == path.tolist()
    assert to_json(_Motion("m", tuple(map(tuple, path)))) == {
        "type": "_Motion",
        "name": "m",
        "path": short,
    }
    assert to_json(object()).startswith("<object")
