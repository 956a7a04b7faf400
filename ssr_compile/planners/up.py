"""``up:ENGINE``: any unified-planning one-shot planner, by its engine name.

The task is renamed where unified-planning needs it (one namespace for types, predicates,
functions, actions and objects; plain identifiers), printed to a temporary directory, read by
unified-planning's PDDL reader and solved by the engine, all in a forked child that is killed,
with the planner processes it started, when the time limit passes.  The plan is mapped back to
the input's names.  unified-planning is imported when a planner is built (it takes about a
second), never by merely importing ssr_compile.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path

from ..errors import SSRError
from ..printer import to_text
from ..syntax import Domain, Problem
from . import proc
from .base import (
    ERROR,
    SOLVED,
    TIMEOUT,
    UNSOLVABLE,
    Capabilities,
    Clock,
    PlanResult,
    over_bound,
)
from .costs import plan_cost
from .features import unsupported
from .rename import rename_task

DEFAULT_ENGINE = "fast-downward"


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
    """What an engine class supports, read from its declared problem kind."""
    kind = cls.supported_kind()
    has = kind.features.__contains__
    return Capabilities(
        costs=has("ACTIONS_COST") and has("INT_NUMBERS_IN_ACTIONS_COST"),
        axioms=False,  # unified-planning's PDDL reader does not read :derived
        negative_preconditions=has("NEGATIVE_CONDITIONS"),
        disjunction=has("DISJUNCTIVE_CONDITIONS"),
        quantifiers=has("EXISTENTIAL_CONDITIONS")
        and has("UNIVERSAL_CONDITIONS")
        and has("FORALL_EFFECTS"),
        conditional_effects=has("CONDITIONAL_EFFECTS"),
        optimal=_optimal(cls),
    )


def _optimal(cls) -> bool:
    from unified_planning.engines.mixins.oneshot_planner import OptimalityGuarantee

    try:
        return bool(cls.satisfies(OptimalityGuarantee.SOLVED_OPTIMALLY))
    except Exception:  # noqa: BLE001
        return False


def _solve_in_child(domain_path: str, problem_path: str, engine: str, params, timeout: float):
    """Runs in the forked child: read the PDDL, solve, return plain data."""
    from unified_planning.io import PDDLReader
    from unified_planning.shortcuts import OneshotPlanner

    _environment()
    task = PDDLReader().parse_problem(domain_path, problem_path)
    with OneshotPlanner(name=engine, params=params or None) as planner:
        res = planner.solve(task, timeout=timeout)
    actions = None
    if res.plan is not None:
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


class UnifiedPlanning:
    """A unified-planning one-shot planner (``up:ENGINE``), reached through PDDL text."""

    def __init__(self, engine: str = DEFAULT_ENGINE, *, params: dict | None = None):
        engines = oneshot_engines()
        if engine not in engines:
            raise SSRError(
                f"unknown unified-planning engine {engine!r}; installed one-shot planners: "
                + ", ".join(engines)
            )
        self.engine = engine
        self.params = dict(params or {})
        self.name = f"up:{engine}"
        self.capabilities = engine_capabilities(engines[engine])

    def solve(
        self,
        domain: Domain,
        problem: Problem,
        time_limit: float = 60.0,
        cost_bound: float | None = None,
    ) -> PlanResult:
        clock = Clock(time_limit)

        def result(status, message="", actions=None, cost=None):
            return PlanResult(status, actions, cost, clock.elapsed(), self.name, message)

        missing = unsupported(self.capabilities, domain, problem)
        if missing:
            return result(ERROR, f"{self.name} does not support " + ", ".join(missing))
        tmp = tempfile.mkdtemp(prefix="ssr-up-")
        try:
            dom, prob, renaming = rename_task(domain, problem)
            d_path, p_path = os.path.join(tmp, "domain.pddl"), os.path.join(tmp, "problem.pddl")
            Path(d_path).write_text(to_text(dom))
            Path(p_path).write_text(to_text(prob))
            left = clock.remaining()
            status, value = proc.run_forked(
                _solve_in_child,
                (d_path, p_path, self.engine, self.params, left),
                timeout=left,
                log_path=os.path.join(tmp, "engine.log"),
            )
            if status == proc.TIMED_OUT:
                return result(TIMEOUT, f"exceeded the time limit of {time_limit:g} s")
            if status != proc.OK:
                return result(ERROR, f"unified-planning failed: {value}")
            up_status, actions, log = value
            mapped = _STATUS.get(up_status, ERROR)
            if mapped != SOLVED:
                why = f"unified-planning status {up_status}"
                if mapped == ERROR and log:
                    why += ": " + " ".join(log.split())[-300:]
                return result(mapped, why)
            actions = renaming.plan_back(actions or [])
            cost = plan_cost(domain, problem, actions)
            refused = over_bound(cost, cost_bound)
            if refused:
                return result(UNSOLVABLE, refused)
            return result(SOLVED, "", actions, cost)
        except Exception as e:  # noqa: BLE001 - a backend answers, it never crashes
            return result(ERROR, f"{type(e).__name__}: {e}")
        finally:
            shutil.rmtree(tmp, ignore_errors=True)


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
