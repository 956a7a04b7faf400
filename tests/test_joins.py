"""Joins over facts: the indexed join of stream domains (``compile/join.py``) gives the bindings
of a walk over every fact, in the same order; a plan preimage finds the objects a derived
condition may hold for through its axiom, in the order of the problem's objects."""

import random

import pytest

from ssr_compile import syntax as S
from ssr_compile.compile.join import FactIndex, _matches
from ssr_compile.parse import parse_domain, parse_problem
from ssr_compile.solver.preimage import PlanInvalid, _SupportTracker, plan_preimage


def fact(pred: str, *args: str) -> S.Atom:
    return S.Atom(pred, tuple(S.Const(a) for a in args))


def var(name: str) -> S.Var:
    return S.Var(name)


# (kin ?o ?p ?g ?q): ?o at ?p with grasp ?g is reached from ?q; ?o must be at ?p and graspable
DOMAIN = S.And(
    (
        S.Atom("pose", (var("?o"), var("?p"))),
        S.Atom("kin", (var("?o"), var("?p"), var("?g"), var("?q"))),
        S.Atom("grasp", (var("?o"), var("?g"))),
        S.Atom("base", (S.Const("robot"), var("?q"))),
    )
)
PARAMS = tuple(S.Typed(n) for n in ("?o", "?p", "?g", "?q"))


def random_facts(rng: random.Random, n: int) -> list[S.Atom]:
    objs, poses, grasps, confs = "abcd", "p1 p2 p3".split(), "g1 g2".split(), "q1 q2 q3 q4".split()
    out = []
    for _ in range(n):
        kind = rng.choice(["pose", "kin", "kin", "grasp", "base"])
        if kind == "pose":
            out.append(fact("pose", rng.choice(objs), rng.choice(poses)))
        elif kind == "kin":
            args = (rng.choice(objs), rng.choice(poses), rng.choice(grasps), rng.choice(confs))
            out.append(fact("kin", *args))
        elif kind == "grasp":
            out.append(fact("grasp", rng.choice(objs), rng.choice(grasps)))
        else:
            out.append(fact("base", rng.choice(["robot", "other"]), rng.choice(confs)))
    return list(dict.fromkeys(out))


def plain_index(facts):
    index: dict[str, list[S.Atom]] = {}
    for f in facts:
        index.setdefault(f.pred, []).append(f)
    return index


def test_an_indexed_join_gives_a_full_walks_bindings_in_its_order():
    rng = random.Random(3)
    facts = random_facts(rng, 160)
    first, later = facts[:40], facts[40:]
    indexed = FactIndex()
    for f in first:
        indexed.add(f)
    before = list(_matches(PARAMS, DOMAIN, indexed, None))
    assert before == list(_matches(PARAMS, DOMAIN, plain_index(first), None))
    assert before  # the join binds something, so the order is compared
    # facts added after the positions were indexed are found too, in their place
    for f in later:
        indexed.add(f)
    after = list(_matches(PARAMS, DOMAIN, indexed, None))
    assert after == list(_matches(PARAMS, DOMAIN, plain_index(facts), None))
    assert len(after) > len(before)
    # joined through the newest facts only (a depth of instantiation)
    fresh = later[:30]
    assert list(_matches(PARAMS, DOMAIN, indexed, None, fresh)) == list(
        _matches(PARAMS, DOMAIN, plain_index(facts), None, fresh)
    )


def test_the_index_narrows_to_the_facts_with_an_object_at_a_position():
    index = FactIndex()
    for f in [fact("kin", "a", "p1", "g1", "q1"), fact("kin", "b", "p1", "g1", "q2")]:
        index.add(f)
    assert index.having("kin", 0, "b") == [fact("kin", "b", "p1", "g1", "q2")]
    index.add(fact("kin", "b", "p2", "g2", "q3"))
    assert [f.args[3].name for f in index.having("kin", 0, "b")] == ["q2", "q3"]
    assert index.having("kin", 2, "g9") == []


STOVE = """
(define (domain stove)
  (:requirements :strips :negative-preconditions :derived-predicates
                 :existential-preconditions :conditional-effects)
  (:constants stove)
  (:predicates (atpose ?o ?p) (supports ?p ?s) (cooked ?o) (ready) (hot))
  (:derived (on ?o ?s) (exists (?p) (and (atpose ?o ?p) (supports ?p ?s))))
  (:derived (warm ?o) (cooked ?o))
  (:derived (warm ?o) (on ?o stove))
  (:action press
    :parameters ()
    :precondition (exists (?o) (on ?o stove))
    :effect (and (hot) (forall (?o) (when (on ?o stove) (cooked ?o)))))
  (:action serve
    :parameters ()
    :precondition (hot)
    :effect (forall (?o) (when (warm ?o) (ready)))))
"""


def stove_problem(objects: str, *init: str, goal: str = "(hot)") -> S.Problem:
    return parse_problem(
        f"""(define (problem p) (:domain stove) (:objects {objects})
        (:init {" ".join(init)}) (:goal {goal}))"""
    )


def test_a_conditional_effect_fires_for_the_objects_its_derived_condition_holds_for():
    domain = parse_domain(STOVE)
    filler = " ".join(f"x{i}" for i in range(200))
    init = ["(atpose z pz)", "(supports pz stove)", "(atpose a pa)", "(supports pa stove)"]
    init += ["(atpose b pb)", "(supports pb table)"]
    problem = stove_problem(f"z a b pz pa pb table {filler}", *init)
    tracker = _SupportTracker(domain, [o.name for o in problem.objects] + ["stove"], set())
    tracker.set_state({f for f in problem.init if isinstance(f, S.Atom)})
    press = next(a for a in domain.actions if a.name == "press")
    effect = next(e for e in press.effect.args if isinstance(e, S.Forall))
    guard = effect.body.condition
    found = [b["?o"].name for b in tracker.bindings(effect.params, guard, only=True)]
    # only the objects the axiom's facts name, in the problem's order (z before a)
    assert found == ["z", "a"]
    every = [b["?o"].name for b in tracker.bindings(effect.params, guard)]
    assert len(every) == len(problem.objects) + 1  # without ``only``: every object
    assert [o for o in every if tracker.holds(guard, env={"?o": S.Const(o)})[0]] == found


def test_the_preimage_supports_the_first_object_in_the_problems_order():
    domain = parse_domain(STOVE)
    init = ["(atpose z pz)", "(supports pz stove)", "(atpose a pa)", "(supports pa stove)"]
    init += ["(atpose b pb)", "(supports pb table)"]
    # a's facts come first in the state; z comes first among the objects
    problem = stove_problem("z a b pz pa pb table", *reversed(init), goal="(and (hot) (ready))")
    pre = plan_preimage(domain, problem, [("press", ()), ("serve", ())])
    assert pre.per_step[0] == {fact("atpose", "z", "pz"), fact("supports", "pz", "stove")}


def test_a_condition_of_two_axioms_fires_where_either_holds():
    domain = parse_domain(STOVE)
    # (warm ?o) has two axioms: serve's effect fires for the cooked object on the table
    problem = stove_problem(
        "a b pa pb table", "(atpose a pa)", "(supports pa table)", "(cooked a)", "(hot)",
        goal="(ready)",
    )  # fmt: skip
    assert plan_preimage(domain, problem, [("serve", ())]).per_step == [set()]
    cold = stove_problem(
        "a pa table", "(atpose a pa)", "(supports pa table)", "(hot)", goal="(ready)"
    )
    with pytest.raises(PlanInvalid, match="goal"):
        plan_preimage(domain, cold, [("serve", ())])


def test_an_object_on_the_table_is_not_cooked():
    domain = parse_domain(STOVE)
    problem = stove_problem(
        "a b pa pb table", "(atpose a pa)", "(supports pa table)", "(atpose b pb)",
        "(supports pb stove)",
    )  # fmt: skip
    tracker = _SupportTracker(domain, [o.name for o in problem.objects] + ["stove"], set())
    state = {f for f in problem.init if isinstance(f, S.Atom)}
    tracker.set_state(state)
    press = next(a for a in domain.actions if a.name == "press")
    effect = next(e for e in press.effect.args if isinstance(e, S.Forall))
    assert [
        b["?o"].name for b in tracker.bindings(effect.params, effect.body.condition, only=True)
    ] == ["b"]


def test_a_constant_listed_among_the_objects_keeps_its_first_place():
    # the preimage's object list is the problem's objects and then the domain's constants, so
    # an object that is also a constant comes twice; the walk over every object meets it first
    domain = parse_domain(STOVE)
    init = ["(atpose s ps)", "(supports ps stove)", "(atpose z pz)", "(supports pz stove)"]
    problem = stove_problem("s z ps pz", *init)
    objects = [o.name for o in problem.objects] + ["stove", "s"]
    tracker = _SupportTracker(domain, objects, set())
    tracker.set_state({f for f in problem.init if isinstance(f, S.Atom)})
    press = next(a for a in domain.actions if a.name == "press")
    effect = next(e for e in press.effect.args if isinstance(e, S.Forall))
    guard = effect.body.condition
    found = [b["?o"].name for b in tracker.bindings(effect.params, guard, only=True)]
    every = [b["?o"].name for b in tracker.bindings(effect.params, guard)]
    walked = [o for o in every if tracker.holds(guard, env={"?o": S.Const(o)})[0]]
    assert found == list(dict.fromkeys(walked)) == ["s", "z"]
