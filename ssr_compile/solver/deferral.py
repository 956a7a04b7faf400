"""The stream plan's schedule: which results to evaluate now and which to defer (paper §VII,
"Deferred stream evaluation"), and in what order to evaluate them."""

from __future__ import annotations

import heapq
import math
from collections.abc import Callable, Sequence
from typing import Any

from .. import syntax as S
from ..compile.instantiate import Instantiation, Result
from .preimage import Preimage

Plan = Sequence[tuple[str, Sequence[str]]]


def reschedule_stream_plan(
    needed: list[Result],
    preimage: Preimage,
    plan: Plan,
    instantiation: Instantiation,
    deferrable: Callable[[str], bool],
    defer: bool = True,
) -> tuple[list[Result], list[Result]]:
    """Reschedule the stream plan (paper §VII): the results of ``needed`` to evaluate now, and
    those to defer to a later replanning call, each in ``needed``'s order.

    Evaluated now: the results the FIRST action of ``plan`` needs (an output among its
    arguments, a certified fact its precondition rests on, a cost term of its effect), those
    of streams that are never deferred (``deferrable(stream)`` false) or that make a shared
    optimistic object; then, recursively, their producers (:func:`stream_producers`).  The rest
    is deferred.  Without ``defer`` (or without a plan) everything is evaluated now."""
    if not defer or not plan:
        return list(needed), []
    first_args = set(plan[0][1])
    first_facts = preimage.per_step[0] if preimage.per_step else set()
    first_costs = preimage.per_step_costs[0] if preimage.per_step_costs else set()
    must = set()
    for r in needed:
        uses_now = (
            bool(set(r.outputs) & first_args)
            or any(f in first_facts for f in r.certified)
            or (r.instance.kind == "function" and _cost_term(r) in first_costs)
        )
        shared = any(o in instantiation.shared for o in r.outputs)
        if uses_now or not deferrable(r.instance.stream) or shared:
            must.add(id(r))
    # Everything a must-result needs (its producers) must be evaluated too.
    producers = stream_producers(needed, instantiation)
    stack = list(must)
    while stack:
        rid = stack.pop()
        for p in producers.get(rid, ()):
            if p not in must:
                must.add(p)
                stack.append(p)
    now = [r for r in needed if id(r) in must]
    later = [r for r in needed if id(r) not in must]
    return now, later


def _cost_term(r: Result) -> S.FuncTerm:
    """The function term a function result gives a value of."""
    return S.FuncTerm(r.instance.stream, tuple(S.Const(a) for a in r.instance.inputs))


def stream_producers(results: list[Result], instantiation: Instantiation) -> dict[int, list[int]]:
    """For each of ``results`` (by id), the ids of those among ``results`` that produce its
    inputs (every producer of a shared object) or the first producer of its domain facts."""
    ids = {id(r) for r in results}
    out: dict[int, list[int]] = {}
    for r in results:
        deps = []
        for x in r.instance.inputs:
            for p in instantiation.shared.get(x) or [instantiation.objects.get(x)]:
                if p is not None and id(p) in ids:
                    deps.append(id(p))
        for fact in r.domain:
            for p in instantiation.facts.get(fact, ())[:1]:
                if id(p) in ids:
                    deps.append(id(p))
        out[id(r)] = deps
    return out


def order_stream_plan(
    results: list[Result], info: Callable[[str], Any], producers: dict[int, list[int]]
) -> list[Result]:
    """Producers before consumers; among the ready ones, cheap and likely-to-fail first.

    The key is the expected cost of finding out that the plan fails, ``cost / (1 - p)``
    (Smith's rule for ordering tests), with level and position as tie-breakers.
    """
    position = {id(r): i for i, r in enumerate(results)}
    waiting = {id(r): set(producers.get(id(r), ())) & set(position) for r in results}
    consumers: dict[int, list[int]] = {}
    for r in results:
        for p in waiting[id(r)]:
            consumers.setdefault(p, []).append(id(r))
    by_id = {id(r): r for r in results}

    def key(r: Result):
        i = info(r.instance.stream)
        p = min(max(getattr(i, "p_success", 1.0), 0.0), 1.0)
        cost = getattr(i, "cost", 1.0)
        score = cost / (1.0 - p) if p < 1.0 else math.inf
        return (score, r.level, position[id(r)])

    heap = [(key(r), id(r)) for r in results if not waiting[id(r)]]
    heapq.heapify(heap)
    out: list[Result] = []
    while heap:
        _, rid = heapq.heappop(heap)
        out.append(by_id[rid])
        for c in consumers.get(rid, ()):
            waiting[c].discard(rid)
            if not waiting[c]:
                heapq.heappush(heap, (key(by_id[c]), c))
    return out
