"""The `check` and `fmt` subcommands: output, exit codes, no tracebacks, no partial writes."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from ssr_compile import __version__
from ssr_compile.cli import main
from ssr_compile.parse import parse_file, parse_text
from ssr_compile.printer import to_text

FIXTURES = Path(__file__).parent / "fixtures" / "lang"
KITCHEN = FIXTURES / "kitchen"


def run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "ssr_compile.cli", *map(str, args)],
        capture_output=True,
        text=True,
        timeout=60,
    )


def test_check_prints_one_line_per_file(capsys):
    files = [KITCHEN / "domain.pddl", KITCHEN / "stream.pddl", KITCHEN / "problem.pddl"]
    assert main(["check", *map(str, files)]) == 0
    out, err = capsys.readouterr()
    lines = out.splitlines()
    assert len(lines) == 3
    assert lines[0] == (
        f"{files[0]}: domain kitchen-belief: 4 actions, 1 axiom, 19 predicates, 3 functions, "
        "4 types, 4 constants"
    )
    assert lines[1].startswith(f"{files[1]}: stream kitchen-belief: 6 streams (2 tests)")
    assert lines[2].startswith(f"{files[2]}: problem inspect-0: 6 objects")
    assert err == ""


@pytest.mark.parametrize("folder", ["kitchen_short", "numeric", "temporal", "quirks"])
def test_every_fixture_folder_checks(folder, capsys):
    files = sorted(str(p) for p in (FIXTURES / folder).glob("*.pddl"))
    assert main(["check", *files]) == 0
    out, _ = capsys.readouterr()
    assert len(out.splitlines()) == len(files)


def test_broken_file_exits_2_with_position_and_no_traceback(tmp_path):
    bad = tmp_path / "bad.pddl"
    bad.write_text("(define (domain d)\n  (:predicates (p ?x))\n  (:actiox a))\n")
    r = run("check", bad)
    assert r.returncode == 2
    assert f"{bad}:3:4: syntax error: found ':actiox'" in r.stderr
    assert "Traceback" not in r.stderr + r.stdout
    assert r.stdout == ""


def test_binary_file_exits_2(tmp_path):
    bad = tmp_path / "junk.pddl"
    bad.write_bytes(b"(define (domain d)\n\x00\x01\xff\xfe(((")
    r = run("check", bad)
    assert r.returncode == 2
    assert f"{bad}:2:1: syntax error: found the control character" in r.stderr
    assert "Traceback" not in r.stderr


def test_semantic_error_exits_2_and_good_files_still_reported(tmp_path, capsys):
    bad = tmp_path / "domain.pddl"
    bad.write_text(
        "(define (domain d) (:predicates (p ?x))\n"
        "  (:action a :parameters (?x) :precondition (q ?x)))\n"
    )
    # The good problem is checked against the domain beside it, not against the broken one.
    good = FIXTURES / "numeric" / "problem.pddl"
    assert main(["check", str(bad), str(FIXTURES / "numeric" / "domain.pddl"), str(good)]) == 2
    out, err = capsys.readouterr()
    assert f"{bad}:2:46: error: undeclared predicate 'q' in the precondition of action 'a'" in err
    assert f"{bad}: 1 error" in err
    assert f"{good}: problem depot-1: 5 objects" in out
    assert len(out.splitlines()) == 2


def test_missing_file_exits_2(tmp_path, capsys):
    assert main(["check", str(tmp_path / "nope.pddl")]) == 2
    _, err = capsys.readouterr()
    assert "nope.pddl: error: no such file" in err


def test_undeclared_requirements_are_warned(tmp_path, capsys):
    path = tmp_path / "d.pddl"
    path.write_text(
        "(define (domain d) (:requirements :strips) (:predicates (p ?x))\n"
        "  (:action a :parameters (?x) :precondition (not (p ?x))))\n"
    )
    assert main(["check", str(path)]) == 0
    out, err = capsys.readouterr()
    assert out.startswith(f"{path}: domain d:")
    assert (
        f"{path}:1:17: warning: uses requirements it does not declare: :negative-preconditions"
        in err
    )


def test_check_with_domain_option(capsys):
    problem = FIXTURES / "numeric" / "problem.pddl"
    domain = FIXTURES / "numeric" / "domain.pddl"
    assert main(["check", "--domain", str(domain), str(problem)]) == 0
    out, _ = capsys.readouterr()
    assert out.splitlines() == [
        f"{problem}: problem depot-1: 5 objects, 10 initial facts, a goal, metric maximize"
    ]


def test_fmt_writes_canonical_text(tmp_path, capsys):
    out_path = tmp_path / "sub" / "domain.pddl"
    src = FIXTURES / "kitchen_short" / "domain.pddl"
    assert main(["fmt", str(src), "-o", str(out_path)]) == 0
    written = out_path.read_text()
    assert written == to_text(parse_file(src))
    assert ":parameters (?o ?pb1 ?obs ?pb2)" in written
    assert capsys.readouterr().out == ""
    # fmt of its own output is the same text
    assert main(["fmt", str(out_path)]) == 0
    assert capsys.readouterr().out == written


def test_fmt_shorthand(capsys):
    src = KITCHEN / "stream.pddl"
    assert main(["fmt", "--shorthand", str(src)]) == 0
    text = capsys.readouterr().out
    assert ":inp (?o ?pb1 ?obs)" in text and ":cert (and (poseb ?o ?pb2)" in text
    assert ":inputs" not in text
    assert parse_text(text, "short") == parse_file(src)


def test_fmt_on_a_broken_file_writes_nothing(tmp_path):
    bad = tmp_path / "bad.pddl"
    bad.write_text("(define (domain d) (:predicates (p ?x)")
    out_path = tmp_path / "out.pddl"
    r = run("fmt", bad, "-o", out_path)
    assert r.returncode == 2
    assert f"{bad}:1:39: syntax error: found the end of the file" in r.stderr
    assert "Traceback" not in r.stderr
    assert not out_path.exists()
    assert list(tmp_path.iterdir()) == [bad]  # no temporary file left either
    # An existing output is left as it was.
    out_path.write_text("keep me")
    assert run("fmt", bad, "-o", out_path).returncode == 2
    assert out_path.read_text() == "keep me"


def test_help_and_version():
    r = run("--help")
    assert r.returncode == 0
    assert "check" in r.stdout and "fmt" in r.stdout and "Exit codes" in r.stdout
    r = run("--version")
    assert r.returncode == 0
    assert r.stdout.strip() == f"ssr-compile {__version__}"
    r = run("fmt", "--help")
    assert r.returncode == 0 and "--shorthand" in r.stdout


def test_no_command_prints_help_and_exits_2(capsys):
    assert main([]) == 2
    assert "usage:" in capsys.readouterr().out
