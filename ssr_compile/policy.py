"""The online replanning policy (paper §VI, Algorithm 1) and the contract of what it acts in.

Each cycle:

1. DETERMINIZE: the :class:`Agent` turns its current belief (and what the robot knows for
   certain: its configuration, what it holds) into a PDDLStream problem and the Python values
   of its objects;
2. when the last plan left a tail and the variant uses constraints, PLAN with the tail's
   structure enforced (Algorithm 2, :mod:`ssr_compile.compile.constraints`) from
   ``s ∪ f_prev`` under its own time limit; on failure or time-out,
3. PLAN again without constraints;
4. no plan: failure; an empty plan: the goal belief is reached;
5. otherwise EXECUTE the first action in the :class:`Environment`, receive its observation,
   UPDATE the belief, keep ``ConstantFacts(f)`` (the certificate's static facts over
   constants only) and the unexecuted tail -- the solver's
   :class:`~ssr_compile.solver.ReplanState`, which the next constrained attempt hands it -- and
   repeat.

PLAN is the Focused solver (:func:`ssr_compile.solver.solve`); with deferral (§VII) it leaves
the deferrable streams the first action does not need optimistic, and they stay so until a
later cycle needs them.

The policy never reads the true state: success is judged afterwards by
:meth:`Environment.goal_holds` on the environment's true state.

The user's code (README, "Writing an environment"; :mod:`ssr_compile.episode_record`): an
exception of the environment or the agent ends the episode (``UserCodeError``, the cycles so
far in its ``result``), as do an ``execute`` past ``execute_time`` and an action that failed
``max_failures`` times from the same problem (the agent learned nothing from its failures).
"""

from __future__ import annotations

import hashlib
import math
import pickle
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any, Protocol, runtime_checkable

from . import syntax as S
from .episode_record import (
    Cycle,
    EpisodeResult,
    UserCodeError,
    add_split,
    failed,
    failure_text,
    where,
)
from .errors import InstanceCapReached, TimeLimitReached
from .json_output import to_json
from .limits import overrunning_stream, time_limit
from .policy_settings import PolicySettings
from .solver import ReplanState, Solution, Statistics, Step, solve
from .solver.carry import constant_facts, stream_constants
from .stream import StreamsModule

STREAM_GRACE = 1.0  # seconds a planning attempt may overrun its limit before the alarm


class StreamOverrun(Exception):
    """A stream did not return within a planning attempt's limit (and its grace)."""

    def __init__(self, stream: str | None, seconds: float):
        super().__init__(stream, seconds)
        self.stream, self.seconds = stream, seconds

    def __str__(self) -> str:
        who = f"stream '{self.stream}'" if self.stream else "a stream"
        return f"{who} did not return within the planning limit ({self.seconds:.1f} s)"


# ---------------------------------------------------------------- the contract


@runtime_checkable
class Environment(Protocol):
    """The world the policy acts in.

    ``observe()`` is the observation before the first plan (``None`` if there is none);
    ``execute(step)`` carries out one action of a plan (its arguments' Python values are in
    ``step.values``) and returns what the robot observes afterwards -- a failed execution is an
    observation too, never an exception; ``goal_holds()`` reads the *true* state, for
    evaluation only (the policy never calls it).  ``close()`` frees resources.
    """

    def observe(self) -> Any: ...

    def execute(self, step: Step) -> Any: ...

    def goal_holds(self) -> bool: ...

    def close(self) -> None: ...


@runtime_checkable
class Agent(Protocol):
    """The robot's side: its belief and what it knows for certain.

    ``domain`` and ``streams`` are the PDDLStream domain and stream file it plans with.
    ``problem()`` (DETERMINIZE) returns the problem for the current belief and a
    :class:`StreamsModule` whose ``values`` hold the Python values of its objects;
    ``update(step, observation)`` (UPDATEBELIEF) folds an observation in (``step`` is ``None``
    for the observation before the first plan); ``is_constant(name)`` says which of the
    problem's objects are constants in the sense of §VI-A (object names, grasps: still valid
    after new observations; not poses, configurations, trajectories or beliefs);
    ``summary()`` is a one-line description of the belief for logs.
    """

    domain: S.Domain
    streams: S.StreamFile

    def problem(self) -> tuple[S.Problem, StreamsModule]: ...

    def update(self, step: Step | None, observation: Any) -> None: ...

    def is_constant(self, name: str) -> bool: ...

    def summary(self) -> str: ...


@dataclass
class Episode:
    """An environment and the agent that acts in it (what an example's factory returns).

    ``render`` (optional): a picture of the episode now, ``render(caption) -> RGB array``, the
    frames of ``ssr-compile run --gif``."""

    environment: Environment
    agent: Agent
    name: str = ""
    render: Callable[[str], Any] | None = None

    def close(self) -> None:
        self.environment.close()


# ---------------------------------------------------------------- Algorithm 1


def run_policy(
    episode: Episode,
    settings: PolicySettings | None = None,
    *,
    on_cycle: Callable[[Cycle], None] | None = None,
    progress: Callable[[str], None] | None = None,
) -> EpisodeResult:
    """Run Algorithm 1 in ``episode`` until the goal belief, a failure or a limit.

    Raises :class:`UserCodeError` (its ``result``: the episode so far) when the environment's
    or the agent's code raises, and ``TypeError`` when ``episode`` is not an :class:`Episode`."""
    if not isinstance(episode, Episode):
        raise TypeError(f"run_policy needs an Episode, got {type(episode).__name__}")
    return _Policy(episode, settings or PolicySettings(), on_cycle, progress).run()


@dataclass
class _CycleState:
    """One cycle so far: its planning attempts' time (``"c"``: constrained, ``"u"``:
    unconstrained) and its parts, stream and planner calls, how its constrained attempt went."""

    index: int
    start: float
    constrained: str = "-"
    spent: dict[str, float] = field(default_factory=lambda: {"c": 0.0, "u": 0.0})
    streams_called: int = 0
    planners_called: int = 0
    split: dict[str, float] = field(default_factory=dict)  # Cycle.planner_time ... compile_time


class _Policy:
    """One run of Algorithm 1 (:func:`run_policy`): what the episode keeps between cycles --
    the planning time spent, the cycles logged, the replanning state and the level the plan in
    use was found at."""

    def __init__(
        self,
        episode: Episode,
        settings: PolicySettings,
        on_cycle: Callable[[Cycle], None] | None,
        progress: Callable[[str], None] | None,
    ):
        self.settings, self.on_cycle, self.progress = settings, on_cycle, progress
        self.env, self.agent = episode.environment, episode.agent
        self.start = time.monotonic()
        self.planning = 0.0
        self.cycles: list[Cycle] = []
        self.state = ReplanState()
        self.last_level = settings.initial_level  # the level the plan in use was found at
        # what the last planning attempt found failing over the problem's objects: the next
        # attempt evaluates it again before it plans (ReplanState.recheck)
        self.recheck: tuple = ()
        # failed executions: (the problem planned from, the action) -> how often
        self.failures: Counter = Counter()
        self.looks = 0  # observations without an action since the last action (max_looks)
        self.overran: str | None = None  # the stream that overran the last attempt, if any

    def user(self, role: str, obj: Any, method: str, *args: Any, limit: float | None = None):
        """Call the environment's or the agent's ``method``: its exception becomes a
        :class:`UserCodeError` naming it; ``limit``: seconds it may take (``TimeLimitReached``)."""
        try:
            with time_limit(limit):
                return getattr(obj, method)(*args)
        except (Exception, SystemExit) as e:
            raise UserCodeError(where(role, obj, method), e) from e

    def run(self) -> EpisodeResult:
        try:
            return self.episode()
        except UserCodeError as e:
            e.result = self.finish(False, e.message, after_error=True)
            raise

    def episode(self) -> EpisodeResult:
        try:
            first = self.user("environment", self.env, "observe", limit=self.execute_limit)
        except TimeLimitReached:
            return self.finish(False, self.hung(where("environment", self.env, "observe")))
        self.user("agent", self.agent, "update", None, first)
        try:
            for index in range(1, self.settings.max_cycles + 1):
                ended = self.cycle(_CycleState(index, time.monotonic()))
                if ended is not None:
                    return ended
        except StreamOverrun as e:
            self.planning += e.seconds
            return self.finish(False, str(e))
        return self.finish(False, f"no goal within {self.settings.max_cycles} cycles")

    @property
    def execute_limit(self) -> float:
        return self.settings.execute_time

    def hung(self, what: str) -> str:
        return f"{what} did not return within the execution limit of {self.execute_limit:g} s"

    def finish(self, believed: bool, reason: str, after_error: bool = False) -> EpisodeResult:
        """The result, the goal judged in the true state.  After the user's code failed
        (``after_error``) the goal holds only if ``goal_holds`` still answers so."""
        success = False
        try:
            success = bool(
                self.user("environment", self.env, "goal_holds", limit=self.execute_limit)
            )
        except TimeLimitReached:
            reason += "; " + self.hung(where("environment", self.env, "goal_holds"))
        except UserCodeError:
            if not after_error:
                raise
        return EpisodeResult(
            success,
            believed,
            reason,
            self.cycles,
            self.planning,
            time.monotonic() - self.start,
        )

    def cycle(self, cycle: _CycleState) -> EpisodeResult | None:
        """DETERMINIZE, PLAN (constrained, then unconstrained), EXECUTE the first action;
        the episode's result when it ends here."""
        settings = self.settings
        if settings.budget - self.planning <= 0:
            return self.finish(False, f"planning budget of {settings.budget:g} s exhausted")
        problem, module = self.determinize()
        solution: Solution | None = None
        comparison: float | None = None
        if settings.constraints and self.state.tail:
            solution, comparison = self.constrained_attempt(cycle, problem, module)
        if solution is None:
            remaining = settings.budget - self.planning
            if remaining <= 0:
                self.log(cycle, None, None)
                return self.finish(False, f"planning budget of {settings.budget:g} s exhausted")
            solution = self.unconstrained_attempt(cycle, problem, module, remaining)
        if not solution.solved:
            why = (
                "planning budget exhausted"
                if self.planning >= settings.budget
                else solution.message
            )
            # No plan from this belief, or none within an unconstrained attempt's own limit
            # with budget left: observe again and plan from the first levels with fresh
            # draws.  A search that ran long has grown its problems level by level (Cook
            # with four boxes that may hide the block, six objects, seed 9: 300 s to level
            # 7, 32,774 objects) and ended the episode with half its budget unused.
            if (
                solution.status in ("unsolvable", "timeout")
                and math.isinf(settings.max_cost)  # "none cheaper than c*" ends it (paper §V)
                and self.looks < settings.max_looks
                and self.planning < settings.budget
            ):
                return self.look_again(cycle, solution, why)
            self.log(cycle, None, solution)
            if math.isfinite(settings.max_cost) and solution.status == "unsolvable":
                return self.finish(False, f"no plan cheaper than c* = {settings.max_cost:g}: {why}")
            return self.finish(False, f"no plan: {why}")
        if solution.stats.levels:
            self.last_level = solution.stats.levels[-1]
        if not solution.plan:
            self.log(cycle, None, solution)
            return self.finish(True, "goal belief reached")
        return self.act(cycle, problem, module, solution, comparison)

    def look_again(self, cycle: _CycleState, solution: Solution, why: str) -> EpisodeResult | None:
        """No plan from this belief: observe again without acting and update the belief (the
        next cycle plans from it); the episode's result when the observation hung."""
        self.looks += 1
        self.log(cycle, None, solution, failed=True, failure=f"no plan ({why}): looking again")
        try:
            observation = self.user("environment", self.env, "observe", limit=self.execute_limit)
        except TimeLimitReached:
            return self.finish(False, self.hung(where("environment", self.env, "observe")))
        self.user("agent", self.agent, "update", None, observation)
        return None

    def determinize(self) -> tuple[S.Problem, StreamsModule]:
        """DETERMINIZE: the agent's problem, checked for its shape."""
        answer = self.user("agent", self.agent, "problem")
        if not (
            isinstance(answer, tuple)
            and len(answer) == 2
            and isinstance(answer[0], S.Problem)
            and isinstance(answer[1], StreamsModule)
        ):
            raise UserCodeError(
                where("agent", self.agent, "problem"),
                message=f"{where('agent', self.agent, 'problem')} returned "
                f"{_short(answer)}, not a (Problem, StreamsModule) pair",
            )
        return answer

    def constrained_attempt(
        self, cycle: _CycleState, problem: S.Problem, module: StreamsModule
    ) -> tuple[Solution | None, float | None]:
        """PLAN with the last plan's tail enforced: its solution (``None``: fall back) and, when
        measured (``compare_unconstrained``), the time an unconstrained solve took."""
        settings, state = self.settings, self.state
        limit = min(settings.constrained_time, settings.budget - self.planning)
        # The constants of this attempt: those carried over (the kept values among
        # them) and the problem's own.  The solver adds the kept facts (s ∪ f_prev).
        own = {o.name for o in problem.objects if self.agent.is_constant(o.name)}
        # It starts at the level the last plan was found at: the tail's instances
        # are no deeper now (more of their inputs are real), and each level below
        # was a planner call on a problem without the tail (Swap: levels 1-4 of
        # every constrained attempt, 0.3-0.7 s each, "0 ground actions").
        # As many levels as from the first (a level rise also retries what failed).
        first = max(settings.initial_level, min(self.last_level, settings.max_level))
        solution = self.attempt(
            cycle,
            problem,
            module,
            limit,
            "c",
            settings.max_level + first - settings.initial_level,
            first_level=first,
            state=replace(state, constants=state.constants | own),
            accept_drawn=True,
            accept_dearer=True,
            retry_levels=settings.constrained_retry_levels,
        )
        if not solution.solved:
            cycle.constrained = "timeout" if solution.status == "timeout" else "fell back"
            return None, None
        cycle.constrained = "held"
        comparison = None
        if settings.compare_unconstrained:
            options = settings.solve_options(time_limit=settings.unconstrained_time)
            other = solve(self.agent.domain, self.agent.streams, problem, module, options)
            comparison = other.stats.total_time if other.solved else None
        return solution, comparison

    def unconstrained_attempt(
        self, cycle: _CycleState, problem: S.Problem, module: StreamsModule, remaining: float
    ) -> Solution:
        """PLAN without the tail: from ``resume_below`` levels below the level the last plan
        was found at (a problem at a level holds every instance of the levels below it; one
        below, so that the level can come down again as the task nears its end), up to the
        same last level as from the first.  Each level below was a planner call on a problem
        no plan fitted: Cook seed 0's replans after a constrained attempt fell back spent
        levels 1-4 so, "0 ground actions" each.  When the level it starts at is already past
        the instance cap, once more from the first level."""
        settings = self.settings
        limit = min(settings.unconstrained_time, remaining)
        last = settings.unconstrained_max_level
        first = settings.initial_level
        if settings.resume_below is not None:
            first = max(first, min(self.last_level - settings.resume_below, last))
        solution = self.attempt(cycle, problem, module, limit, "u", last, first_level=first)
        capped_at_once = solution.status == "unsolvable" and not solution.stats.levels
        if first == settings.initial_level or not capped_at_once:
            return solution
        remaining = settings.budget - self.planning
        if remaining <= 0:
            return solution
        limit = min(settings.unconstrained_time, remaining)
        return self.attempt(cycle, problem, module, limit, "u", last)

    def attempt(
        self,
        cycle: _CycleState,
        problem: S.Problem,
        module: StreamsModule,
        limit: float,
        key: str,
        max_level: int,
        first_level: int | None = None,
        state: ReplanState | None = None,
        accept_drawn: bool | None = None,
        accept_dearer: bool = False,
        retry_levels: int | None = None,
    ) -> Solution:
        """One planning attempt of at most ``limit`` seconds (``key``: "c" constrained, "u"
        unconstrained), counted in the episode's planning time and in ``cycle``."""
        settings = self.settings
        began = time.monotonic()
        first = settings.initial_level if first_level is None else first_level
        options = settings.solve_options(
            time_limit=limit,
            initial_level=first,
            max_level=max_level,
            progress=self.progress,
            accept_drawn=accept_drawn,
            accept_dearer=accept_dearer,
            retry_levels=retry_levels,
        )
        state = replace(state or ReplanState(), recheck=self.recheck)
        try:
            # The solver stops itself at ``limit``; the alarm stops a stream that never
            # returns (user code) a little later.
            with time_limit(limit + STREAM_GRACE):
                sol = solve(self.agent.domain, self.agent.streams, problem, module, options, state)
        except InstanceCapReached as e:
            if first == settings.initial_level:
                raise
            # An attempt started above the first level (at or below the last plan's):
            # passing the cap there is no plan of this attempt; an unconstrained one then
            # starts again from the first level (:meth:`unconstrained_attempt`).
            stats = Statistics(total_time=time.monotonic() - began)
            sol = Solution("unsolvable", None, None, [], stats, message=e.message)
        except TimeLimitReached as e:
            name = overrunning_stream(e)
            # An attempt cut short by the budget's end (its limit the budget left) catches
            # whatever stream runs then: the budget is what ran out, not the stream (Cook
            # with four boxes, seed 6: a 2 s arm motion begun 1 s before the budget's end
            # was reported as a stream that did not return).
            budget_end = self.planning + limit >= settings.budget - 1e-9
            # A stream of an unconstrained attempt that overran is a hang only when it
            # overruns the next attempt too: the kitchen's arm motions take up to 5 s, and
            # one begun seconds before the limit passed its grace (Cook with four boxes,
            # seed 4: "did not return" at 378 s of the 600 s budget).  The first time, the
            # attempt timed out and the robot looks again (:meth:`cycle`).
            if name is not None and key != "c" and not budget_end:
                if self.overran == name:
                    raise StreamOverrun(name, time.monotonic() - began) from None
                self.overran = name
            # The solver's own work (compiling a large level, the translator) ran past
            # the limit, or a stream of a constrained attempt did (a kitchen sampler's
            # batch, a second or two, started just before the limit: Swap seed 0
            # ended there once): this attempt timed out, the episode goes on.  A stream
            # that never returns stops the unconstrained attempts next, and the episode.
            stats = Statistics(total_time=time.monotonic() - began)
            running = f" (stream '{name}' was running)" if name is not None else ""
            sol = Solution(
                "timeout", None, None, [], stats,
                message=f"time limit of {limit:g} s reached{running}",
            )  # fmt: skip
        else:
            self.overran = None
        self.recheck = tuple(sol.failed)
        self.planning += sol.stats.total_time
        cycle.spent[key] += sol.stats.total_time
        cycle.streams_called += sum(s.calls for s in sol.stats.streams.values())
        cycle.planners_called += sol.stats.planner_calls
        add_split(cycle.split, sol.stats)
        return sol

    def act(
        self,
        cycle: _CycleState,
        problem: S.Problem,
        module: StreamsModule,
        solution: Solution,
        comparison: float | None,
    ) -> EpisodeResult | None:
        """EXECUTE the plan's first action, UPDATE the belief, keep ``ConstantFacts(f)`` and
        the tail for the next cycle, and log the cycle; the episode's result when it ends here
        (``execute`` hung, or the action failed ``max_failures`` times from this problem)."""
        agent, plan = self.agent, solution.plan
        # ConstantFacts(f) and the tail, before acting (the solution's names are still valid).
        constants = {
            o.name for o in problem.objects if self.user("agent", agent, "is_constant", o.name)
        }
        constants |= stream_constants(solution, module)
        constants |= {n for n in self.state.kept_values}
        kept_facts, kept_values = constant_facts(
            solution,
            problem,
            lambda n: n in constants,
        )
        tail = [(s.name, tuple(s.args)) for s in plan[1:]]
        step = plan[0]
        self.looks = 0
        before_exec = time.monotonic()
        executed = {"comparison_time": comparison}  # what the cycle's log says of the action
        try:
            observation = self.user(
                "environment", self.env, "execute", step, limit=self.execute_limit
            )
        except (TimeLimitReached, UserCodeError) as e:
            # The action's cycle is logged (failed) before the episode ends.
            executed["execution_time"] = time.monotonic() - before_exec
            if isinstance(e, UserCodeError):
                self.log(cycle, str(step), solution, **executed, failed=True, failure=e.message)
                raise
            why = f"did not return within {self.execute_limit:g} s"
            self.log(cycle, str(step), solution, **executed, failed=True, failure=why)
            return self.finish(
                False, self.hung(f"{where('environment', self.env, 'execute')} of {step}")
            )
        after_exec = time.monotonic()
        is_failure = failed(observation)
        executed.update(
            execution_time=after_exec - before_exec,
            observation=to_json(observation),
            failed=is_failure,
            failure=failure_text(observation) if is_failure else None,
        )
        try:
            self.user("agent", agent, "update", step, observation)
        except UserCodeError:
            self.log(cycle, str(step), solution, **executed)
            raise
        executed["update_time"] = time.monotonic() - after_exec
        self.state = ReplanState(
            tail or None,
            frozenset(
                n for n in constants if n in kept_values or n in {o.name for o in problem.objects}
            ),
            kept_facts,
            kept_values,
        )
        self.log(cycle, str(step), solution, **executed)
        if is_failure:
            key = (_fingerprint(problem, module), _ground(step, problem))
            self.failures[key] += 1
            if self.failures[key] >= self.settings.max_failures:
                return self.finish(
                    False,
                    f"{step} failed {self.failures[key]} times from the same state (the "
                    "agent's problem did not change after its failures: it learned nothing "
                    "from them)",
                )
        return None

    def log(self, cycle: _CycleState, action, sol, **timings) -> None:
        """Record this cycle (the policy's own time is what is left of it)."""
        record = _record(
            cycle.index,
            action,
            cycle.constrained,
            cycle.spent,
            cycle.streams_called,
            cycle.planners_called,
            sol,
            self.agent,
            cycle.start,
        )
        for key, value in (cycle.split | timings).items():
            setattr(record, key, value)
        if "execution_time" in timings:
            total = time.monotonic() - cycle.start - (timings["comparison_time"] or 0.0)
            record.overhead_time = max(
                total - record.planning_time - record.execution_time - record.update_time,
                0.0,
            )
        self.cycles.append(record)
        if self.on_cycle:
            self.on_cycle(record)


def _record(
    index, action, constrained, spent, streams_called, planners_called, solution, agent, cycle_start
) -> Cycle:
    deferred = len(solution.deferred) if solution is not None else 0
    plan_len = len(solution.plan) if solution is not None and solution.plan is not None else None
    cost = solution.cost if solution is not None and solution.solved else None
    plan = [str(s) for s in solution.plan] if plan_len is not None else None
    record = Cycle(
        index,
        action,
        constrained,
        spent["c"] + spent["u"],
        streams_called,
        planners_called,
        deferred,
        plan_len,
        cost,
        _summary(agent),
        constrained_time=spent["c"],
        unconstrained_time=spent["u"],
        plan=plan,
    )
    record.overhead_time = max(time.monotonic() - cycle_start - record.planning_time, 0.0)
    return record


def _summary(agent: Agent) -> str:
    try:
        return str(agent.summary())
    except (Exception, SystemExit) as e:
        raise UserCodeError(where("agent", agent, "summary"), e) from e


def _short(value: Any) -> str:
    text = repr(value)
    return f"{type(value).__name__} {text if len(text) <= 60 else text[:57] + '...'}"


def _ground(step: Step, problem: S.Problem) -> str:
    """The action as far as the problem names it: its arguments that are problem objects, the
    stream outputs (new names at every solve) as ``*``."""
    declared = {o.name for o in problem.objects}
    return " ".join([step.name, *(a if a in declared else "*" for a in step.args)])


def _fingerprint(problem: S.Problem, module: StreamsModule) -> Any:
    """The state a problem describes: its objects, initial facts and goal, and the Python
    values of its objects (an unpicklable value: a state never seen again)."""
    names = sorted(o.name for o in problem.objects)
    try:
        values = pickle.dumps([(n, module.values.get(n)) for n in names], protocol=4)
    except Exception:  # noqa: BLE001 - whatever it holds; such a state is never "the same"
        return object()
    return (
        tuple(names),
        frozenset(map(str, problem.init)),
        str(problem.goal),
        hashlib.sha256(values).hexdigest(),
    )
