"""What the solver's loops share (:class:`SolverLoop`): one call of
:func:`~ssr_compile.solver.solve`, its options, its stream evaluation and statistics, compiling
the optimistic problem of a level and calling the planner on it."""

from __future__ import annotations

import time

from .. import syntax as S
from ..compile.instantiate import Instance, Instantiation, Result, real_instances
from ..compile.lazy_tests import lazy_tests
from ..compile.pipeline import compile_problem
from ..compile.predicates import optimistic_truth
from ..compile.standins import StandIns
from ..errors import InstanceCapReached
from ..planners import fd as _default_backend  # noqa: F401 - the default, loaded with the solver
from ..planners import get_planner
from ..planners.base import UNSOLVABLE, PlanResult
from ..stream import StreamsModule, ValueTable
from .deferral import order_stream_plan, reschedule_stream_plan, stream_producers
from .evaluation import Evaluation, RealJoin, evaluate_eagerly
from .options import ReplanState, SolveOptions
from .preimage import Preimage, plan_preimage, stream_plan
from .results import SOLVED, Solution, Statistics, plan_steps


class SolverLoop:
    """One call of :func:`~ssr_compile.solver.solve`; each algorithm's loop derives from it
    and defines :meth:`run`."""

    def __init__(
        self,
        domain: S.Domain,
        streams: S.StreamFile,
        problem: S.Problem,
        module: StreamsModule,
        state: ReplanState,
        options: SolveOptions,
    ):
        self.start = time.monotonic()
        self.options = options
        self.deadline = self.start + options.time_limit
        self.time_limit, self.max_cost, self.defer = (
            options.time_limit, options.max_cost, options.defer
        )  # fmt: skip
        self.max_level = options.max_level
        self.domain, self.streams, self.problem, self.module = domain, streams, problem, module
        self.state = state
        planner = options.planner
        self.backend = get_planner(planner) if isinstance(planner, str) else planner
        module.check_against(streams)
        self.stats = Statistics()
        self.values = state.values
        if self.values is None:
            taken = {o.name for o in problem.objects} | {c.name for c in domain.constants}
            self.values = ValueTable(module.values, taken)
        self.say = options.progress or (lambda msg: None)
        self.standins = StandIns.of(module, self.values.value)
        # streams declared never to succeed on optimistic values (StreamInfo.p_success 0)
        self.real_only = frozenset(n for n, i in module.info.items() if i.p_success <= 0)
        self.optimistic_values = {
            f.name: module.info_for(f.name).optimistic_value
            for f in streams.functions
            if module.info_for(f.name).optimistic_value is not None
        }
        self.level = max(options.initial_level, 0)
        self.first_level = self.level
        base = options.complexity_base
        self.complexity_base = self.level if base is None else min(max(base, 0), self.level)
        self.best_failure = "no plan"
        self.last_compile = 0.0  # seconds the last optimistic problem took to compile
        accept_drawn = options.accept_drawn
        if accept_drawn is None:
            accept_drawn = bool(getattr(self.backend.capabilities, "optimal", False))
        self.accept_drawn = accept_drawn
        self.eager_join: RealJoin | None = None  # the eager instances, joined incrementally
        self.eager_seen = -1  # number of real results when cheap functions were last evaluated
        self.rechecked = False  # the last call's failures evaluated again (:meth:`recheck`)
        eager_cost = options.eager_cost
        self.eager = {
            f.name for f in streams.functions if module.info_for(f.name).cost <= eager_cost
        }
        self.eager_tests = {
            s.name
            for s in streams.streams
            if options.eager_tests and s.is_test and module.info_for(s.name).cost <= eager_cost
        }
        self.eager_streams = {
            s.name for s in streams.streams if not s.is_test and module.info_for(s.name).eager
        }
        # cheap tests read only through their failures: stated where they failed, checked
        # where a plan relies on them (compile/lazy_tests.py)
        self.lazy: dict[str, str] = {}
        if options.lazy_tests and self.eager_tests:
            turned = lazy_tests(domain, streams, problem, self.eager_tests)
            if turned.tests:
                self.domain, self.streams = domain, streams = turned.domain, turned.streams
                self.lazy = turned.tests
                self.eager_tests -= set(turned.tests.values())
        self.ev = Evaluation(streams, module, self.values, self.stats, self.lazy)
        self.ev.expect = optimistic_truth(domain, streams, problem)
        self.ev.results.extend(state.evaluated)
        self.inherited = len(state.evaluated)  # ev.results[:inherited] came from earlier calls
        for r in state.evaluated:  # their facts have complexity 0 in this call
            self.ev.fact_complexity.update((f, 0) for f in r.certified)

    def run(self) -> Solution:
        """The algorithm's loop: each registered algorithm (``dispatch.LOOPS``) gives its own."""
        raise NotImplementedError(f"{type(self).__name__} does not define run()")

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
        sol.failed = self.failed_over_objects()
        sol.level = self.level
        return sol

    def failed_over_objects(self) -> list[Instance]:
        """The instances over the problem's objects alone that failed in this call: tests,
        streams of one output at most, and generators whose last draw found nothing (what
        the next replanning call rechecks: :meth:`recheck`)."""
        names = {o.name for o in self.problem.objects} | {c.name for c in self.domain.constants}
        ev, out = self.ev, []
        for inst in sorted(ev.exhausted | set(ev.outcomes) | ev.failed_draws, key=str):
            if not all(x in names for x in inst.inputs):
                continue
            if inst.kind == "test":
                failed = ev.outcomes.get(inst) is False
            elif self.module.info_for(inst.stream).kind == "function":
                failed = inst in ev.exhausted and not ev.outcomes.get(inst)
            else:
                failed = inst in ev.failed_draws
            if failed:
                out.append(inst)
        return out

    def recheck(self) -> None:
        """The instances that failed in the last replanning call (``ReplanState.recheck``),
        evaluated again now where their domain holds, before the first plan: a failure found
        again is never planned with.  The kitchen's Swap asked, cycle after cycle with the
        robot where it was, to push the drawer closed from there, and each plan through that
        push cost a planner call before its evaluation failed it again."""
        wanted = {i for i in self.state.recheck if i.stream in self.ev.decl}
        if not wanted:
            return
        tests = {i.stream for i in wanted if i.kind == "test"}
        found = real_instances(
            self.streams, self.problem, self.ev.results, functions=(), tests=tests,
            streams_with_outputs={i.stream for i in wanted if i.kind == "stream"},
        )  # fmt: skip
        for inst in found:
            if inst in wanted and inst not in self.ev.outcomes and inst not in self.ev.tried:
                self.ev.evaluate_real(inst)

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

    def evaluate_cheap_functions(self) -> None:
        """The cheap cost functions and tests over real arguments, once per new real result
        (a test that passes adds facts: again until none does); the first time, the last
        call's failures too (:meth:`recheck`)."""
        if not self.rechecked:
            self.rechecked = True
            self.recheck()
        while (
            self.eager or self.eager_tests or self.eager_streams or self.streams.predicates
        ) and len(self.ev.results) != self.eager_seen:
            self.eager_seen = len(self.ev.results)
            if self.eager_join is None:
                self.eager_join = RealJoin(
                    self.streams, self.problem, self.eager, self.eager_tests, self.eager_streams
                )
            evaluate_eagerly(self.eager_join, self.ev)

    def function_estimates(self) -> dict[str, float]:
        """The value each cost function's unevaluated terms are planned with: its declared
        ``optimistic_value``; for a function that declares none, the least value it gave so
        far in this solve (the default of 1 before any).  A default far below every real value
        makes each plan over real arguments whose terms are not evaluated look cheaper than
        any plan drawn (continuous_tamp: moves cost 10 and more, planned at 1), and the planner
        is asked again for each of them once a plan is kept; declare ``optimistic_value`` for
        a bound the planner may rely on."""
        least: dict[str, float] = {}
        for term, value in self.ev.real_functions.items():
            if term.name in self.optimistic_values or value == float("inf"):
                continue
            if value < least.get(term.name, float("inf")):
                least[term.name] = value
        return {**least, **self.optimistic_values}

    def compile(self):
        """The optimistic problem of this level, constrained by the inherited plan tail."""
        started = time.perf_counter()
        compiled = compile_problem(
            self.domain,
            self.streams,
            self.problem,
            caps=self.backend.capabilities,
            level=self.level,
            evaluated=self.visible_results(),
            disabled=self.ev.tried,
            exhausted=self.ev.exhausted,
            function_values=self.function_estimates(),
            real_function_values=self.ev.real_functions,
            plan_tail=self.state.tail,
            is_constant=self.state.is_constant,
            unit_cost=self.options.unit_cost,
            share=self.options.share,
            leaves=self.options.leaves,
            hubs=self.options.hubs,
            standins=self.standins,
            real_only=self.real_only,
        )
        self.last_compile = time.perf_counter() - started
        self.stats.compile_time += self.last_compile
        return compiled

    def visible_results(self) -> list[Result]:
        """The real results the optimistic problem of this level is built on: all of them
        (a loop may hide some: :meth:`FocusedLoop.visible_results
        <ssr_compile.solver.focused.FocusedLoop.visible_results>`)."""
        return self.ev.results

    def call_planner(self, compiled, remaining: float, bound: float | None):
        """One backend call, counted in the statistics: its result and the compiled problem's
        size (objects, facts, values, ground actions if the backend reports them).

        A plan tail that no value of the problem fits (:attr:`Constrained.unfit`) is
        unsolvable as compiled, and no backend is asked: on Swap, a third of the planner calls
        of a constrained attempt that fell back, 0.05-0.15 s each, translated a task to no
        operator at all."""
        constrained = compiled.constrained
        if constrained is not None and constrained.unfit:
            names = ", ".join(constrained.unfit[:3]) + (
                ", ..." if len(constrained.unfit) > 3 else ""
            )
            result = PlanResult(
                UNSOLVABLE, None, None, 0.0, self.backend.name,
                message=f"no value of the problem fits the plan tail's {names}",
            )  # fmt: skip
            size = problem_size(compiled, 0)
            self.stats.sizes.append(size)
            return result, size
        result = self.backend.solve(
            compiled.domain, compiled.problem, time_limit=max(remaining, 0.01), cost_bound=bound
        )
        self.stats.planner_calls += 1
        self.stats.planner_time += result.time
        self.stats.translate_time += getattr(result, "translate_time", 0.0)
        self.stats.search_time += getattr(result, "search_time", 0.0)
        size = problem_size(compiled, getattr(self.backend, "last_operators", None))
        self.stats.sizes.append(size)
        return result, size

    def stream_plan_of(
        self, compiled, result
    ) -> tuple[list, Preimage, Instantiation | None, list[Result]]:
        """The planner's plan over the optimistic problem's names, its preimage, the
        instantiation and the stream plan: the optimistic results the plan needs."""
        plan = compiled.map_plan(result.actions or [])
        inst = compiled.instantiation
        unknown = inst.unknown if inst else frozenset()
        pre = plan_preimage(compiled.source_domain, compiled.source_problem, plan, unknown)
        needed = stream_plan(inst, pre, plan) if inst else []
        return plan, pre, inst, needed

    def schedule(
        self,
        plan,
        pre: Preimage,
        inst: Instantiation,
        needed: list[Result],
        cost: float,
        certificate: list,
    ) -> tuple[list[Result], list[Result]] | Solution:
        """The stream plan rescheduled for the first action (§VII,
        :func:`~ssr_compile.solver.deferral.reschedule_stream_plan`): the results to evaluate
        now, in order, and those deferred -- or the solution itself when nothing is left to
        evaluate now."""
        checks = self.ev.expect  # a stream predicate's check is never deferred
        deferrable = lambda s: s not in checks and self.info_for(s).deferrable  # noqa: E731
        now, later = reschedule_stream_plan(needed, pre, plan, inst, deferrable, self.defer)
        if not now:
            deferred = {o for r in later for o in r.outputs}
            steps = plan_steps(plan, self.values, deferred)
            return self.finish(SOLVED, steps, cost, certificate, deferred=later)
        return order_stream_plan(now, self.info_for, stream_producers(now, inst)), later

    def info_for(self, name: str):
        """The stream info of ``name`` (a lazy test's complement has its test's)."""
        return self.module.info_for(self.lazy.get(name, name))


def problem_size(compiled, operators: int | None) -> tuple[int, int, int, int | None]:
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
