"""Issue 14 rows 8 and 15: deeply nested formulas are bad input with a position (never a
RecursionError traceback); problems named by a number and files starting with a UTF-8
byte-order mark are read."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from ssr_compile.cli import main
from ssr_compile.errors import PDDLSyntaxError
from ssr_compile.parse import MAX_DEPTH, parse_file, parse_text
from ssr_compile.printer import to_text

PP = Path(__file__).parent / "fixtures" / "compile" / "pp1d"

STREAM = """(define (stream d)
  (:stream s :inputs (?x) :domain (p ?x) :certified (q ?x)))
"""


def _nested(n: int, inner: str) -> str:
    return "(and " * n + inner + ")" * n


def _files(tmp_path: Path, n: int, where: str) -> list[str]:
    pre = _nested(n, "(p ?x)") if where == "domain" else "(p ?x)"
    goal = _nested(n, "(q a)") if where == "problem" else "(q a)"
    (tmp_path / "domain.pddl").write_text(
        "(define (domain d)\n  (:requirements :strips)\n  (:predicates (p ?x) (q ?x))\n"
        f"  (:action a :parameters (?x)\n    :precondition {pre}\n    :effect (q ?x)))\n"
    )
    (tmp_path / "stream.pddl").write_text(STREAM)
    (tmp_path / "problem.pddl").write_text(
        f"(define (problem pr) (:domain d) (:objects a) (:init (p a))\n  (:goal {goal}))\n"
    )
    (tmp_path / "streams.py").write_text("STREAMS = {'s': lambda x: ()}\n")
    return [str(tmp_path / n) for n in ("domain.pddl", "stream.pddl", "problem.pddl")]


def _commands(files: list[str], tmp_path: Path, where: str) -> list[list[str]]:
    d, s, p = files
    return [
        ["check", d, s, p],
        ["fmt", d if where == "domain" else p],
        ["compile", d, s, p, "-o", str(tmp_path / "out")],
        ["plan", d, s, p],
        ["solve", d, s, p, "--streams", str(tmp_path / "streams.py")],
    ]


def _cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "ssr_compile.cli", *args],
        capture_output=True,
        text=True,
        timeout=120,
    )


@pytest.mark.parametrize("where", ["domain", "problem"])
@pytest.mark.parametrize("depth", [330, 2000])
def test_deep_nesting_is_bad_input_at_its_position(tmp_path, where, depth):
    files = _files(tmp_path, depth, where)
    path = files[0] if where == "domain" else files[2]
    # The first '(' too deep: the (MAX_DEPTH+1)-th level.  In the domain, the formula starts at
    # line 5, column 19 at level 3; in the problem, line 2 column 10 at level 3.
    line, col0, level0 = (5, 19, 3) if where == "domain" else (2, 10, 3)
    col = col0 + len("(and ") * (MAX_DEPTH + 1 - level0)
    want = f"{path}:{line}:{col}: syntax error: nested too deeply (limit {MAX_DEPTH})"
    for argv in _commands(files, tmp_path, where):
        r = _cli(*argv)
        assert r.returncode == 2, (argv, r.stderr[-500:])
        assert r.stderr.startswith(want), (argv, r.stderr[:300])
        assert "Traceback" not in r.stderr and "RecursionError" not in r.stderr
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("where", ["domain", "problem"])
def test_nesting_up_to_the_limit_is_read_and_compiled(tmp_path, where, capsys):
    # The deepest formula allowed; every command handles it.
    files = _files(tmp_path, MAX_DEPTH - 3, where)
    for argv in _commands(files, tmp_path, where):
        assert main(argv) == 0, argv
    capsys.readouterr()


def test_parentheses_in_comments_do_not_count():
    deep = "(" * (MAX_DEPTH + 5) + ")" * (MAX_DEPTH + 5)
    text = f"; {deep}\n(define (domain d) ; {deep}\n (:predicates (p)))\n"
    assert parse_text(text).name == "d"


def test_many_shallow_formulas_are_fine():
    facts = " ".join(f"(p o{i})" for i in range(5000))
    text = f"(define (problem pr) (:domain d) (:objects a) (:init {facts}) (:goal (p a)))"
    assert len(parse_text(text).init) == 5000


# ---------------------------------------------------------------- row 15


def test_a_problem_named_by_a_number_is_accepted(tmp_path, capsys):
    text = (PP / "problem.pddl").read_text().replace("(problem pp1d-free)", "(problem 37)")
    problem = tmp_path / "problem.pddl"
    problem.write_text(text)
    node = parse_file(problem)
    assert node.kind == "problem" and node.name == "37"
    assert "(define (problem 37)" in to_text(node)
    d, s = str(PP / "domain.pddl"), str(PP / "stream.pddl")
    assert main(["check", d, s, str(problem)]) == 0
    assert "problem 37:" in capsys.readouterr().out
    assert main(["plan", d, s, str(problem)]) == 0
    assert main(["solve", d, s, str(problem), "--streams", str(PP / "streams.py")]) == 0
    capsys.readouterr()


def test_a_domain_named_by_a_number_is_still_refused():
    with pytest.raises(PDDLSyntaxError) as info:
        parse_text("(define (domain 37) (:predicates (p)))")
    assert info.value.line == 1 and info.value.col == 17


@pytest.mark.parametrize("name", ["domain.pddl", "stream.pddl", "problem.pddl"])
def test_a_utf8_byte_order_mark_is_accepted(tmp_path, name, capsys):
    for n in ("domain.pddl", "stream.pddl", "problem.pddl"):
        data = (PP / n).read_bytes()
        (tmp_path / n).write_bytes(b"\xef\xbb\xbf" + data if n == name else data)
    files = [str(tmp_path / n) for n in ("domain.pddl", "stream.pddl", "problem.pddl")]
    assert main(["check", *files]) == 0
    assert main(["fmt", files[["domain.pddl", "stream.pddl", "problem.pddl"].index(name)]]) == 0
    assert "\ufeff" not in capsys.readouterr().out


def test_positions_after_a_byte_order_mark_are_those_the_user_sees(tmp_path):
    bad = tmp_path / "bad.pddl"
    bad.write_bytes(b"\xef\xbb\xbf(define (domain d)\n  (:actiox a))\n")
    with pytest.raises(PDDLSyntaxError) as info:
        parse_file(bad)
    assert (info.value.line, info.value.col) == (2, 4)
    assert "\ufeff" not in str(info.value)
