"""``up:ENGINE``: any unified-planning one-shot planner, by its engine name.

The task arrives with the names unified-planning needs (one namespace for types, predicates,
functions, actions and objects; plain identifiers: ``compile/rename.py``).  A ground task is
built with unified-planning's modelling API, any other is printed to a temporary directory and
read by its PDDL reader; the engine solves it in a forked child that is killed, with the
planner processes it started, when the time limit passes (:class:`~.external.ExternalPlanner`).  unified-planning is imported when a planner is built (it takes about a
second), never by merely importing ssr_compile.
"""

from __future__ import annotations

import os

from ..compile.constraints import is_chained
from ..errors import SSRError
from ..syntax import Domain, Problem
from .base import ERROR, SOLVED, TIMEOUT, UNSOLVABLE, Capabilities
from .external import ExternalPlanner, Job, Stop
from .fd import SEARCHES

DEFAULT_ENGINE = "fast-downward"
# The search string ``fd`` runs by default, without a cost bound.
COST_AWARE_SEARCH = SEARCHES["default"].replace("{bound}", "")


def _environment():
    import unified_planning.shortcuts as up

    env = up.get_environment()
    env.credits_stream = None  # engines print a banner otherwise
    return env


def oneshot_engines() -> dict[str, type]:
    """unified-planning's installed one-shot planners by name (meta engines left out)."""
    from unified_planning.engines.mixins.oneshot_planner import OneshotPlannerMixin

    factory = _environment().factory
    out = {}
    for name in factory.engines:
        if "[" in name:
            continue
        cls = factory.engine(name)
        if issubclass(cls, OneshotPlannerMixin):
            out[name] = cls
    return out


def engine_capabilities(cls) -> Capabilities:
    """What an engine supports natively, read from its declared problem kind.

    ssr-compile's lowering removes what the engine lacks before the task is written (its
    splitting refuses, with a clear message, tasks whose normal form would explode, where
    unified-planning's compilers would grind until the time limit); whatever the PDDL reader
    still finds unsupported — equality for pyperplan, say — is removed by unified-planning's
    own compilers (:func:`_fit_to_engine`).  Axioms are left to the lowering: the reader does
    not read ``:derived``.
    """
    kind = cls.supported_kind()
    has = kind.features.__contains__
    return Capabilities(
        costs=has("ACTIONS_COST") and has("INT_NUMBERS_IN_ACTIONS_COST"),
        axioms=False,
        negative_preconditions=has("NEGATIVE_CONDITIONS"),
        disjunction=has("DISJUNCTIVE_CONDITIONS"),
        quantifiers=has("EXISTENTIAL_CONDITIONS")
        and has("UNIVERSAL_CONDITIONS")
        and has("FORALL_EFFECTS"),
        conditional_effects=has("CONDITIONAL_EFFECTS"),
        optimal=_optimal(cls),
        # unified-planning's writer lists every grounding of every predicate over all
        # objects: hand it the ground task (a few hundred 0-ary facts) instead.
        ground=True,
    )


# unified-planning compilers, in the order they are applied, with the problem-kind features
# each one removes.
_COMPILERS = (
    ("QUANTIFIERS_REMOVING", ("EXISTENTIAL_CONDITIONS", "UNIVERSAL_CONDITIONS", "FORALL_EFFECTS")),
    ("CONDITIONAL_EFFECTS_REMOVING", ("CONDITIONAL_EFFECTS",)),
    ("DISJUNCTIVE_CONDITIONS_REMOVING", ("DISJUNCTIVE_CONDITIONS",)),
    ("NEGATIVE_CONDITIONS_REMOVING", ("NEGATIVE_CONDITIONS",)),
)


def _fit_to_engine(task, engine_cls):
    """Apply unified-planning's compilers until the engine supports the task.

    Returns the compiled task and the map-back functions (last compiler first), which turn the
    engine's action instances back into the original task's.
    """
    from unified_planning.engines import CompilationKind
    from unified_planning.exceptions import UPException
    from unified_planning.shortcuts import Compiler

    map_backs = []
    supported = engine_cls.supported_kind().features
    # ``Problem.kind`` walks the whole task at every access (40 ms on tamp2d's blocked
    # problem, read 10 times here per call): once per task
    task_kind = task.kind
    steps = [
        getattr(CompilationKind, name)
        for name, features in _COMPILERS
        if any(f in task_kind.features and f not in supported for f in features)
    ]
    steps.append(CompilationKind.GROUNDING)  # last resort: equality, for instance
    for kind in steps:
        if engine_cls.supports(task_kind):
            break
        try:
            with Compiler(problem_kind=task_kind, compilation_kind=kind) as compiler:
                res = compiler.compile(task, kind)
        except UPException:
            # No compiler takes this task (undefined static cost values, say): let the engine
            # try it as it is, which is what it would have been given without this step.
            break
        task = res.problem
        task_kind = task.kind
        map_backs.insert(0, res.map_back_action_instance)
    return task, map_backs


def _takes_translate_options(cls) -> bool:
    """Does the engine's constructor take Fast Downward's translator options?"""
    import inspect

    try:
        return "fast_downward_translate_options" in inspect.signature(cls.__init__).parameters
    except (TypeError, ValueError):
        return False


def _optimal(cls) -> bool:
    from unified_planning.engines.mixins.oneshot_planner import OptimalityGuarantee

    try:
        return bool(cls.satisfies(OptimalityGuarantee.SOLVED_OPTIMALLY))
    except Exception:  # noqa: BLE001
        return False


def to_up_problem(domain: Domain, problem: Problem):
    """A ground task (0-ary predicates, parameterless actions) as a unified-planning
    ``Problem``, built through UP's public modelling API -- no PDDL text to re-parse (UP's
    reader takes seconds on a few hundred ground actions)."""
    from unified_planning.model.metrics import MinimizeActionCosts
    from unified_planning.shortcuts import (
        And,
        BoolType,
        Fluent,
        InstantaneousAction,
        Int,
        Not,
        Or,
    )
    from unified_planning.shortcuts import Problem as UPProblem

    from .. import syntax as S

    env = _environment()
    fluents = {d.name: Fluent(d.name, BoolType(), environment=env) for d in domain.predicates}
    task = UPProblem(problem.name, environment=env)
    for f in fluents.values():
        task.add_fluent(f, default_initial_value=False)

    def expr(f):
        if isinstance(f, S.Atom):
            if f.args:
                raise ValueError(f"not a ground task: atom {f} has arguments")
            return fluents[f.pred]()
        if isinstance(f, S.Not):
            return Not(expr(f.arg))
        if isinstance(f, S.And):
            return And(*[expr(x) for x in f.args]) if f.args else env.expression_manager.TRUE()
        if isinstance(f, S.Or):
            return Or(*[expr(x) for x in f.args]) if f.args else env.expression_manager.FALSE()
        raise ValueError(f"cannot hand {type(f).__name__} to unified-planning")

    costs = {}
    for a in domain.actions:
        if a.parameters:
            raise ValueError(f"not a ground task: action {a.name} has parameters")
        act = InstantaneousAction(a.name, _env=env)
        if a.precondition is not None:
            act.add_precondition(expr(a.precondition))
        cost = 0
        adds, dels, conditional = [], [], []
        for e in S.conjuncts(a.effect):
            if isinstance(e, S.NumericEffect):
                cost += int(e.value.value) if isinstance(e.value, S.Num) else 0
            elif isinstance(e, S.When):
                for x in S.conjuncts(e.effect):
                    positive = not isinstance(x, S.Not)
                    atom = x if positive else x.arg
                    conditional.append((expr(e.condition), atom.pred, positive))
            elif isinstance(e, S.Not):
                dels.append(e.arg.pred)
            elif isinstance(e, S.Atom):
                adds.append(e.pred)
        for name in dict.fromkeys(adds):
            act.add_effect(fluents[name](), True)
        for name in dict.fromkeys(dels):
            if name not in adds:  # PDDL: add after delete
                act.add_effect(fluents[name](), False)
        for cond, name, positive in conditional:
            act.add_effect(fluents[name](), positive, condition=cond)
        task.add_action(act)
        costs[act] = Int(cost)
    for x in problem.init:
        if isinstance(x, S.Atom):
            task.set_initial_value(fluents[x.pred](), True)
    if problem.goal is not None:
        task.add_goal(expr(problem.goal))
    if problem.metric is not None:
        task.add_quality_metric(MinimizeActionCosts(costs, default=Int(0), environment=env))
    return task


def _is_ground(domain: Domain) -> bool:
    return (
        not domain.axioms
        and all(not a.parameters for a in domain.actions)
        and all(not p.params for p in domain.predicates)
    )


def _solve_in_child(domain_path, problem_path, engine: str, params, timeout: float, tree=None):
    """Runs in the forked child: build or read the task, solve, return plain data."""
    from unified_planning.shortcuts import OneshotPlanner

    # Engines write scratch files into the working directory (Fast Downward's translator:
    # output.sas): two calls in one folder -- a parallel sweep -- would read each other's.
    # The child works in the call's private folder.
    os.chdir(os.path.dirname(os.path.abspath(domain_path)))
    _environment()
    if tree is not None:
        task = to_up_problem(*tree)
    else:
        from unified_planning.io import PDDLReader

        task = PDDLReader().parse_problem(domain_path, problem_path)
    task, map_backs = _fit_to_engine(task, oneshot_engines()[engine])
    with OneshotPlanner(name=engine, params=params or None) as planner:
        res = planner.solve(task, timeout=timeout)
    actions = None
    if res.plan is not None:
        plan = res.plan
        for back in map_backs:
            plan = plan.replace_action_instances(back)
        res = res.__class__(res.status, plan, res.engine_name, res.metrics, res.log_messages)
        actions = [
            (a.action.name, tuple(p.object().name for p in a.actual_parameters))
            for a in res.plan.actions
        ]
    log = " | ".join(m.message.strip() for m in (res.log_messages or []) if m.message.strip())
    return res.status.name, actions, log[-500:]


_STATUS = {
    "SOLVED_SATISFICING": SOLVED,
    "SOLVED_OPTIMALLY": SOLVED,
    "UNSOLVABLE_PROVEN": UNSOLVABLE,
    "UNSOLVABLE_INCOMPLETELY": UNSOLVABLE,
    "TIMEOUT": TIMEOUT,
}


class UnifiedPlanning(ExternalPlanner):
    """A unified-planning one-shot planner (``up:ENGINE``), in a forked child."""

    def __init__(
        self,
        engine: str = DEFAULT_ENGINE,
        *,
        params: dict | None = None,
        invariants: str = "auto",
    ):
        engines = oneshot_engines()
        if engine not in engines:
            raise SSRError(
                f"unknown unified-planning engine {engine!r}; installed one-shot planners: "
                + ", ".join(engines)
            )
        if invariants not in ("auto", "on", "off"):
            raise SSRError(f"invariants must be auto, on or off, got {invariants!r}")
        self.engine = engine
        self.params = dict(params or {})
        self.name = f"up:{engine}"
        self.capabilities = engine_capabilities(engines[engine])
        self.invariants = invariants
        self.translate_options = _takes_translate_options(engines[engine])
        if invariants != "auto" and not self.translate_options:
            raise SSRError(
                f"engine {engine} takes no translator options: invariants={invariants} "
                "cannot be set for it"
            )

    def engine_params(self, domain: Domain) -> dict:
        """The engine's parameters for this task.  Fast Downward's translator synthesises
        invariants (mutex groups) on a plan-constrained task for nothing (the search walks the
        chain of steps) and, on such a task grounded, for long: 14.5 of 15 s of one Swap
        replan.  With ``invariants="auto"`` an engine that takes translator options (unified-
        planning's ``fast-downward``, through its public ``fast_downward_translate_options``
        parameter) skips them on such tasks; "off" always, "on" never."""
        params = dict(self.params)
        if (
            self.engine == DEFAULT_ENGINE
            and not {
                "fast_downward_alias",
                "fast_downward_search_config",
            }
            & params.keys()
        ):
            # The engine's own default, LAMA's first iteration, plans with unit costs: the
            # search of ``fd`` instead (LAMA's cost-aware weighted-A* stage), through the
            # engine's public search-configuration parameter.
            params["fast_downward_search_config"] = COST_AWARE_SEARCH
        off = self.invariants == "off" or (self.invariants == "auto" and is_chained(domain))
        if off and self.translate_options and "fast_downward_translate_options" not in params:
            params["fast_downward_translate_options"] = [
                "--invariant-generation-max-candidates",
                "0",
            ]
        return params

    def run(self, job: Job) -> list | None:
        """A ground task goes to the engine as a tree (UP's modelling API), any other as the
        PDDL files (UP's reader)."""
        tree = job.task if _is_ground(job.task[0]) else None
        params = self.engine_params(job.task[0])
        args = (job.domain, job.problem, self.engine, params, job.clock.remaining(), tree)
        up_status, actions, log = self.run_forked(
            job, _solve_in_child, args, what="unified-planning"
        )
        mapped = _STATUS.get(up_status, ERROR)
        if mapped != SOLVED:
            why = f"unified-planning status {up_status}"
            if mapped == ERROR and log:
                why += ": " + " ".join(log.split())[-300:]
            raise Stop(mapped, why, log)
        return actions or []


def make_planner(variant: str | None = None, **options) -> UnifiedPlanning:
    """Entry-point factory: ``up:ENGINE`` (``up`` alone is ``up:fast-downward``)."""
    return UnifiedPlanning(variant or options.pop("engine", DEFAULT_ENGINE), **options)


def describe() -> list[dict]:
    rows = []
    for name, cls in oneshot_engines().items():
        rows.append(
            {
                "name": f"up:{name}",
                "planner": f"up:{name}",
                "capabilities": engine_capabilities(cls).as_dict(),
                "description": f"unified-planning engine {name} (through PDDL text)",
            }
        )
    return rows


make_planner.describe = describe
