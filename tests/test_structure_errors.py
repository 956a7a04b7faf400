"""Issue 9 item 7: errors say whose fault they are.  Bad input leaves with exit 2; a stream's
code or a planner that fails leaves with exit 3, one line naming the stream or the backend, and
the traceback only behind --debug."""

from __future__ import annotations

from pathlib import Path

from ssr_compile.cli import build_parser, main
from ssr_compile.errors import Failure, PlannerFailure, SSRError, StreamFailure
from ssr_compile.planners.base import Capabilities, PlanResult

PP = Path(__file__).parent / "fixtures" / "compile" / "pp1d"
D, S, P = (str(PP / n) for n in ("domain.pddl", "stream.pddl", "problem.pddl"))

BUGGY = """
import importlib.util
spec = importlib.util.spec_from_file_location("pp1d_streams_copy", {path!r})
base = importlib.util.module_from_spec(spec)
spec.loader.exec_module(base)
STREAMS = dict(base.STREAMS)
STREAM_INFO = base.STREAM_INFO
VALUES = base.VALUES

def broken(*args):
    return 1 / 0

STREAMS["sample-pose"] = broken
"""


def _buggy(tmp_path: Path) -> str:
    path = tmp_path / "buggy_streams.py"
    path.write_text(BUGGY.format(path=str(PP / "streams.py")))
    return str(path)


def test_failures_are_not_input_errors():
    assert not issubclass(Failure, SSRError)
    assert StreamFailure("ik", "x").exit_code == PlannerFailure("fd", "x").exit_code == 3
    assert "planner fd failed: boom" in str(PlannerFailure("fd", "boom"))


def test_a_stream_that_raises_is_exit_3_naming_it(tmp_path, capsys):
    code = main(["solve", D, S, P, "--streams", _buggy(tmp_path), "--time-limit", "60"])
    err = capsys.readouterr().err
    assert code == 3
    assert "stream 'sample-pose' raised ZeroDivisionError" in err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1


def test_debug_shows_the_stream_traceback(tmp_path, capsys):
    argv = ["solve", D, S, P, "--streams", _buggy(tmp_path), "--time-limit", "60", "--debug"]
    assert main(argv) == 3
    err = capsys.readouterr().err
    assert "Traceback" in err and "return 1 / 0" in err  # the user's own line
    assert err.strip().splitlines()[-1].startswith("ssr-compile: stream 'sample-pose' raised")
    # --debug before the command works too
    assert main(["--debug", *argv[:-1]]) == 3
    assert "Traceback" in capsys.readouterr().err


class _CrashingPlanner:
    name = "crashy"
    capabilities = Capabilities(
        costs=True,
        axioms=True,
        negative_preconditions=True,
        disjunction=True,
        quantifiers=True,
        conditional_effects=True,
    )

    def solve(self, domain, problem, time_limit=60.0, cost_bound=None):
        return PlanResult("error", None, None, 0.0, self.name, "segfault", detail="core dumped")


def test_a_planner_error_is_a_planner_failure():
    import pytest

    from ssr_compile.parse import parse_domain, parse_problem, parse_stream_file
    from ssr_compile.solver import SolveOptions, solve
    from ssr_compile.stream import load_streams_module

    domain = parse_domain(Path(D).read_text())
    streams = parse_stream_file(Path(S).read_text())
    problem = parse_problem(Path(P).read_text())
    module = load_streams_module(str(PP / "streams.py"))
    with pytest.raises(PlannerFailure) as info:
        options = SolveOptions(planner=_CrashingPlanner(), time_limit=30)
        solve(domain, streams, problem, module, options)
    assert info.value.exit_code == 3 and info.value.detail == "core dumped"
    assert "planner crashy failed: segfault" in str(info.value)


def test_an_internal_error_is_exit_3(monkeypatch, capsys):
    import ssr_compile.cli as cli

    def bug(args):
        raise KeyError("oops")

    configure, _run, help_text = cli.COMMANDS["check"]
    monkeypatch.setitem(cli.COMMANDS, "check", (configure, bug, help_text))
    assert main(["check", D]) == 3
    err = capsys.readouterr().err
    assert "internal error: KeyError" in err and "Traceback" not in err


def test_epilog_documents_exit_3():
    assert "3 a planner, a stream's code, an environment's code or ssr-compile failed" in " ".join(
        build_parser().epilog.split()
    )


def test_plan_reports_a_planner_error_as_the_planners_fault(monkeypatch, capsys):
    """`plan` with a backend that answers "error": exit 3 and one line naming the backend."""
    from ssr_compile.cli import main
    from ssr_compile.planners import base
    from ssr_compile.planners.fd import FastDownward

    def broken(self, domain, problem, time_limit=60.0, cost_bound=None):
        return base.PlanResult("error", None, None, 0.0, self.name, "exploded", detail="log")

    monkeypatch.setattr(FastDownward, "solve", broken)
    code = main(["plan", "tamp2d", "--problem", "problem", "--planner", "fd"])
    err = capsys.readouterr().err
    assert code == 3
    assert "planner fd failed: exploded" in err and "Traceback" not in err
