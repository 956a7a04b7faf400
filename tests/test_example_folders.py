"""Issue 38, "Streams and example folders" (items 1, 7's planner, 8, 9, 10): an example folder
is self-contained in every command, example.toml has one checked reader, a stream's bad value
is its error at once, and a stream file may name a problem object as a domain may."""

from __future__ import annotations

import json
import shutil
import sys
from pathlib import Path

import pytest

from ssr_compile.cli import main
from ssr_compile.errors import StreamError
from ssr_compile.stream import Generator, call_function

ROOT = Path(__file__).resolve().parent.parent
PROGRESS = ROOT / "domains" / "pddl" / "progress"
PP = ROOT / "tests" / "fixtures" / "compile" / "pp1d"
D, S, P = (str(PP / n) for n in ("domain.pddl", "stream.pddl", "problem.pddl"))

ENV = """
from {helper} import NOTE  # a module beside this one, in the example folder
from ssr_compile.streams.environments.progress import make_episode as _make


def make_episode(problem, seed):
    from {helper} import NOTE as again  # imported when the factory runs
    assert again == NOTE == {note!r}
    return _make(problem, seed)
"""
STREAMS = """
from {helper} import NOTE
from ssr_compile.streams.progress import STREAMS, STREAM_INFO, VALUES, for_problem
"""


def _folder(tmp_path: Path, name: str, toml: str, tag: str = "a") -> Path:
    """The progress example copied, with an environment and a streams module of its own
    beside its files (each importing a third module of the folder)."""
    folder = tmp_path / name
    shutil.copytree(PROGRESS, folder)
    (folder / "folder_helper.py").write_text(f"NOTE = {tag!r}\n")
    (folder / "folder_env.py").write_text(ENV.format(helper="folder_helper", note=tag))
    (folder / "folder_streams.py").write_text(STREAMS.format(helper="folder_helper"))
    (folder / "example.toml").write_text(toml)
    return folder


OWN = 'streams = "folder_streams"\nenvironment = "folder_env:make_episode"\n'


# ---------------------------------------------------------------- item 1: self-contained


def test_run_imports_an_environment_beside_the_folders_files(tmp_path, capsys):
    folder = _folder(tmp_path, "own", OWN)
    assert main(["run", str(folder), "--seed", "3"]) == 0
    assert "the goal holds in the true state" in capsys.readouterr().out
    assert str(folder) not in sys.path and str(folder.resolve()) not in sys.path


def test_solve_imports_a_streams_module_beside_the_folders_files(tmp_path, capsys):
    folder = _folder(tmp_path, "own", OWN)
    assert main(["solve", str(folder)]) == 0
    assert capsys.readouterr().out.startswith("plan (")
    assert str(folder.resolve()) not in sys.path


def test_a_streams_file_of_example_toml_is_the_folders(tmp_path, capsys, monkeypatch):
    _folder(tmp_path, "own", 'streams = "folder_streams.py"\n')
    monkeypatch.chdir(tmp_path)  # not the folder: the path is the folder's, not the cwd's
    assert main(["solve", "own"]) == 0
    assert capsys.readouterr().out.startswith("plan (")


def test_two_folders_with_modules_of_one_name_each_get_their_own(tmp_path, capsys):
    first = _folder(tmp_path, "first", OWN, tag="first")
    second = _folder(tmp_path, "second", OWN, tag="second")
    assert main(["run", str(first), "--seed", "3"]) == 0
    assert main(["run", str(second), "--seed", "3"]) == 0  # its helper says "second"
    capsys.readouterr()


# ---------------------------------------------------------------- item 7: run's planner


def test_run_honours_example_tomls_planner(tmp_path, monkeypatch, capsys):
    import ssr_compile.policy as policy

    seen = {}
    real = policy.run_policy

    def spy(episode, settings, **kw):
        seen["planner"] = settings.planner
        seen["resample"] = settings.resample
        return real(episode, settings, **kw)

    monkeypatch.setattr(policy, "run_policy", spy)
    folder = _folder(tmp_path, "own", OWN + 'planner = "fd:opt"\nresample = 1\n')
    assert main(["run", str(folder), "--seed", "3"]) == 0
    assert seen == {"planner": "fd:opt", "resample": 1}
    assert main(["run", str(folder), "--seed", "3", "--planner", "fd"]) == 0
    assert seen["planner"] == "fd"  # a flag wins, as in solve
    capsys.readouterr()


# ---------------------------------------------------------------- item 9: one checked reader

BAD_SETTINGS = [
    ('time_limit = "abc"', "time_limit"),
    ("time_limit = -5", "time_limit"),
    ("time_limit = nan", "time_limit"),
    ('planner = "nosuch"', "planner"),
    ('defer = "yes"', "defer"),
    ("level = 2.5", "level"),
    ("resample = -1", "resample"),
    ("seed = true", "seed"),
    ('algorithm = "greedy"', "algorithm"),
    ("max_cost = 0", "max_cost"),
    ("time_limt = 5", "time_limt"),
]


@pytest.mark.parametrize("command", ["run", "solve"])
@pytest.mark.parametrize(("line", "key"), BAD_SETTINGS)
def test_a_bad_example_toml_is_bad_input_in_every_command(tmp_path, capsys, command, line, key):
    folder = _folder(tmp_path, "own", OWN + line + "\n")
    assert main([command, str(folder), "--seed", "3"]) == 2
    err = capsys.readouterr().err
    assert "example.toml:3:" in err and key in err and "Traceback" not in err


def test_an_unknown_key_says_what_was_meant(tmp_path, capsys):
    folder = _folder(tmp_path, "own", OWN + "time_limt = 5\n")
    assert main(["solve", str(folder)]) == 2
    err = capsys.readouterr().err
    assert "unknown key" in err and "did you mean 'time_limit'" in err


@pytest.mark.parametrize(
    "toml",
    [
        'streams = "no_such_streams_module"\n',
        'streams = "missing.py"\n',
        OWN + 'problems = ["nope.pddl"]\n',
        'streams = "folder_streams"\nenvironment = 42\n',
    ],
)
def test_a_missing_module_or_file_in_example_toml_is_bad_input(tmp_path, capsys, toml):
    folder = _folder(tmp_path, "own", toml)
    for command in ("run", "solve"):
        assert main([command, str(folder)]) == 2
        assert "example.toml" in capsys.readouterr().err


def test_the_experiment_reads_example_toml_the_same_way(tmp_path, capsys):
    folder = _folder(tmp_path, "own", OWN + "time_limt = 5\n")
    code = main(["experiment", "--tasks", str(folder), "--seeds", "0", "-o", str(tmp_path / "x")])
    assert code == 2 and "time_limt" in capsys.readouterr().err


# ---------------------------------------------------------------- item 8: bad stream values

MODULE = """
import math
import importlib.util
import numpy as np

spec = importlib.util.spec_from_file_location("pp1d_streams_copy", {path!r})
base = importlib.util.module_from_spec(spec)
spec.loader.exec_module(base)
STREAMS = dict(base.STREAMS)
STREAM_INFO = base.STREAM_INFO
VALUES = base.VALUES

def sample_pose(block, region):
{body}

STREAMS["sample-pose"] = sample_pose
"""

BAD_VALUES = {
    "inf": ("    yield (math.inf,)", "inf"),
    "nan": ("    while True:\n        yield (math.nan,)", "nan"),
    "nested": ("    yield (('pose', -math.inf),)", "-inf"),
    "array": ("    yield (np.array([0.5, np.nan]),)", "nan"),
    "none": ("    yield (None,)", "None"),
    "iterator": ("    yield (iter([1.0]),)", "iterator"),
    "int": ("    yield 5", "5 (int)"),
    "return": ("    if region == 'goal':\n        return 5\n    yield (0.5,)", "returned 5"),
}


@pytest.mark.parametrize("case", sorted(BAD_VALUES))
def test_a_bad_stream_value_is_the_streams_error_at_once(tmp_path, capsys, case):
    body, shown = BAD_VALUES[case]
    mod = tmp_path / "bad_streams.py"
    mod.write_text(MODULE.format(path=str(PP / "streams.py"), body=body))
    assert main(["solve", D, S, P, "--streams", str(mod), "--time-limit", "20"]) == 3
    err = capsys.readouterr().err
    assert "stream 'sample-pose'" in err and shown in err and "planner" not in err


def test_good_values_pass_the_check():
    import numpy as np

    gen = Generator(lambda: iter([((1.0, (2, "x")), np.array([1.0]), {"k": 3.5})]), (), "g", "s")
    assert gen.next() is not None


def test_a_cost_function_that_is_nan_or_no_number_is_its_error():
    for value in (float("nan"), "3", True):
        with pytest.raises(StreamError, match="cost function 'dist'"):
            call_function(lambda v=value: v, (), "dist")
    assert call_function(lambda: float("inf"), (), "dist") is None  # not applicable
    assert call_function(lambda: 2, (), "dist") == 2.0


# ---------------------------------------------------------------- item 10: problem objects


def test_a_stream_file_may_name_a_problem_object_as_a_domain_may(tmp_path, capsys):
    folder = tmp_path / "pp"
    shutil.copytree(PP, folder)
    stream = folder / "stream.pddl"
    # the paper's (Conf base ?bq): here (conf q0), q0 an object of the problem
    stream.write_text(
        stream.read_text().replace(
            ":domain (and (conf ?q1) (conf ?q2))\n    :outputs (?t)",
            ":domain (and (conf ?q1) (conf ?q2) (conf q0))\n    :outputs (?t)",
        )
    )
    assert "(conf q0)" in stream.read_text()
    files = [str(folder / n) for n in ("domain.pddl", "stream.pddl", "problem.pddl")]
    assert main(["check", *files]) == 0
    err = capsys.readouterr().err
    assert "warning" in err and "'q0'" in err
    assert main(["solve", *files, "--streams", str(folder / "streams.py"), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["results"][0]["status"] == "solved"
    # a problem that does not declare it: an error of the problem, naming the stream file's use
    problem = folder / "problem-noq.pddl"
    problem.write_text((folder / "problem.pddl").read_text().replace(" q0 ", " "))
    assert main(["check", *files[:2], str(problem)]) == 2
    assert "the stream file uses 'q0'" in capsys.readouterr().err
