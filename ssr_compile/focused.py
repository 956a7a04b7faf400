"""The Focused algorithm with deferred stream evaluation (paper §IV, §VII; PDDLStream [11]).

Loop: compile the optimistic problem at the current level; plan with the backend; from the
plan, extract the stream plan (the optimistic stream results its preimage needs, back-chained
through their inputs), ordered so that cheap and likely-to-fail instances come first; evaluate
it, binding optimistic objects to real values and adding certified facts.  A plan whose facts
are all real is a solution.  No plan at a level raises the level.

Each stream instance is evaluated at most once per level: afterwards it is left out of the
optimistic instantiation until the level rises (so the planner does not keep asking for new
samples of the same instance), and a failed test is never retried (tests are deterministic).

Deferred evaluation (§VII): with ``defer=True``, results of deferrable streams whose outputs are
first needed after the first action are not evaluated; the returned plan keeps them
optimistic (marked), and the next replanning call evaluates them if they are still needed.
"""

from __future__ import annotations

import heapq
import itertools
import math
import sys
import time
from collections.abc import Callable, Container, Iterable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

from . import syntax as S
from .compile.instantiate import Instance, Result, ground_atom, real_instances
from .compile.pipeline import compile_problem
from .errors import InstanceCapReached, PlannerFailure, SSRError, StreamError, StreamFailure
from .planners import fd as _default_backend  # noqa: F401 - the default, loaded with the solver
from .planners.base import UNSOLVABLE
from .planners.costs import plan_cost
from .preimage import PlanInvalid, plan_preimage, stream_plan
from .stream import Generator, StreamsModule, ValueTable, call_function, call_test

SOLVED = "solved"
# Cost functions and tests at most this expensive (StreamInfo.cost) are evaluated eagerly.
EAGER_COST = 0.1
RESAMPLE = 2  # default ``resample`` of :func:`solve`
# A planner call on a level with instances held back: at most SLICE_FACTOR times the longest
# call that found a plan, and at least SLICE_MIN seconds (:meth:`_FocusedLoop.plan`)
SLICE_FACTOR = 10.0
SLICE_MIN = 1.0


@dataclass
class StreamStats:
    calls: int = 0
    successes: int = 0
    failures: int = 0
    time: float = 0.0


@dataclass
class Statistics:
    iterations: int = 0
    levels: list[int] = field(default_factory=list)
    planner_calls: int = 0
    planner_time: float = 0.0
    stream_time: float = 0.0
    total_time: float = 0.0
    streams: dict[str, StreamStats] = field(default_factory=dict)
    # Per iteration: the compiled problem handed to the planner (objects, facts, function
    # values, ground actions when the planner reports them, else None).
    sizes: list[tuple[int, int, int, int | None]] = field(default_factory=list)
    compile_time: float = 0.0
    resamples: int = 0  # generator draws taken again within one stream plan (``resample``)

    def stream(self, name: str) -> StreamStats:
        return self.streams.setdefault(name, StreamStats())

    def as_dict(self) -> dict:
        return {
            "iterations": self.iterations,
            "levels": self.levels,
            "planner_calls": self.planner_calls,
            "planner_time": round(self.planner_time, 4),
            "stream_time": round(self.stream_time, 4),
            "total_time": round(self.total_time, 4),
            "compile_time": round(self.compile_time, 4),
            "resamples": self.resamples,
            "sizes": [list(z) for z in self.sizes],
            "streams": {
                k: vars(v) | {"time": round(v.time, 4)} for k, v in sorted(self.streams.items())
            },
        }


@dataclass
class Step:
    """One action of a solution: object names, their Python values, deferred arguments."""

    name: str
    args: tuple[str, ...]
    values: tuple[Any, ...]
    deferred: tuple[str, ...] = ()  # arguments still optimistic (their streams deferred)

    def __str__(self) -> str:
        return "(" + " ".join([self.name, *self.args]) + ")"


@dataclass
class Solution:
    status: str  # "solved", "unsolvable" (no plan within the level / cost bound), "timeout"
    plan: list[Step] | None
    cost: float | None
    certificate: list[S.Atom]
    stats: Statistics
    deferred: list[Result] = field(default_factory=list)
    evaluated: list[Result] = field(default_factory=list)
    values: ValueTable | None = None
    message: str = ""
    # the planner cannot take action costs (pyperplan): it planned with unit costs
    costs_ignored_by: str | None = None

    @property
    def solved(self) -> bool:
        return self.status == SOLVED


class _Evaluation:
    """Stream state that persists across iterations: generators, results, values."""

    def __init__(
        self, streams: S.StreamFile, module: StreamsModule, values: ValueTable, stats: Statistics
    ):
        self.decl = {s.name: s for s in streams.streams}
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

    def evaluate(self, res: Result, binding: dict[str, str]) -> bool:
        """Evaluate one optimistic result under ``binding`` (optimistic -> real names).

        A stream whose code raises, exits or answers outside its declaration is a
        :class:`StreamFailure` (the streams module's fault, not the input's)."""
        try:
            return self._evaluate(res, binding)
        except StreamError as e:
            raise StreamFailure(res.instance.stream, e.message) from e

    def _evaluate(self, res: Result, binding: dict[str, str]) -> bool:
        inst = _bound(res, binding)
        inputs = inst.inputs
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
        fn = self.module.streams[inst.stream]
        args = tuple(self.values.value(x) for x in inputs)
        stats = self.stats.stream(inst.stream)
        start = time.perf_counter()
        stats.calls += 1
        try:
            if inst.kind == "function":
                value = call_function(fn, args, inst.stream)
                term = S.FuncTerm(inst.stream, tuple(S.Const(x) for x in inputs))
                self.real_functions[term] = math.inf if value is None else value
                ok = value is not None
                self.tried.add(inst)
                self.outcomes[inst] = ok
                return ok
            decl = self.decl[inst.stream]
            if inst.kind == "test":
                ok = call_test(fn, args, inst.stream)
                self.exhausted.add(inst)  # deterministic: never retried
                self.outcomes[inst] = ok
                if ok:
                    mapping = {p.name: v for p, v in zip(decl.inputs, inputs)}
                    self.results.append(_real_result(inst, (), decl, mapping, res.level))
                return ok
            gen = self.generators.get(inst)
            if gen is None:
                kind = self.module.info_for(inst.stream).kind or "generator"
                gen = self.generators[inst] = Generator(fn, args, kind, inst.stream)
            self.tried.add(inst)
            out = gen.next()
            if gen.exhausted:
                self.exhausted.add(inst)
            if out is None:
                return False
            if len(out) != len(decl.outputs):
                raise StreamError(
                    f"stream '{inst.stream}' produced {len(out)} outputs, its declaration has {len(decl.outputs)}"
                )
            names = tuple(self.values.name_for(v, p.name) for v, p in zip(out, decl.outputs))
            mapping = {p.name: v for p, v in zip(decl.inputs, inputs)}
            mapping.update({p.name: n for p, n in zip(decl.outputs, names)})
            self.results.append(_real_result(inst, names, decl, mapping, res.level))
            self.outcomes[inst] = names
            for opt, real in zip(res.outputs, names):
                binding[opt] = real
            return True
        finally:
            elapsed = time.perf_counter() - start
            stats.time += elapsed
            self.stats.stream_time += elapsed

    def record(self, ok: bool, name: str) -> None:
        """Count the outcome of the last :meth:`evaluate` if it really called the stream."""
        if not self.called:
            return
        stats = self.stats.stream(name)
        if ok:
            stats.successes += 1
        else:
            stats.failures += 1


def _renamed(x, mapping: dict[str, str]):
    """An atom or function term with its arguments renamed (optimistic -> real)."""
    return replace(x, args=tuple(S.Const(mapping.get(a.name, a.name)) for a in x.args))


def _bound_result(r: Result, mapping: dict[str, str]) -> Result:
    """A deferred result with its inputs bound to the real values of the plan."""
    inst = r.instance
    return replace(
        r,
        instance=Instance(inst.stream, tuple(mapping.get(x, x) for x in inst.inputs), inst.kind),
        certified=tuple(_renamed(f, mapping) for f in r.certified),
        domain=tuple(_renamed(f, mapping) for f in r.domain),
    )


def _real_problem(problem, compiled, results, real_functions, later, mapping) -> S.Problem:
    """The problem a plan bound to drawn values (``mapping``: optimistic -> real) is checked in:
    the problem's facts and those of the real ``results``; with deferred results (``later``),
    their facts and optimistic cost terms over the values drawn for their inputs (paper §VII);
    the problem's numeric values and the real function values over those."""
    facts = {f for f in problem.init if isinstance(f, S.Atom)}
    for r in results:
        facts.update(r.certified)
    terms: dict[S.FuncTerm, float] = {}
    for r in later:
        facts.update(_renamed(a, mapping) for a in r.certified)
    if later:
        for v in compiled.source_problem.init:
            if isinstance(v, S.InitValue):
                terms[_renamed(v.fluent, mapping)] = v.value.value
    for v in problem.init:
        if isinstance(v, S.InitValue):
            terms[v.fluent] = v.value.value
    terms.update(real_functions)
    values = tuple(S.InitValue(t, S.Num(x)) for t, x in terms.items())
    return replace(compiled.source_problem, init=tuple(sorted(facts, key=str)) + values)


def _bound(res: Result, binding: dict[str, str]) -> Instance:
    """``res``'s stream instance with its optimistic inputs bound to their real names."""
    inst = res.instance
    return Instance(inst.stream, tuple(binding.get(y, y) for y in inst.inputs), inst.kind)


def _real_result(
    inst: Instance, outputs, decl: S.Stream, mapping: dict[str, str], level: int
) -> Result:
    certified = tuple(
        ground_atom(a, mapping) for a in S.conjuncts(decl.certified) if isinstance(a, S.Atom)
    )
    domain = tuple(
        ground_atom(a, mapping) for a in S.conjuncts(decl.domain) if isinstance(a, S.Atom)
    )
    return Result(inst, tuple(outputs), certified, domain, level, optimistic=False)


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


@dataclass
class ReplanState:
    """What one replanning call inherits from the last (paper Algorithm 1: ``a_prev``, and
    ``f_prev``; the solver's own memory of what it already evaluated).

    ``tail``: the unexecuted actions of the last plan (object names), whose structure the next
    plan keeps (Algorithm 2); ``constants``: the names that are constants in the sense of §VI-A
    (anything that answers ``name in constants``); ``kept_facts``: ``ConstantFacts(f)``, the
    certificate's static facts over constants only; ``kept_values``: the Python values of the
    constants those facts name that are not objects of the next problem (stream outputs such as
    grasps); ``evaluated``: real stream results kept from earlier calls; ``values``: the table
    of the objects' names and Python values those results use (``None``: a new table).
    """

    tail: list[tuple[str, tuple[str, ...]]] | None = None
    constants: Container[str] = frozenset()
    kept_facts: tuple[S.Atom, ...] = ()
    kept_values: dict[str, Any] = field(default_factory=dict)
    evaluated: Sequence[Result] = ()
    values: ValueTable | None = None

    def is_constant(self, name: str) -> bool:
        return name in self.constants


class _Satisfying:
    """The names a test accepts, as a container (``is_constant`` callables of older callers)."""

    def __init__(self, test: Callable[[str], bool]):
        self.test = test

    def __contains__(self, name: object) -> bool:
        return bool(self.test(name))


def with_kept(
    problem: S.Problem, module: StreamsModule, state: ReplanState
) -> tuple[S.Problem, StreamsModule]:
    """``s ∪ f_prev``: the problem with the kept constant facts and their objects added (and the
    objects' Python values in the module)."""
    if not state.kept_facts:
        return problem, module
    declared = {o.name for o in problem.objects}
    clash = [n for n in state.kept_values if n in declared]
    values = {k: v for k, v in state.kept_values.items() if k not in clash}
    extra = tuple(S.Typed(n) for n in values if n not in declared)
    present = set(problem.init)
    facts = tuple(
        f for f in state.kept_facts if f not in present and not any(a.name in clash for a in f.args)
    )
    new_problem = replace(problem, objects=problem.objects + extra, init=problem.init + facts)
    new_module = replace(module, values={**module.values, **values})
    return new_problem, new_module


def solve(
    domain: S.Domain,
    streams: S.StreamFile,
    problem: S.Problem,
    module: StreamsModule,
    *,
    planner: str | Any = "fd",
    time_limit: float = 60.0,
    max_cost: float = math.inf,
    defer: bool = False,
    initial_level: int = 1,
    max_level: int = 8,
    plan_tail: Sequence[tuple[str, Sequence[str]]] | None = None,
    is_constant: Callable[[str], bool] | None = None,
    evaluated: Iterable[Result] = (),
    values: ValueTable | None = None,
    progress: Callable[[str], None] | None = None,
    unit_cost: bool = False,
    eager_cost: float = EAGER_COST,
    eager_tests: bool = True,
    redraws: int = 0,
    resample: int = RESAMPLE,
    accept_drawn: bool | None = None,
    share: bool = False,
    state: ReplanState | None = None,
    algorithm: str = "focused",
    leaves: bool = True,
) -> Solution:
    """Solve a PDDLStream problem with the Focused algorithm (see the module docstring).

    ``state`` is what a replanning call inherits from the last (Algorithm 1,
    :class:`ReplanState`): its kept facts join the problem (``s ∪ f_prev``), its tail and
    constants constrain the plan's structure (Algorithm 2), its evaluated results and values
    table are kept.  ``plan_tail``, ``is_constant``, ``evaluated`` and ``values`` are the same
    state given one by one (each, when given, takes the place of the state's field).
    Cost functions whose stream info gives a cost of at most ``eager_cost`` are evaluated as
    soon as their arguments are real (before planning), so the planner sees their real
    values instead of rediscovering them one plan at a time; ``eager_cost=-1`` turns this off.
    With ``eager_tests``, so are the tests that cheap: a test that fails on real inputs is
    never an optimistic fact the planner builds a plan on (one planner call per failed test).
    ``redraws``: a generator whose draw a test of the same stream plan rejected may draw again
    at the same level, up to this many times per instance and level, instead of leaving the
    level without a sample (whose optimistic problem the planner may then have to prove
    unsolvable, at a cost exponential in the number of objects to arrange); off by default
    (it is slower on the shipped examples, faster on many blocks: ``bench/scaling_bench.py``).
    ``resample``: a generator of the stream plan whose draw was rejected by one of the plan's
    tests draws again at once, up to this many times per other draw of the stream plan that
    a test checks it against (at least once over), and what depends on it is evaluated again
    -- a stream call instead of a planner call; one whose draw failed draws again once, while
    that pays off for its stream (``0``: off).
    ``accept_drawn``: when every result of a stream plan succeeds and the plan, with the
    values drawn, is valid and costs no more than planned, it is the solution (no planner call
    to find it again).  ``None`` (default): only with a cost-optimal planner, whose optimistic
    cost bounds every plan of the level; a suboptimal one may find a cheaper plan on replanning.
    ``share``: instances with optimistic inputs share their optimistic outputs (see
    :func:`~ssr_compile.compile.instantiate.instantiate`): smaller first optimistic problems,
    but more real values later (each consumer is evaluated for every value bound to a shared
    object); off by default, as it is not faster on the shipped examples yet.
    ``leaves``: one object in the planner's task for all the optimistic leaf outputs of a
    stream (motion trajectories; :mod:`ssr_compile.compile.leaves`), mapped back per instance;
    on by default (the kitchen's replans: 4,225 objects down to 128 at the same level).
    ``algorithm``: "focused" (this module's loop) or "adaptive" (a queue of plan skeletons
    sampled incrementally between planner calls: :mod:`ssr_compile.adaptive`).
    Returns a :class:`Solution` with status "solved", "unsolvable" or "timeout".
    """
    state = _inherited(state, plan_tail, is_constant, evaluated, values)
    problem, module = with_kept(problem, module, state)
    loop = _loop_class(algorithm)(
        domain,
        streams,
        problem,
        module,
        state,
        planner=planner,
        time_limit=time_limit,
        max_cost=max_cost,
        defer=defer,
        level=max(initial_level, 0),
        max_level=max_level,
        progress=progress,
        unit_cost=unit_cost,
        eager_cost=eager_cost,
        eager_tests=eager_tests,
        redraws=redraws,
        resample=resample,
        accept_drawn=accept_drawn,
        share=share,
        leaves=leaves,
    )
    return loop.run()


ALGORITHMS = ("focused", "adaptive")


def _loop_class(algorithm: str):
    """The loop that runs one call of :func:`solve` for ``algorithm``."""
    if algorithm == "focused":
        return _FocusedLoop
    if algorithm == "adaptive":
        from .adaptive import AdaptiveLoop

        return AdaptiveLoop
    raise ValueError(f"unknown algorithm {algorithm!r}: expected one of {', '.join(ALGORITHMS)}")


def _inherited(state, plan_tail, is_constant, evaluated, values) -> ReplanState:
    """The replanning state of one call: ``state`` with the fields given one by one."""
    state = state or ReplanState()
    given: dict[str, Any] = {}
    if plan_tail is not None:
        given["tail"] = plan_tail
    if is_constant is not None:
        given["constants"] = _Satisfying(is_constant)
    if evaluated:
        given["evaluated"] = evaluated
    if values is not None:
        given["values"] = values
    return replace(state, **given) if given else state


class _FocusedLoop:
    """One call of :func:`solve`: the Focused loop and what it keeps between iterations."""

    def __init__(
        self,
        domain: S.Domain,
        streams: S.StreamFile,
        problem: S.Problem,
        module: StreamsModule,
        state: ReplanState,
        *,
        planner,
        time_limit: float,
        max_cost: float,
        defer: bool,
        level: int,
        max_level: int,
        progress: Callable[[str], None] | None,
        unit_cost: bool,
        eager_cost: float,
        eager_tests: bool,
        redraws: int,
        resample: int,
        accept_drawn: bool | None,
        share: bool,
        leaves: bool = True,
    ):
        from .planners import get_planner

        self.start = time.monotonic()
        self.deadline = self.start + time_limit
        self.time_limit, self.max_cost, self.defer = time_limit, max_cost, defer
        self.max_level, self.unit_cost, self.share = max_level, unit_cost, share
        self.leaves = leaves
        self.domain, self.streams, self.problem, self.module = domain, streams, problem, module
        self.state = state
        self.backend = get_planner(planner) if isinstance(planner, str) else planner
        module.check_against(streams)
        self.stats = Statistics()
        self.values = state.values
        if self.values is None:
            taken = {o.name for o in problem.objects} | {c.name for c in domain.constants}
            self.values = ValueTable(module.values, taken)
        self.ev = _Evaluation(streams, module, self.values, self.stats)
        self.ev.results.extend(state.evaluated)
        self.say = progress or (lambda msg: None)
        self.optimistic_values = {
            f.name: module.info_for(f.name).optimistic_value
            for f in streams.functions
            if module.info_for(f.name).optimistic_value is not None
        }
        self.level = level
        self.first_level = level
        self.best_failure = "no plan"
        # the longest planner call that found a plan: what a held-back level's call may take
        # (:meth:`plan`)
        self.longest_found = 0.0
        self.last_compile = 0.0  # seconds the last optimistic problem took to compile
        self.sliced = False  # was the last planner call cut at its slice?
        self.redraws: dict[Instance, int] = {}  # rejected draws given back at this level
        self.redraws_per_level = max(int(redraws), 0)
        self.resample = max(int(resample), 0)
        # per stream: draws again after a failed draw, and how many gave a value
        self.draw_again_paid: dict[str, list[int]] = {}
        if accept_drawn is None:
            accept_drawn = bool(getattr(self.backend.capabilities, "optimal", False))
        self.accept_drawn = accept_drawn
        # the cheapest plan so far whose stream plan all succeeded (with its values drawn),
        # kept when not taken at once (``accept_drawn`` off): see :meth:`use_plan`
        self.incumbent: Solution | None = None
        self.eager_seen = -1  # number of real results when cheap functions were last evaluated
        self.eager = {
            f.name for f in streams.functions if module.info_for(f.name).cost <= eager_cost
        }
        self.eager_tests = {
            s.name
            for s in streams.streams
            if eager_tests and s.is_test and module.info_for(s.name).cost <= eager_cost
        }
        self.eager_streams = {
            s.name for s in streams.streams if not s.is_test and module.info_for(s.name).eager
        }

    def run(self) -> Solution:
        """Compile, plan, evaluate the stream plan; until a plan's facts are all real, no plan
        is left up to the last level, or time is up."""
        while True:
            if time.monotonic() >= self.deadline:
                return self.incumbent_or(
                    "timeout", message=f"time limit of {self.time_limit:g} s reached"
                )
            if time.monotonic() + self.last_compile >= self.deadline:
                # compiling is not interrupted: one that would end past the limit is not
                # started (tamp2d with 7 blocks: a 2.3 s compile began 1 s before the limit)
                return self.incumbent_or(
                    "timeout",
                    message=f"time limit of {self.time_limit:g} s reached (too little left to "
                    f"compile the next problem, {self.last_compile:.1f} s last time)",
                )
            self.stats.iterations += 1
            self.stats.levels.append(self.level)
            self.evaluate_cheap_functions()
            try:
                compiled = self.compile()
            except InstanceCapReached as e:
                return self.capped(e)
            result, bound = self.plan(compiled)
            if result.status == "error":
                raise PlannerFailure(self.backend.name, result.message, detail=result.detail)
            if result.status == "timeout" and self.sliced:
                done = self.raise_level(result, bound)
                if done is not None:
                    return done
                continue
            if result.status == "timeout":
                return self.incumbent_or(
                    "timeout", message=f"the planner ran out of time at level {self.level}"
                )
            if result.status != "solved":
                done = self.saturated(compiled, result, bound) or self.raise_level(result, bound)
            else:
                done = self.use_plan(compiled, result)
            if done is not None:
                return done

    def capped(self, e: InstanceCapReached) -> Solution:
        """The level would pass the instance cap: a resource limit, like the last level (no
        plan up to the level before); at the first level it stays an error."""
        if self.level <= self.first_level:
            raise e
        took = time.monotonic() - self.start
        return self.finish(
            "unsolvable",
            message=f"no plan found up to level {self.level - 1} in {took:.1f} s; "
            f"level {self.level} would pass the cap ({e.message})",
        )

    def incumbent_or(self, status: str, message: str) -> Solution:
        """Out of time: the incumbent plan (see :meth:`use_plan`) when there is one, else
        ``status`` with ``message``."""
        if self.incumbent is None:
            return self.finish(status, message=message)
        self.say(f"  {message}: the cheapest plan drawn so far")
        return self.finish_incumbent()

    def finish_incumbent(self) -> Solution:
        sol = self.incumbent
        assert sol is not None
        return self.finish(SOLVED, sol.plan, sol.cost, sol.certificate, deferred=sol.deferred)

    def finish(self, status, plan=None, cost=None, certificate=(), deferred=(), message=""):
        self.stats.total_time = time.monotonic() - self.start
        sol = Solution(
            status,
            plan,
            cost,
            list(certificate),
            self.stats,
            list(deferred),
            list(self.ev.results),
            self.values,
            message,
        )
        if self.problem.metric is not None and not self.backend.capabilities.costs:
            sol.costs_ignored_by = self.backend.name
        return sol

    def evaluate_cheap_functions(self) -> None:
        """The cheap cost functions and tests over real arguments, once per new real result
        (a test that passes adds facts: again until none does)."""
        while (self.eager or self.eager_tests or self.eager_streams) and len(
            self.ev.results
        ) != self.eager_seen:
            self.eager_seen = len(self.ev.results)
            _evaluate_eagerly(
                self.streams,
                self.problem,
                self.eager,
                self.eager_tests,
                self.ev,
                self.eager_streams,
            )

    def compile(self):
        """The optimistic problem of this level, constrained by the inherited plan tail."""
        started = time.perf_counter()
        compiled = compile_problem(
            self.domain,
            self.streams,
            self.problem,
            caps=self.backend.capabilities,
            level=self.level,
            evaluated=self.ev.results,
            disabled=self.ev.tried,
            exhausted=self.ev.exhausted,
            function_values=self.optimistic_values,
            real_function_values=self.ev.real_functions,
            plan_tail=self.state.tail,
            is_constant=self.state.is_constant,
            unit_cost=self.unit_cost,
            share=self.share,
            leaves=self.leaves,
        )
        self.last_compile = time.perf_counter() - started
        self.stats.compile_time += self.last_compile
        return compiled

    def plan(self, compiled):
        """The backend's answer on the compiled problem (within the time left and the cost
        bound, in planner units), and that bound."""
        remaining = self.deadline - time.monotonic()
        bound = None if math.isinf(self.max_cost) else self.max_cost * compiled.scale
        # With instances held back at this level (their draws failed or were rejected), "no
        # plan" only means "the next level", which gives them back -- and the planner may take
        # any time to prove it, exponential in the objects to arrange (tamp2d with 7 blocks:
        # the whole limit on the second call, at level 3).  Such a call gets a slice of
        # SLICE_FACTOR times the longest call that found a plan (at least SLICE_MIN); cut
        # there, the level rises as after "no plan".  Not at the last level (nothing would
        # give the instances back), nor before a plan was found.
        limit = remaining
        if self.ev.tried and self.longest_found > 0 and self.level < self.max_level:
            limit = min(remaining, max(SLICE_MIN, SLICE_FACTOR * self.longest_found))
        result, size = self.call_planner(compiled, limit, bound)
        self.sliced = result.status == "timeout" and limit < remaining
        if result.status == SOLVED:
            self.longest_found = max(self.longest_found, result.time)
        elif self.sliced:
            result = replace(
                result,
                message=f"the planner found no plan in its slice of {limit:.1f} s at level "
                f"{self.level}, with instances held back",
            )
        task = len(compiled.problem.objects) + len(compiled.domain.constants)
        # (a ground task, unified-planning's or pyperplan's, names no object at all)
        shared = f" ({task} in the planner's task)" if 0 < task < size[0] else ""
        self.say(
            f"iteration {self.stats.iterations}: level {self.level}, problem {size[0]} objects"
            f"{shared}, {size[1]} facts, {size[2]} values"
            + (f", {size[3]} ground actions" if size[3] is not None else "")
            + f"; planner {result.status} in {result.time:.3f} s"
            + (" (its slice, with instances held back: the level rises)" if self.sliced else "")
        )
        return result, bound

    def call_planner(self, compiled, remaining: float, bound: float | None):
        """One backend call, counted in the statistics: its result and the compiled problem's
        size (objects, facts, values, ground actions if the backend reports them)."""
        result = self.backend.solve(
            compiled.domain, compiled.problem, time_limit=max(remaining, 0.01), cost_bound=bound
        )
        self.stats.planner_calls += 1
        self.stats.planner_time += result.time
        size = _size(compiled, getattr(self.backend, "last_operators", None))
        self.stats.sizes.append(size)
        return result, size

    def saturated(self, compiled, result, bound) -> Solution | None:
        """ "unsolvable" now when no level can change the answer: the planner proved this
        problem unsolvable, instantiation reached its fixed point below the level limit (a
        higher level adds no stream instance), and no instance was held back at this level
        (a level rise would give those back).  The next level's problem would be this one
        again: a constrained attempt of the policy whose tail no longer fits spent its
        levels 5-8 on the same problem, 2-3 s a call (Swap, eight times an episode)."""
        inst = compiled.instantiation
        if (
            result.status != UNSOLVABLE
            or self.ev.tried
            or (inst is not None and not inst.saturated)
        ):
            return None
        if self.level >= self.max_level:
            return None  # the last level's own message says as much
        took = time.monotonic() - self.start
        why = " under the cost bound" if bound is not None else ""
        return self.finish(
            "unsolvable",
            message=f"no plan{why} at level {self.level}, and no higher level adds a stream "
            f"instance (found in {took:.1f} s)",
        )

    def raise_level(self, result, bound) -> Solution | None:
        """No plan at this level: the next level (failed instances may be retried there), or
        "unsolvable" after the last."""
        if result.message:
            self.best_failure = result.message
        if self.level >= self.max_level:
            why = "under the cost bound " if bound is not None else ""
            took = time.monotonic() - self.start  # a level cut-off proves nothing: not "unsolvable"
            return self.finish(
                "unsolvable",
                message=f"no plan found {why}up to level {self.max_level} in {took:.1f} s "
                f"({self.best_failure})",
            )
        self.level += 1
        self.ev.tried.clear()
        self.redraws.clear()
        return None

    def use_plan(self, compiled, result) -> Solution | None:
        """A plan: a solution when it needs no optimistic result (or only deferred ones), else
        its stream plan is evaluated (``None``: plan again)."""
        plan = compiled.map_plan(result.actions or [])
        pre = plan_preimage(compiled.source_domain, compiled.source_problem, plan)
        inst = compiled.instantiation
        needed = stream_plan(inst, pre, plan) if inst else []
        cost = (result.cost or 0.0) / compiled.scale
        if self.problem.metric is not None and not self.backend.capabilities.costs:
            # The planner planned with unit costs (its cost counts the compiled task's
            # actions): the plan's cost is the metric's, over the values as planned -- the
            # one the incumbent's is compared with, and the one reported.
            cost = plan_cost(compiled.source_domain, compiled.source_problem, plan)
        if self.incumbent is not None and cost >= self.incumbent.cost - 1e-9:
            # Optimistic costs are lower bounds: this plan costs at least what the incumbent
            # costs.  (A suboptimal planner, asked again after a stream plan that all
            # succeeded, often answers with another plan of the same cost over other
            # optimistic motions: tamp2d with 6 blocks evaluated such plans until its limit.)
            self.say("  no cheaper than the plan drawn before: taken")
            return self.finish_incumbent()
        if not needed:
            return self.finish(
                SOLVED, _steps(plan, self.values, set()), cost, sorted(pre.static_facts, key=str)
            )
        now, later = _split_deferred(needed, pre, plan, inst, self.module, self.defer)
        if not now:
            deferred_objs = {o for r in later for o in r.outputs}
            return self.finish(
                SOLVED,
                _steps(plan, self.values, deferred_objs),
                cost,
                sorted(pre.static_facts, key=str),
                deferred=later,
            )
        ordered = order_stream_plan(now, self.module.info_for, _producers(now, inst))
        self.compiled_objects = inst.objects
        self.say("  stream plan: " + ", ".join(str(r.instance) for r in ordered))
        done = self.evaluate_stream_plan(ordered, inst.shared)
        usable = self.stream_plan_ok and not inst.shared
        if done is None and usable:
            found = self.bound_solution(compiled, plan, inst, later)
            if found is not None and self.accept_drawn:
                return found
            if found is not None:
                # cheaper than any kept before (a plan no cheaper was not evaluated, above);
                # a suboptimal planner may still find a cheaper one
                self.incumbent = found
        return done

    def bound_solution(self, compiled, plan, inst, later=()) -> Solution | None:
        """Every result of the stream plan succeeded: the plan with its optimistic objects
        bound to their real values, when it is valid over the real facts and costs no more
        than planned (optimistic costs are lower bounds: replanning would find it again,
        after one more planner call); ``None``: plan again.

        ``later``: the results deferred to a later cycle (paper §VII): their outputs stay
        optimistic, and their facts and cost terms hold as planned, over the values drawn
        for their inputs -- as they would in the plan found by planning again, whose only
        optimistic results would be these (a constrained replan of the kitchen spent its
        last planner call, 1-1.5 s, finding the same plan again)."""
        binding = self.stream_plan_binding
        bound = [(name, tuple(binding.get(a, a) for a in args)) for name, args in plan]
        deferred_objs = {o for r in later for o in r.outputs}
        if any(a in inst.objects and a not in deferred_objs for _, args in bound for a in args):
            return None
        mapping = {o: v for o, v in binding.items() if isinstance(v, str)}
        real = _real_problem(
            self.problem, compiled, self.ev.results, self.ev.real_functions, later, mapping
        )
        try:
            pre = plan_preimage(compiled.source_domain, real, bound)
            cost = plan_cost(compiled.source_domain, real, bound)
            planned = plan_cost(compiled.source_domain, compiled.source_problem, plan)
        except (PlanInvalid, SSRError):
            return None
        if cost > self.max_cost:
            return None
        dearer = not cost <= planned + 1e-9
        if dearer and self.incumbent is not None and cost >= self.incumbent.cost - 1e-9:
            return None
        drawn = self.finish(
            SOLVED,
            _steps(bound, self.values, deferred_objs),
            cost,
            sorted(pre.static_facts, key=str),
            deferred=[_bound_result(r, mapping) for r in later],
        )
        if dearer:
            # Valid, but dearer than planned (an optimistic cost was below the real one):
            # planning again may find a cheaper plan, and this one is kept meanwhile -- the
            # answer when time runs out, or when the next plan's optimistic cost is no lower
            # (tamp2d with 8 blocks drew eight valid plans, each dearer than planned, and
            # timed out with none of them).
            self.say(f"  the plan holds with the values drawn but costs {cost:g} "
                     f"(planned {planned:g}): kept, planning again")
            self.incumbent = drawn
            return None
        self.say(
            "  the plan holds with the values drawn"
            + (f", {len(later)} deferred" if later else "")
            + ("" if self.accept_drawn else f" (cost {cost:g}; kept, planning again)")
        )
        return drawn

    def evaluate_stream_plan(self, ordered: list[Result], shared) -> Solution | None:
        """Evaluate the stream plan in order, binding optimistic objects to real values; a
        result whose inputs or domain facts come from a failed one is skipped (``None``: plan
        again, with the new real facts).

        A generator whose draw a test of this stream plan rejected draws again at once -- at
        most ``resample`` times per result -- and what depends on its outputs is evaluated
        again (:meth:`_to_redraw`): one more sample for the same plan costs a stream call,
        where planning again cost a planner call on a larger problem (Cook: 2-6 s per call,
        once per rejected placement or observation).  A generator whose draw failed draws
        again once, while that pays off for its stream in this solve: a sampler that found
        nothing for its inputs mostly finds nothing again (Swap's placements into a drawer out
        of reach, ~0.3 s a draw), one that fails at first by design does not."""
        binding: dict[str, Any] = {}  # optimistic object -> its real name
        values_of: dict[str, list[str]] = {}  # shared optimistic object -> real names
        facts = _RealFacts(self.problem, self.ev)
        settled: dict[int, bool] = {}  # evaluated results (by id) and their outcome
        drawn: set[int] = set()  # generator results drawn afresh in this evaluation
        again: dict[int, int] = {}  # draws each result had again
        after_failure: set[int] = set()  # results drawing again after a failed draw
        producer = {o: r for r in ordered for o in r.outputs}
        position = {id(r): i for i, r in enumerate(ordered)}
        # Draws again after rejections, per result: ``resample`` for each other draw of this
        # stream plan that a test checks its outputs against (a placement among k others
        # drawn for the same plan must miss each of them: the draws it needs grow with k).
        partners: dict[int, set[int]] = {id(r): set() for r in ordered}
        for t in ordered:
            if t.instance.kind == "test":
                ids = {id(producer[x]) for x in t.instance.inputs if x in producer}
                for rid in ids:
                    partners[rid] |= ids - {rid}
        rejected_limit = {rid: self.resample * max(len(p), 1) for rid, p in partners.items()}
        self.stream_plan_ok = False
        while True:
            failed: set[str] = set()
            # Facts the stream plan counted on whose producer failed in this iteration: a
            # result whose domain needs one of them is not evaluated (its domain does not
            # hold), and what it would certify is unproven too.
            failed_facts: set[S.Atom] = set()
            all_ok = True
            redraw: list[Result] = []
            for res in ordered:
                if time.monotonic() >= self.deadline:
                    return self.finish(
                        "timeout",
                        message=f"time limit of {self.time_limit:g} s reached while evaluating streams",
                    )
                rid = id(res)
                if rid in settled:
                    if not settled[rid]:
                        all_ok = False
                        failed.update(res.outputs)
                        failed_facts.update(res.certified)
                    continue
                if any(x in failed for x in res.instance.inputs) or any(
                    f in failed_facts for f in res.domain
                ):
                    failed.update(res.outputs)
                    failed_facts.update(res.certified)
                    all_ok = False
                    continue
                if shared and any(x in shared for x in (*res.instance.inputs, *res.outputs)):
                    ok = self.evaluate_shared(res, shared, binding, values_of, facts)
                    settled[rid] = ok
                    if not ok:
                        all_ok = False
                        failed.update(res.outputs)
                    continue
                ok = self.ev.evaluate(res, binding)
                fresh = self.ev.called
                self.ev.record(ok, res.instance.stream)
                settled[rid] = ok
                if rid in after_failure:
                    after_failure.discard(rid)
                    paid = self.draw_again_paid.setdefault(res.instance.stream, [0, 0])
                    paid[0] += 1
                    paid[1] += int(ok)
                if res.instance.kind == "stream" and fresh:
                    drawn.add(rid)
                if ok:
                    continue
                all_ok = False
                failed.update(res.outputs)
                failed_facts.update(res.certified)
                self.say(f"  {res.instance} failed")
                own = []
                if res.instance.kind != "test" and self._draw_again_pays(res.instance.stream):
                    own = self._to_redraw([res], drawn, again, binding, min(self.resample, 1))
                    own = [r for r in own if all(r is not x for x in redraw)]
                    after_failure.update(id(r) for r in own)
                    redraw += own
                inputs_blamed = self.module.info_for(res.instance.stream).redraw_inputs
                if res.instance.kind == "test" or (inputs_blamed and not own):
                    # A test rejected values drawn for this plan, or a stream that blames its
                    # inputs (StreamInfo.redraw_inputs: tamp2d's ik of a placement out of
                    # reach) found nothing for them: the draw made last among its inputs is
                    # drawn again (the earlier ones passed their own tests) -- values drawn in
                    # turn, each against those kept.
                    if res.instance.kind == "test":
                        self.redraw_rejected(res, binding)
                    blamed = [producer[x] for x in res.instance.inputs if x in producer]
                    blamed.sort(key=lambda r: position[id(r)], reverse=True)
                    redraw += [
                        r
                        for r in self._to_redraw(blamed, drawn, again, binding, rejected_limit)[:1]
                        if all(r is not x for x in redraw)
                    ]
            if all_ok or not redraw:
                break
            # The redrawn results and everything downstream of them are evaluated again.
            outputs = {o for r in redraw for o in r.outputs}
            for r in ordered:
                if id(r) in {id(x) for x in redraw} or any(x in outputs for x in r.instance.inputs):
                    outputs.update(r.outputs)
                    settled.pop(id(r), None)
                    drawn.discard(id(r))
            for o in outputs:
                binding.pop(o, None)
            for r in redraw:
                again[id(r)] = again.get(id(r), 0) + 1
                self.stats.resamples += 1
            self.say("  drawing again: " + ", ".join(str(r.instance) for r in redraw))
        self.stream_plan_ok = all_ok
        self.stream_plan_binding = binding
        return None

    def _draw_again_pays(self, stream: str) -> bool:
        """Drawing again after a failed draw of ``stream``: not tried yet in this solve, or it
        gave a value at least once."""
        tries, successes = self.draw_again_paid.get(stream, (0, 0))
        return tries == 0 or successes > 0

    def _to_redraw(
        self,
        blamed: list[Result],
        drawn: set[int],
        again: dict[int, int],
        binding: dict,
        limit: int | dict[int, int],
    ) -> list[Result]:
        """Those of ``blamed`` to draw again now: generator results drawn afresh in this
        evaluation, not exhausted, that have drawn again fewer than ``limit`` times (a number,
        or one per result id)."""
        out = []
        for r in blamed:
            if r.instance.kind != "stream" or id(r) not in drawn:
                continue
            most = limit if isinstance(limit, int) else limit.get(id(r), 0)
            if again.get(id(r), 0) >= most:
                continue
            if _bound(r, binding) not in self.ev.exhausted and all(x is not r for x in out):
                out.append(r)
        return out

    def redraw_rejected(self, test: Result, binding: dict[str, str]) -> None:
        """A test failed on a value a generator of this stream plan just drew: the draw was
        rejected, so the generator may draw again at this level (at most ``redraws`` rejected
        draws per instance and level) instead of leaving the level without that sample."""
        inst = self.compiled_objects
        for x in test.instance.inputs:
            producer = inst.get(x)
            if producer is None or producer.instance.kind != "stream":
                continue
            real = _bound(producer, binding)
            if real in self.ev.exhausted or real not in self.ev.tried:
                continue
            count = self.redraws.get(real, 0)
            if count < self.redraws_per_level:
                self.redraws[real] = count + 1
                self.ev.tried.discard(real)

    def evaluate_shared(self, res, shared, binding, values_of, facts) -> bool:
        """A shared object stands for every real value bound to it: evaluate the instance for
        each combination whose domain facts really hold.  True if one succeeded."""
        inputs = res.instance.inputs
        choices = [values_of.get(x, []) if x in shared else [binding.get(x, x)] for x in inputs]
        any_ok = False
        for combo in itertools.product(*choices):
            local = dict(zip(inputs, combo))
            if not all(facts.holds(f, local, binding) for f in res.domain):
                continue
            ok = self.ev.evaluate(res, local)
            self.ev.record(ok, res.instance.stream)
            if not ok:
                self.say(f"  {res.instance.stream}({', '.join(combo)}) failed")
                continue
            any_ok = True
            for o in res.outputs:
                if o in shared:
                    if local[o] not in values_of.setdefault(o, []):
                        values_of[o].append(local[o])
                else:
                    binding[o] = local[o]
        return any_ok


class _RealFacts:
    """The real facts (the problem's and the evaluated results'), kept up to date."""

    def __init__(self, problem: S.Problem, ev: _Evaluation):
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


def _evaluate_eagerly(
    streams: S.StreamFile,
    problem: S.Problem,
    names: set[str],
    tests: set[str],
    ev: _Evaluation,
    eager_streams: set[str] = frozenset(),
) -> None:
    """Evaluate the cheap cost-function terms (``names``) and tests (``tests``), and the
    streams whose info says ``eager`` (one draw), whose domain holds in the real facts and
    that have no outcome yet (nor, for a stream, a draw at this level or an end)."""
    found = real_instances(
        streams, problem, ev.results, functions=names, tests=tests,
        streams_with_outputs=eager_streams,
    )
    for inst in found:
        if inst in ev.outcomes:
            continue
        if inst.kind == "stream" and (inst in ev.tried or inst in ev.exhausted):
            continue
        res = Result(inst, (), (), (), 0)
        ok = ev.evaluate(res, {})
        ev.record(ok, inst.stream)


def _split_deferred(needed, pre, plan, inst, module, defer: bool):
    """Which results to evaluate now, and which to defer (paper §VII)."""
    if not defer or not plan:
        return list(needed), []
    first_args = set(plan[0][1])
    first_facts = pre.per_step[0] if pre.per_step else set()
    first_costs = pre.per_step_costs[0] if pre.per_step_costs else set()
    must = set()
    for r in needed:
        deferrable = module.info_for(r.instance.stream).deferrable
        uses_now = (
            bool(set(r.outputs) & first_args)
            or any(f in first_facts for f in r.certified)
            or (
                r.instance.kind == "function"
                and S.FuncTerm(r.instance.stream, tuple(S.Const(a) for a in r.instance.inputs))
                in first_costs
            )
        )
        if uses_now or not deferrable or any(o in inst.shared for o in r.outputs):
            must.add(id(r))
    # Everything a must-result needs (its producers) must be evaluated too.
    producers = _producers(needed, inst)
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


def _producers(results: list[Result], inst) -> dict[int, list[int]]:
    ids = {id(r) for r in results}
    out: dict[int, list[int]] = {}
    for r in results:
        deps = []
        for x in r.instance.inputs:
            for p in inst.shared.get(x) or [inst.objects.get(x)]:
                if p is not None and id(p) in ids:
                    deps.append(id(p))
        for fact in r.domain:
            for p in inst.facts.get(fact, ())[:1]:
                if id(p) in ids:
                    deps.append(id(p))
        out[id(r)] = deps
    return out


def _size(compiled, operators: int | None) -> tuple[int, int, int, int | None]:
    """Objects, facts and function values of the optimistic problem, and the ground actions
    of the planner's task (the planner's count, or the grounding pass's; ``None``: unknown)."""
    problem = compiled.source_problem or compiled.problem
    facts = sum(1 for f in problem.init if isinstance(f, S.Atom))
    grounded = compiled.lowered.grounded if compiled.lowered is not None else None
    if operators is None and grounded is not None:
        operators = len(grounded.domain.actions)
    objects = len(problem.objects) + len(
        compiled.source_domain.constants if compiled.source_domain else ()
    )
    return (objects, facts, len(problem.init) - facts, operators)


def _steps(plan, values: ValueTable, deferred_objects: set[str]) -> list[Step]:
    steps = []
    for name, args in plan:
        vals = tuple(None if a in deferred_objects else values.value(a) for a in args)
        steps.append(Step(name, tuple(args), vals, tuple(a for a in args if a in deferred_objects)))
    return steps


def print_solution(solution: Solution, out=sys.stdout) -> None:
    """A human-readable report: plan with values, cost, statistics."""
    st = solution.stats
    if solution.plan is not None:
        print(f"plan ({len(solution.plan)} actions, cost {solution.cost:g}):", file=out)
        if solution.costs_ignored_by:
            print(
                f"  (costs ignored: {solution.costs_ignored_by} plans with unit costs, so a "
                "cheaper plan may exist; the cost above is the plan's under the problem's metric)",
                file=out,
            )
        for i, step in enumerate(solution.plan, 1):
            vals = ", ".join(
                f"{a}={_short(v)}"
                for a, v in zip(step.args, step.values)
                if v is not None and not (isinstance(v, str) and v == a)  # any type (numpy)
            )
            mark = f"  [deferred: {' '.join(step.deferred)}]" if step.deferred else ""
            print(f"  {i:2d}. {step}{mark}", file=out)
            if vals:
                print(f"      {vals}", file=out)
    else:
        print(f"no plan: {solution.message}", file=out)
    print(
        f"iterations {st.iterations}, levels {st.levels[0] if st.levels else 0}..{max(st.levels, default=0)}, "
        f"planner calls {st.planner_calls} ({st.planner_time:.3f} s), streams {st.stream_time:.3f} s, "
        f"total {st.total_time:.3f} s",
        file=out,
    )
    if st.sizes:
        big = max(st.sizes, key=lambda z: (z[1], z[0]))
        print(
            f"largest compiled problem: {big[0]} objects, {big[1]} facts, {big[2]} values"
            + (f", {big[3]} ground actions" if big[3] is not None else "")
            + f"; compilation {st.compile_time:.3f} s",
            file=out,
        )
    for name, s in sorted(st.streams.items()):
        print(
            f"  {name:24s} calls {s.calls:4d}  ok {s.successes:4d}  failed {s.failures:4d}  {s.time:8.4f} s",
            file=out,
        )


def _short(v: Any) -> str:
    text = repr(v)
    if isinstance(v, tuple) and all(isinstance(x, float) for x in v):
        text = "(" + ", ".join(f"{x:.3g}" for x in v) + ")"
    return text if len(text) <= 60 else text[:57] + "..."
