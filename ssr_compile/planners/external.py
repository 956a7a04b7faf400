"""The base of every backend that plans outside this process (docs/design.md §4 "Planner backend").

:class:`ExternalPlanner` does, once for all of them, what such a call needs: refuse a task
outside the backend's :class:`~ssr_compile.planners.base.Capabilities`, make a private
temporary folder, write the task there as PDDL, run the planner under the call's wall-clock
limit (killed, with whatever it started, when the limit passes), read the plan back, price it
under the problem's metric (refused when not below the cost bound), and remove the folder
whatever happens.  A backend is then its command line and its plan reader::

    class Madagascar(ExternalPlanner):
        name = "mp"
        capabilities = Capabilities(costs=False, axioms=False, negative_preconditions=True,
                                    disjunction=False, quantifiers=False,
                                    conditional_effects=True)

        def command(self, job):
            return ["Mp", job.domain, job.problem, "-o", job.plan]

        def read_plan(self, job):
            return read_plan_file(job.plan)  # None: the planner found no plan

Backends that do more (Fast Downward's two stages, a Python planner run in a forked child)
override :meth:`ExternalPlanner.run`; they stop with a non-solved answer by raising
:class:`Stop`.  Names need no care in a backend: tasks from the compiler already have plain
identifiers in one namespace (``compile/rename.py``, run by the lowering); a task handed in
directly is renamed here, with the same pass, when ``plain_names`` says the planner's reader
needs it, and its plan mapped back.
"""

from __future__ import annotations

import os
import shutil
import tempfile
import traceback
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..compile.rename import rename_task
from ..printer import to_text
from ..syntax import Domain, Problem
from . import proc
from .base import ERROR, TIMEOUT, UNSOLVABLE, Capabilities, Clock, GroundAction, PlanResult
from .costs import priced
from .features import unsupported


class Stop(Exception):
    """Raised by a backend's hooks: answer with ``status`` (``unsolvable``, ``timeout``,
    ``error``) and a one-line ``message``; ``detail`` (a log, a traceback) is kept for
    ``--debug``."""

    def __init__(self, status: str, message: str, detail: str = ""):
        super().__init__(message)
        self.status = status
        self.message = message
        self.detail = detail


@dataclass
class Job:
    """One planner call: its folder, the files in it, the clock and the cost bound."""

    dir: str
    domain: str  # path of the domain file written for the planner
    problem: str  # path of the problem file
    plan: str  # where the planner is asked to write its plan
    log: str  # where its output goes
    clock: Clock
    time_limit: float
    cost_bound: float | None
    task: tuple[Domain, Problem]  # the task as syntax trees (for in-process readers)
    # seconds per stage ("translate", "search") for the answer (PlanResult.translate_time...)
    stages: dict[str, float] = field(default_factory=dict)

    def file(self, name: str) -> str:
        return os.path.join(self.dir, name)


def read_plan_file(path: str) -> list[GroundAction] | None:
    """Ground actions of a plan file (``(name arg ...)`` per line, ``;`` comments); ``None``
    when there is no such file."""
    if not os.path.exists(path):
        return None
    actions = []
    for line in Path(path).read_text().splitlines():
        line = line.strip()
        if not line or line.startswith(";"):
            continue
        name, *args = line.strip("()").lower().split()
        actions.append((name, tuple(args)))
    return actions


def log_tail(path: str, lines: int = 6) -> str:
    """The last non-empty lines of a log, joined on one line."""
    try:
        text = Path(path).read_text(errors="replace").strip().splitlines()
    except OSError:
        return ""
    return " | ".join(line.strip() for line in text[-lines:] if line.strip())


def log_text(path: str, limit: int = 20_000) -> str:
    """A log's text (its end, when long), for ``--debug``."""
    try:
        return Path(path).read_text(errors="replace")[-limit:]
    except OSError:
        return ""


class ExternalPlanner:
    """A backend that writes the task to files and plans in another process.

    Subclasses set ``name`` and ``capabilities`` and give :meth:`command` and
    :meth:`read_plan` (or override :meth:`run`).  ``keep_files`` leaves the folder in place
    (its path is added to the answer's message)."""

    name: str = "external"
    capabilities: Capabilities
    keep_files: bool = False
    equality: bool = True  # may the task use '=' (see planners.features.unsupported)?
    plain_names: bool = True  # does the reader need plain identifiers in one namespace?

    # ---------------------------------------------------------------- a backend's hooks

    def command(self, job: Job) -> list[str]:
        """The planner's command line (run in ``job.dir``, output to ``job.log``)."""
        raise NotImplementedError(f"{type(self).__name__} gives neither command() nor run()")

    def read_plan(self, job: Job) -> list[GroundAction] | None:
        """The plan the planner wrote, or ``None`` when it found none."""
        return read_plan_file(job.plan)

    def refuse(self, domain: Domain, problem: Problem) -> str | None:
        """Why this backend cannot take the task (``None``: it can)."""
        missing = unsupported(self.capabilities, domain, problem, equality=self.equality)
        return f"{self.name} does not support " + ", ".join(missing) if missing else None

    def write(self, job: Job, domain: Domain, problem: Problem) -> None:
        Path(job.domain).write_text(to_text(domain))
        Path(job.problem).write_text(to_text(problem))

    def run(self, job: Job) -> list[GroundAction] | None:
        """Run :meth:`command` under the time limit and read the plan back."""
        code = proc.run_command(
            self.command(job), job.clock.remaining(), cwd=job.dir, log_path=job.log
        )
        if code is None:
            raise Stop(TIMEOUT, f"exceeded the time limit of {job.time_limit:g} s")
        actions = self.read_plan(job)
        if code != 0 and actions is None:
            raise Stop(ERROR, f"exited with code {code}: {log_tail(job.log)}", log_text(job.log))
        return actions

    # ---------------------------------------------------------------- helpers for run()

    def run_forked(self, job: Job, fn, args: tuple, *, what: str) -> Any:
        """``fn(*args)`` in a forked child killed at the time limit; its value.  A timeout or
        an exception in the child stops the call (``what failed: ...``, the child's traceback
        as detail)."""
        status, value = proc.run_forked(fn, args, timeout=job.clock.remaining(), log_path=job.log)
        if status == proc.TIMED_OUT:
            raise Stop(TIMEOUT, f"exceeded the time limit of {job.time_limit:g} s")
        if status != proc.OK:
            raise Stop(ERROR, f"{what} failed: {value}", log_text(job.log))
        return value

    # ---------------------------------------------------------------- the call

    def solve(
        self,
        domain: Domain,
        problem: Problem,
        time_limit: float = 60.0,
        cost_bound: float | None = None,
    ) -> PlanResult:
        clock = Clock(time_limit)
        folder = ""
        stages: dict[str, float] = {}

        def result(status, message="", actions=None, cost=None, detail=""):
            if self.keep_files and folder:
                message = f"{message} [files in {folder}]".strip()
            return PlanResult(
                status,
                actions,
                cost,
                clock.elapsed(),
                self.name,
                message,
                detail,
                translate_time=stages.get("translate", 0.0),
                search_time=stages.get("search", 0.0),
            )

        self.before(domain, problem)
        refusal = self.refuse(domain, problem)
        if refusal:
            return result(ERROR, refusal)
        folder = tempfile.mkdtemp(prefix=f"ssr-{self.name.partition(':')[0]}-")
        job = Job(
            folder,
            os.path.join(folder, "domain.pddl"),
            os.path.join(folder, "problem.pddl"),
            os.path.join(folder, "plan"),
            os.path.join(folder, "planner.log"),
            clock,
            time_limit,
            cost_bound,
            (domain, problem),
            stages,
        )
        try:
            task, renaming = self.prepare(domain, problem), None
            if self.plain_names:
                renamed = rename_task(*task)  # a no-op on the compiler's output
                task, renaming = (renamed.domain, renamed.problem), renamed.renaming
            job.task = tuple(task)
            self.write(job, *job.task)
            actions = self.run(job)
            if actions is None:
                return result(UNSOLVABLE, f"{self.name} found no plan")
            if renaming:
                actions = renaming.plan_back(actions)
            return priced(result, domain, problem, actions, cost_bound)
        except Stop as s:
            return result(s.status, s.message, detail=s.detail)
        except Exception as e:  # noqa: BLE001 - a backend answers, it never crashes
            return result(ERROR, f"{type(e).__name__}: {e}", detail=traceback.format_exc())
        finally:
            if not self.keep_files:
                shutil.rmtree(folder, ignore_errors=True)

    def before(self, domain: Domain, problem: Problem) -> None:
        """Called first in every :meth:`solve` (reset per-call statistics)."""

    def prepare(self, domain: Domain, problem: Problem) -> tuple[Domain, Problem]:
        """The task as this backend's planner reads it (default: unchanged)."""
        return domain, problem
