"""The eager evaluation's join over real facts, kept up to date as results are appended
(:class:`ssr_compile.solver.evaluation.RealJoin`), finds what the full join over every real
fact finds (:func:`ssr_compile.compile.instantiate.real_instances`), after each append and
after results were taken back."""

from __future__ import annotations

from pathlib import Path

from ssr_compile import syntax as S
from ssr_compile.compile.instantiate import Instance, Result, real_instances
from ssr_compile.parse import parse_problem, parse_stream_file
from ssr_compile.solver.evaluation import RealJoin

TAMP2D = Path(__file__).resolve().parent.parent / "domains/pddl/tamp2d"


def placement(block: str, pose: str, region: str = "table") -> Result:
    facts = (
        S.Atom("pose", (S.Const(block), S.Const(pose))),
        S.Atom("contained", (S.Const(block), S.Const(pose), S.Const(region))),
    )
    inst = Instance("sample-placement", (block, region))
    return Result(inst, (pose,), facts, (), 0, optimistic=False)


def conf(name: str) -> Result:
    inst = Instance("ik", ("b1", "p0", name))
    return Result(inst, (name,), (S.Atom("conf", (S.Const(name),)),), (), 0, optimistic=False)


def full(streams, problem, results) -> set[Instance]:
    return set(
        real_instances(
            streams,
            problem,
            results,
            functions={"distance"},
            tests={"test-cfree"},
            predicates=True,
        )  # fmt: skip
    )


def test_the_join_kept_up_to_date_finds_what_the_full_join_finds():
    streams = parse_stream_file((TAMP2D / "stream.pddl").read_text())
    problem = parse_problem((TAMP2D / "problem-blocked.pddl").read_text())
    join = RealJoin(streams, problem, {"distance"}, {"test-cfree"}, ())
    results: list[Result] = []
    seen = []
    steps = [
        placement("b1", "p-1"),
        conf("q-1"),
        placement("b2", "p-2"),
        placement("b1", "p-3"),
        conf("q-2"),
    ]
    for res in steps:
        results.append(res)
        found = join.instances(results)
        assert len(found) == len(set(found))  # each instance once
        assert set(found) == full(streams, problem, results)
        seen.append(len(found))
    # every step added instances, the earlier ones kept in the order found
    assert seen == sorted(set(seen))
    assert Instance("test-cfree", ("b1", "p-3", "b2", "p-2"), "test") in found
    assert Instance("distance", ("q-1", "q-2"), "function") in found

    # Results taken back (the adaptive loop does): the join starts over, the instances over
    # the facts taken back are gone.
    results.pop()
    results.pop()
    found = join.instances(results)
    assert set(found) == full(streams, problem, results)
    assert Instance("distance", ("q-1", "q-2"), "function") not in found
    assert Instance("test-cfree", ("b1", "p-3", "b2", "p-2"), "test") not in found

    # A result replaced by another at the same position is seen as well.
    results[-1] = placement("b2", "p-9")
    found = join.instances(results)
    assert set(found) == full(streams, problem, results)
    assert Instance("test-cfree", ("b1", "p-1", "b2", "p-9"), "test") in found
