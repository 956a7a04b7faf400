"""The record of an episode of the online policy, and how the environment's answers and the
user's faults enter it.

* :func:`failed` and :func:`failure_text`: an observation says that its action failed with
  ``ok`` false (a mapping's ``"ok"`` key or an object's ``ok`` attribute), and why with its
  ``message`` (README, "Writing an environment");
* :class:`UserCodeError`: the environment's or the agent's code raised or broke the contract
  (:func:`where` names the method, the traceback's innermost frame where it was raised);
* :class:`Cycle` (one line of the log; its ``observation`` is JSON data), :class:`EpisodeResult`
  (the outcome, judged on the true state) and :func:`summarize`.
"""

from __future__ import annotations

import math
import sysconfig
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

from .errors import Failure


class UserCodeError(Failure):
    """The environment's or the agent's code raised, or returned what the contract rules out
    (exit 3 in the CLI, like a stream's code).  ``where`` names the method
    (``environment my_env.World.execute``), ``error`` is the exception (None: a wrong answer,
    said in ``message``); ``result`` is the episode up to there (set by :func:`run_policy`:
    its cycles, its reason, the goal judged in the true state if that still answers)."""

    def __init__(self, where: str, error: BaseException | None = None, message: str = ""):
        if error is not None:
            message = f"{where} raised {type(error).__name__}: {error}{origin(error)}"
        super().__init__(where, f"{message or where}")
        self.where, self.error = where, error
        self.result: EpisodeResult | None = None

    def __str__(self) -> str:
        return f"ssr-compile: the user's code failed: {self.message}"


def origin(error: BaseException) -> str:
    """`` (file:line)`` where ``error`` was raised: the innermost frame of its traceback outside
    Python's own and installed libraries (the user's line rather than numpy's), else the
    innermost frame."""
    if isinstance(error, SyntaxError) and error.filename:
        return f" ({error.filename}:{error.lineno})"
    frames = []
    tb = error.__traceback__
    while tb is not None:
        frames.append((tb.tb_frame.f_code.co_filename, tb.tb_lineno))
        tb = tb.tb_next
    if not frames:
        return ""
    libraries = tuple({sysconfig.get_path(k) for k in ("stdlib", "purelib", "platlib")})
    own = [f for f in frames if not f[0].startswith(libraries) and not f[0].startswith("<")]
    file, line = (own or frames)[-1]
    return f" ({file}:{line})"


def where(role: str, obj: Any, method: str) -> str:
    """``role module.Class.method``: the user's method, for messages."""
    kind = type(obj)
    return f"{role} {kind.__module__}.{kind.__qualname__}.{method}"


def failed(observation: Any) -> bool:
    """Did the environment report that the action failed?  An observation says so with ``ok``
    false: a mapping's ``"ok"`` key or an object's ``ok`` attribute (``False``, ``0``,
    ``numpy.False_``); without ``ok`` (or ``None``, or no observation) the action succeeded."""
    if observation is None:
        return False
    if isinstance(observation, Mapping):
        ok = observation.get("ok", True)
    else:
        ok = getattr(observation, "ok", True)
    if ok is None:
        return False
    try:
        return not bool(ok)
    except Exception as e:  # noqa: BLE001 - e.g. a numpy array: not a truth value
        raise UserCodeError(
            "environment", message=f"the observation's ok must be true or false, got {ok!r}"
        ) from e


def failure_text(observation: Any) -> str:
    """What a failed observation says: its ``message`` (key or attribute), else its text."""
    if isinstance(observation, Mapping):
        message = observation.get("message")
    else:
        message = getattr(observation, "message", None)
    return str(message) if message else str(observation)


# The parts of a cycle's planning time kept in its record (Statistics and Cycle fields).
SPLIT = ("planner_time", "translate_time", "search_time", "stream_time", "compile_time")


def add_split(split: dict[str, float], stats) -> None:
    """Add the parts of one solve's planning time (its ``Statistics``) to ``split``."""
    for part in SPLIT:
        split[part] = split.get(part, 0.0) + getattr(stats, part)


@dataclass
class Cycle:
    """One cycle of the policy, as logged."""

    index: int
    action: str | None  # the executed action, None when the plan was empty or none was found
    constrained: str  # "held", "fell back", "timeout" (constrained attempt ran out) or "-"
    planning_time: float
    stream_calls: int
    planner_calls: int
    deferred: int  # optimistic results left for a later cycle
    plan_length: int | None
    cost: float | None
    belief: str
    execution_time: float = 0.0
    update_time: float = 0.0
    overhead_time: float = 0.0  # the policy's own time (determinize, constants, bookkeeping)
    constrained_time: float = 0.0  # planning time of the constrained attempt alone
    unconstrained_time: float = 0.0  # planning time of the unconstrained attempt alone
    comparison_time: float | None = None  # unconstrained time on a held cycle (measurement)
    # Of planning_time (both attempts), from the solver's statistics: the planner calls
    # (the translator's and the search's shares of them apart), stream evaluation, compiling
    # the optimistic problems.  The rest is the solver's own work (preimages, stream plans).
    planner_time: float = 0.0
    translate_time: float = 0.0
    search_time: float = 0.0
    stream_time: float = 0.0
    compile_time: float = 0.0
    plan: list[str] | None = None  # the whole plan of this cycle (its first action executed)
    observation: Any = None  # what the environment answered, as JSON data (``to_json``)
    failed: bool = False  # the execution failed: the observation's ``ok`` false (``failed``)
    failure: str | None = None  # why it failed: the observation's message, or a limit

    def as_dict(self) -> dict:
        d = dict(vars(self))
        for k, v in d.items():
            if isinstance(v, float):
                d[k] = round(v, 4) if math.isfinite(v) else None
        return d

    def said(self) -> str | None:
        """What the environment answered to a failed execution, for the cycle's line."""
        if self.failure:
            return f"FAILED: {self.failure}"
        return self.observation if isinstance(self.observation, str) else None

    def line(self) -> str:
        what = self.action if self.action is not None else "(no action)"
        cost = "-" if self.cost is None else f"{self.cost:g}"
        return (
            f"cycle {self.index:3d}  {what:48s}  constrained {self.constrained:9s}  "
            f"plan {self.plan_length if self.plan_length is not None else '-'} (cost {cost})  "
            f"planning {self.planning_time:7.3f} s  streams {self.stream_calls:3d}  "
            f"deferred {self.deferred:2d}  | {self.belief}"
            + (f"  | {self.said()}" if self.failed and self.said() else "")
        )


@dataclass
class EpisodeResult:
    """The outcome: judged on the environment's true state."""

    success: bool  # the goal holds in the true state at the end
    believed: bool  # the policy reached the goal belief (an empty plan)
    reason: str  # why the episode ended
    cycles: list[Cycle]
    planning_time: float
    wall_time: float

    @property
    def constrained_held(self) -> int:
        return sum(c.constrained == "held" for c in self.cycles)

    @property
    def fallbacks(self) -> int:
        return sum(c.constrained in ("fell back", "timeout") for c in self.cycles)

    @property
    def actions(self) -> list[str]:
        return [c.action for c in self.cycles if c.action is not None]

    def as_dict(self) -> dict:
        return {
            "success": self.success,
            "believed": self.believed,
            "reason": self.reason,
            "cycles": len(self.cycles),
            "actions": len(self.actions),
            "planning_time": round(self.planning_time, 4),
            "wall_time": round(self.wall_time, 4),
            "constrained_held": self.constrained_held,
            "fallbacks": self.fallbacks,
            "stream_calls": sum(c.stream_calls for c in self.cycles),
            "planner_calls": sum(c.planner_calls for c in self.cycles),
        }


def summarize(results: Iterable[EpisodeResult]) -> dict:
    """Success rate and mean planning time of the successful episodes."""
    results = list(results)
    ok = [r for r in results if r.success]
    return {
        "episodes": len(results),
        "successes": len(ok),
        "success_rate": len(ok) / len(results) if results else 0.0,
        "mean_planning_time": (sum(r.planning_time for r in ok) / len(ok)) if ok else None,
    }
