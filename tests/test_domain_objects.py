"""A domain may name an object its problems declare (the paper's ``(AtConf base ?bq)`` with
``base`` an object): accepted with a warning saying how to declare it, an error only when no
file declares the name, and every planner gets a domain that declares it."""

from __future__ import annotations

import pytest

from ssr_compile.cli import main

DOMAIN = """(define (domain conf) (:requirements :strips)
  (:predicates (atconf ?r ?q) (conf ?q) (done ?q))
  (:action go :parameters (?q1 ?q2)
    :precondition (and (atconf base ?q1) (conf ?q2))
    :effect (and (atconf base ?q2) (not (atconf base ?q1)) (done ?q2))))
"""
PROBLEM = """(define (problem p) (:domain conf) (:objects {objects})
  (:init (atconf base q1) (conf q1) (conf q2)) (:goal (done q2)))
"""


@pytest.fixture
def files(tmp_path):
    (tmp_path / "domain.pddl").write_text(DOMAIN)
    (tmp_path / "stream.pddl").write_text("(define (stream none))")
    (tmp_path / "problem.pddl").write_text(PROBLEM.format(objects="base q1 q2"))
    (tmp_path / "problem-nobase.pddl").write_text(PROBLEM.format(objects="q1 q2"))
    return tmp_path


def test_the_domain_alone_gets_a_warning_with_the_fix(files, capsys):
    assert main(["check", str(files / "domain.pddl")]) == 0
    err = capsys.readouterr().err
    assert f"{files / 'domain.pddl'}:4:" in err and "(:constants base)" in err


def test_a_problem_that_declares_the_object_checks(files, capsys):
    assert main(["check", str(files / "domain.pddl"), str(files / "problem.pddl")]) == 0


def test_a_problem_that_does_not_is_an_error(files, capsys):
    code = main(["check", str(files / "domain.pddl"), str(files / "problem-nobase.pddl")])
    assert code == 2
    assert "neither its :constants nor this problem's :objects declare" in capsys.readouterr().err


@pytest.mark.parametrize("planner", ["fd", "pyperplan", "up:pyperplan"])
def test_every_planner_plans_it(files, capsys, planner):
    d, s, p = (str(files / n) for n in ("domain.pddl", "stream.pddl", "problem.pddl"))
    assert main(["plan", d, s, p, "--planner", planner]) == 0
    assert "(go q1 q2)" in capsys.readouterr().out
