"""What one call of :func:`~ssr_compile.solver.solve` is given besides the problem: its options
(:class:`SolveOptions`) and what it inherits from the last call (:class:`ReplanState`)."""

from __future__ import annotations

import math
from collections.abc import Callable, Collection, Container, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

from .. import syntax as S
from ..compile.instantiate import Instance, Result
from ..errors import UnsupportedError
from ..stream import StreamsModule, ValueTable

# The algorithms :func:`~ssr_compile.solver.solve` runs (its registry maps each to its loop).
ALGORITHMS = ("focused", "adaptive")
# Cost functions and tests at most this expensive (StreamInfo.cost) are evaluated eagerly.
EAGER_COST = 0.1
RESAMPLE = 2  # default ``resample`` of :class:`SolveOptions`


@dataclass(frozen=True)
class SolveOptions:
    """The options of one solve.

    ``algorithm``: "focused" (:mod:`ssr_compile.solver.focused`: evaluate each plan's stream
    plan once, then plan again) or "adaptive" (a queue of plan skeletons sampled incrementally
    between planner calls: :mod:`ssr_compile.solver.adaptive`).  ``planner``: a backend name
    or object; ``time_limit`` in seconds; the levels from ``initial_level`` up to
    ``max_level``; ``complexity_base``: the level from which the levels climbed are counted
    for the draws the planner sees (:meth:`~ssr_compile.solver.focused.FocusedLoop.
    visible_results`; ``None``: ``initial_level``; a call that resumes at the level an
    earlier call climbed to passes the level that call began at); ``max_cost``: plans must
    cost less; ``defer``: deferred stream evaluation
    (paper §VII, :func:`~ssr_compile.solver.deferral.reschedule_stream_plan`).
    Cost functions whose stream info gives a cost of at most ``eager_cost`` are evaluated as
    soon as their arguments are real (before planning), so the planner sees their real
    values instead of rediscovering them one plan at a time; ``eager_cost=-1`` turns this off.
    With ``eager_tests``, so are the tests that cheap: a test that fails on real inputs is
    never an optimistic fact the planner builds a plan on (one planner call per failed test).
    ``lazy_tests``: such a test that the domain reads only where it holding permits plans,
    and only beside its own domain's atoms, is stated in the optimistic problem only where it
    failed and checked where a plan relies on it (:mod:`ssr_compile.compile.lazy_tests`:
    pairs of poses are then no longer most of each optimistic problem).
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
    ``accept_dearer``: with ``accept_drawn``, such a plan is the solution even when it costs
    more than planned (an optimistic cost was below the real one; the Focused loop).  For a
    plan-constrained attempt (the policy's), whose planner can only bind the tail's free
    values otherwise: a kitchen replan's second planner call found the same plan again in 8
    of the 10 constrained attempts of Cook seed 4 where it was asked.
    ``retry_levels``: how many times the level may rise when the problem is saturated -- no
    higher level adds a stream instance, so a rise only gives back the instances that failed
    or were held back, to be drawn again (the Focused loop).  ``None`` (default): every level
    up to ``max_level``.  Past it the answer is "unsolvable" (or the incumbent).  For an
    attempt that has somewhere to fall back to (the policy's plan-constrained one): Cook seed
    0 climbed levels 9 to 13 of one such attempt over the same problem, 1,693 objects, each
    level drawing the same failing ``inv-reach`` again, 4.4 s before it fell back.
    ``rebind``: before the Focused loop answers, the stream plan of the last plan that held
    with its values drawn but cost more than planned is drawn again until this many draws in
    a row give no cheaper plan (at most 20 draws), and the cheapest binding is the answer.
    ``None`` (default): 3 with a cost-optimal planner (whose answer should be the cheapest
    plan over the values drawn), else 0.  tamp2d's blocked problem, seeds 0-9: mean plan cost
    33.69 -> 30.73 at the same planner calls.
    ``cheaper_rises``: when the planner's next plan is no cheaper than the plan kept (held
    with its values drawn, not taken at once: ``accept_drawn`` off), and a plan planned
    cheaper than the kept one failed at the level on the values it drew (not on a test over
    values drawn before), the level rises -- giving back the instances held back, to be drawn
    again -- up to this many times in the call before the kept plan is the answer.  ``0`` (default): the kept plan at once.  The
    kitchen's Cook, seed 8: the cheaper plan (move the cracker box first) failed its three
    placement draws at level 6, and the answer was the plan kept before, 32.60 instead of
    28.57 (with one rise: 28.57; the policy's default, ``PolicySettings.cheaper_rises``).  Off
    by default: where optimistic costs are far below the real ones almost every answer would
    rise (tamp2d's problem.pddl with ``fd:opt``, seeds 0-9: 3 planner calls -> 9, no plan
    cheaper).
    ``share``: instances with optimistic inputs share their optimistic outputs (see
    :func:`~ssr_compile.compile.instantiate.instantiate`): smaller first optimistic problems,
    but more real values later (each consumer is evaluated for every value bound to a shared
    object); off by default, as it is not faster on the shipped examples yet.
    ``leaves``: one object in the planner's task for all the optimistic leaf outputs of a
    stream (motion trajectories; :mod:`ssr_compile.compile.leaves`), mapped back per instance;
    on by default (the kitchen's replans: 4,225 objects down to 128 at the same level).
    ``hubs``: an action over many pairs (the base motions between every two base
    configurations) as two half-steps through a hub in the planner's task
    (:mod:`ssr_compile.compile.hubs`), from ``hubs.MIN_PAIRS`` pairs; on by default.
    ``unit_cost``: plan with unit action costs.  ``progress``: called with a line of text per
    iteration and per stream plan (``None``: silent).
    """

    algorithm: str = "focused"
    planner: str | Any = "fd"
    time_limit: float = 60.0
    initial_level: int = 1
    complexity_base: int | None = None
    max_level: int = 8
    max_cost: float = math.inf
    defer: bool = False
    resample: int = RESAMPLE
    redraws: int = 0
    accept_drawn: bool | None = None
    accept_dearer: bool = False
    retry_levels: int | None = None
    rebind: int | None = None
    cheaper_rises: int = 0
    eager_cost: float = EAGER_COST
    eager_tests: bool = True
    lazy_tests: bool = True
    unit_cost: bool = False
    share: bool = False
    leaves: bool = True
    hubs: bool = True
    progress: Callable[[str], None] | None = None

    def __post_init__(self) -> None:
        if self.algorithm not in ALGORITHMS:
            raise ValueError(
                f"unknown algorithm {self.algorithm!r}: expected one of {', '.join(ALGORITHMS)}"
            )
        if self.algorithm == "adaptive" and self.share:
            raise UnsupportedError(
                "the adaptive algorithm does not take shared optimistic outputs (share=True); "
                "use algorithm='focused' for them"
            )
        if self.retry_levels is not None and self.retry_levels < 0:
            raise ValueError(f"retry_levels must be 0 or more, got {self.retry_levels}")
        if self.cheaper_rises < 0:
            raise ValueError(f"cheaper_rises must be 0 or more, got {self.cheaper_rises}")


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
    of the objects' names and Python values those results use (``None``: a new table);
    ``recheck``: stream instances over the problem's objects that failed in the last call
    (:attr:`~.results.Solution.failed`), evaluated again before this call plans.
    """

    tail: Sequence[tuple[str, Sequence[str]]] | None = None
    constants: Container[str] = frozenset()
    kept_facts: tuple[S.Atom, ...] = ()
    kept_values: dict[str, Any] = field(default_factory=dict)
    evaluated: Sequence[Result] = ()
    values: ValueTable | None = None
    recheck: Collection[Instance] = ()

    def is_constant(self, name: str) -> bool:
        return name in self.constants


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
