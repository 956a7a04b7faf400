"""The formula walkers, the atom matcher and the feature detector of ssr_compile.formulas.

The expected features of the shipped domains and of the pddlstream example corpus
(tests/fixtures/lang/features.json) were recorded from the three detectors that the module
replaced: the planners' (planners/features.py), the lowering's requirement flags
(compile/lower.py) and the checker's "uses requirements it does not declare" warning.
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import pytest

from ssr_compile import syntax as S
from ssr_compile.check import check_domain
from ssr_compile.formulas import (
    atoms,
    changed_atoms,
    domain_requirements,
    formula_features,
    free_variables,
    match,
    planner_features,
    requirements_of,
    undeclared_requirements,
    unify,
    variable_names,
)
from ssr_compile.parse import parse_domain, parse_file

ROOT = Path(__file__).resolve().parent.parent
CORPUS = Path("/work/shared/corpus/pddlstream-examples")
EXPECTED = json.loads((ROOT / "tests/fixtures/lang/features.json").read_text())


def _domain(body: str) -> S.Domain:
    return parse_domain(
        "(define (domain d) (:predicates (p ?x) (q ?x ?y) (r)) (:functions (f ?x)) " + body + ")"
    )


def _action(domain: S.Domain, i: int = 0) -> S.Action:
    return domain.actions[i]


def _names(vs) -> list[str]:
    return [v.name for v in vs]


# ---------------------------------------------------------------- walkers


def test_quantifiers_bind_their_variables():
    d = _domain(
        "(:action a :parameters (?x) :precondition (and (p ?x) (exists (?y) (q ?x ?y)) "
        "(forall (?z) (imply (p ?z) (q ?z ?w)))) :effect (r))"
    )
    pre = _action(d).precondition
    assert _names(free_variables(pre)) == ["?x", "?x", "?w"]
    assert variable_names(pre) == {"?x", "?y", "?z", "?w"}
    assert [str(a) for a in atoms(pre)] == ["(p ?x)", "(q ?x ?y)", "(p ?z)", "(q ?z ?w)"]


def test_a_variable_bound_inside_is_free_outside():
    f = S.And(
        (
            S.Exists((S.Typed("?y"),), S.Atom("p", (S.Var("?y"),))),
            S.Atom("p", (S.Var("?y"),)),
        )
    )
    assert _names(free_variables(f)) == ["?y"]
    assert free_variables(None) == [] and atoms(None) == []


def test_when_effects_change_only_their_effect():
    d = _domain(
        "(:action a :parameters (?x) :precondition (p ?x) :effect (and (not (p ?x)) "
        "(forall (?y) (when (and (q ?x ?y) (not (r))) (and (q ?y ?x) (increase (f ?y) 1))))))"
    )
    eff = _action(d).effect
    assert [str(a) for a in changed_atoms(eff)] == ["(p ?x)", "(q ?y ?x)"]
    assert [str(a) for a in atoms(eff)] == ["(p ?x)", "(q ?x ?y)", "(r)", "(q ?y ?x)"]
    # the numeric effect's (f ?y) is a variable use too; ?y is bound by the forall
    assert _names(free_variables(eff)) == ["?x", "?x", "?x"]


def test_free_variables_of_comparisons():
    f = S.Compare("<", S.FuncTerm("f", (S.Var("?a"),)), S.Arith("+", (S.Var("?b"), S.Num(1))))
    assert _names(free_variables(f)) == ["?a", "?b"]


def test_derived_predicates():
    d = _domain(
        "(:derived (r) (exists (?x) (and (p ?x) (not (q ?x ?v))))) "
        "(:action a :parameters () :precondition (not (r)) :effect (p c))"
    )
    (ax,) = d.axioms
    assert _names(free_variables(ax.body)) == ["?v"]
    assert [a.pred for a in atoms(ax.body)] == ["p", "q"]
    features = planner_features(d, S.Problem("p"))
    assert features == {"axioms", "quantifiers", "negative_preconditions"}
    assert ":derived-predicates" in requirements_of(d, S.Problem("p"))


# ---------------------------------------------------------------- matching


def test_match_extends_a_binding_without_changing_it():
    pattern = S.Atom("q", (S.Var("?x"), S.Var("?x")))
    binding = {"?z": "o"}
    assert match(pattern, ("a", "a"), binding) == {"?z": "o", "?x": "a"}
    assert binding == {"?z": "o"}
    assert match(pattern, ("a", "b"), binding) is None
    assert match(pattern, ("a",), binding) is None
    same = {"?x": "a"}
    assert match(pattern, ("a", "a"), same) is same  # nothing added: no copy


def test_unify_against_a_ground_atom():
    pattern = S.Atom("q", (S.Const("c"), S.Var("?y")))
    assert unify(pattern, S.Atom("q", (S.const("c"), S.const("d"))), {}) == {"?y": "d"}
    assert unify(pattern, S.Atom("q", (S.const("e"), S.const("d"))), {}) is None


# ---------------------------------------------------------------- features


def test_negation_is_read_with_its_polarity():
    # (not (not p)) is positive for a planner, but its requirements line names the negation
    d = _domain("(:action a :parameters () :precondition (not (not (r))) :effect (r))")
    assert "negative_preconditions" not in planner_features(d, S.Problem("p"))
    assert ":negative-preconditions" in requirements_of(d, S.Problem("p"))
    d = _domain("(:action a :parameters () :precondition (imply (r) (r)) :effect (r))")
    assert planner_features(d, S.Problem("p")) == {"disjunction", "negative_preconditions"}


def test_a_when_condition_is_read_by_planners_not_by_the_requirements_line():
    d = _domain("(:action a :parameters (?x) :effect (when (not (= ?x c)) (p ?x)))")
    assert planner_features(d, S.Problem("p")) == {
        "conditional_effects",
        "equality",
        "negative_preconditions",
    }
    assert requirements_of(d, S.Problem("p")) == (":strips", ":conditional-effects")
    assert domain_requirements(d) == {
        ":conditional-effects",
        ":equality",
        ":negative-preconditions",
    }


def test_features_of_one_formula():
    f = S.Not(S.Exists((S.Typed("?y"),), S.Atom("=", (S.Var("?y"), S.Const("c")))))
    assert formula_features(f) == {
        ("not", "condition"),
        ("exists", "condition"),
        ("=", "condition"),
        ("negative", "condition"),
    }
    cost = S.NumericEffect("increase", S.FuncTerm("total-cost"), S.Num(1))
    assert formula_features(cost, effect=True) == {
        ("cost-increase", "effect"),
        ("total-cost", "effect"),
    }


def test_implied_requirements():
    assert undeclared_requirements([":adl"], [":equality", ":action-costs"]) == [":action-costs"]
    assert undeclared_requirements([":fluents"], [":numeric-fluents"]) == []


def _domains():
    for key in sorted(EXPECTED):
        if key.startswith("corpus:"):
            path = CORPUS / key.removeprefix("corpus:")
        else:
            path = ROOT / key
        yield pytest.param(key, path, id=key)


@pytest.mark.parametrize(("key", "path"), list(_domains()))
def test_the_detector_agrees_with_the_detectors_it_replaced(key, path):
    if not path.exists():
        pytest.skip(f"{path} is not on this machine")
    domain = parse_file(path, kind="domain")
    want = EXPECTED[key]
    problem = S.Problem("p")
    assert sorted(planner_features(domain, problem)) == want["planner"]
    assert list(requirements_of(domain, problem)) == want["requirements"]
    report = check_domain(replace(domain, requirements=()))
    found = [w.split("declare: ", 1)[1].split() for w in report.warnings if "declare: " in w]
    assert (found[0] if found else []) == want["checker"]
