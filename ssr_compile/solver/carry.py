"""What one planning call of the online policy hands the next (paper Algorithm 1,
``ConstantFacts(f)``): the static facts of a plan's certificate, and of the stream results it
rests on, over constants only, and the values of those constants."""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Any

from .. import syntax as S
from ..stream import StreamsModule
from .results import Solution


def _supported(solution: Solution, init: Iterable = ()) -> list[S.Atom]:
    """The certificate and, transitively, the facts certified by the real stream results it
    rests on (a result whose certified facts are needed brings its domain facts in).  Facts of
    the initial state ``init`` are the state's, not the plan's: the next problem states them
    again if they still hold (a held object's grasp does not outlive the placement)."""
    given = set(init)
    needed = [f for f in dict.fromkeys(solution.certificate) if f not in given]
    seen = set(needed)
    results = [r for r in solution.evaluated if not r.optimistic]
    used: set[int] = set()
    changed = True
    while changed:
        changed = False
        for i, r in enumerate(results):
            if i in used or not any(f in seen for f in r.certified):
                continue
            used.add(i)
            changed = True
            for f in (*r.certified, *r.domain):
                if f not in seen and f not in given:
                    seen.add(f)
                    needed.append(f)
    return needed


def constant_facts(
    solution: Solution, problem: S.Problem, is_constant: Callable[[str], bool]
) -> tuple[tuple[S.Atom, ...], dict[str, Any]]:
    """``ConstantFacts(f)``: the static facts of the plan's certificate and of the stream
    results it rests on (the plan's stream plan, transitively) whose arguments are all constants, and the values of
    the constants among them that the problem does not declare.  Facts of other streams that
    were evaluated while solving are not kept: every kept grasp multiplies the next optimistic
    problem (a kitchen replan grew from 242 to 1,655 objects at the same level)."""
    declared = {o.name for o in problem.objects}
    facts: list[S.Atom] = []
    values: dict[str, Any] = {}
    proven = _supported(solution, problem.init)
    for atom in proven:
        if not isinstance(atom, S.Atom) or atom.pred == "=":
            continue
        names = [a.name for a in atom.args]
        if not all(is_constant(n) for n in names):
            continue
        facts.append(atom)
        for n in names:
            if n not in declared and solution.values is not None and n in solution.values:
                values[n] = solution.values.value(n)
    return tuple(dict.fromkeys(facts)), values


def stream_constants(solution: Solution, module: StreamsModule) -> set[str]:
    """Real outputs of streams whose info declares their outputs constants (e.g. grasps)."""
    out: set[str] = set()
    for r in solution.evaluated:
        if not r.optimistic and module.info_for(r.instance.stream).constant_outputs:
            out.update(r.outputs)
    return out
