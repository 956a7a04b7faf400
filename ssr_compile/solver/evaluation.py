"""Stream evaluation across the iterations of one solve: the stream instances called, their
outcomes and real results (:class:`Evaluation`), and the real problem a plan bound to drawn
values is checked in (:func:`real_problem`)."""

from __future__ import annotations

import math
import time
from dataclasses import replace
from typing import Any

from .. import syntax as S
from ..compile.instantiate import (
    Instance,
    Result,
    _matches,
    ground_atom,
    real_instances,
    real_parts,
)
from ..compile.join import FactIndex, facts_by_predicate
from ..compile.predicates import predicate_tests
from ..errors import StreamError, StreamFailure
from ..stream import Generator, StreamsModule, ValueTable, call_function, call_test
from .results import Statistics


class Evaluation:
    """Stream state that persists across iterations: generators, results, values."""

    def __init__(
        self,
        streams: S.StreamFile,
        module: StreamsModule,
        values: ValueTable,
        stats: Statistics,
        lazy: dict[str, str] | None = None,
    ):
        self.decl = {s.name: s for s in streams.streams}
        # a lazy test's complement predicate -> the test it calls (true when the test fails)
        self.lazy = dict(lazy or {})
        self.decl.update((p.name, p) for p in predicate_tests(streams))
        # each stream predicate's optimistic value (set by the solver's loop): a check of one
        # succeeds when the predicate has that value
        self.expect: dict[str, bool] = {}
        self.functions = {f.name: f for f in streams.functions}
        self.module = module
        self.values = values
        self.stats = stats
        self.generators: dict[Instance, Generator] = {}
        self.results: list[Result] = []
        self.exhausted: set[Instance] = set()
        self.tried: set[Instance] = set()  # evaluated at this level
        self.real_functions: dict[S.FuncTerm, float] = {}
        # instance (real inputs) -> last outcome: output names, True (test passed) or
        # False/None (failed)
        self.outcomes: dict[Instance, Any] = {}
        self.called = False  # did the last evaluate() call the stream (or reuse an outcome)?
        # draws made per generator instance, and the least complexity of each fact a result
        # of this solve certified (:meth:`complexity_of`; facts absent here have 0)
        self.draws: dict[Instance, int] = {}
        # generator instances whose last draw found nothing
        self.failed_draws: set[Instance] = set()
        self.fact_complexity: dict[S.Atom, int] = {}

    def evaluate(self, res: Result, binding: dict[str, str]) -> bool:
        """Evaluate one optimistic result under ``binding`` (optimistic -> real names).

        A stream whose code raises, exits or answers outside its declaration is a
        :class:`StreamFailure` (the streams module's fault, not the input's)."""
        try:
            return self._evaluate(res, binding)
        except StreamError as e:
            raise StreamFailure(res.instance.stream, e.message) from e

    def _evaluate(self, res: Result, binding: dict[str, str]) -> bool:
        inst = bound_instance(res, binding)
        # Optimistic inputs bound to real values may coincide with an instance evaluated
        # before: reuse its outcome instead of asking an exhausted generator (or a
        # deterministic test, or a function) again and calling the plan a failure.
        self.called = False
        known = self.outcomes.get(inst)
        if inst.kind in ("function", "test") and known is not None:
            self.tried.add(inst)
            return bool(known)
        if inst.kind == "stream" and isinstance(known, tuple) and inst in self.exhausted:
            for opt, real in zip(res.outputs, known):
                binding[opt] = real
            return True
        self.called = True
        name = self.lazy.get(inst.stream, inst.stream)
        fn = self.module.streams[name]
        args = tuple(self.values.value(x) for x in inst.inputs)
        stats = self.stats.stream(name)
        start = time.perf_counter()
        stats.calls += 1
        try:
            if inst.kind == "function":
                return self._call_function(inst, fn, args)
            if inst.kind == "test":
                return self._call_test(res, inst, fn, args)
            return self._draw(res, inst, fn, args, binding)
        finally:
            elapsed = time.perf_counter() - start
            stats.time += elapsed
            self.stats.stream_time += elapsed

    def _call_function(self, inst: Instance, fn, args: tuple) -> bool:
        value = call_function(fn, args, inst.stream)
        term = S.FuncTerm(inst.stream, tuple(S.Const(x) for x in inst.inputs))
        self.real_functions[term] = math.inf if value is None else value
        ok = value is not None
        self.tried.add(inst)
        self.outcomes[inst] = ok
        return ok

    def _call_test(self, res: Result, inst: Instance, fn, args: tuple) -> bool:
        decl = self.decl[inst.stream]
        expect = self.expect.get(inst.stream)  # None: a test stream, else a predicate
        test = self.lazy.get(inst.stream)
        if test is not None:  # the complement of a lazy test: true when the test fails
            value = ok = not call_test(fn, args, test, "test stream")
        else:
            what = "test stream" if expect is None else "predicate"
            value = ok = call_test(fn, args, inst.stream, what)
        if expect is not None:
            ok = value == expect
        self.exhausted.add(inst)  # deterministic: never retried
        self.outcomes[inst] = ok
        if value:
            mapping = {p.name: v for p, v in zip(decl.inputs, inst.inputs)}
            self._add(real_result(inst, (), decl, mapping, res.level), 0)
        return ok

    def _add(self, real: Result, index: int) -> None:
        """Keep the real result ``real``, its instance's draw number ``index`` (0 for the
        first), with its complexity: its domain's, plus one per draw its instance made before
        (a first draw is as complex as its inputs: values drawn once are all seen at once, as
        before; only the draws again of one instance wait for the level)."""
        real.complexity = self.complexity_of(real.domain) + index
        for f in real.certified:
            if real.complexity < self.fact_complexity.get(f, real.complexity + 1):
                self.fact_complexity[f] = real.complexity
        self.results.append(real)

    def complexity_of(self, facts) -> int:
        """The largest complexity among ``facts`` (0: the problem's, or none)."""
        return max((self.fact_complexity.get(f, 0) for f in facts), default=0)

    def _draw(self, res: Result, inst: Instance, fn, args: tuple, binding: dict) -> bool:
        """One more value of a generator: its outputs named, bound and certified."""
        decl = self.decl[inst.stream]
        gen = self.generators.get(inst)
        if gen is None:
            kind = self.module.info_for(inst.stream).kind or "generator"
            gen = self.generators[inst] = Generator(fn, args, kind, inst.stream)
        self.tried.add(inst)
        index = self.draws.get(inst, 0)
        self.draws[inst] = index + 1
        out = gen.next()
        if gen.exhausted:
            self.exhausted.add(inst)
        if out is None:
            self.failed_draws.add(inst)
            return False
        self.failed_draws.discard(inst)
        if len(out) != len(decl.outputs):
            raise StreamError(
                f"stream '{inst.stream}' produced {len(out)} outputs, "
                f"its declaration has {len(decl.outputs)}"
            )
        names = tuple(self.values.name_for(v, p.name) for v, p in zip(out, decl.outputs))
        mapping = {p.name: v for p, v in zip(decl.inputs, inst.inputs)}
        mapping.update({p.name: n for p, n in zip(decl.outputs, names)})
        self._add(real_result(inst, names, decl, mapping, res.level), index)
        self.outcomes[inst] = names
        for opt, real in zip(res.outputs, names):
            binding[opt] = real
        return True

    def evaluate_real(self, inst: Instance) -> bool:
        """Evaluate an instance over real inputs only (no output bound to a plan) and count
        its outcome."""
        ok = self.evaluate(Result(inst, (), (), (), 0), {})
        self.record(ok, inst.stream)
        return ok

    def record(self, ok: bool, name: str) -> None:
        """Count the outcome of the last :meth:`evaluate` if it really called the stream."""
        if not self.called:
            return
        stats = self.stats.stream(self.lazy.get(name, name))
        if ok:
            stats.successes += 1
        else:
            stats.failures += 1


class RealFacts:
    """The real facts (the problem's and the evaluated results'), kept up to date."""

    def __init__(self, problem: S.Problem, ev: Evaluation):
        self.ev = ev
        self.facts = {f for f in problem.init if isinstance(f, S.Atom)}
        self.seen = 0

    def holds(self, fact: S.Atom, local: dict[str, str], binding: dict[str, str]) -> bool:
        results = self.ev.results
        for r in results[self.seen :]:
            self.facts.update(r.certified)
        self.seen = len(results)
        ground = S.Atom(
            fact.pred,
            tuple(S.Const(local.get(t.name, binding.get(t.name, t.name))) for t in fact.args),
        )
        return ground in self.facts


class RealJoin:
    """The instances :func:`~..compile.instantiate.real_instances` finds (``functions``,
    ``tests``, eager ``streams``, stream predicates) over the problem and a growing list of
    real results, kept up to date: each call joins only the facts the results appended since
    the last call certify (pivoting on them) and returns every instance found so far, in the
    order found.  The full join at every iteration was half of the eager evaluation on
    tamp2d's blocked problem (its ``distance`` and ``cfree`` pairs over hundreds of facts).
    When the results were not only appended to (the adaptive loop takes some back), or the
    stream file has ``:rule`` blocks, the join starts over."""

    def __init__(self, streams, problem, functions, tests, eager_streams):
        self.streams, self.problem = streams, problem
        self.selection = (set(functions), set(tests), set(eager_streams))
        self.parts = real_parts(streams, *self.selection, predicates=True)
        self._reset()

    def _reset(self) -> None:
        self.levels: dict[S.Atom, int] = {}
        self.index = FactIndex()
        self.found: list[Instance] = []
        self.known: set[Instance] = set()
        self.seen: list[Result] = []  # the results joined, by identity
        self.started = False

    def _add(self, atom: S.Atom, fresh: list[S.Atom]) -> None:
        if atom not in self.levels:
            self.levels[atom] = 0
            self.index.add(atom)
            fresh.append(atom)

    def instances(self, results: list[Result]) -> list[Instance]:
        if self.streams.rules:
            wanted_functions, wanted_tests, wanted_streams = self.selection
            return real_instances(
                self.streams, self.problem, results, functions=wanted_functions,
                tests=wanted_tests, streams_with_outputs=wanted_streams, predicates=True,
            )  # fmt: skip
        n = len(self.seen)
        if len(results) < n or any(a is not b for a, b in zip(self.seen[-1:], results[n - 1 : n])):
            self._reset()
            n = 0
        fresh: list[S.Atom] = []
        if not self.started:
            for fact in self.problem.init:
                if isinstance(fact, S.Atom):
                    self._add(fact, fresh)
        for res in results[n:]:
            for atom in res.certified:
                self._add(atom, fresh)
        self.seen.extend(results[n:])
        if not fresh and self.started:
            return self.found
        pivots = None if not self.started else facts_by_predicate(fresh)
        self.started = True
        for name, params, domain, kind in self.parts:
            for binding, _facts in _matches(params, domain, self.index, self.levels, pivots):
                inst = Instance(name, tuple(binding[p.name] for p in params), kind)
                if inst not in self.known:
                    self.known.add(inst)
                    self.found.append(inst)
        return self.found


def evaluate_eagerly(join: RealJoin, ev: Evaluation) -> None:
    """Evaluate the cheap cost-function terms and tests, the stream predicates, and the
    streams whose info says ``eager`` (one draw) that ``join`` finds over the real facts and
    that have no outcome yet (nor, for a stream, a draw at this level or an end)."""
    for inst in list(join.instances(ev.results)):
        if inst in ev.outcomes:
            continue
        if inst.kind == "stream" and (inst in ev.tried or inst in ev.exhausted):
            continue
        ev.evaluate_real(inst)


def bound_instance(res: Result, binding: dict[str, str]) -> Instance:
    """``res``'s stream instance with its optimistic inputs bound to their real names."""
    inst = res.instance
    return Instance(inst.stream, tuple(binding.get(y, y) for y in inst.inputs), inst.kind)


def real_result(
    inst: Instance, outputs, decl: S.Stream, mapping: dict[str, str], level: int
) -> Result:
    """The real result of ``inst`` (declaration ``decl``; ``mapping``: its parameters -> the
    real names of its inputs and outputs): the facts it certifies and its domain, grounded."""
    certified = tuple(
        ground_atom(a, mapping) for a in S.conjuncts(decl.certified) if isinstance(a, S.Atom)
    )
    domain = tuple(
        ground_atom(a, mapping) for a in S.conjuncts(decl.domain) if isinstance(a, S.Atom)
    )
    return Result(inst, tuple(outputs), certified, domain, level, optimistic=False)


def renamed(x, mapping: dict[str, str]):
    """An atom or function term with its arguments renamed (optimistic -> real)."""
    return replace(x, args=tuple(S.Const(mapping.get(a.name, a.name)) for a in x.args))


def bound_result(r: Result, mapping: dict[str, str]) -> Result:
    """A deferred result with its inputs bound to the real values of the plan."""
    inst = r.instance
    return replace(
        r,
        instance=Instance(inst.stream, tuple(mapping.get(x, x) for x in inst.inputs), inst.kind),
        certified=tuple(renamed(f, mapping) for f in r.certified),
        domain=tuple(renamed(f, mapping) for f in r.domain),
    )


def real_terms(problem, compiled, real_functions, later, mapping) -> dict[S.FuncTerm, float]:
    """The numeric values of :func:`real_problem`: the problem's, the real function values, and
    with deferred results (``later``) the optimistic cost terms over the values drawn for their
    inputs (paper §VII)."""
    terms: dict[S.FuncTerm, float] = {}
    if later:
        for v in compiled.source_problem.init:
            if isinstance(v, S.InitValue):
                terms[renamed(v.fluent, mapping)] = v.value.value
    for v in problem.init:
        if isinstance(v, S.InitValue):
            terms[v.fluent] = v.value.value
    terms.update(real_functions)
    return terms


class RealValues:
    """The numeric values of :func:`real_terms` without deferred results, as
    :func:`~ssr_compile.planners.costs.plan_cost` reads them (by function name and argument
    names), looked up where they are instead of copied: a plan's cost reads a few of them,
    and a solve prices many plans over a growing set of real function values."""

    def __init__(self, problem: S.Problem, real_functions: dict[S.FuncTerm, float]):
        self.real_functions = real_functions
        self.initial = {v.fluent: v.value.value for v in problem.init if isinstance(v, S.InitValue)}

    def _term(self, key) -> S.FuncTerm:
        return S.FuncTerm(key[0], tuple(S.Const(a) for a in key[1]))

    def __contains__(self, key) -> bool:
        term = self._term(key)
        return term in self.real_functions or term in self.initial

    def __getitem__(self, key) -> float:
        term = self._term(key)
        if term in self.real_functions:
            return self.real_functions[term]
        return self.initial[term]


def real_problem(problem, compiled, results, real_functions, later, mapping, terms=None):
    """The problem a plan bound to drawn values (``mapping``: optimistic -> real) is checked in:
    the problem's facts and those of the real ``results``; with deferred results (``later``),
    their facts; the numeric values of :func:`real_terms` (``terms``, when computed already)."""
    facts = {f for f in problem.init if isinstance(f, S.Atom)}
    for r in results:
        facts.update(r.certified)
    for r in later:
        facts.update(renamed(a, mapping) for a in r.certified)
    if terms is None:
        terms = real_terms(problem, compiled, real_functions, later, mapping)
    values = tuple(S.InitValue(t, S.Num(x)) for t, x in terms.items())
    return replace(compiled.source_problem, init=tuple(sorted(facts, key=str)) + values)
