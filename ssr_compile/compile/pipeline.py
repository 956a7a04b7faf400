"""The whole compilation: PDDLStream (domain, streams, problem) -> plain cost-PDDL for a backend.

The passes, each a module of this package, in the order :func:`compile_problem` runs them:

1. ``objects_as_constants`` (here): problem objects the domain names become domain constants;
2. ``instantiate``: optimistic stream instantiation (optimistic objects and facts, provenance);
3. ``constraints``: Algorithm 2, when a plan tail is given;
4. ``lower``, which fits the task to the backend's :class:`~.capabilities.Capabilities` with
   ``ground`` (for backends that take a ground task), ``derived`` (axioms compiled away when
   unsupported), ``quantifiers``, ``disjunctions``, ``negations``, ``costs`` (integer action
   costs) and ``rename`` (names every reader accepts).

Each pass keeps what maps a plan of its output back to its input (``Lowered.map_plan``,
``Grounded.map_plan``, ``Constrained.map_plan``, the renaming); :meth:`Compiled.map_plan`
chains them, and the instantiation names the stream instances a plan relies on.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, replace

from .. import syntax as S
from ..check import atoms
from .capabilities import Capabilities
from .constraints import Constrained, constrain_plan
from .instantiate import Instance, Instantiation, Result, instantiate
from .lower import Lowered, lower

Plan = list[tuple[str, tuple[str, ...]]]


# Everything supported (``FullCapabilities`` is the old name of the type).
EVERYTHING = Capabilities()
FullCapabilities = Capabilities


@dataclass
class Compiled:
    """A compiled problem: the plain domain and problem, and the maps back."""

    domain: S.Domain  # after lowering: what the planner reads
    problem: S.Problem
    source_domain: S.Domain  # before lowering (optimistic facts added, axioms kept)
    source_problem: S.Problem
    instantiation: Instantiation | None
    lowered: Lowered
    constrained: Constrained | None = None

    @property
    def scale(self) -> int:
        return self.lowered.scale

    def map_plan(self, plan: Plan) -> Plan:
        """A planner's plan, in the names of the input domain."""
        plan = self.lowered.map_plan(plan)
        if self.constrained is not None:
            plan = self.constrained.map_plan(plan)
        return plan


def declare_stream_predicates(domain: S.Domain, streams: S.StreamFile | None) -> S.Domain:
    """Declare, in the domain, the predicates that only the stream file mentions."""
    if streams is None:
        return domain
    declared = {p.name for p in domain.predicates} | {ax.name for ax in domain.axioms}
    extra: dict[str, int] = {}
    for s in streams.streams:
        for formula in (s.domain, s.certified):
            for a in atoms(formula):
                if a.pred not in declared and a.pred != "=":
                    extra.setdefault(a.pred, len(a.args))
    for r in streams.rules:
        for a in atoms(r.certified):
            if a.pred not in declared and a.pred != "=":
                extra.setdefault(a.pred, len(a.args))
    if not extra:
        return domain
    new = tuple(
        S.PredicateDecl(name, tuple(S.Typed(f"?x{i}") for i in range(arity)))
        for name, arity in sorted(extra.items())
    )
    return replace(domain, predicates=domain.predicates + new)


def objects_as_constants(domain: S.Domain, problem: S.Problem) -> tuple[S.Domain, S.Problem]:
    """Objects of the problem that the domain's formulas name (the paper's ``(AtConf base
    ?bq)`` with ``base`` an object) become domain constants: planners' readers refuse a
    domain that names an undeclared object."""
    from ..check import undeclared_domain_names

    used = undeclared_domain_names(domain)
    if not used:
        return domain, problem
    moved = tuple(o for o in problem.objects if o.name in used)
    if not moved:
        return domain, problem
    names = {o.name for o in moved}
    return (
        replace(domain, constants=domain.constants + moved),
        replace(problem, objects=tuple(o for o in problem.objects if o.name not in names)),
    )


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
) -> Compiled:
    """Compile a PDDLStream problem to a plain domain and problem for ``caps``."""
    domain, problem = objects_as_constants(domain, problem)
    inst = None
    if streams is not None:
        inst = instantiate(
            domain,
            streams,
            problem,
            level=level,
            evaluated=evaluated,
            disabled=disabled,
            exhausted=exhausted,
            function_values=function_values,
            real_function_values=real_function_values,
            share=share,
        )
        problem = inst.problem
        domain = declare_stream_predicates(domain, streams)
    source_domain, source_problem = domain, problem
    constrained = None
    if plan_tail:
        constrained = constrain_plan(domain, problem, plan_tail, is_constant or (lambda v: False))
        domain, problem = constrained.domain, constrained.problem
    cost_functions = {f.name for f in streams.functions} if streams is not None else set()
    lowered = lower(
        domain, problem, caps, cost_functions=cost_functions, scale=scale, unit_cost=unit_cost
    )
    return Compiled(
        lowered.domain, lowered.problem, source_domain, source_problem, inst, lowered, constrained
    )
