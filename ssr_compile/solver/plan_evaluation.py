"""Evaluating one stream plan of the Focused loop: its results in order, binding optimistic
objects to real values, and drawing a generator again at once when a draw failed or a test of
the same stream plan rejected it (paper §VII; ``SolveOptions.resample`` and ``redraws``)."""

from __future__ import annotations

import itertools
import time
from collections.abc import Callable
from dataclasses import dataclass, field

from .. import syntax as S
from ..compile.instantiate import Instance, Instantiation, Result
from ..stream import StreamsModule
from .evaluation import Evaluation, RealFacts, bound_instance
from .results import Statistics

# The draws again of a result tested against k other draws of its stream plan: PAIR_DRAWS * k
# times those of a result tested against fixed values only (:meth:`StreamPlanEvaluation.
# _rejected_limits`)
PAIR_DRAWS = 3


@dataclass
class DrawMemory:
    """What the draws again of one solve remember across its stream plans.

    ``resample``: draws again per result after a rejection (``SolveOptions.resample``);
    ``per_level``: rejected draws given back per instance and level (``redraws``);
    ``given_back``: those given back at this level; ``paid``: per stream, the draws again
    after a failed draw, and how many of them gave a value; ``rejected_plans``: the stream
    plans of this solve whose evaluation ended failed after a test rejected a draw."""

    resample: int
    per_level: int
    given_back: dict[Instance, int] = field(default_factory=dict)
    paid: dict[str, list[int]] = field(default_factory=dict)
    rejected_plans: int = 0

    def draw_again_pays(self, stream: str) -> bool:
        """Drawing again after a failed draw of ``stream``: not tried yet in this solve, or it
        gave a value at least once."""
        tries, successes = self.paid.get(stream, (0, 0))
        return tries == 0 or successes > 0


class StreamPlanEvaluation:
    """One evaluation of a stream plan (:meth:`run`): afterwards ``ok`` (every result
    succeeded) and ``binding`` (optimistic object -> its real name).

    A result whose inputs or domain facts come from a failed one is skipped (the loop plans
    again, with the new real facts).  A generator whose draw a test of this stream plan
    rejected draws again at once -- at most ``resample`` times per result and per other draw
    the test checks it against -- and what depends on its outputs is evaluated again
    (:meth:`_to_redraw`): one more sample for the same plan costs a stream call, where planning
    again cost a planner call on a larger problem (Cook: 2-6 s per call, once per rejected
    placement or observation).  A generator whose draw failed draws again once, while that pays
    off for its stream in this solve: a sampler that found nothing for its inputs mostly finds
    nothing again (Swap's placements into a drawer out of reach, ~0.3 s a draw), one that fails
    at first by design does not."""

    def __init__(
        self,
        ordered: list[Result],
        instantiation: Instantiation,
        ev: Evaluation,
        module: StreamsModule,
        problem: S.Problem,
        draws: DrawMemory,
        stats: Statistics,
        say: Callable[[str], None],
        deadline: float,
        before_tests: Callable[[dict[str, str]], bool] | None = None,
    ):
        self.ordered, self.ev, self.module, self.draws = ordered, ev, module, draws
        # asked once, with the binding, when every result before the first test succeeded:
        # True stops the evaluation there (``stopped``; FocusedLoop.draw_kept_again)
        self.before_tests = before_tests
        self.stopped = False
        self.objects, self.shared = instantiation.objects, instantiation.shared
        self.stats, self.say, self.deadline = stats, say, deadline
        self.binding: dict[str, str] = {}  # optimistic object -> its real name
        self.values_of: dict[str, list[str]] = {}  # shared optimistic object -> real names
        self.facts = RealFacts(problem, ev)
        self.settled: dict[int, bool] = {}  # evaluated results (by id) and their outcome
        self.drawn: set[int] = set()  # generator results drawn afresh in this evaluation
        self.again: dict[int, int] = {}  # draws each result had again
        self.after_failure: set[int] = set()  # results drawing again after a failed draw
        # the values each generator result drew in this evaluation, and those to bind again
        # (an earlier value, instead of a new draw: :meth:`_earlier_value`)
        self.values_drawn: dict[int, list[tuple[str, ...]]] = {}
        self.rebind: dict[int, tuple[str, ...]] = {}
        self.rebinds: dict[int, int] = {}  # earlier values bound again, per result
        self.producer = {o: r for r in ordered for o in r.outputs}
        self.position = {id(r): i for i, r in enumerate(ordered)}
        self.rejected_limit = self._rejected_limits()
        self.rejected = False  # did a test of this stream plan reject a draw?
        self.fresh_only = False  # no earlier values bound again (see :meth:`run`)
        # the tests over real values only (no output of this stream plan) that failed
        # (FocusedLoop.test_siblings)
        self.failed_real_tests: list[Instance] = []
        self.ok = False

    def _rejected_limits(self) -> dict[int, int]:
        """Draws again after rejections, per result: ``resample`` for each other draw of this
        stream plan that a test checks its outputs against (a placement among k others drawn
        for the same plan must miss each of them: the draws it needs grow with k), times one
        more for each stream plan of this solve a rejection already failed.  Each such failure
        cost a planner call, on a problem larger by the values drawn (the planner then tries
        those values pair by pair, a call per pair: two blocks into a region with one unit of
        slack, where one pair of placements in nine fits); drawing again for the plan in hand
        costs stream calls only, so the budget of draws follows the planner calls spent.

        A draw tested against other draws of the plan gets PAIR_DRAWS times that: each value it
        draws meets every earlier value of its partners (:meth:`_earlier_value`), so its draws
        buy pairs, not single tries, and a value that pairs with none (a placement in the
        region's middle) is common.  With the budget of a lone draw, a quarter of the seeds of
        continuous_tamp's ``tight(2)`` (0-39) ran out of draws, and each then climbed two
        levels: 9-12 planner calls against the median's 6.  A draw tested only against fixed
        values (a placement against a blocker that has not moved) keeps the lone budget: there
        drawing again mostly cannot help (tamp2d's blocked problem: the same 448 stream calls
        with PAIR_DRAWS, 1,428 with every budget tripled)."""
        partners: dict[int, set[int]] = {id(r): set() for r in self.ordered}
        for t in self.ordered:
            if t.instance.kind == "test":
                ids = {id(self.producer[x]) for x in t.instance.inputs if x in self.producer}
                for rid in ids:
                    partners[rid] |= ids - {rid}
        scale = self.draws.resample * (1 + self.draws.rejected_plans)
        return {rid: scale * (PAIR_DRAWS * len(p) if p else 1) for rid, p in partners.items()}

    def run(self) -> bool:
        """Evaluate the stream plan, drawing again while that is allowed; False when time ran
        out (``ok`` stays false)."""
        passes: set[frozenset] = set()  # the bindings each pass ended with
        while True:
            outcome = self._one_pass()
            if outcome is None:
                return False
            all_ok, redraw = outcome
            if all_ok or not redraw:
                break
            state = frozenset(self.binding.items())
            if state in passes and not self.fresh_only:
                # A pass ended with values it ended with before: the earlier values bound
                # again went round in a circle (two draws each rebound against the other's
                # last value, which the check of each alone cannot see; Cook seed 20 went
                # round for 300 s).  From here on only fresh draws, which are counted.
                self.fresh_only = True
                rebound = [r for r in redraw if id(r) in self.rebind]
                self.rebind.clear()
                redraw = [r for r in redraw if all(r is not x for x in rebound)]
                redraw += [
                    r
                    for r in self._to_redraw(rebound, self.rejected_limit)
                    if all(r is not x for x in redraw)
                ]
                if not redraw:
                    break
            passes.add(state)
            self._draw_again(redraw)
        self.ok = all_ok
        if self.rejected and not all_ok:
            self.draws.rejected_plans += 1
        return True

    def _one_pass(self) -> tuple[bool, list[Result]] | None:
        """Every result not settled yet, in order: whether all succeeded, and those to draw
        again (``None``: time ran out)."""
        failed: set[str] = set()
        # Facts the stream plan counted on whose producer failed in this pass: a result whose
        # domain needs one of them is not evaluated (its domain does not hold), and what it
        # would certify is unproven too.
        failed_facts: set[S.Atom] = set()
        all_ok = True
        redraw: list[Result] = []
        for res in self.ordered:
            if time.monotonic() >= self.deadline:
                return None
            rid = id(res)
            if self.before_tests is not None and res.instance.kind == "test":
                check, self.before_tests = self.before_tests, None
                if all_ok and rid not in self.settled and check(self.binding):
                    self.stopped = True
                    return False, []
            if rid in self.settled:
                if not self.settled[rid]:
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
            if self.shared and any(x in self.shared for x in (*res.instance.inputs, *res.outputs)):
                ok = self.evaluate_shared(res)
                self.settled[rid] = ok
                if not ok:
                    all_ok = False
                    failed.update(res.outputs)
                continue
            if rid in self.rebind:
                self.binding.update(zip(res.outputs, self.rebind.pop(rid)))
                self.settled[rid] = True
                self.drawn.add(rid)  # it may still draw afresh
                continue
            if self._evaluate(res):
                continue
            all_ok = False
            failed.update(res.outputs)
            failed_facts.update(res.certified)
            self.say(f"  {res.instance} failed")
            if res.instance.kind == "test" and not any(
                x in self.producer for x in res.instance.inputs
            ):
                self.failed_real_tests.append(bound_instance(res, self.binding))
            self._blame(res, redraw)
        return all_ok, redraw

    def _evaluate(self, res: Result) -> bool:
        """Evaluate one result under the binding, counting its outcome."""
        rid = id(res)
        ok = self.ev.evaluate(res, self.binding)
        fresh = self.ev.called
        self.ev.record(ok, res.instance.stream)
        self.settled[rid] = ok
        if rid in self.after_failure:
            self.after_failure.discard(rid)
            paid = self.draws.paid.setdefault(res.instance.stream, [0, 0])
            paid[0] += 1
            paid[1] += int(ok)
        if res.instance.kind == "stream" and fresh:
            self.drawn.add(rid)
            if ok:
                out = tuple(self.binding[o] for o in res.outputs)
                self.values_drawn.setdefault(rid, []).append(out)
        return ok

    def _blame(self, res: Result, redraw: list[Result]) -> None:
        """``res`` failed: add to ``redraw`` the draws to take again for it -- its own (a
        generator whose draw failed), or the last draw among its inputs."""
        kind = res.instance.kind
        own: list[Result] = []
        if kind != "test" and self.draws.draw_again_pays(res.instance.stream):
            own = self._to_redraw([res], min(self.draws.resample, 1))
            own = [r for r in own if all(r is not x for x in redraw)]
            self.after_failure.update(id(r) for r in own)
            redraw += own
        inputs_blamed = self.module.info_for(res.instance.stream).redraw_inputs
        if kind == "test" or (inputs_blamed and not own):
            # A test rejected values drawn for this plan, or a stream that blames its
            # inputs (StreamInfo.redraw_inputs: tamp2d's ik of a placement out of
            # reach) found nothing for them: the draw made last among its inputs is
            # drawn again (the earlier ones passed their own tests) -- values drawn in
            # turn, each against those kept.
            if kind == "test":
                self.rejected = True
                self.redraw_rejected(res)
            # The draw drawn again least so far, the last of those: draws checked against
            # each other take turns (a placement drawn where no partner fits is drawn again
            # too, not only the partner drawn against it)
            blamed = [self.producer[x] for x in res.instance.inputs if x in self.producer]
            blamed.sort(key=lambda r: (self._changes(r), -self.position[id(r)]))
            if kind == "test":
                # An earlier value first, of the draw with the most values: a value drawn anew
                # meets every earlier value of its partners before either draws again, and
                # the one with the fewest values draws next (below) -- k values each give
                # k * k pairs.  (Rebinding the draw changed least starved the other: once
                # one placement had many values, all in the region's middle where no partner
                # fits, only its partner drew.)
                for r in sorted(blamed, key=lambda r: -self._values(r)):
                    if self.fresh_only:
                        break
                    earlier = self._earlier_value(r, res)
                    if earlier is not None and all(r is not x for x in redraw):
                        self.rebind[id(r)] = earlier
                        self.rebinds[id(r)] = self.rebinds.get(id(r), 0) + 1
                        redraw.append(r)
                        return
            if kind == "test":
                blamed.sort(key=lambda r: (self._values(r), self.again.get(id(r), 0)))
            redraw += [
                r
                for r in self._to_redraw(blamed, self.rejected_limit)[:1]
                if all(r is not x for x in redraw)
            ]

    def _values(self, r: Result) -> int:
        """The values ``r`` drew in this evaluation."""
        return len(self.values_drawn.get(id(r), ()))

    def _changes(self, r: Result) -> int:
        return self.again.get(id(r), 0) + self.rebinds.get(id(r), 0)

    def _earlier_value(self, r: Result, test: Result) -> tuple[str, ...] | None:
        """A value ``r`` drew earlier in this evaluation that ``test`` has not been asked
        about with the other values bound now, and that no test of the stream plan is known
        to reject: bound again, it pairs with the values drawn since at the price of the
        tests alone (the draws of k placements that must miss each other give k * k pairs,
        not k)."""
        current = tuple(self.binding.get(o) for o in r.outputs)
        for old in self.values_drawn.get(id(r), ()):
            if old == current:
                continue
            trial = {**self.binding, **dict(zip(r.outputs, old))}
            if bound_instance(test, trial) in self.ev.outcomes:
                continue
            tests = (t for t in self.ordered if t.instance.kind == "test")
            if any(self._known_rejected(t, trial) for t in tests):
                continue
            return old
        return None

    def _known_rejected(self, test: Result, binding: dict[str, str]) -> bool:
        """``test``, with every input bound under ``binding``, failed before."""
        if any(x in self.objects and x not in binding for x in test.instance.inputs):
            return False
        known = self.ev.outcomes.get(bound_instance(test, binding))
        return known is not None and not known

    def _draw_again(self, redraw: list[Result]) -> None:
        """The redrawn results and everything downstream of them are evaluated again."""
        outputs = {o for r in redraw for o in r.outputs}
        for r in self.ordered:
            if id(r) in {id(x) for x in redraw} or any(x in outputs for x in r.instance.inputs):
                outputs.update(r.outputs)
                self.settled.pop(id(r), None)
                self.drawn.discard(id(r))
        for o in outputs:
            self.binding.pop(o, None)
        for r in redraw:
            if id(r) in self.rebind:
                continue
            self.again[id(r)] = self.again.get(id(r), 0) + 1
            self.stats.resamples += 1
        self.say(
            "  drawing again: "
            + ", ".join(
                str(r.instance) + (" (an earlier value)" if id(r) in self.rebind else "")
                for r in redraw
            )
        )

    def _to_redraw(self, blamed: list[Result], limit: int | dict[int, int]) -> list[Result]:
        """Those of ``blamed`` to draw again now: generator results drawn afresh in this
        evaluation, not exhausted, that have drawn again fewer than ``limit`` times (a number,
        or one per result id)."""
        out = []
        for r in blamed:
            if r.instance.kind != "stream" or id(r) not in self.drawn:
                continue
            most = limit if isinstance(limit, int) else limit.get(id(r), 0)
            if self.again.get(id(r), 0) >= most:
                continue
            real = bound_instance(r, self.binding)
            if real not in self.ev.exhausted and all(x is not r for x in out):
                out.append(r)
        return out

    def redraw_rejected(self, test: Result) -> None:
        """A test failed on a value a generator of this stream plan just drew: the draw was
        rejected, so the generator may draw again at this level (at most ``redraws`` rejected
        draws per instance and level) instead of leaving the level without that sample."""
        for x in test.instance.inputs:
            producer = self.objects.get(x)
            if producer is None or producer.instance.kind != "stream":
                continue
            real = bound_instance(producer, self.binding)
            if real in self.ev.exhausted or real not in self.ev.tried:
                continue
            count = self.draws.given_back.get(real, 0)
            if count < self.draws.per_level:
                self.draws.given_back[real] = count + 1
                self.ev.tried.discard(real)

    def evaluate_shared(self, res: Result) -> bool:
        """A shared object stands for every real value bound to it: evaluate the instance for
        each combination whose domain facts really hold.  True if one succeeded."""
        shared, binding, values_of = self.shared, self.binding, self.values_of
        inputs = res.instance.inputs
        choices = [values_of.get(x, []) if x in shared else [binding.get(x, x)] for x in inputs]
        any_ok = False
        for combo in itertools.product(*choices):
            local = dict(zip(inputs, combo))
            if not all(self.facts.holds(f, local, binding) for f in res.domain):
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
