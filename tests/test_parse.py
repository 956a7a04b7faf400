"""Parser tests: the trees built from the fixtures, both syntaxes, and broken input.

Every broken input must give an SSRError that says where (line and column) and, in words,
what was expected; no Lark exception may escape, and the parser must keep working afterwards.
"""

from __future__ import annotations

import random
from pathlib import Path

import pytest

from ssr_compile import syntax as S
from ssr_compile.errors import PDDLSyntaxError, SSRError
from ssr_compile.parse import parse_file, parse_text, parser

FIXTURES = Path(__file__).parent / "fixtures" / "lang"
ALL_FIXTURES = sorted(FIXTURES.rglob("*.pddl"))


def fixture(path: str) -> S.File:
    return parse_file(FIXTURES / path)


def V(name: str) -> S.Var:
    return S.Var(name)


def C(name: str) -> S.Const:
    return S.Const(name)


def A(pred: str, *args: str) -> S.Atom:
    return S.Atom(pred, tuple(V(a) if a.startswith("?") else C(a) for a in args))


# ---------------------------------------------------------------- the fixtures' trees


def test_every_fixture_parses_to_its_kind():
    kinds = {
        p.relative_to(FIXTURES).as_posix(): fixture(p.relative_to(FIXTURES)).kind
        for p in ALL_FIXTURES
    }
    assert len(kinds) >= 12
    for path, kind in kinds.items():
        expected = Path(path).stem if Path(path).stem in ("domain", "problem") else "stream"
        assert kind == expected, path


def test_kitchen_domain_header():
    d = fixture("kitchen/domain.pddl")
    assert d.name == "kitchen-belief"
    assert ":derived-predicates" in d.requirements and len(d.requirements) == 11
    assert d.types == (
        S.Typed("movable", "object"),
        S.Typed("surface", "object"),
        S.Typed("drawer", S.Either(("surface", "movable"))),
        S.Typed("robot", None),
    )
    assert d.constants == (
        S.Typed("base", "robot"),
        S.Typed("arm", "robot"),
        S.Typed("@top", "drawer"),
        S.Typed("bottom", "drawer"),
    )
    inside = next(p for p in d.predicates if p.name == "inside")
    assert inside.params == (S.Typed("?o", "movable"), S.Typed("?d", "drawer"))
    assert next(p for p in d.predicates if p.name == "handempty").params == ()
    assert d.functions == (
        S.FunctionDecl("obscost", (S.Typed("?o"), S.Typed("?pb"), S.Typed("?obs")), "number"),
        S.FunctionDecl("dist", (S.Typed("?q1"), S.Typed("?q2")), "number"),
        S.FunctionDecl("total-cost", (), "number"),
    )


def test_boccluded_is_the_papers_derived_predicate():
    (ax,) = fixture("kitchen/domain.pddl").axioms
    assert ax == S.Axiom(
        "boccluded",
        (S.Typed("?o"), S.Typed("?obs")),
        S.Exists(
            (S.Typed("?o2"), S.Typed("?pb2")),
            S.And(
                (
                    A("obs", "?o", "?obs"),
                    A("atposeb", "?o2", "?pb2"),
                    S.Not(A("bvis", "?o", "?obs", "?o2", "?pb2")),
                )
            ),
        ),
    )


def test_detect_action_with_obscost():
    d = fixture("kitchen/domain.pddl")
    detect = next(a for a in d.actions if a.name == "detect")
    assert [p.name for p in detect.parameters] == ["?o", "?pb1", "?obs", "?pb2"]
    assert S.Not(A("boccluded", "?o", "?obs")) in detect.precondition.args
    cost = detect.effect.args[-1]
    assert cost == S.NumericEffect(
        "increase",
        S.FuncTerm("total-cost"),
        S.FuncTerm("obscost", (V("?o"), V("?pb1"), V("?obs"))),
    )


def test_formulas_of_close_action():
    d = fixture("kitchen/domain.pddl")
    close = next(a for a in d.actions if a.name == "close")
    assert close.parameters == (S.Typed("?d", "drawer"),)
    opened, either, imply, forall = close.precondition.args
    assert opened == A("open", "?d")
    assert either == S.Or(
        (A("handempty"), S.Exists((S.Typed("?o"), S.Typed("?g")), A("holding", "?o", "?g")))
    )
    assert imply == S.Imply(A("inside", "@top", "?d"), S.Not(A("=", "?d", "bottom")))
    assert forall == S.Forall((S.Typed("?o", "movable"),), S.Not(A("inside", "?o", "@top")))
    assert close.effect.args[1] == S.Forall(
        (S.Typed("?o", "movable"),),
        S.When(S.And((A("inside", "?o", "?d"), A("seen", "?o"))), S.Not(A("seen", "?o"))),
    )
    move = next(a for a in d.actions if a.name == "move")
    assert move.precondition.args[-1] == S.Compare(
        "<=", S.FuncTerm("dist", (V("?q1"), V("?q2"))), S.Num(100)
    )


def test_numeric_domain_operators():
    d = fixture("numeric/domain.pddl")
    ops = [e.op for a in d.actions for e in S.conjuncts(a.effect) if isinstance(e, S.NumericEffect)]
    assert sorted(set(ops)) == ["assign", "decrease", "increase", "scale-down", "scale-up"]
    comps = {
        c.op for a in d.actions for c in S.conjuncts(a.precondition) if isinstance(c, S.Compare)
    }
    assert comps == {"<", "<=", ">", ">=", "="}
    refuel = next(a for a in d.actions if a.name == "refuel")
    assert refuel.precondition == S.Compare(
        "<", S.FuncTerm("fuel", (V("?t"),)), S.Arith("-", (S.Num(5),))
    )
    drive = next(a for a in d.actions if a.name == "drive")
    cost = S.conjuncts(drive.effect)[-1]
    assert cost.value == S.Arith(
        "+",
        (
            S.FuncTerm("distance", (V("?a"), V("?b"))),
            S.Arith("/", (S.FuncTerm("load", (V("?t"),)), S.Num(4))),
            S.Num(1),
        ),
    )
    at = next(p for p in d.predicates if p.name == "at")
    assert at.params[0].type == S.Either(("truck", "crate"))


def test_numeric_problem():
    p = fixture("numeric/problem.pddl")
    assert p.domain_name == "depot-numeric"
    assert p.requirements == (":typing", ":numeric-fluents")
    assert p.objects[:3] == (S.Typed("t1", "truck"), S.Typed("c1", "crate"), S.Typed("c2", "crate"))
    values = {f.fluent: f.value.value for f in p.init if isinstance(f, S.InitValue)}
    assert values[S.FuncTerm("weight", (C("c1"),))] == 1.5
    assert values[S.FuncTerm("weight", (C("c2"),))] == 20.0
    assert values[S.FuncTerm("fuel", (C("t1"),))] == 40
    assert isinstance(values[S.FuncTerm("fuel", (C("t1"),))], int)
    assert values[S.FuncTerm("total-cost")] == 0
    assert p.metric.direction == "maximize"
    assert p.metric.expr.op == "-"


def test_kitchen_problem():
    p = fixture("kitchen/problem.pddl")
    assert S.Not(A("open", "@top")) in p.init
    assert S.InitValue(S.FuncTerm("dist", (C("q0"), C("q1"))), S.Num(2.5)) in p.init
    assert p.metric == S.Metric("minimize", S.FuncTerm("total-cost"))
    assert isinstance(p.goal.args[1], S.Exists)


def test_durative_actions():
    d = fixture("temporal/domain.pddl")
    drive, wait = d.durative_actions
    assert drive.duration == S.Compare(
        "=", V("?duration"), S.FuncTerm("travel-time", (V("?a"), V("?b")))
    )
    start, over, forall = drive.condition.args
    assert start == S.Timed("at start", A("at", "?v", "?a"))
    assert over == S.Timed("over all", A("road", "?a", "?b"))
    assert forall == S.Forall(
        (S.Typed("?p", "package"),), S.Timed("at start", S.Not(A("delivered", "?p")))
    )
    assert drive.effect.args[2] == S.Forall(
        (S.Typed("?p", "package"),),
        S.When(S.Timed("at start", A("in", "?p", "?v")), S.Timed("at end", A("delivered", "?p"))),
    )
    assert wait.duration == S.Compare("<=", V("?duration"), S.Num(5))
    assert wait.effect == S.Timed("at end", S.Not(A("ready", "?v")))


def test_stream_file_constructs():
    f = fixture("kitchen/stream.pddl")
    names = [s.name for s in f.streams]
    assert names == [
        "inv-kin",
        "motion",
        "sample-obs",
        "update-belief",
        "test-vis",
        "test-graspable",
    ]
    ub = f.streams[3]
    assert ub.inputs == (S.Typed("?o"), S.Typed("?pb1"), S.Typed("?obs"))
    assert ub.outputs == (S.Typed("?pb2"),)
    assert ub.domain == S.And((A("poseb", "?o", "?pb1"), A("obs", "?o", "?obs")))
    assert not ub.is_test
    assert f.streams[1].fluents == ("atposeb",)
    assert f.streams[4].is_test and f.streams[4].outputs == ()
    assert f.streams[5].is_test
    obscost, dist = f.functions
    assert obscost.name == "obscost" and len(obscost.params) == 3
    assert dist.domain == S.And((A("conf", "base", "?q1"), A("conf", "base", "?q2")))
    assert f.predicates == (
        S.StreamPredicate("free", (S.Typed("?o"), S.Typed("?pb")), A("poseb", "?o", "?pb")),
    )
    assert f.rules == (
        S.Rule((S.Typed("?o"), S.Typed("?g")), A("grasp", "?o", "?g"), A("graspable", "?o")),
    )
    (opt,) = f.optimizers
    assert [b.kind for b in opt.blocks] == ["variables", "constraint", "objective"]
    variables = opt.blocks[0]
    assert variables.head == (S.Typed("?pb"),)
    assert [k for k, _ in variables.fields] == [":inputs", ":domain", ":graph"]
    assert opt.blocks[1].head == A("kin", "?o", "?pb", "?g", "?bq", "?aq")
    assert opt.blocks[2].head == "dist"


@pytest.mark.parametrize("kind", ["domain", "stream"])
def test_shorthand_and_long_forms_give_equal_trees(kind):
    long_form = fixture(f"kitchen/{kind}.pddl")
    short = fixture(f"kitchen_short/{kind}.pddl")
    assert short == long_form
    # The texts really differ in their keywords.
    short_text = (FIXTURES / f"kitchen_short/{kind}.pddl").read_text()
    long_text = (FIXTURES / f"kitchen/{kind}.pddl").read_text()
    words = (":pre ", ":eff ", "incr ") if kind == "domain" else (":inp ", ":dom ", ":cert ")
    for w in words:
        assert w in short_text and w not in long_text


def test_incr_is_read_as_increase():
    d = parse_text("(define (domain d) (:action a :param () :eff (incr (total-cost) 3)))", "x.pddl")
    assert d.actions[0].effect == S.NumericEffect("increase", S.FuncTerm("total-cost"), S.Num(3))


# ---------------------------------------------------------------- real-file quirks


def test_names_are_case_insensitive_and_may_start_with_at():
    d = fixture("quirks/domain.pddl")
    assert d.name == "quirky"
    assert d.constants == (S.Typed("@table", "object"),)
    pick = d.actions[0]
    assert pick.name == "pick"
    assert pick.precondition.args[0] == A("bloc", "?b", "?p")  # written BLoc
    assert pick.precondition.args[1] == A("clear", "?b")  # written ?B
    assert pick.effect.args[0] == A("@holding", "?b")  # written @HOLDING
    assert [p.name for p in d.predicates] == ["block", "bloc", "@holding", "clear"]
    assert d.requirements is None  # missing :requirements is not the same as empty


def test_comments_anywhere():
    text = (
        "; head\n(define ; a\n (domain ; b\n d) ; c\n (:predicates ; d\n (p ; e\n ?x)) ; f\n"
        " (:action a :parameters ( ; g\n ?x) :precondition (and ; h\n (p ?x) ; (q ?x)\n)))\n; tail"
    )
    d = parse_text(text, "c.pddl")
    assert d.predicates == (S.PredicateDecl("p", (S.Typed("?x"),)),)
    assert d.actions[0].precondition == S.And((A("p", "?x"),))


def test_keywords_inside_names_are_names():
    d = parse_text(
        "(define (domain d) (:predicates (android ?x) (at ?x) (over ?x) (domain ?x)"
        " (notify ?x) (either-way ?x)))",
        "k.pddl",
    )
    assert [p.name for p in d.predicates] == [
        "android",
        "at",
        "over",
        "domain",
        "notify",
        "either-way",
    ]


def test_trailing_note_after_last_block_is_a_warning():
    warnings: list[str] = []
    d = parse_text(
        "(define (domain d)\n  (:predicates (p))\n  : TODO: more\n)", "t.pddl", warnings=warnings
    )
    assert d.predicates == (S.PredicateDecl("p"),)
    assert len(warnings) == 1
    assert warnings[0].startswith("t.pddl:3:3: ignored text after the last block")


def test_kind_argument():
    assert parse_text("(define (problem p))", kind="problem").name == "p"
    with pytest.raises(PDDLSyntaxError) as e:
        parse_text("(define (problem p) (:domain d))", "p.pddl", kind="domain")
    assert e.value.message == "found a problem file; expected a domain file"
    assert (e.value.line, e.value.col) == (1, 18)


def test_equality_of_names_vs_numbers():
    d = parse_text(
        "(define (domain d) (:action a :parameters (?x) :precondition"
        " (and (= ?x c) (= ?x 3) (= 2.0 2))))",
        "e.pddl",
    )
    eq_names, eq_num, eq_nums = d.actions[0].precondition.args
    assert eq_names == A("=", "?x", "c")
    assert eq_num == S.Compare("=", V("?x"), S.Num(3))
    assert eq_nums == S.Compare("=", S.Num(2.0), S.Num(2))


def test_spans_point_at_the_source_and_are_ignored_by_equality():
    d = fixture("kitchen/domain.pddl")
    (ax,) = d.axioms
    assert ax.span == S.Span(25, 14)  # the name after "(:derived ("
    assert S.Atom("p", (), span=S.Span(1, 1)) == S.Atom("p", (), span=S.Span(9, 9))
    assert hash(S.Atom("p", (), span=S.Span(1, 1))) == hash(S.Atom("p"))


# ---------------------------------------------------------------- broken input

DOMAIN_OK = """(define (domain d)
  (:predicates (p ?x))
  (:action a :parameters (?x) :precondition (p ?x) :effect (not (p ?x))))
"""

# (name, text, line, col, words the message must contain)
BAD_SYNTAX = [
    (
        "missing close paren",
        "(define (domain d)\n  (:predicates (p ?x)\n  (:action a :parameters (?x)))\n",
        3,
        4,
        "found ':action'; expected a name after '('",
    ),
    (
        "truncated file",
        "(define (domain d)\n  (:predicates (p ?x))\n  (:action a :parameters (?x) :precondition (and (p ?x)",
        3,
        56,
        "found the end of the file (3 unclosed '('); expected '(' or ')'",
    ),
    (
        "misspelled :action",
        "(define (domain d)\n  (:predicates (p ?x))\n  (:actiox a :parameters (?x)))\n",
        3,
        4,
        "found ':actiox'; expected one of :action, :constants, :derived",
    ),
    (
        "misspelled :parameters",
        "(define (domain d)\n  (:action a :parameterx (?x)))\n",
        2,
        14,
        "found ':parameterx'; expected one of :effect, :parameters, :precondition or ')'",
    ),
    (
        "misspelled :init",
        "(define (problem p) (:domain d)\n  (:inix (p a))\n  (:goal (p a)))\n",
        2,
        4,
        "found ':inix'; expected one of :domain, :goal, :init, :metric, :objects",
    ),
    (
        "misspelled :outputs",
        "(define (stream s)\n  (:stream g :inputs (?x) :outputx (?y)))\n",
        2,
        27,
        "found ':outputx'; expected one of :certified, :domain, :fluents, :inputs, :outputs",
    ),
    (
        "stray token between blocks",
        "(define (domain d)\n  (:predicates (p ?x))\n  :bogus-key 17 (:action a :parameters (?x)))\n",
        3,
        3,
        "found text ':bogus-key' outside any block; expected '(' starting a block",
    ),
    (
        "stray token inside an action",
        "(define (domain d)\n  (:action a :bogus-key 17 :parameters (?x)))\n",
        2,
        14,
        "found ':bogus-key'; expected one of :effect, :parameters, :precondition",
    ),
    (
        "parameters without a list",
        "(define (domain d)\n  (:action a :parameters ?x))\n",
        2,
        26,
        "expected a parameter list such as (?x ?y - type) after :parameters",
    ),
    (
        "shorthand parameters without a list",
        "(define (domain d)\n  (:action a :param ?x))\n",
        2,
        21,
        "expected a parameter list such as (?x ?y - type) after :param",
    ),
    (
        "precondition missing",
        "(define (domain d)\n  (:action a :parameters (?x) :precondition))\n",
        2,
        44,
        "found ')' too early; expected a condition such as (and (p ?x) (not (q ?x)))",
    ),
    (
        "inputs without a list",
        "(define (stream s)\n  (:stream g :inputs ?x))\n",
        2,
        22,
        "expected a variable list such as (?x ?y) after :inputs",
    ),
    (
        "binary junk",
        "(define (domain d)\n  (:pred\x00\x07icates (p ?x)))\n",
        2,
        9,
        "found the control character '\\x00'; expected plain text",
    ),
    ("empty file", "", 1, 1, "the file is empty"),
    ("only a comment", "  \n; nothing here\n", 1, 1, "the file is empty"),
    (
        "type marker with no name",
        "(define (domain d)\n  (:types - object))\n",
        2,
        11,
        "found '- type' with no name before it",
    ),
    (
        "type marker with no variable",
        "(define (domain d)\n  (:predicates (p - t)))\n",
        2,
        19,
        "found '- type' with no variable before it",
    ),
    (
        "non-= in :init",
        "(define (problem p) (:domain d)\n  (:init (< (f a) 3)))\n",
        2,
        11,
        "found '<' in :init; expected '=' giving a function's value",
    ),
    (
        "one ')' too many",
        "(define (domain d)\n  (:predicates (p ?x))))\n",
        2,
        24,
        "found one ')' too many",
    ),
    ("no define", "(domain d)\n", 1, 2, "found 'domain'; expected define after '('"),
    (
        "duplicate field",
        "(define (domain d)\n  (:action a :parameters (?x) :parameters (?y)))\n",
        2,
        31,
        "duplicate :parameters in action a",
    ),
    (
        "duplicate section",
        "(define (domain d)\n  (:predicates (p))\n  (:predicates (q)))\n",
        3,
        4,
        "duplicate :predicates in domain d",
    ),
    (
        "variable among objects",
        "(define (problem p) (:domain d)\n  (:objects ?a))\n",
        2,
        13,
        "found '?a'; expected object names after :objects",
    ),
    (
        "unary plus",
        "(define (domain d)\n (:action a :parameters () :precondition (< (+ 1) 2)))\n",
        2,
        46,
        "'+' needs at least two arguments",
    ),
    (
        "number too large",
        "(define (problem p) (:init (= (f) 1e999)))",
        1,
        35,
        "the number 1e999 is too large",
    ),
    (
        "text between blocks",
        "(define (domain d)\n  (:predicates (p ?x)) junk\n  (:action a :parameters ()))\n",
        2,
        24,
        "found text 'junk' outside any block",
    ),
    (
        "rule with outputs",
        "(define (stream s)\n  (:rule :inputs (?x) :outputs (?y)))\n",
        2,
        23,
        "a :rule has no :outputs",
    ),
]


@pytest.mark.parametrize(
    "text,line,col,words", [c[1:] for c in BAD_SYNTAX], ids=[c[0] for c in BAD_SYNTAX]
)
def test_bad_syntax_message_and_position(text, line, col, words):
    with pytest.raises(PDDLSyntaxError) as info:
        parse_text(text, "bad.pddl")
    e = info.value
    assert words in e.message
    assert (e.line, e.col) == (line, col)
    rendered = str(e)
    assert rendered.startswith(f"bad.pddl:{line}:{col}: syntax error: ")
    if text.strip():
        # The caret line points at the column.
        caret = rendered.splitlines()[-1]
        assert caret.index("^") == 4 + col - 1


def test_no_lark_exception_escapes_and_parser_survives():
    """Random damage to every fixture gives an SSRError or a tree; the parser keeps working."""
    rng = random.Random(7)
    before = parser()
    for path in ALL_FIXTURES:
        good = path.read_text()
        for _ in range(25):
            i = rng.randrange(len(good))
            j = min(len(good), i + rng.randrange(1, 12))
            bad = (
                good[:i]
                + rng.choice(["", "(", ")", "- ", "?", ":x ", "\x01", "@", "1e"])
                + good[j:]
            )
            try:
                parse_text(bad, "bad.pddl")
            except SSRError as e:
                assert e.line is not None and e.col is not None, (bad, e)
            assert parse_text(good, str(path)) == parse_file(path)
    assert parser() is before


def test_parser_works_after_a_failed_parse():
    with pytest.raises(SSRError):
        parse_text("(define (domain d) (:predicates (p ?x)", "x.pddl")
    with pytest.raises(SSRError):
        parse_text("(define (domain d) (:predicates - t))", "x.pddl")
    d = parse_text(DOMAIN_OK, "ok.pddl")
    assert d.actions[0].name == "a"


def test_deep_nesting_is_an_error_or_a_tree():
    text = "(define (domain d) (:predicates (p)) (:action a :parameters () :precondition "
    text += "(not " * 3000 + "(p)" + ")" * 3000 + "))"
    try:
        d = parse_text(text, "deep.pddl")
    except SSRError as e:
        assert e.line is not None
    else:
        assert isinstance(d.actions[0].precondition, S.Not)


def test_missing_file_and_directory(tmp_path):
    with pytest.raises(SSRError, match="no such file"):
        parse_file(tmp_path / "missing.pddl")
    with pytest.raises(SSRError, match="is a directory"):
        parse_file(tmp_path)
