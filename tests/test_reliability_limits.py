"""Issue 14 row 5 and issue 17 row 4: one validation for every numeric option, and the time
limit bounds the whole command (reading, compiling, streams, planning)."""

from __future__ import annotations

import json
import time
from pathlib import Path

import pytest

from ssr_compile.cli import main

PP = Path(__file__).parent / "fixtures" / "compile" / "pp1d"
D, S, P = (str(PP / n) for n in ("domain.pddl", "stream.pddl", "problem.pddl"))
STREAMS = str(PP / "streams.py")

BAD = [
    # (command line, option, value)
    (["plan", D, S, P], "--time-limit", "0"),
    (["plan", D, S, P], "--time-limit", "-5"),
    (["plan", D, S, P], "--time-limit", "nan"),
    (["plan", D, S, P], "--time-limit", "inf"),
    (["plan", D, S, P], "--time-limit", "1e999"),
    (["plan", D, S, P], "--time-limit", "soon"),
    (["plan", D, S, P], "--level", "-1"),
    (["compile", D, S, P, "-o", "unused"], "--level", "-1"),
    (["solve", D, S, P, "--streams", STREAMS], "--time-limit", "0"),
    (["solve", D, S, P, "--streams", STREAMS], "--time-limit", "-5"),
    (["solve", D, S, P, "--streams", STREAMS], "--time-limit", "nan"),
    (["solve", D, S, P, "--streams", STREAMS], "--time-limit", "inf"),
    (["solve", D, S, P, "--streams", STREAMS], "--seed", "-1"),
    (["solve", D, S, P, "--streams", STREAMS], "--seed", str(2**32)),
    (["solve", D, S, P, "--streams", STREAMS], "--level", "-1"),
    (["solve", D, S, P, "--streams", STREAMS], "--max-level", "-1"),
    (["solve", D, S, P, "--streams", STREAMS], "--max-cost", "-1"),
    (["solve", D, S, P, "--streams", STREAMS], "--max-cost", "0"),
    (["solve", D, S, P, "--streams", STREAMS], "--max-cost", "nan"),
    (["render", "inspect", "-o", "x.png"], "--seed", "-1"),
    (["belief-plot", "inspect", "-o", "x.png"], "--seed", "-1"),
    (["belief-plot", "inspect", "-o", "x.png"], "--particles", "0"),
]


@pytest.mark.parametrize("argv, option, value", BAD, ids=[f"{a[0]} {o} {v}" for a, o, v in BAD])
def test_an_invalid_number_is_bad_input(argv, option, value, capsys):
    with pytest.raises(SystemExit) as info:
        main([*argv, f"{option}={value}"])
    assert info.value.code == 2
    err = capsys.readouterr().err
    last = err.splitlines()[-1]  # after argparse's usage lines, one line says what is wrong
    assert f"{argv[0]}: error: argument {option}: expected " in last and f"got '{value}'" in last
    assert err.startswith("usage:") and "Traceback" not in err


def test_valid_numbers_still_work(capsys):
    assert main(["plan", D, S, P, "--time-limit", "30", "--level", "0"]) in (0, 1)
    capsys.readouterr()


def test_a_bad_number_in_example_toml_is_bad_input(tmp_path, capsys):
    for name in ("domain.pddl", "stream.pddl", "problem.pddl"):
        (tmp_path / name).write_text((PP / name).read_text())
    (tmp_path / "example.toml").write_text(f'streams = "{STREAMS}"\ntime_limit = -3\n')
    assert main(["solve", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "time_limit = -3" in err and "greater than 0" in err


def _slow_compile(*args, **kwargs):
    time.sleep(30)
    raise AssertionError("the time limit did not stop compiling")


@pytest.mark.parametrize("as_json", [False, True])
def test_plans_time_limit_covers_compiling(monkeypatch, capsys, as_json):
    import ssr_compile.compile.pipeline as pipeline

    monkeypatch.setattr(pipeline, "compile_problem", _slow_compile)
    start = time.monotonic()
    argv = ["plan", D, S, P, "--time-limit", "0.5"] + (["--json"] if as_json else [])
    assert main(argv) == 1
    assert time.monotonic() - start < 10
    out = capsys.readouterr().out
    if as_json:
        report = json.loads(out)["results"][0]
        assert report["status"] == "timeout"
        assert report["message"] == "time limit of 0.5 s reached while compiling"
    else:
        assert (
            out.strip()
            == "no plan (timeout) at level 3: time limit of 0.5 s reached while compiling"
        )


HANGING = """
import time
from pathlib import Path
import importlib.util

spec = importlib.util.spec_from_file_location("pp1d_streams", {path!r})
base = importlib.util.module_from_spec(spec)
spec.loader.exec_module(base)

def hang(*args):
    while True:
        {body}

STREAMS = dict(base.STREAMS)
STREAMS["{stream}"] = hang
STREAM_INFO = base.STREAM_INFO
VALUES = base.VALUES
"""


@pytest.mark.parametrize(
    "stream, body", [("sample-pose", "time.sleep(0.2)"), ("test-cfree", "pass")]
)
@pytest.mark.parametrize("as_json", [False, True])
def test_solve_stops_a_stream_that_never_returns(tmp_path, capsys, stream, body, as_json):
    module = tmp_path / "hanging.py"
    module.write_text(HANGING.format(path=STREAMS, body=body, stream=stream))
    problem = str(PP / "problem-blocked.pddl")
    argv = ["solve", D, S, problem, "--streams", str(module), "--time-limit", "1", "--level", "3"]
    start = time.monotonic()
    assert main(argv + (["--json"] if as_json else [])) == 1
    assert time.monotonic() - start < 15
    out = capsys.readouterr().out
    message = (
        f"time limit of 1 s reached while stream '{stream}' was running (it overran the limit)"
    )
    if as_json:
        report = json.loads(out)["results"][0]
        assert report["status"] == "timeout" and report["message"] == message
    else:
        assert out.strip() == f"no plan: {message}"
