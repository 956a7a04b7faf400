"""Issue 14 rows 9, 10 and 13: numpy values print (and are lists in --json); a stream that
calls sys.exit() or a test stream that returns a non-bool is an error of that stream; a
solver that gives up at its maximum level says so, without claiming "unsolvable"."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from ssr_compile.cli import main
from ssr_compile.errors import StreamError
from ssr_compile.stream import Generator, call_function, call_test

np = pytest.importorskip("numpy")

PP = Path(__file__).parent / "fixtures" / "compile" / "pp1d"
D, S, P = (str(PP / n) for n in ("domain.pddl", "stream.pddl", "problem.pddl"))

# A streams module: pp1d's streams with some replaced (REPLACE is a dict of name -> source).
MODULE = """
import sys
import importlib.util
import numpy as np

spec = importlib.util.spec_from_file_location("pp1d_streams_copy", {path!r})
base = importlib.util.module_from_spec(spec)
spec.loader.exec_module(base)
STREAMS = dict(base.STREAMS)
STREAM_INFO = base.STREAM_INFO
VALUES = base.VALUES
{replace}
"""


def _module(tmp_path: Path, replace: str) -> str:
    path = tmp_path / "streams_variant.py"
    path.write_text(MODULE.format(path=str(PP / "streams.py"), replace=replace))
    return str(path)


# ---------------------------------------------------------------- row 9: numpy values

NUMPY = """
def plan_motion(q1, q2):
    return (np.array([q1[1], q2[1]]),)

def sample_pose(block, region):
    for (x,) in base.sample_pose(block, region):
        yield (np.float64(x),)

STREAMS["plan-motion"] = plan_motion
STREAMS["sample-pose"] = sample_pose
"""


def test_numpy_values_print(tmp_path, capsys):
    mod = _module(tmp_path, NUMPY)
    assert main(["solve", D, S, P, "--streams", mod]) == 0
    out = capsys.readouterr().out
    assert out.startswith("plan (") and "cost 12)" in out.splitlines()[0]
    assert re.search(r"t-\d+=array\(\[-?\d", out)  # a trajectory's value, printed


def test_numpy_values_are_lists_in_json(tmp_path, capsys):
    mod = _module(tmp_path, NUMPY)
    assert main(["solve", D, S, P, "--streams", mod, "--json"]) == 0
    report = json.loads(capsys.readouterr().out)["results"][0]
    assert report["status"] == "solved"
    values = [v for step in report["plan"] for v in step["values"]]
    # the trajectories (numpy arrays of two floats)
    assert any(
        isinstance(v, list) and len(v) == 2 and all(type(x) is float for x in v) for v in values
    )
    assert ["q", -5.0] in values  # a tuple value: a list, not a repr string
    assert all(not (isinstance(v, str) and v.startswith("array(")) for v in values)
    place = report["plan"][-1]
    assert place["action"] == "place" and isinstance(place["values"][1], float)  # np.float64


# ---------------------------------------------------------------- row 10: exits, non-bool tests


@pytest.mark.parametrize(
    "stream, replace, message",
    [
        (
            "sample-pose",
            "def bad(block, region):\n    sys.exit(0)\n    yield\nSTREAMS['sample-pose'] = bad",
            "stream 'sample-pose' called sys.exit(0)",
        ),
        (
            "test-cfree",
            "STREAMS['test-cfree'] = lambda *args: sys.exit(0)",
            "test stream 'test-cfree' called sys.exit(0)",
        ),
        (
            "dist",
            "STREAMS['dist'] = lambda *args: sys.exit(3)",
            "cost function 'dist' called sys.exit(3)",
        ),
        (
            "test-cfree",
            "STREAMS['test-cfree'] = lambda *args: 'False'",
            "test stream 'test-cfree' returned 'False' (str); a test stream must return True or False",
        ),
        (
            "test-cfree",
            "STREAMS['test-cfree'] = lambda *args: None",
            "test stream 'test-cfree' returned None (NoneType)",
        ),
    ],
    ids=["generator exits", "test exits", "function exits", "test says 'False'", "test None"],
)
def test_a_misbehaving_stream_is_an_error_naming_it(tmp_path, capsys, stream, replace, message):
    mod = _module(tmp_path, replace)
    code = main(["solve", D, S, P, "--streams", mod, "--time-limit", "60"])
    out, err = capsys.readouterr()
    assert code == 3  # the streams module's code failed, not the input (issue 9 item 7)
    assert message in err and "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert "plan (" not in out


def test_numpy_bools_are_bools():
    assert call_test(lambda: np.bool_(True), (), "t") is True
    assert call_test(lambda: np.float64(1.0) > 2, (), "t") is False


def test_exits_are_stream_errors_at_the_api():
    def leave():
        raise SystemExit("bye")

    with pytest.raises(StreamError, match="test stream 't' called sys.exit"):
        call_test(leave, (), "t")
    with pytest.raises(StreamError, match="cost function 'f' called sys.exit"):
        call_function(leave, (), "f")

    def gen():
        yield (1,)
        raise SystemExit(0)

    g = Generator(gen, (), "generator", "g")
    assert g.next() == (1,)
    with pytest.raises(StreamError, match="stream 'g' called sys.exit"):
        g.next()


# ---------------------------------------------------------------- row 13: "unsolvable" only when proven


def test_giving_up_at_the_maximum_level_says_so(capsys):
    problem = str(PP / "problem-blocked.pddl")
    argv = ["solve", D, S, problem, "--streams", str(PP / "streams.py")]
    assert main([*argv, "--level", "0", "--max-level", "1"]) == 1
    out = capsys.readouterr().out
    first = out.splitlines()[0]
    assert re.fullmatch(r"no plan: no plan found up to level 1 in \d+\.\d s \(.*\)", first), first
    assert "unsolvable" not in out


@pytest.mark.parametrize(
    "replace, message",
    [
        (
            "STREAM_INFO = {**STREAM_INFO, 'test-cfree': StreamInfo(kind='test', p_success=1.5)}",
            "StreamInfo p_success must be a number from 0 to 1, not 1.5",
        ),
        (
            "STREAM_INFO = {**STREAM_INFO, 'test-cfree': {'kind': 'test', 'p_success': -0.1}}",
            "STREAM_INFO['test-cfree']: StreamInfo p_success must be a number from 0 to 1",
        ),
    ],
    ids=["StreamInfo", "dict"],
)
def test_a_success_probability_outside_0_1_is_refused(tmp_path, capsys, replace, message):
    mod = _module(tmp_path, "from ssr_compile.stream import StreamInfo\n" + replace)
    code = main(["solve", D, S, P, "--streams", mod, "--time-limit", "60"])
    out, err = capsys.readouterr()
    assert code == 2
    assert message in err and "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert "plan (" not in out
