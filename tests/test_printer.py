"""Printer tests: canonical text, round trips over fixtures and the corpus, and a property test.

``parse(to_text(t)) == t`` and ``to_text`` is idempotent, in the long forms and in the paper's
shorthand; hypothesis generates valid trees (lower-case names, untyped names only at the end
of a typed list, ...) and checks print -> parse -> equal.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from conftest import require_corpus
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ssr_compile import syntax as S
from ssr_compile.parse import parse_file, parse_text
from ssr_compile.printer import to_text, typed_list

FIXTURES = Path(__file__).parent / "fixtures" / "lang"

SHORT_WORDS = re.compile(r"(:param|:pre|:eff|:inp|:dom|:out|:cert|\(incr) ")


def assert_round_trip(tree: S.File, where: str) -> None:
    long_text = to_text(tree)
    again = parse_text(long_text, f"{where} (printed)")
    assert again == tree, where
    assert to_text(again) == long_text, f"printing {where} is not idempotent"
    assert not SHORT_WORDS.search(long_text), f"{where}: long form printed with shorthand"
    short_text = to_text(tree, shorthand=True)
    again = parse_text(short_text, f"{where} (shorthand)")
    assert again == tree, where
    assert to_text(again, shorthand=True) == short_text


@pytest.mark.parametrize(
    "path",
    sorted(FIXTURES.rglob("*.pddl")),
    ids=lambda p: p.relative_to(FIXTURES).as_posix(),
)
def test_fixture_round_trip(path):
    assert_round_trip(parse_file(path), str(path))


def test_corpus_round_trip():
    corpus_files = sorted(require_corpus("pddlstream-examples").rglob("*.pddl"))
    assert len(corpus_files) > 50
    for path in corpus_files:
        assert_round_trip(parse_file(path), str(path))


def test_shorthand_printing_uses_the_papers_keywords():
    d = parse_file(FIXTURES / "kitchen" / "domain.pddl")
    short = to_text(d, shorthand=True)
    assert "\n    :param (?o ?pb1 ?obs ?pb2)\n" in short
    assert ":pre (and (beliefupdate ?o ?pb1 ?obs ?pb2)" in short
    assert "(incr (total-cost) (obscost ?o ?pb1 ?obs))" in short
    assert ":parameters" not in short and "increase" not in short
    f = parse_file(FIXTURES / "kitchen" / "stream.pddl")
    short = to_text(f, shorthand=True)
    for word in (":inp (?o ?pb1 ?obs)", ":dom (and (poseb ?o ?pb1)", ":out (?pb2)", ":cert "):
        assert word in short
    assert ":inputs" not in short and ":certified" not in short


def test_short_fixture_prints_as_the_long_fixture():
    for kind in ("domain", "stream"):
        short = parse_file(FIXTURES / "kitchen_short" / f"{kind}.pddl")
        long_form = parse_file(FIXTURES / "kitchen" / f"{kind}.pddl")
        assert to_text(short) == to_text(long_form)


def test_canonical_text_of_a_small_domain():
    d = parse_text(
        "(DEFINE (DOMAIN D) (:requirements :strips :TYPING) (:types b - object)"
        " (:predicates (P ?x - b) (q))"
        " (:functions (f ?x) - number) (:action A :param (?x - b ?y - b) :pre (and (p ?x) (Q))"
        " :eff (and (not (q)) (incr (f ?x) 1.0))))",
        "d.pddl",
    )
    assert to_text(d) == (
        "(define (domain d)\n"
        "  (:requirements :strips :typing)\n"
        "  (:types b - object)\n"
        "  (:predicates (p ?x - b) (q))\n"
        "  (:functions (f ?x) - number)\n"
        "  (:action a\n"
        "    :parameters (?x ?y - b)\n"
        "    :precondition (and (p ?x) (q))\n"
        "    :effect (and (not (q)) (increase (f ?x) 1.0))))\n"
    )


def test_canonical_text_of_a_problem_and_stream_file():
    p = parse_text(
        "(define (problem p) (:domain d) (:objects a b - t c) (:init (p a) (= (f a) 2))"
        " (:goal (p b)) (:metric minimize (total-cost)))",
        "p.pddl",
    )
    assert to_text(p) == (
        "(define (problem p)\n"
        "  (:domain d)\n"
        "  (:objects a b - t c)\n"
        "  (:init (p a) (= (f a) 2))\n"
        "  (:goal (p b))\n"
        "  (:metric minimize (total-cost)))\n"
    )
    f = parse_text(
        "(define (stream s) (:stream g :inp (?x) :dom (p ?x) :out (?y) :cert (q ?x ?y))"
        " (:function (F ?x) (p ?x)))",
        "s.pddl",
    )
    assert to_text(f) == (
        "(define (stream s)\n"
        "  (:stream g\n"
        "    :inputs (?x)\n"
        "    :domain (p ?x)\n"
        "    :outputs (?y)\n"
        "    :certified (q ?x ?y))\n"
        "  (:function (f ?x)\n"
        "    (p ?x)))\n"
    )


def test_long_formulas_break_over_lines_and_stay_in_width():
    atoms = " ".join(f"(some-long-predicate-{i} ?x ?y)" for i in range(8))
    d = parse_text(
        f"(define (domain d) (:action a :parameters (?x ?y) :precondition (and {atoms})))", "d"
    )
    text = to_text(d)
    assert max(len(line) for line in text.splitlines()) <= 92
    assert text.count("\n") > 8
    assert parse_text(text, "again") == d


def test_numbers_print_as_they_parse():
    d = parse_text(
        "(define (domain d) (:action a :parameters () :effect (and (increase (f) 2)"
        " (decrease (f) 2.0) (assign (f) -0.25) (scale-up (f) 1e-07) (scale-down (f) 3e20))))",
        "n",
    )
    text = to_text(d)
    assert "(increase (f) 2)" in text and "(decrease (f) 2.0)" in text
    assert "(assign (f) -0.25)" in text and "(scale-up (f) 1e-07)" in text
    values = [e.value.value for e in d.actions[0].effect.args]
    assert [type(v) for v in values] == [int, float, float, float, float]
    assert parse_text(text, "again") == d


def test_typed_list_groups_consecutive_types():
    items = (
        S.Typed("?a", "t"),
        S.Typed("?b", "t"),
        S.Typed("?c", S.Either(("t", "u"))),
        S.Typed("?d"),
    )
    assert typed_list(items) == "?a ?b - t ?c - (either t u) ?d"


# ---------------------------------------------------------------- property test

KEYWORDS = {
    "define", "domain", "problem", "stream", "and", "or", "not", "imply", "exists", "forall",
    "when", "either", "at", "over", "increase", "incr", "decrease", "assign", "scale-up",
    "scale-down", "minimize", "maximize",
}  # fmt: skip

names = st.from_regex(r"@?[a-z][a-z0-9_\-]{0,5}", fullmatch=True).filter(
    lambda n: n not in KEYWORDS
)
variables = names.map(lambda n: "?" + n)
type_refs = st.one_of(
    names, st.lists(names, min_size=1, max_size=3).map(lambda ts: S.Either(tuple(ts)))
)


def typed(item_names):
    """A typed list: groups of names with a type, then (optionally) untyped names at the end."""
    group = st.tuples(st.lists(item_names, min_size=1, max_size=3), type_refs)
    return st.builds(
        lambda groups, tail: tuple(
            [S.Typed(n, t) for ns, t in groups for n in ns] + [S.Typed(n) for n in tail]
        ),
        st.lists(group, max_size=2),
        st.lists(item_names, max_size=2),
    )


terms = st.one_of(variables.map(S.Var), names.map(S.Const))
const_terms = names.map(S.Const)
numbers = st.one_of(
    st.integers(-(10**6), 10**6),
    st.floats(allow_nan=False, allow_infinity=False, width=64, min_value=-1e30, max_value=1e30),
).map(S.Num)
func_terms = st.builds(S.FuncTerm, names, st.lists(terms, max_size=3).map(tuple))


def _arith(children):
    two = st.builds(
        S.Arith,
        st.sampled_from(["+", "*", "/", "-"]),
        st.lists(children, min_size=2, max_size=3).map(tuple),
    )
    negate = st.builds(lambda x: S.Arith("-", (x,)), children)
    return st.one_of(two, negate)


num_exprs = st.recursive(st.one_of(numbers, func_terms, terms), _arith, max_leaves=4)
atoms = st.builds(S.Atom, names, st.lists(terms, max_size=3).map(tuple))


def _compare(op, left, right):
    both_terms = all(isinstance(x, (S.Var, S.Const)) for x in (left, right))
    if op == "=" and both_terms:
        return S.Atom("=", (left, right))  # how (= a b) is read
    return S.Compare(op, left, right)


comparisons = st.builds(
    _compare, st.sampled_from(["=", "<", "<=", ">", ">="]), num_exprs, num_exprs
)


def _gd_children(children):
    small = st.lists(children, max_size=3).map(tuple)
    quantified = st.lists(variables, min_size=1, max_size=2)
    return st.one_of(
        st.builds(S.And, small),
        st.builds(S.Or, small),
        st.builds(S.Not, children),
        st.builds(S.Imply, children, children),
        st.builds(S.Exists, typed(variables).filter(bool), children),
        st.builds(S.Forall, quantified.map(lambda vs: tuple(S.Typed(v) for v in vs)), children),
    )


gds = st.recursive(st.one_of(atoms, comparisons), _gd_children, max_leaves=6)
numeric_effects = st.builds(
    S.NumericEffect,
    st.sampled_from(["increase", "decrease", "assign", "scale-up", "scale-down"]),
    func_terms,
    num_exprs,
)


def _effect_children(children):
    return st.one_of(
        st.builds(S.And, st.lists(children, max_size=3).map(tuple)),
        st.builds(S.Forall, typed(variables).filter(bool), children),
        st.builds(S.When, gds, children),
    )


effects = st.recursive(
    st.one_of(atoms, atoms.map(S.Not), numeric_effects), _effect_children, max_leaves=5
)
time_specs = st.sampled_from(["at start", "at end", "over all"])
da_gds = st.recursive(
    st.builds(S.Timed, time_specs, gds),
    lambda c: st.one_of(
        st.builds(S.And, st.lists(c, max_size=2).map(tuple)),
        st.builds(S.Forall, typed(variables).filter(bool), c),
    ),
    max_leaves=3,
)
da_effects = st.recursive(
    st.builds(S.Timed, time_specs, effects),
    lambda c: st.one_of(
        st.builds(S.And, st.lists(c, max_size=2).map(tuple)),
        st.builds(S.When, da_gds, c),
    ),
    max_leaves=3,
)

requirements = st.one_of(
    st.none(), st.lists(names.map(lambda n: ":" + n.lstrip("@")), max_size=3).map(tuple)
)
functions = st.builds(
    lambda typed_part, tail: tuple(typed_part + tail),
    st.lists(st.builds(S.FunctionDecl, names, typed(variables), st.just("number")), max_size=2),
    st.lists(st.builds(S.FunctionDecl, names, typed(variables)), max_size=1),
)
actions = st.builds(
    S.Action, names, typed(variables), st.one_of(st.none(), gds), st.one_of(st.none(), effects)
)
durative_actions = st.builds(
    S.DurativeAction,
    names,
    typed(variables),
    st.one_of(
        st.none(),
        st.builds(
            S.Compare,
            st.sampled_from(["=", "<=", ">="]),
            st.just(S.Var("?duration")),
            st.one_of(numbers, func_terms),
        ),
    ),
    st.one_of(st.none(), da_gds),
    st.one_of(st.none(), da_effects),
)
domains = st.builds(
    S.Domain,
    names,
    requirements,
    typed(names),
    typed(names),
    st.lists(st.builds(S.PredicateDecl, names, typed(variables)), max_size=3).map(tuple),
    functions,
    st.lists(st.builds(S.Axiom, names, typed(variables), gds), max_size=2).map(tuple),
    st.lists(actions, max_size=2).map(tuple),
    st.lists(durative_actions, max_size=1).map(tuple),
)
init_facts = st.one_of(
    st.builds(S.Atom, names, st.lists(const_terms, max_size=3).map(tuple)),
    st.builds(S.Not, st.builds(S.Atom, names, st.lists(const_terms, max_size=2).map(tuple))),
    st.builds(
        S.InitValue,
        st.builds(S.FuncTerm, names, st.lists(const_terms, max_size=2).map(tuple)),
        numbers,
    ),
)
problems = st.builds(
    S.Problem,
    names,
    st.one_of(st.none(), names),
    requirements,
    typed(names),
    st.lists(init_facts, max_size=4).map(tuple),
    st.one_of(st.none(), gds),
    st.one_of(st.none(), st.builds(S.Metric, st.sampled_from(["minimize", "maximize"]), num_exprs)),
)
streams = st.builds(
    S.Stream,
    names,
    typed(variables),
    st.one_of(st.none(), gds),
    st.lists(names, max_size=2).map(tuple),
    typed(variables),
    st.one_of(st.none(), gds),
)
opt_field = st.one_of(
    st.tuples(st.just(":inputs"), typed(variables)),
    st.tuples(st.just(":domain"), gds),
    st.tuples(st.just(":fluents"), st.lists(names, max_size=2).map(tuple)),
    st.tuples(st.just(":graph"), gds),
    st.tuples(st.just(":necessary"), gds),
)
opt_fields = st.lists(opt_field, max_size=3, unique_by=lambda kv: kv[0]).map(tuple)
optimizer_blocks = st.one_of(
    st.builds(S.OptimizerBlock, st.just("variables"), typed(variables), opt_fields),
    st.builds(S.OptimizerBlock, st.just("constraint"), atoms, opt_fields),
    st.builds(S.OptimizerBlock, st.just("objective"), names),
)
stream_files = st.builds(
    S.StreamFile,
    names,
    st.lists(streams, max_size=2).map(tuple),
    st.lists(
        st.builds(S.StreamFunction, names, typed(variables), st.one_of(st.none(), gds)), max_size=1
    ).map(tuple),
    st.lists(
        st.builds(S.StreamPredicate, names, typed(variables), st.one_of(st.none(), gds)),
        max_size=1,
    ).map(tuple),
    st.lists(
        st.builds(S.Rule, typed(variables), st.one_of(st.none(), gds), st.one_of(st.none(), gds)),
        max_size=1,
    ).map(tuple),
    st.lists(
        st.builds(S.Optimizer, names, st.lists(optimizer_blocks, max_size=3).map(tuple)),
        max_size=1,
    ).map(tuple),
)


@settings(
    max_examples=200,
    derandomize=True,
    deadline=None,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
@given(st.one_of(domains, problems, stream_files))
def test_print_parse_round_trip(tree):
    assert_round_trip(tree, "generated")
