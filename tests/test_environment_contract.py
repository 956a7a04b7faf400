"""The environment contract (issue 38, README "Writing an environment"): how an environment
says that an action failed, whose fault the user's exceptions are, the execution limit, the
cost bound c*, a failure repeated from one state, and ``run kitchen`` without a task.

Each environment here is the progress example's (``streams/environments/progress.py``) with
one fault, in an example folder of its own under ``tmp_path`` that ``ssr-compile run`` runs."""

from __future__ import annotations

import json
import shutil
import textwrap
from pathlib import Path

import numpy as np
import pytest

from ssr_compile.cli.app import main
from ssr_compile.episode_record import UserCodeError, failed
from ssr_compile.policy import PolicySettings, run_policy
from ssr_compile.resources import domains_dir

HEADER = """\
import pathlib
import time

import numpy as np

from ssr_compile.examples import load_example
from ssr_compile.policy import Episode
from ssr_compile.streams.environments.progress import ProgressAgent, ProgressWorld


class Agent(ProgressAgent):
    pass


def episode(world_class, seed, agent_class=Agent):
    ex = load_example(pathlib.Path(__file__).parent)
    return Episode(world_class(seed), agent_class(ex.domain, ex.streams, seed), "faulty")
"""


def example_folder(tmp_path: Path, monkeypatch, body: str, name: str = "faulty_env") -> Path:
    """An example folder with the progress domain and an environment module ``name``."""
    folder = tmp_path / "faulty"
    folder.mkdir()
    for f in ("domain.pddl", "stream.pddl", "problem.pddl"):
        shutil.copy(domains_dir() / "progress" / f, folder / f)
    module = f"{name}_{abs(hash(str(tmp_path)))}"
    (folder / "example.toml").write_text(
        f'streams = "ssr_compile.streams.progress"\nenvironment = "{module}:make_episode"\n'
    )
    (folder / f"{module}.py").write_text(HEADER + "\n\n" + textwrap.dedent(body))
    monkeypatch.syspath_prepend(str(folder))
    return folder


def run_cli(capsys, *argv: str) -> tuple[int, str, str]:
    code = main(["run", *argv])
    out = capsys.readouterr()
    return code, out.out, out.err


def log_lines(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines()]


# ------------------------------------------------------------------ how an action fails

JAMMED = """
class JamWorld(ProgressWorld):  # every pick jams: a dict with "ok": False
    def execute(self, step):
        if step.name == "pick":
            return {**self.observe(), "ok": False, "message": "the gripper jammed",
                    "force": np.float64(2.5), "where": np.array([1.0, 2.0])}
        return super().execute(step)


def make_episode(problem, seed):
    return episode(JamWorld, seed)
"""


def test_failed_reads_ok_of_a_mapping_or_an_object():
    class Obs:
        def __init__(self, ok):
            self.ok = ok

    assert failed({"ok": False}) and failed({"ok": 0}) and failed({"ok": np.False_})
    assert failed(Obs(False)) and failed(Obs(np.bool_(False)))
    assert not failed({"ok": True}) and not failed({"base": (0, 0)}) and not failed(None)
    assert not failed(Obs(True)) and not failed("ok") and not failed({"ok": None})


def test_a_dict_with_ok_false_is_logged_failed_and_the_trace_is_json(tmp_path, monkeypatch, capsys):
    folder = example_folder(tmp_path, monkeypatch, JAMMED)
    log = tmp_path / "trace.jsonl"
    code, out, err = run_cli(capsys, str(folder), "--log", str(log), "--json")
    assert code == 1, err
    doc = json.loads(out)
    picks = [c for c in doc["trace"] if c["action"].startswith("(pick")]
    assert picks and all(c["failed"] for c in picks)
    assert all(c["failure"] == "the gripper jammed" for c in picks)
    moves = [c for c in doc["trace"] if c["action"].startswith("(move-base")]
    assert moves and not any(c["failed"] for c in moves)
    # observations are JSON data, numpy values converted
    obs = picks[0]["observation"]
    assert obs["ok"] is False and obs["force"] == 2.5 and obs["where"] == [1.0, 2.0]
    assert isinstance(obs["base"], list) and all(isinstance(v, float) for v in obs["base"])
    assert [c["failed"] for c in log_lines(log)] == [c["failed"] for c in doc["trace"]]


def test_an_object_with_ok_false_is_logged_failed(tmp_path, monkeypatch, capsys):
    body = """
    class Answer:  # an object, not a mapping
        def __init__(self, ok, message, base, holding):
            self.ok, self.message, self.base, self.holding = ok, message, base, holding

    class JamWorld(ProgressWorld):
        def execute(self, step):
            if step.name != "pick":
                super().execute(step)
            return Answer(step.name != "pick", "stuck", self.base, self.holding)

    class ObjectAgent(Agent):
        def update(self, step, observation):
            if isinstance(observation, Answer):
                observation = {"base": observation.base, "holding": observation.holding}
            super().update(step, observation)

    def make_episode(problem, seed):
        return episode(JamWorld, seed, ObjectAgent)
    """
    folder = example_folder(tmp_path, monkeypatch, body)
    code, out, err = run_cli(capsys, str(folder), "--max-cycles", "6", "--json")
    doc = json.loads(out)
    picks = [c for c in doc["trace"] if c["action"] and c["action"].startswith("(pick")]
    assert picks and all(c["failed"] and c["failure"] == "stuck" for c in picks)


# ------------------------------------------------------------------ a failure repeated


def test_an_action_that_fails_from_one_state_is_not_repeated_forever(tmp_path, monkeypatch, capsys):
    # The pick jams from wherever the robot is; the agent's belief does not change with the
    # failure, so every replan is the same problem and plans the same pick.
    folder = example_folder(tmp_path, monkeypatch, JAMMED)
    code, out, err = run_cli(capsys, str(folder), "--max-failures", "3")
    assert code == 1, err
    lines = [line for line in out.splitlines() if line.startswith("cycle")]
    assert sum("(pick" in line and "FAILED: the gripper jammed" in line for line in lines) == 3
    assert len(lines) == 4  # a base motion, then three picks
    outcome = out.splitlines()[-1]
    assert "failed 3 times from the same state" in outcome, outcome
    assert "does NOT hold" in outcome


def test_failures_from_different_states_are_not_counted_together():
    from ssr_compile.streams.environments import progress

    class Clumsy(progress.ProgressWorld):  # a pick fails once from each base pose
        tried: set = set()

        def execute(self, step):
            if step.name == "pick" and self.base not in self.tried:
                self.tried.add(self.base)
                return {**self.observe(), "ok": False}
            return super().execute(step)

    episode = progress.make_episode(None, 0)
    episode.environment = Clumsy(0)
    episode.environment.tried = set()
    result = run_policy(episode, PolicySettings(max_failures=2, max_cycles=30))
    assert result.success, result.reason
    assert sum(c.failed for c in result.cycles) >= 1


# ------------------------------------------------------------------ the user's exceptions

RAISES_IN_EXECUTE = """
class BoomWorld(ProgressWorld):
    def execute(self, step):
        if step.name == "pick":
            raise RuntimeError("the door is jammed")
        return super().execute(step)


def make_episode(problem, seed):
    return episode(BoomWorld, seed)
"""


def test_an_environment_that_raises_is_the_users_fault(tmp_path, monkeypatch, capsys):
    folder = example_folder(tmp_path, monkeypatch, RAISES_IN_EXECUTE)
    log = tmp_path / "trace.jsonl"
    code, out, err = run_cli(capsys, str(folder), "--log", str(log))
    assert code == 3
    assert "internal error" not in err
    assert "BoomWorld.execute raised RuntimeError: the door is jammed" in err
    assert "faulty_env" in err and ".py:" in err  # the module and the line
    outcome = out.splitlines()[-1]
    assert outcome.startswith("outcome: ") and "BoomWorld.execute raised" in outcome
    cycles = log_lines(log)
    assert cycles[0]["action"].startswith("(move-base") and not cycles[0]["failed"]
    assert cycles[-1]["action"].startswith("(pick") and cycles[-1]["failed"]


@pytest.mark.parametrize(
    ("body", "culprit"),
    [
        (
            """
            class BadAgent(Agent):
                def update(self, step, observation):
                    if step is not None:
                        raise ValueError("an observation I cannot read")
                    super().update(step, observation)

            def make_episode(problem, seed):
                return episode(ProgressWorld, seed, BadAgent)
            """,
            "BadAgent.update raised ValueError: an observation I cannot read",
        ),
        (
            """
            class BadAgent(Agent):
                def problem(self):
                    raise KeyError("pose")

            def make_episode(problem, seed):
                return episode(ProgressWorld, seed, BadAgent)
            """,
            "BadAgent.problem raised KeyError",
        ),
        (
            """
            class BadAgent(Agent):
                def problem(self):
                    return super().problem()[0]

            def make_episode(problem, seed):
                return episode(ProgressWorld, seed, BadAgent)
            """,
            "BadAgent.problem returned Problem",
        ),
        (
            """
            class BadWorld(ProgressWorld):
                def observe(self):
                    raise OSError("camera unplugged")

            def make_episode(problem, seed):
                return episode(BadWorld, seed)
            """,
            "BadWorld.observe raised OSError: camera unplugged",
        ),
        (
            """
            class BadWorld(ProgressWorld):
                def goal_holds(self):
                    raise AttributeError("no such sensor")

            def make_episode(problem, seed):
                return episode(BadWorld, seed)
            """,
            "BadWorld.goal_holds raised AttributeError: no such sensor",
        ),
        (
            """
            def make_episode(problem, seed):
                return 42
            """,
            "make_episode returned int 42, not an ssr_compile.policy.Episode",
        ),
        (
            """
            def make_episode(problem, seed):
                raise RuntimeError("no robot today")
            """,
            "make_episode raised RuntimeError: no robot today",
        ),
    ],
)
def test_the_users_code_is_named_when_it_fails(tmp_path, monkeypatch, capsys, body, culprit):
    folder = example_folder(tmp_path, monkeypatch, body)
    code, out, err = run_cli(capsys, str(folder))
    assert code == 3, (out, err)
    assert culprit in err and "internal error" not in err
    assert "the user's code failed" in err
    if "return episode(" in body:  # an episode ran: its outcome is printed
        assert out.splitlines()[-1].startswith("outcome: "), out


@pytest.mark.parametrize(
    ("source", "said"),
    [
        ("def make_episode(problem, seed)\n    return None\n", "SyntaxError"),
        ("raise ImportError('needs the robot driver')\n", "needs the robot driver"),
        ("import json\njson.loads('{')\n", "JSONDecodeError"),
    ],
)
def test_an_environment_module_that_does_not_import_is_named(
    tmp_path, monkeypatch, capsys, source, said
):
    folder = example_folder(tmp_path, monkeypatch, "")
    module = next(folder.glob("faulty_env_*.py"))
    module.write_text(source)
    code, out, err = run_cli(capsys, str(folder))
    assert code == 2, err
    assert said in err and module.stem in err and "internal error" not in err


def test_user_code_error_keeps_the_episode_so_far():
    from ssr_compile.streams.environments import progress

    class Boom(progress.ProgressWorld):
        def execute(self, step):
            if step.name == "pick":
                raise RuntimeError("boom")
            return super().execute(step)

    episode = progress.make_episode(None, 0)
    episode.environment = Boom(0)
    with pytest.raises(UserCodeError) as caught:
        run_policy(episode, PolicySettings())
    result = caught.value.result
    assert result is not None and not result.success
    assert result.cycles[-1].failed and "raised RuntimeError: boom" in result.reason
    with pytest.raises(TypeError, match="needs an Episode"):
        run_policy(42)  # type: ignore[arg-type]


# ------------------------------------------------------------------ limits


def test_a_hanging_execute_ends_at_the_execution_limit(tmp_path, monkeypatch, capsys):
    body = """
    class HangWorld(ProgressWorld):
        def execute(self, step):
            if step.name == "pick":
                while True:
                    time.sleep(0.05)
            return super().execute(step)

    def make_episode(problem, seed):
        return episode(HangWorld, seed)
    """
    folder = example_folder(tmp_path, monkeypatch, body)
    log = tmp_path / "trace.jsonl"
    code, out, err = run_cli(capsys, str(folder), "--execute-time", "0.5", "--log", str(log))
    assert code == 1, err
    outcome = out.splitlines()[-1]
    assert "HangWorld.execute of (pick" in outcome
    assert "did not return within the execution limit of 0.5 s" in outcome
    last = log_lines(log)[-1]
    assert last["failed"] and 0.5 <= last["execution_time"] < 5


def test_execute_time_is_a_policy_setting():
    assert PolicySettings().execute_time == 60.0
    with pytest.raises(ValueError, match="execute_time"):
        PolicySettings(execute_time=0)
    with pytest.raises(ValueError, match="max_failures"):
        PolicySettings(max_failures=0)


def test_a_goal_no_plan_reaches_under_max_cost_ends_at_once(capsys):
    # progress: a pick costs 1 and a base motion 5, so every plan costs at least 6
    code, out, err = run_cli(capsys, "progress", "--max-cost", "4")
    assert code == 1, err
    lines = out.splitlines()
    assert len([line for line in lines if line.startswith("cycle")]) == 1
    assert "no plan cheaper than c* = 4" in lines[-1]
    code, out, err = run_cli(capsys, "progress", "--max-cost", "7", "--seed", "1")
    assert code == 0, out + err


def test_run_kitchen_without_a_task_lists_the_tasks(capsys):
    code, out, err = run_cli(capsys, "kitchen")
    assert code == 2
    assert "None" not in err and "needs a task" in err
    for task in ("inspect", "stow", "swap", "cook"):
        assert task in err
