"""Rescheduling the stream plan (paper §VII, "Deferred stream evaluation"): the streams the
first action needs, those never deferred and, recursively, their producers are evaluated now;
the rest is deferred.  Small hand-built stream plans, no planner."""

from __future__ import annotations

from ssr_compile import syntax as S
from ssr_compile.compile.instantiate import Instance, Instantiation, Result
from ssr_compile.solver.deferral import reschedule_stream_plan, stream_producers
from ssr_compile.solver.preimage import Preimage


def atom(pred: str, *args: str) -> S.Atom:
    return S.Atom(pred, tuple(S.Const(a) for a in args))


def result(stream, inputs, outputs=(), certified=(), domain=(), kind="stream") -> Result:
    return Result(Instance(stream, tuple(inputs), kind), tuple(outputs), tuple(certified),
                  tuple(domain), 1)  # fmt: skip


def instantiation(results: list[Result]) -> Instantiation:
    inst = Instantiation(None, None, results=list(results))
    for r in results:
        for o in r.outputs:
            inst.objects[o] = r
        for f in r.certified:
            inst.facts.setdefault(f, []).append(r)
    return inst


def deferrable_except(*never: str):
    return lambda stream: stream not in never


# The paper's example (equation 3), small: move the base to a configuration for the pick, pick,
# then move the arm.  #g, #q, #t1, #t2 are optimistic objects.
GRASP = result("sample-grasp", ["o"], ["#g"], [atom("Grasp", "o", "#g")])
IK = result("inv-kin", ["o", "#g"], ["#q"], [atom("Kin", "o", "#g", "#q")],
            [atom("Grasp", "o", "#g")])  # fmt: skip
BASE = result("motion", ["q0", "#q"], ["#t1"], [atom("Motion", "q0", "#t1", "#q")])
ARM = result("motion", ["#q", "q9"], ["#t2"], [atom("Motion", "#q", "#t2", "q9")])
PLAN = [
    ("move-base", ("q0", "#t1", "#q")),
    ("pick", ("o", "#g", "#q")),
    ("move-arm", ("#q", "#t2", "q9")),
]
PREIMAGE = Preimage(
    per_step=[
        {atom("Motion", "q0", "#t1", "#q")},
        {atom("Kin", "o", "#g", "#q"), atom("Grasp", "o", "#g")},
        {atom("Motion", "#q", "#t2", "q9")},
    ],
    per_step_costs=[set(), set(), set()],
)
NEEDED = [GRASP, IK, BASE, ARM]


def reschedule(needed=NEEDED, preimage=PREIMAGE, plan=PLAN, never=("sample-grasp",), defer=True):
    inst = instantiation(needed)
    return reschedule_stream_plan(needed, preimage, plan, inst, deferrable_except(*never), defer)


def test_a_deferrable_output_used_only_by_a_later_step_stays_deferred():
    now, later = reschedule()
    assert later == [ARM]  # the arm's motion: first used by the third action
    assert now == [GRASP, IK, BASE]  # in the stream plan's order


def test_an_argument_of_the_first_step_without_a_certifying_precondition_is_evaluated_now():
    # (look #p): #p is an argument of the first action, but no fact of its precondition
    # names it -- it is needed now all the same (a view is then used by a later step too).
    view = result("sample-view", ["o"], ["#p"], [atom("View", "o", "#p")])
    grasp = result("sample-grasp", ["o"], ["#g2"], [atom("Grasp", "o", "#g2")])
    plan = [("look", ("o", "#p")), ("pick", ("o", "#g2", "#p"))]
    preimage = Preimage(per_step=[set(), {atom("Grasp", "o", "#g2")}],
                        per_step_costs=[set(), set()])  # fmt: skip
    now, later = reschedule([view, grasp], preimage, plan, never=())
    assert now == [view]
    assert later == [grasp]


def test_producers_of_a_needed_stream_are_needed_too():
    # Only #t1 and #q are arguments of the first action; the base motion's input #q needs
    # inv-kin, whose input #g and domain fact (Grasp o #g) need sample-grasp: all evaluated
    # now although every one of them may be deferred.
    now, later = reschedule(never=())
    assert now == [GRASP, IK, BASE] and later == [ARM]
    producers = stream_producers(NEEDED, instantiation(NEEDED))
    assert producers[id(BASE)] == [id(IK)]
    assert set(producers[id(IK)]) == {id(GRASP)}  # by its input and by its domain fact
    assert producers[id(GRASP)] == [] and producers[id(ARM)] == [id(IK)]


def test_a_producer_reached_only_through_a_domain_fact_is_needed():
    check = result("test-reach", ["#q"], [], [atom("Reachable", "#q")], kind="test")
    ik = result("inv-kin", ["o"], ["#q"], [atom("Kin", "o", "#q")])
    step = result("motion", ["q0"], ["#t"], [atom("Motion", "q0", "#t")],
                  [atom("Reachable", "#q")])  # fmt: skip
    plan = [("move", ("q0", "#t")), ("pick", ("o", "#q"))]
    preimage = Preimage(per_step=[{atom("Motion", "q0", "#t")}, {atom("Kin", "o", "#q")}],
                        per_step_costs=[set(), set()])  # fmt: skip
    now, later = reschedule([ik, check, step], preimage, plan, never=())
    assert now == [ik, check, step] and later == []


def test_a_stream_never_deferred_is_evaluated_now_wherever_it_is_used():
    # sample-grasp's output is first used by the second action, but it is not deferrable
    # (it may fail: better to find out before moving)
    grasp = result("sample-grasp", ["o"], ["#g"], [atom("Grasp", "o", "#g")])
    plan = [("move", ("q0", "q1")), ("pick", ("o", "#g", "q1"))]
    preimage = Preimage(per_step=[set(), {atom("Grasp", "o", "#g")}],
                        per_step_costs=[set(), set()])  # fmt: skip
    assert reschedule([grasp], preimage, plan, never=("sample-grasp",)) == ([grasp], [])
    assert reschedule([grasp], preimage, plan, never=()) == ([], [grasp])


def test_a_cost_term_of_the_first_step_is_evaluated_now():
    dist = result("distance", ["q0", "q1"], kind="function")
    later_dist = result("distance", ["q1", "q2"], kind="function")
    term = S.FuncTerm("distance", (S.Const("q0"), S.Const("q1")))
    other = S.FuncTerm("distance", (S.Const("q1"), S.Const("q2")))
    plan = [("move", ("q0", "q1")), ("move", ("q1", "q2"))]
    preimage = Preimage(per_step=[set(), set()], per_step_costs=[{term}, {other}])
    now, later = reschedule([dist, later_dist], preimage, plan, never=())
    assert now == [dist] and later == [later_dist]


def test_with_deferral_off_nothing_is_deferred():
    now, later = reschedule(never=(), defer=False)
    assert now == NEEDED and later == []
    assert now is not NEEDED  # a new list: the caller's stream plan is left as it was
    assert reschedule([], defer=True) == ([], [])


def test_an_empty_plan_defers_nothing():
    now, later = reschedule(plan=[], never=())
    assert now == NEEDED and later == []


def test_a_fact_the_first_precondition_rests_on_is_evaluated_now():
    # A test has no output to appear among the arguments: the certified fact it makes, which
    # the first action's precondition needs, is what makes it needed now.
    first = result("test-cfree", ["q0", "o"], [], [atom("CFree", "q0", "o")], kind="test")
    second = result("test-cfree", ["q1", "o"], [], [atom("CFree", "q1", "o")], kind="test")
    plan = [("move", ("q0", "q1")), ("move", ("q1", "q2"))]
    preimage = Preimage(per_step=[{atom("CFree", "q0", "o")}, {atom("CFree", "q1", "o")}],
                        per_step_costs=[set(), set()])  # fmt: skip
    now, later = reschedule([first, second], preimage, plan, never=())
    assert now == [first] and later == [second]
