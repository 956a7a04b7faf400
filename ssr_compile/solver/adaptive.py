"""Adaptive sampling: the Focused loop with a queue of plan skeletons (``algorithm="adaptive"``).

The Focused loop (:mod:`ssr_compile.solver.focused`) evaluates each stream plan once and plans
again after any failure: a test that rejects one sample costs a planner call, and an instance
tried at a level waits for the next level, whose optimistic problem is larger. Here every
optimistic plan the planner returns becomes a *skeleton*: its action plan, its optimistic cost
and its ordered stream plan. A skeleton's partial assignments (*bindings*: the first ``i``
results of its stream plan bound to real values) sit in one priority queue; visiting a binding
asks the ``i``-th stream instance, with its inputs bound, for one more value, and each value it
gave becomes a child binding one result deeper. A binding whose generator can give more stays in
the queue, so a sample a later test rejected is drawn again without planning again. A binding
that binds the whole stream plan gives a real plan (checked over the real facts and priced with
the real costs).

Search and sampling share the work: each planner call buys a number of stream calls for the
queue (``samples_per_plan``, more as the optimistic problem grows), counted in calls rather
than seconds so that one seed gives one plan and one number of stream calls.  The queue visits
first the deepest unvisited binding of each skeleton (a new skeleton is tried through once, as
the Focused loop would), then the bindings that asked their instances least often, cheaper
skeletons first.

Costs stay first-class: a plan the queue completes is an *incumbent*; it is returned at once
when the planner is cost-optimal and the plan costs no more than planned (and no queued
skeleton is cheaper), otherwise the planner is asked for a plan cheaper than it over the real
facts so far, and the incumbent is returned when there is none.  Skeletons whose optimistic cost
is not below the incumbent's are dropped.

No plan at a level: the queue samples until it finds new values (the planner may then plan with
them at the same level); when it has nothing new, or after ``stalls_per_level`` such rounds, the
level rises.  Deferral (paper §VII) and the replanning state (:class:`~.options.ReplanState`)
work as in the Focused loop: the deferred results of a skeleton are left out of its stream plan,
and once the rest is bound the planner is asked again (its plan then needs only deferred
results).  Shared optimistic outputs (``share=True``) are refused.
"""

from __future__ import annotations

import heapq
import itertools
import math
import time
from dataclasses import dataclass, field
from typing import Any

from ..compile.instantiate import Instance, Result
from ..errors import InstanceCapReached, PlannerFailure, SSRError
from ..planners.costs import plan_cost
from .evaluation import bound_result, real_problem
from .loop import SolverLoop
from .preimage import PlanInvalid, plan_preimage
from .results import SOLVED, Solution, plan_steps

# Stream calls the queue may make per planner call (scaled by the optimistic problem's size
# relative to the first one), no-plan rounds at one level before it rises.
SAMPLES_PER_PLAN = 40
STALLS_PER_LEVEL = 2
# After a "no plan", draws per result of the queued stream plans the queue may make.
RETRIES = 20
# Planner calls after the first incumbent before it is returned, with a planner that is not
# cost-optimal (an optimal one stops when it finds no cheaper plan); each may take at most
# CONFIRM_SHARE times the time spent so far (at least a second): with one, the planner sees
# the real facts once more, as the Focused loop's last call does, without waiting for a proof
# that may take as long as optimal search.
IMPROVEMENTS = 1
CONFIRM_SHARE = 2.0
EPS = 1e-9


@dataclass(eq=False)
class _Skeleton:
    index: int
    plan: list[tuple[str, tuple[str, ...]]]  # over the optimistic problem's names
    results: list[Result]  # the stream plan evaluated now, producers first
    later: list[Result]  # deferred results (paper §VII)
    cost: float  # optimistic, in the problem's units
    compiled: Any
    live: int = 0  # bindings of it in the queue
    best: Any = None  # its deepest binding so far

    def describe(self) -> str:
        return f"skeleton {self.index} (cost {self.cost:g}, {len(self.results)} results)"


@dataclass(eq=False)
class _Binding:
    skeleton: _Skeleton
    index: int  # results bound
    mapping: dict[str, str]  # optimistic name -> real name
    attempts: int  # how deep into the instances' histories its values come from
    seq: int
    calls: int = 0  # outcomes of its instance's history already turned into children
    visits: int = 0


@dataclass
class _History:
    """Every outcome one real instance gave (output names, or ``None`` for no value)."""

    outcomes: list[tuple[str, ...] | None] = field(default_factory=list)
    enumerated: bool = False


class AdaptiveLoop(SolverLoop):
    """One call of :func:`~ssr_compile.solver.solve` with ``algorithm="adaptive"``.  Shared
    optimistic outputs are refused by :class:`~ssr_compile.solver.options.SolveOptions`."""

    def __init__(self, *args, samples_per_plan: int = SAMPLES_PER_PLAN, **kwargs):
        super().__init__(*args, **kwargs)
        self.samples_per_plan = samples_per_plan
        self.skeletons: list[_Skeleton] = []
        self.queue: list[tuple[tuple, _Binding]] = []
        self.seq = itertools.count()
        self.histories: dict[Instance, _History] = {}
        for r in self.ev.results:  # values kept from earlier calls come first
            h = self.histories.setdefault(r.instance, _History())
            if r.outputs and r.outputs not in h.outcomes:
                h.outcomes.append(r.outputs)
        self.credit = 0.0
        self.first_size: int | None = None
        # cost, steps, certificate, deferred results
        self.incumbent: tuple[float, list, list, list] | None = None
        self.after_incumbent = 0
        # A cost-optimal planner is asked for a plan cheaper than the incumbent (its "none"
        # proves the incumbent best at this level); another one plans as usual, and the
        # incumbent stands when its plan is no cheaper (proving it would be optimal search).
        self.optimal = bool(getattr(self.backend.capabilities, "optimal", False))
        self.replan_now = False
        self.done: Solution | None = None
        self.sampled = 0  # stream calls made by the queue
        # Later values wait before the planner sees them (as a level caps how deep optimistic
        # instantiation goes): an instance's value k (from 0, counting values, not failed
        # calls) is hidden until ``self.round >= k``; so are results over hidden values.  ``round`` rises with every
        # no-plan answer.
        self.round = 0
        self.hidden: list[tuple[int, Result]] = []
        self.hidden_names: set[str] = set()

    # ------------------------------------------------------------------ the loop

    def run(self) -> Solution:
        stalls = 0
        while True:
            if time.monotonic() + self.last_compile >= self.deadline:
                return self.out_of_time()  # a compile would end past the limit (focused.py)
            self.stats.iterations += 1
            self.stats.levels.append(self.level)
            self.evaluate_cheap_functions()
            try:
                compiled = self.compile()
            except InstanceCapReached as e:
                if self.incumbent is not None and self.level > self.first_level:
                    return self.finish_incumbent()
                return self.capped(e)
            result = self.plan_bounded(compiled)
            if result.status == "error":
                raise PlannerFailure(self.backend.name, result.message, detail=result.detail)
            if result.status == "timeout":
                if self.incumbent is not None:
                    return self.finish_incumbent()
                return self.finish(
                    "timeout", message=f"the planner ran out of time at level {self.level}"
                )
            if self.incumbent is not None:
                self.after_incumbent += 1
            self.replan_now = False
            if result.status == "solved":
                stalls = 0
                done = self.new_plan(compiled, result)
                if done is not None:
                    return done
                last = (
                    self.incumbent is not None
                    and not self.optimal
                    and self.after_incumbent >= IMPROVEMENTS
                )
                # the last chance of a cheaper plan gets the larger share
                self.sample(self.large_share() if last else self.credit)
                if self.done is None and last and not self.replan_now:
                    self.say("  the planner is not cost-optimal: the incumbent is the solution")
                    return self.finish_incumbent()
            else:
                if result.message:
                    self.best_failure = result.message
                if self.incumbent is not None:
                    self.say("  no cheaper plan: the incumbent is the solution")
                    return self.finish_incumbent()
                new = 0
                if stalls < STALLS_PER_LEVEL and (self.queue or self.hidden):
                    # Before a larger problem (whose "no plan" may take the planner long to
                    # prove), the queue gets a larger share: as many calls as all planner
                    # calls so far bought.
                    if self.queue:
                        self.sample(self.large_share())
                    self.round += 1
                    new = self.publish()
                if self.done is not None:
                    return self.done
                if new or self.replan_now:
                    stalls += 1
                    self.say(f"  the queue found {new} new value(s): planning again at this level")
                elif self.level >= self.max_level:
                    why = "under the cost bound " if not math.isinf(self.max_cost) else ""
                    took = time.monotonic() - self.start
                    return self.finish(
                        "unsolvable",
                        message=f"no plan found {why}up to level {self.max_level} in {took:.1f} s "
                        f"({self.best_failure})",
                    )
                else:
                    stalls = 0
                    self.level += 1
                    self.ev.tried.clear()
                    self.round += 1
                    self.publish()
            if self.done is not None:
                return self.done

    def finish(self, status, *args, **kwargs) -> Solution:
        self.ev.results.extend(r for _, r in self.hidden)  # every real value, for the caller
        self.hidden.clear()
        self.hidden_names.clear()
        return super().finish(status, *args, **kwargs)

    def publish(self) -> int:
        """Hidden results of calls up to the current round join the real facts (in the
        order they were made: producers first).  How many did."""
        keep, shown = [], 0
        for k, r in self.hidden:
            if k <= self.round and not any(x in self.hidden_names for x in r.instance.inputs):
                self.ev.results.append(r)
                self.hidden_names.difference_update(r.outputs)
                shown += 1
            else:
                keep.append((k, r))
        self.hidden = keep
        return shown

    def large_share(self) -> float:
        """Stream calls for the queue before a decision that costs more than a planner call
        (a larger problem, or returning the incumbent): as many as all planner calls so far
        bought, and ``RETRIES`` per result of the live stream plans."""
        pending = sum(len(s.results) for s in self.skeletons if s.live)
        return self.samples_per_plan * self.stats.planner_calls + RETRIES * pending

    def plan_bounded(self, compiled):
        """The backend's answer under the cost bound: ``max_cost``, or the incumbent's cost."""
        remaining = self.deadline - time.monotonic()
        if self.incumbent is not None and not self.optimal:
            spent = time.monotonic() - self.start
            remaining = min(remaining, max(1.0, CONFIRM_SHARE * spent))
        limit = self.max_cost
        if self.incumbent is not None and self.optimal:
            limit = min(limit, self.incumbent[0])
        bound = None if math.isinf(limit) else limit * compiled.scale
        result, size = self.call_planner(compiled, remaining, bound)
        # Sampling bought by this call: more for larger optimistic problems (slower calls).
        weight = size[3] if size[3] is not None else size[1]
        if self.first_size is None:
            self.first_size = max(weight, 1)
        self.credit += self.samples_per_plan * max(1.0, weight / self.first_size)
        live = sum(1 for s in self.skeletons if s.live)
        self.say(
            f"iteration {self.stats.iterations}: level {self.level}, problem {size[0]} objects, "
            f"{size[1]} facts, {size[2]} values"
            + (f", {size[3]} ground actions" if size[3] is not None else "")
            + f"; planner {result.status} in {result.time:.3f} s"
            + f"; queue {live} skeleton(s), {len(self.queue)} binding(s), "
            f"{self.sampled} stream call(s) sampled"
            + (f"; incumbent cost {self.incumbent[0]:g}" if self.incumbent else "")
        )
        return result

    def new_plan(self, compiled, result) -> Solution | None:
        """A plan: the solution when it needs no optimistic result now, else a new skeleton."""
        plan, pre, inst, needed = self.stream_plan_of(compiled, result)
        cost = (result.cost or 0.0) / compiled.scale
        certificate = sorted(pre.static_facts, key=str)
        if self.incumbent is not None and cost >= self.incumbent[0] - EPS:
            self.say(f"  the planner's plan costs {cost:g}: the incumbent is the solution")
            return self.finish_incumbent()
        if not needed:
            return self.better_of(SOLVED, plan_steps(plan, self.values, set()), cost, certificate)
        scheduled = self.schedule(plan, pre, inst, needed, cost, certificate)
        if isinstance(scheduled, Solution):
            return scheduled
        ordered, later = scheduled
        sk = _Skeleton(len(self.skeletons), list(plan), ordered, later, cost, compiled)
        self.skeletons.append(sk)
        self.say(f"  new {sk.describe()}: " + ", ".join(str(r.instance) for r in ordered))
        root = _Binding(sk, 0, {}, 0, next(self.seq))
        sk.best = root
        self.push(root)
        return None

    def better_of(self, status, steps, cost, certificate) -> Solution:
        """A real plan from the planner, or the incumbent when that is cheaper."""
        if self.incumbent is not None and self.incumbent[0] < cost - EPS:
            return self.finish_incumbent()
        return self.finish(status, steps, cost, certificate)

    def finish_incumbent(self) -> Solution:
        cost, steps, certificate, deferred = self.incumbent
        return self.finish(SOLVED, steps, cost, certificate, deferred=deferred)

    def out_of_time(self) -> Solution:
        if self.incumbent is not None:
            return self.finish_incumbent()
        return self.finish("timeout", message=f"time limit of {self.time_limit:g} s reached")

    # ------------------------------------------------------------------ the queue

    def priority(self, b: _Binding) -> tuple:
        sk = b.skeleton
        return (
            sk.best is not b,  # the deepest binding of each skeleton first
            b.visits > 0,  # then what was never tried
            b.attempts + b.visits,  # then what asked its instances least
            sk.cost,
            -b.index,
            sk.index,
            b.seq,
        )

    def push(self, b: _Binding) -> None:
        b.skeleton.live += 1
        heapq.heappush(self.queue, (self.priority(b), b.seq, b))

    def pop(self) -> _Binding:
        _, _, b = heapq.heappop(self.queue)
        b.skeleton.live -= 1
        return b

    def sample(self, credit: float) -> None:
        """Visit bindings: first every untried deepest one (free), then while the credit of
        stream calls lasts.  Stops when a binding
        completes a skeleton (the planner is asked again) or the solve ends."""
        spent = 0
        visits = 0
        # A visit that calls no stream is cheap but not free: bound them too.
        max_visits = 20 * max(credit, 1.0) + 100
        while self.queue and self.done is None and not self.replan_now:
            if time.monotonic() >= self.deadline:
                self.done = self.out_of_time()
                return
            (first, tried, *_), _, top = self.queue[0]
            if not first and top.skeleton.best is not top:  # a deeper one came since
                self.push(self.pop())
                continue
            free = not first and not tried
            if not free:
                if spent >= credit or visits >= max_visits:
                    break
            b = self.pop()
            visits += 1
            called = self.visit(b)
            spent += called
            if not free:
                self.credit = max(self.credit - called, 0.0)

    def visit(self, b: _Binding) -> int:
        """Ask ``b``'s instance for a value (unless its history has unused ones); children for
        the new values; ``b`` back in the queue while its instance can give more.  The number
        of stream calls made."""
        sk = b.skeleton
        if self.incumbent is not None and sk.cost >= self.incumbent[0] - EPS:
            return 0  # cannot beat the incumbent
        if b.index == len(sk.results):
            self.complete(b)
            return 0
        res = sk.results[b.index]
        inputs = tuple(b.mapping.get(x, x) for x in res.instance.inputs)
        inst = Instance(res.instance.stream, inputs, res.instance.kind)
        h = self.histories.setdefault(inst, _History())
        b.visits += 1
        called = 0
        if b.calls >= len(h.outcomes) and not h.enumerated:
            called = self.call(res, inst, h, b.mapping)
        elif inst.kind == "stream":
            self.ev.tried.add(inst)  # asked at this level, as if called
        for k in range(b.calls, len(h.outcomes)):
            out = h.outcomes[k]
            if out is None:
                continue
            mapping = dict(b.mapping)
            mapping.update(zip(res.outputs, out))
            child = _Binding(sk, b.index + 1, mapping, b.attempts + k, next(self.seq))
            if sk.best is None or child.index > sk.best.index:
                sk.best = child
            self.push(child)
        b.calls = len(h.outcomes)
        if not h.enumerated:
            self.push(b)
        elif not sk.live:
            self.say(f"  {sk.describe()} abandoned: {inst} has no more values")
        return called

    def call(self, res: Result, inst: Instance, h: _History, mapping: dict[str, str]) -> int:
        """One more outcome of ``inst`` into its history; 1 if the stream was called."""
        binding = {x: mapping[x] for x in res.instance.inputs if x in mapping}
        made = len(self.ev.results)
        ok = self.ev.evaluate(res, binding)
        if len(self.ev.results) > made:
            r = self.ev.results.pop()
            k = sum(1 for o in h.outcomes if o is not None)  # values drawn before this one
            if k > self.round or any(x in self.hidden_names for x in r.instance.inputs):
                self.hidden.append((k, r))
                self.hidden_names.update(r.outputs)
            else:
                self.ev.results.append(r)
        self.ev.record(ok, res.instance.stream)
        if inst.kind != "stream":
            h.outcomes.append(() if ok else None)
            h.enumerated = True
        else:
            out = tuple(binding[o] for o in res.outputs) if ok else None
            h.outcomes.append(None if out in h.outcomes else out)  # an old value: nothing new
            if inst in self.ev.exhausted:
                h.enumerated = True
        if not ok:
            self.say(f"  {inst} failed")
        if self.ev.called:
            self.sampled += 1
            return 1
        return 0

    def complete(self, b: _Binding) -> None:
        """Every result of a stream plan has a value: the plan over the real values, when it
        holds, is an incumbent (or the solution); the planner is asked again in any case.
        With deferral, the deferred results stay optimistic: their facts and costs join the
        real ones, and their objects are the plan's deferred arguments (paper §VII)."""
        sk = b.skeleton
        self.replan_now = True
        bound = [(name, tuple(b.mapping.get(a, a) for a in args)) for name, args in sk.plan]
        inst = sk.compiled.instantiation
        deferred = {o for r in sk.later for o in r.outputs}
        if any(a in inst.objects and a not in deferred for _, args in bound for a in args):
            return
        real_results = itertools.chain(self.ev.results, (r for _, r in self.hidden))
        real = real_problem(
            self.problem, sk.compiled, real_results, self.ev.real_functions, sk.later, b.mapping
        )
        domain = sk.compiled.source_domain
        try:
            pre = plan_preimage(domain, real, bound)
            cost = plan_cost(domain, real, bound)
        except (PlanInvalid, SSRError) as e:
            self.say(f"  {sk.describe()} bound, but the plan does not hold: {e}")
            return
        if not math.isinf(self.max_cost) and cost >= self.max_cost - EPS:
            return  # plans must cost less than the bound, as the planner's do
        if self.incumbent is not None and cost >= self.incumbent[0] - EPS:
            return
        steps = plan_steps(bound, self.values, deferred)
        later = [bound_result(r, b.mapping) for r in sk.later]
        self.incumbent = (cost, steps, sorted(pre.static_facts, key=str), later)
        self.after_incumbent = 0
        self.say(
            f"  {sk.describe()} bound: a plan of cost {cost:g}"
            + (f", {len(sk.later)} result(s) deferred" if sk.later else "")
        )
        cheaper = [s for s in self.skeletons if s.live and s.cost < cost - EPS]
        if self.accept_drawn and cost <= sk.cost + 1e-6 and not cheaper:
            self.say("  the plan holds with the values drawn")
            self.done = self.finish_incumbent()
