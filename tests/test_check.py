"""Semantic checks: every fixture is clean; each kind of mistake is found, said and placed."""

from __future__ import annotations

from pathlib import Path

import pytest

from ssr_compile.check import check_domain, check_problem, check_streams
from ssr_compile.errors import CheckError
from ssr_compile.parse import parse_file, parse_text

FIXTURES = Path(__file__).parent / "fixtures" / "lang"


def load(folder: str, kind: str):
    path = FIXTURES / folder / f"{kind}.pddl"
    return parse_file(path) if path.exists() else None


@pytest.mark.parametrize("folder", ["kitchen", "kitchen_short", "numeric", "temporal"])
def test_fixtures_check_clean(folder):
    domain, streams, problem = (load(folder, k) for k in ("domain", "stream", "problem"))
    reports = [check_domain(domain, streams=streams)]
    if streams is not None:
        reports.append(check_streams(streams, domain))
    if problem is not None:
        reports.append(check_problem(problem, domain, streams=streams))
    for r in reports:
        assert r.errors == [] and r.warnings == [], r.filename


def test_quirks_fixture_checks_with_the_expected_warnings():
    domain, streams, problem = (load("quirks", k) for k in ("domain", "stream", "problem"))
    alone = check_domain(domain, filename="q.pddl")
    assert alone.errors == []
    # (total-cost) needs no declaration; an undeclared cost function is only a warning.
    assert alone.warnings == [
        "q.pddl:19:42: warning: function 'movecost' is not declared in :functions"
    ]
    with_streams = check_domain(domain, streams=streams)
    assert with_streams.errors == [] and with_streams.warnings == []
    r = check_streams(streams, domain, filename="s.pddl")
    assert r.errors == []
    assert r.warnings == [
        "s.pddl:8:35: warning: predicates used by the stream file but not declared by the domain: pose"
    ]
    r = check_problem(problem, domain, streams=streams)
    assert r.errors == [] and r.warnings == []


DOMAIN = """(define (domain d)
  (:requirements :strips :typing :equality)
  (:types block)
  (:constants table - block)
  (:predicates (on ?x ?y - block) (clear ?x - block))
  (:action a :parameters (?x - block) :precondition (clear ?x) :effect (not (clear ?x))))
"""
STREAMS = """(define (stream s)
  (:stream gen :inputs (?x) :domain (clear ?x) :outputs (?y) :certified (on ?x ?y)))
"""
PROBLEM = """(define (problem p) (:domain d)
  (:objects b1 b2 - block)
  (:init (clear b1) (on b1 b2))
  (:goal (on b2 b1)))
"""


def errors_of(kind: str, text: str) -> list[CheckError]:
    domain = parse_text(DOMAIN, "d.pddl")
    tree = parse_text(text, f"{kind}.pddl")
    if kind == "domain":
        report = check_domain(tree, filename="domain.pddl", source=text)
    elif kind == "stream":
        report = check_streams(tree, domain, filename="stream.pddl", source=text)
    else:
        report = check_problem(tree, domain, filename="problem.pddl", source=text)
    return report.errors


PRE = ":precondition (clear ?x)"
BAD = [
    (
        "undeclared predicate",
        "domain",
        DOMAIN.replace(PRE, ":precondition (and (clear ?x) (holding ?x))"),
        6,
        70,
        "undeclared predicate 'holding' in the precondition of action 'a'",
    ),
    (
        "wrong arity",
        "domain",
        DOMAIN.replace(PRE, ":precondition (on ?x)"),
        6,
        54,
        "'on' takes 2 arguments, found 1 in the precondition of action 'a'",
    ),
    (
        "undeclared type",
        "domain",
        DOMAIN.replace("(?x - block) :pre", "(?x - blok) :pre"),
        6,
        27,
        "undeclared type 'blok' in action 'a'",
    ),
    (
        "free variable in a precondition",
        "domain",
        DOMAIN.replace(PRE, ":precondition (clear ?y)"),
        6,
        60,
        "free variable ?y in the precondition of action 'a'",
    ),
    (
        "free variable in an effect",
        "domain",
        DOMAIN.replace(":effect (not (clear ?x))", ":effect (clear ?z)"),
        6,
        79,
        "free variable ?z in the effect of action 'a'",
    ),
    (
        "duplicate action",
        "domain",
        DOMAIN.rstrip()[:-1] + "\n  (:action A :parameters () :effect (and)))\n",
        7,
        12,
        "duplicate action 'a'",
    ),
    (
        "duplicate parameter",
        "domain",
        DOMAIN.replace("(?x - block) :pre", "(?x ?x - block) :pre"),
        6,
        30,
        "duplicate parameter ?x in action 'a'",
    ),
    (
        "effect on a derived predicate",
        "domain",
        DOMAIN.rstrip()[:-1] + "\n  (:derived (clear ?x - block) (on ?x table)))\n",
        6,
        78,
        "the effect of action 'a' changes derived predicate 'clear'",
    ),
    (
        "undeclared function",
        "domain",
        DOMAIN.replace(PRE, ":precondition (< (weight ?x) 3)"),
        6,
        57,
        "undeclared function 'weight' in the precondition of action 'a'",
    ),
    (
        "certified variable neither input nor output",
        "stream",
        STREAMS.replace(":certified (on ?x ?y)", ":certified (on ?x ?z)"),
        2,
        80,
        "variable ?z in the certified facts of stream 'gen' is neither an input nor an output",
    ),
    (
        "output used in a stream's domain",
        "stream",
        STREAMS.replace(":domain (clear ?x)", ":domain (and (clear ?x) (clear ?y))"),
        2,
        60,
        "output ?y is used in the domain of stream 'gen'; the domain may only use inputs",
    ),
    (
        "free variable in a stream's domain",
        "stream",
        STREAMS.replace(":domain (clear ?x)", ":domain (on ?x ?w)"),
        2,
        44,
        "free variable ?w in the domain of stream 'gen': not an input",
    ),
    (
        "duplicate stream",
        "stream",
        STREAMS.rstrip()[:-1] + "\n  (:stream GEN :inputs (?x) :outputs (?y)))\n",
        3,
        12,
        "duplicate stream 'gen'",
    ),
    (
        "stream arity against the domain",
        "stream",
        STREAMS.replace(":certified (on ?x ?y)", ":certified (on ?x ?y ?x)"),
        2,
        74,
        "'on' takes 2 arguments, found 3 in the certified facts of stream 'gen'",
    ),
    (
        "input that is also an output",
        "stream",
        STREAMS.replace(":outputs (?y)", ":outputs (?x ?y)"),
        2,
        44,
        "output ?x is used in the domain of stream 'gen'",
    ),
    (
        "fluent that is not a predicate",
        "stream",
        STREAMS.replace(":outputs", ":fluents (nothing) :outputs"),
        2,
        12,
        "fluent 'nothing' of stream 'gen' is not a predicate of the domain",
    ),
    (
        "undeclared object in the goal",
        "problem",
        PROBLEM.replace("(:goal (on b2 b1))", "(:goal (on b3 b1))"),
        4,
        14,
        "undeclared constant 'b3' in the goal",
    ),
    (
        "variable in the goal",
        "problem",
        PROBLEM.replace("(:goal (on b2 b1))", "(:goal (on ?x b1))"),
        4,
        14,
        "free variable ?x in the goal",
    ),
    (
        "wrong arity in :init",
        "problem",
        PROBLEM.replace("(clear b1)", "(clear b1 b2)"),
        3,
        11,
        "'clear' takes 1 argument, found 2 in the initial state",
    ),
    (
        "undeclared object type",
        "problem",
        PROBLEM.replace("- block", "- blk"),
        2,
        13,
        "undeclared type 'blk' in the :objects section",
    ),
    (
        "duplicate object",
        "problem",
        PROBLEM.replace("b1 b2 - block", "b1 b2 B1 - block"),
        2,
        19,
        "duplicate object 'b1'",
    ),
]


@pytest.mark.parametrize("kind,text,line,col,words", [c[1:] for c in BAD], ids=[c[0] for c in BAD])
def test_mistake_is_found_and_placed(kind, text, line, col, words):
    errors = errors_of(kind, text)
    assert errors, "no error found"
    first = min(errors, key=lambda e: (e.line, e.col))
    assert words in first.message
    assert (first.line, first.col) == (line, col)
    assert str(first).startswith(f"{kind}.pddl:{line}:{col}: error: ")
    assert "^" in str(first)  # the caret line


def test_a_domain_naming_an_undeclared_object_is_a_placed_warning():
    # (issue 14 row 14: a problem may declare it, as Fast Downward allows; see
    # tests/test_domain_objects.py for the error when no file declares it)
    from ssr_compile.check import check_domain
    from ssr_compile.parse import parse_text

    text = DOMAIN.replace(PRE, ":precondition (on ?x floor)")
    report = check_domain(parse_text(text, "domain.pddl"), filename="domain.pddl", source=text)
    assert report.errors == []
    assert any(w.startswith("domain.pddl:6:60: warning: 'floor'") for w in report.warnings)


def test_each_mistake_is_said_once():
    errors = errors_of("stream", STREAMS.replace(":certified (on ?x ?y)", ":certified (on ?x ?z)"))
    assert len(errors) == 1
    errors = errors_of(
        "stream", STREAMS.replace(":certified (on ?x ?y)", ":certified (on ?x ?y ?x)")
    )
    assert len(errors) == 1


def test_undeclared_requirements_are_warnings():
    text = DOMAIN.replace(PRE, ":precondition (and (not (clear ?x)) (or (clear ?x)))")
    report = check_domain(parse_text(text), filename="d.pddl")
    assert report.errors == []
    assert report.warnings == [
        "d.pddl:1:17: warning: uses requirements it does not declare: "
        ":disjunctive-preconditions :negative-preconditions"
    ]
    # :adl implies them; no :requirements at all means nothing to compare against.
    adl = text.replace(":strips :typing :equality", ":adl")
    assert check_domain(parse_text(adl)).warnings == []
    none = text.replace("(:requirements :strips :typing :equality)", "")
    assert check_domain(parse_text(none)).warnings == []


def test_bare_total_cost_in_the_metric_is_a_function():
    text = PROBLEM.replace("(:goal (on b2 b1))", "(:goal (on b2 b1)) (:metric minimize total-cost)")
    assert errors_of("problem", text) == []


def test_stream_file_alone_judges_arity_consistency():
    text = """(define (stream s)
  (:stream g :inputs (?x) :domain (p ?x) :outputs (?y) :certified (p ?x ?y)))"""
    report = check_streams(parse_text(text), None, filename="s.pddl", source=text)
    assert [(e.line, e.col) for e in report.errors] == [(2, 68)]
    assert "'p' takes 1 argument, found 2" in report.errors[0].message


def test_a_derived_predicate_may_be_read_in_a_conditional_effect():
    # Only what an effect adds or deletes "changes" a predicate: a `when` condition reads it
    # (the kitchen's press-on cooks what is derived to be on the stove).
    text = """(define (domain d) (:requirements :strips :derived-predicates :conditional-effects)
      (:predicates (at ?x ?s) (hot) (cooked ?x) (on ?x))
      (:derived (on ?x) (at ?x stove))
      (:action press :parameters ()
        :effect (and (hot) (forall (?o) (when (on ?o) (cooked ?o))))))"""
    errors = [str(e) for e in check_domain(parse_text(text, "d.pddl")).errors]
    assert not any("derived" in e for e in errors), errors
    bad = text.replace("(cooked ?o)))))", "(on ?o)))))")
    errors = [str(e) for e in check_domain(parse_text(bad, "d.pddl")).errors]
    assert any("changes derived predicate 'on'" in e for e in errors), errors


def test_a_disjunct_that_leaves_a_head_variable_unbound_is_warned_about():
    """Fast Downward grounds a disjunct of an axiom that does not bind ?o over every object:
    the kitchen's boccluded once produced 22,540 atoms on a Swap replan that way."""
    domain = parse_text(
        """(define (domain d)
          (:requirements :strips :derived-predicates :disjunctive-preconditions
                         :existential-preconditions)
          (:predicates (obs ?o ?x) (obson ?x ?d) (closed ?d) (hidden ?o ?x) (seen ?o ?x))
          (:derived (hidden ?o ?x)
            (or (seen ?o ?x)
                (exists (?d) (and (obson ?x ?d) (closed ?d))))))""",
        "d.pddl",
    )
    report = check_domain(domain, filename="d.pddl")
    assert report.errors == []
    assert len(report.warnings) == 1
    warning = report.warnings[0]
    assert "disjunct 2 of derived predicate 'hidden'" in warning and "?o" in warning
    assert "?x" not in warning.split("bind")[1].split("with")[0]


def test_shipped_domains_bind_every_head_variable():
    for folder in Path(__file__).resolve().parent.parent.joinpath("domains", "pddl").iterdir():
        domain = parse_file(folder / "domain.pddl")
        report = check_domain(domain)
        assert not [w for w in report.warnings if "does not bind" in w], folder.name
