"""Issue 17: what the CLI's options promise holds (rows 1, 2, 3, 5, 6, 7, 13)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from ssr_compile.cli import build_parser, main

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = ROOT / "domains" / "pddl"
KITCHEN = EXAMPLES / "kitchen"
TAMP2D = EXAMPLES / "tamp2d"


def run(*args: str, stdin: str | None = None) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "ssr_compile.cli", *map(str, args)],
        capture_output=True,
        text=True,
        timeout=120,
        input=stdin,
    )


def _help(command: str) -> str:
    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    return sub.choices[command].format_help()


# ---------------------------------------------------------------- row 1: example.toml vs --help


def test_solve_help_says_example_settings_apply_first():
    text = " ".join(_help("solve").split())
    assert "example.toml" in text and "apply first" in text
    assert "an option given on the command line always wins" in text
    assert "--no-defer" in text


def test_verbose_prints_each_setting_and_its_source(capsys):
    assert main(["solve", "tamp2d", "--problem", "problem", "--time-limit", "30", "-v"]) == 0
    err = capsys.readouterr().err
    lines = {line.split()[0] + " " + line.split()[1]: line for line in err.splitlines()[:9]}
    assert "settings in force:" in err
    assert "fd:opt  (example.toml)" in lines["planner fd:opt"]
    assert "30 s  (flag --time-limit)" in lines["time limit"]
    assert "3  (example.toml)" in lines["level 3"]
    assert "8  (default)" in lines["max level"]
    assert "off  (default)" in lines["defer off"]


def test_every_example_setting_can_be_overridden(capsys):
    # the kitchen's example.toml turns deferral on; --no-defer turns it off again
    from ssr_compile.cli.solve import resolve_settings

    ns = build_parser().parse_args(["solve", "kitchen", "--no-defer", "--planner", "fd"])
    config = {"defer": True, "planner": "fd:opt", "time_limit": 120, "level": 3}
    got = resolve_settings(ns, config)
    assert got["defer"] == (False, "flag --defer/--no-defer")
    assert got["planner"] == ("fd", "flag --planner")
    assert got["time_limit"] == (120.0, "example.toml")
    ns = build_parser().parse_args(["solve", "kitchen"])
    assert resolve_settings(ns, config)["defer"] == (True, "example.toml")
    assert resolve_settings(ns, {})["defer"] == (False, "default")


def test_bad_example_setting_is_bad_input(tmp_path, capsys):
    folder = tmp_path / "ex"
    folder.mkdir()
    for name in ("domain.pddl", "stream.pddl", "problem.pddl"):
        (folder / name).write_text((TAMP2D / name).read_text())
    (folder / "example.toml").write_text(
        'streams = "ssr_compile.streams.tamp2d"\ndefer = "maybe"\n'
    )
    assert main(["solve", str(folder)]) == 2
    assert "defer = 'maybe'" in capsys.readouterr().err


# ---------------------------------------------------------------- row 2: a flag wins


def test_max_level_flag_wins_over_example_level(capsys):
    assert main(["solve", "tamp2d", "--problem", "problem", "--max-level", "2", "--json"]) == 1
    doc = json.loads(capsys.readouterr().out)
    result = doc["results"][0]
    assert result["stats"]["levels"] and max(result["stats"]["levels"]) <= 2
    assert doc["settings"]["level"]["value"] == 2
    assert "lowered to --max-level" in doc["settings"]["level"]["source"]
    assert "up to level 2" in result["message"]


def test_level_flag_above_example_max_level_raises_it():
    from ssr_compile.cli.solve import resolve_settings

    ns = build_parser().parse_args(["solve", "x", "--level", "5"])
    got = resolve_settings(ns, {"max_level": 4})
    assert got["level"] == (5, "flag --level") and got["max_level"][0] == 5


def test_contradicting_level_flags_are_bad_input(capsys):
    assert main(["solve", "tamp2d", "--level", "4", "--max-level", "2"]) == 2
    assert "above the last" in capsys.readouterr().err


# ---------------------------------------------------------------- row 3: --max-cost in user units

WALK_DOMAIN = """(define (domain walk)
  (:requirements :strips :action-costs)
  (:predicates (at ?x) (link ?x ?y))
  (:functions (total-cost) - number)
  (:action go
    :parameters (?x ?y)
    :precondition (and (at ?x) (link ?x ?y))
    :effect (and (at ?y) (not (at ?x)) (increase (total-cost) 12.5))))
"""
WALK_PROBLEM = """(define (problem walk-1)
  (:domain walk)
  (:objects a b)
  (:init (at a) (link a b))
  (:goal (at b))
  (:metric minimize (total-cost)))
"""


@pytest.fixture
def walk(tmp_path):
    (tmp_path / "domain.pddl").write_text(WALK_DOMAIN)
    (tmp_path / "stream.pddl").write_text("(define (stream walk))\n")
    (tmp_path / "problem.pddl").write_text(WALK_PROBLEM)
    (tmp_path / "streams.py").write_text("STREAMS = {}\n")
    return [str(tmp_path / n) for n in ("domain.pddl", "stream.pddl", "problem.pddl")] + [
        "--streams",
        str(tmp_path / "streams.py"),
    ]


def test_max_cost_is_in_the_users_units(walk, capsys):
    # the action costs 12.5: the compiler scales costs by 10 for the planner
    assert main(["solve", *walk, "--max-cost", "10", "--max-level", "1"]) == 1
    out = capsys.readouterr().out
    assert "cost bound 10)" in out and "100" not in out
    assert main(["solve", *walk, "--max-cost", "13", "--max-level", "1"]) == 0
    assert "cost 12.5" in capsys.readouterr().out


@pytest.mark.parametrize("value", ["-1", "0", "nan", "ten"])
def test_invalid_max_cost_is_bad_input(walk, value):
    r = run("solve", *walk, "--max-cost", value)
    assert r.returncode == 2 and "--max-cost" in r.stderr and "Traceback" not in r.stderr


# ---------------------------------------------------------------- row 5: a wrong file in a role


def test_check_refuses_a_non_domain_as_domain():
    r = run("check", "--domain", KITCHEN / "stream.pddl", KITCHEN / "problem-inspect.pddl")
    assert r.returncode == 2
    assert "--domain names a stream file; expected a domain file" in r.stderr


@pytest.mark.parametrize(
    "roles, found",
    [
        (("stream.pddl", "stream.pddl", "problem-inspect.pddl"), "expected a domain file"),
        (("domain.pddl", "problem-inspect.pddl", "problem-inspect.pddl"), "expected a stream file"),
        (("domain.pddl", "stream.pddl", "domain.pddl"), "expected a problem file"),
    ],
)
def test_compile_refuses_a_file_in_the_wrong_role(tmp_path, roles, found):
    r = run("compile", *(KITCHEN / x for x in roles), "-o", tmp_path / "out")
    assert r.returncode == 2 and found in r.stderr


def test_problem_for_another_domain_is_said_first():
    r = run("check", "--domain", TAMP2D / "domain.pddl", KITCHEN / "problem-inspect.pddl")
    assert r.returncode == 2
    first = r.stderr.splitlines()[0]
    assert "the problem is for domain 'kitchen', but is checked against domain 'tamp2d'" in first


# ---------------------------------------------------------------- row 6: plan raises the level


def test_plan_raises_the_level_instead_of_calling_a_cutoff_unsolvable(capsys):
    # Stow has no optimistic plan at level 3; it has one at a higher level
    assert main(["plan", "kitchen", "--problem", "stow", "--json"]) == 0
    result = json.loads(capsys.readouterr().out)["results"][0]
    assert result["status"] == "solved" and result["level"] > 3


def test_plan_level_cutoff_is_not_unsolvable(capsys):
    argv = ["plan", "kitchen", "--problem", "stow", "--level", "3", "--max-level", "3"]
    assert main(argv) == 1
    out = capsys.readouterr().out
    assert "unsolvable" not in out
    assert "no optimistic plan up to level 3" in out and "try --max-level" in out


# ---------------------------------------------------------------- row 7: names, stdin, STREAM_INFO


def test_example_names_work_in_plan_check_compile(tmp_path, capsys):
    assert main(["check", "kitchen"]) == 0
    assert len(capsys.readouterr().out.splitlines()) == 6  # domain, stream, 4 problems
    assert main(["plan", "tamp2d", "--problem", "blocked"]) == 0
    assert "optimistic plan" in capsys.readouterr().out
    assert main(["compile", "progress", "-o", str(tmp_path / "p")]) == 0
    assert (tmp_path / "p" / "problem.pddl").exists()
    assert main(["compile", "kitchen", "--problem", "inspect", "-o", str(tmp_path / "k")]) == 0
    assert "(:domain kitchen" in (tmp_path / "k" / "problem.pddl").read_text()


def test_example_with_several_problems_asks_which(capsys):
    assert main(["plan", "kitchen"]) == 2
    assert "choose one with --problem (cook, inspect, stow, swap)" in capsys.readouterr().err
    assert main(["plan", "kitchen", "--problem", "dance"]) == 2
    assert "no problem 'dance'" in capsys.readouterr().err


def test_fmt_reads_standard_input():
    source = (EXAMPLES / "progress" / "problem.pddl").read_text()
    from_file = run("fmt", EXAMPLES / "progress" / "problem.pddl")
    from_stdin = run("fmt", "-", stdin=source)
    assert from_stdin.returncode == 0, from_stdin.stderr
    assert from_stdin.stdout == from_file.stdout and from_stdin.stdout.startswith("(define")


# ---------------------------------------------------------------- row 13: no pybullet banner


@pytest.mark.parametrize(
    "argv",
    [
        ("render", "inspect", "--seed", "1", "-o", "{tmp}/s.png"),
        ("solve", "belief-detect", "--problem", "clear"),
    ],
)
def test_no_pybullet_banner(tmp_path, argv):
    r = run(*(a.format(tmp=tmp_path) for a in argv))
    assert r.returncode == 0, r.stderr
    assert "pybullet build time" not in r.stdout + r.stderr


def test_quiet_import_keeps_output_working(tmp_path):
    code = (
        "from ssr_compile.quiet_pybullet import import_pybullet\n"
        "import sys; print('before'); sys.stderr.write('err\\n')\n"
        "p = import_pybullet(); print('after', p.connect(p.DIRECT))\n"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert r.stdout == "before\nafter 0\n" and r.stderr == "err\n"


def test_resample_is_a_setting_with_the_solvers_default(capsys):
    from ssr_compile.cli.solve import DEFAULTS
    from ssr_compile.solver import RESAMPLE

    assert DEFAULTS["resample"] == RESAMPLE
    # the Focused loop's drawing again (tamp2d's example.toml picks the adaptive algorithm)
    focused = ["--algorithm", "focused"]
    assert main(["solve", "tamp2d", "--problem", "problem", "--resample", "0", "-v", *focused]) == 0
    err = capsys.readouterr().err
    assert "resample    0  (flag --resample)" in err
    assert "drawing again" not in err  # off: sample-grasp's failed first draw is planned around
    assert main(["solve", "tamp2d", "--problem", "problem", "-v", *focused]) == 0
    err = capsys.readouterr().err
    assert f"resample    {RESAMPLE}  (default)" in err and "drawing again: sample-grasp" in err
    with pytest.raises(SystemExit) as exit_:
        main(["solve", "tamp2d", "--resample", "-1"])
    assert exit_.value.code == 2
    assert "expected a number of draws 0 or more, got '-1'" in capsys.readouterr().err
