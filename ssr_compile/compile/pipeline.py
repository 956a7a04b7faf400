"""The whole compilation: PDDLStream (domain, streams, problem) -> plain cost-PDDL for a backend.

Every pass has one contract (:mod:`.result`): it takes a task and returns a
:class:`~.result.PassResult`, the task it made and the map from that task's plans back to its
input's, with the fields of its own the later steps need.  The passes, each a module of this
package, in the order :func:`compile_problem` runs them:

1. ``objects_as_constants`` (here): problem objects the domain names become domain constants;
2. ``instantiate``: optimistic stream instantiation (:class:`~.instantiate.Instantiation`:
   optimistic objects and facts, their provenance);
3. ``constraints``: Algorithm 2, when a plan tail is given (:class:`~.constraints.Constrained`);
4. ``leaves``: one shared object for the optimistic leaf outputs of a stream (motion
   trajectories: nothing consumes them, their facts name the inputs), mapped back per instance
   (:class:`~.leaves.SharedLeaves`);
5. ``hubs``: an action over many pairs (the base motions between every two base
   configurations) as two half-steps through a hub (:class:`~.hubs.Hubs`);
6. ``lower``, which fits the task to the backend's :class:`~.capabilities.Capabilities` with
   ``ground`` (for backends that take a ground task), ``derived`` (axioms compiled away when
   unsupported), ``quantifiers``, ``disjunctions``, ``negations``, ``costs`` (integer action
   costs; the result keeps the ``scale``) and ``rename`` (names every reader accepts), in that
   order; :class:`~.lower.Lowered` keeps the result of each.

:class:`Compiled` is the result of the whole: its :meth:`~Compiled.map_plan` chains the passes'
map-backs (:func:`~.result.map_back`), and its instantiation names the stream instances a
plan relies on.
"""

from __future__ import annotations

import contextlib
import gc
from collections.abc import Callable, Container, Iterable, Mapping, Sequence
from dataclasses import dataclass, replace

from .. import syntax as S
from .capabilities import Capabilities
from .constraints import Constrained, constrain_plan
from .hubs import route_through_hubs
from .instantiate import (  # noqa: F401  (declare_stream_predicates: re-exported)
    Instance,
    Instantiation,
    Result,
    declare_stream_predicates,
    instantiate,
)
from .leaves import share_leaves
from .lower import Lowered, lower
from .result import PassResult, Plan, map_back
from .standins import StandIns

# Share the optimistic leaf outputs of streams (pass 4); measurement scripts turn it off to
# compare (bench/solve_bench.py --no-shared-leaves).
SHARE_LEAVES = True
# Route actions over many pairs through hubs (pass 5) when the caller asks (the solver does,
# SolveOptions.hubs; a compile artifact maps each action to one of the user's, so `compile`
# does not); measurement scripts turn it off here to compare.
ROUTE_HUBS = True

# Everything supported (``FullCapabilities`` is the old name of the type).
EVERYTHING = Capabilities()
FullCapabilities = Capabilities


@dataclass
class Compiled(PassResult):
    """A compiled problem: the plain domain and problem (what the planner reads), and the
    result of every pass that made it, in order (``passes``)."""

    # the task before constraints and lowering (optimistic facts added, axioms kept)
    source_domain: S.Domain | None = None
    source_problem: S.Problem | None = None
    instantiation: Instantiation | None = None
    lowered: Lowered | None = None
    constrained: Constrained | None = None
    passes: tuple[PassResult, ...] = ()

    @property
    def scale(self) -> int:
        return self.lowered.scale

    def map_plan(self, plan) -> Plan:
        """A planner's plan, in the names of the input domain."""
        return map_back(self.passes, plan)


def objects_as_constants(domain: S.Domain, problem: S.Problem) -> PassResult:
    """Objects of the problem that the domain's formulas name (the paper's ``(AtConf base
    ?bq)`` with ``base`` an object) become domain constants: planners' readers refuse a
    domain that names an undeclared object.  Plans map back unchanged."""
    from ..check import undeclared_domain_names

    used = undeclared_domain_names(domain)
    if not used:
        return PassResult(domain, problem)
    moved = tuple(o for o in problem.objects if o.name in used)
    if not moved:
        return PassResult(domain, problem)
    names = {o.name for o in moved}
    return PassResult(
        replace(domain, constants=domain.constants + moved),
        replace(problem, objects=tuple(o for o in problem.objects if o.name not in names)),
    )


@contextlib.contextmanager
def _collector_paused():
    """Python's cyclic garbage collector off for the block (or the decorated call, here
    :func:`compile_problem`), then back as it was.  A compilation allocates hundreds of
    thousands of atoms and tuples, none of them in a reference cycle; each allocation burst
    set off full collections that traversed every object alive -- the solver's values, its
    results, the last compilation's facts -- 37% of the kitchen's compilation time (Stow: 5.7
    s -> 3.3 s).  Garbage without cycles is freed at once as ever; what has cycles waits for
    the next collection after the block."""
    if not gc.isenabled():
        yield
        return
    gc.disable()
    try:
        yield
    finally:
        gc.enable()


@_collector_paused()
def compile_problem(
    domain: S.Domain,
    streams: S.StreamFile | None,
    problem: S.Problem,
    *,
    caps=EVERYTHING,
    level: int = 3,
    evaluated: Iterable[Result] = (),
    disabled: Iterable[Instance] = (),
    exhausted: Iterable[Instance] = (),
    function_values: Mapping[str, float] | None = None,
    real_function_values: Mapping[S.FuncTerm, float] | None = None,
    plan_tail: Sequence[tuple[str, Sequence[str]]] | None = None,
    is_constant: Callable[[str], bool] | None = None,
    scale: int | None = None,
    unit_cost: bool = False,
    share: bool = False,
    leaves: bool | None = None,
    hubs: bool = False,
    standins: StandIns | None = None,
    real_only: Container[str] = frozenset(),
) -> Compiled:
    """Compile a PDDLStream problem to a plain domain and problem for ``caps``."""
    passes: list[PassResult] = [objects_as_constants(domain, problem)]
    inst = None
    if streams is not None:
        inst = instantiate(
            passes[-1].domain,
            streams,
            passes[-1].problem,
            level=level,
            evaluated=evaluated,
            disabled=disabled,
            exhausted=exhausted,
            function_values=function_values,
            real_function_values=real_function_values,
            share=share,
            standins=standins,
            real_only=real_only,
        )
        passes.append(inst)
    source = passes[-1]
    constrained = None
    if plan_tail:
        constrained = constrain_plan(
            source.domain, source.problem, plan_tail, is_constant or (lambda v: False)
        )
        passes.append(constrained)
    if inst is not None and (SHARE_LEAVES if leaves is None else leaves):
        shared = share_leaves(passes[-1].domain, passes[-1].problem, streams, inst)
        if shared.merged:
            passes.append(shared)
    if inst is not None and hubs and ROUTE_HUBS:
        routed = route_through_hubs(passes[-1].domain, passes[-1].problem)
        if routed.split:
            passes.append(routed)
    cost_functions = {f.name for f in streams.functions} if streams is not None else set()
    lowered = lower(
        passes[-1].domain,
        passes[-1].problem,
        caps,
        cost_functions=cost_functions,
        scale=scale,
        unit_cost=unit_cost,
    )
    passes.append(lowered)
    return Compiled(
        lowered.domain,
        lowered.problem,
        source.domain,
        source.problem,
        inst,
        lowered,
        constrained,
        tuple(passes),
    )
