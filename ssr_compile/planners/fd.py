"""``fd``: Fast Downward without unified-planning's PDDL round trip.

One call writes the task as canonical PDDL into a fresh temporary directory, runs Fast
Downward's Python translator in a forked worker process (the translator modules are imported
once, in the parent, before the fork; the worker is kept between calls, so a call pays neither
an interpreter start nor a fork; it is killed and re-forked when a call times out), then runs the
``downward`` search binary shipped by the ``up_fast_downward`` package as a subprocess in its
own process group, reading the SAS file.  Both steps share the call's wall-clock limit and are
killed when it passes.  Supports everything the translator does: negation, disjunction,
quantifiers, conditional effects, derived predicates (axioms), and costs given as numbers or
static functions.
"""

from __future__ import annotations

import atexit
import importlib.util
import math
import os
import shutil
import tempfile
from pathlib import Path

from ..printer import to_text
from ..syntax import Domain, Problem
from . import proc
from .base import (
    ERROR,
    TIMEOUT,
    UNSOLVABLE,
    Capabilities,
    Clock,
    PlanResult,
    describe_variants,
)
from .costs import fractional_costs, priced
from .features import unsupported

# Search configurations; ``{bound}`` receives ``,bound=N`` when a cost bound is given.
# "default" is cost-aware (LAMA's weighted-A* stage: ff + landmarks with costs plus one) and
# works with axioms; "lama-first" ignores costs (it is unified-planning's fast-downward);
# "opt" is A* with LM-cut, or with the blind heuristic where LM-cut cannot handle the task
# (axioms, conditional effects).
_LM = "landmark_sum(lm_reasonable_orders_hps(lm_rhw()),pref=false)"
SEARCHES = {
    "default": (
        f"let(hlm,eval_modify_costs({_LM},cost_type=plusone),"
        "let(hff,eval_modify_costs(ff(),cost_type=plusone),"
        "lazy_wastar([hff,hlm],preferred=[hff,hlm],w=5{bound})))"
    ),
    "lama-first": (
        f"let(hlm,eval_modify_costs({_LM},cost_type=one),"
        "let(hff,eval_modify_costs(ff(),cost_type=one),"
        "lazy_greedy([hff,hlm],preferred=[hff,hlm],cost_type=one,reopen_closed=false{bound})))"
    ),
    "opt": "astar(lmcut(){bound})",
    "blind": "astar(blind(){bound})",
}
OPTIMAL = {"opt", "blind"}
_OPT_FALLBACK = "astar(blind(){bound})"

# Fast Downward's exit codes (driver/returncodes.py).
_UNSOLVABLE_CODES = {
    10: "proved unsolvable",
    11: "proved unsolvable",
    12: "search space exhausted without a plan",
    13: "no plan within the cost bound",
}
_TIMEOUT_CODES = {21, 23, 24}
_MEMORY_CODES = {20, 22}


def downward_dir() -> Path:
    """The Fast Downward tree inside the installed ``up_fast_downward`` package."""
    spec = importlib.util.find_spec("up_fast_downward")
    if spec is None or not spec.submodule_search_locations:
        raise FileNotFoundError("the up_fast_downward package is not installed")
    return Path(next(iter(spec.submodule_search_locations))) / "downward"


def search_binary() -> Path:
    path = downward_dir() / "builds" / "release" / "bin" / "downward"
    if not path.exists():
        raise FileNotFoundError(f"Fast Downward search binary not found at {path}")
    return path


def _translate(domain_path: str, problem_path: str, sas_path: str) -> dict:
    """Run the translator in this (forked) process; a summary of the SAS task written."""
    from fast_downward.translate import main as translate_main
    from fast_downward.translate import normalize, options, pddl_parser

    options.set_options([domain_path, problem_path, "--sas-file", sas_path])
    reasons: list[str] = []
    make_unsolvable = translate_main.unsolvable_sas_task

    def record(msg):  # the translator proves some tasks unsolvable on its own
        reasons.append(msg)
        return make_unsolvable(msg)

    translate_main.unsolvable_sas_task = record  # only in this forked child
    task = pddl_parser.open(domain_filename=domain_path, problem_filename=problem_path)
    normalize.normalize(task)
    sas_task = translate_main.pddl_to_sas(task)
    with open(sas_path, "w") as f:
        sas_task.output(f)
    return {
        "unsolvable": reasons[0] if reasons else None,
        "axioms": len(sas_task.axioms),
        "operators": len(sas_task.operators),
        "conditional_effects": any(c for op in sas_task.operators for *_, c in op.pre_post),
    }


# One translator process for all fd planners of this process, forked on first use.
_TRANSLATOR = proc.ForkedWorker(_translate)
atexit.register(_TRANSLATOR.close)


def _log_tail(path: str, lines: int = 6) -> str:
    try:
        text = Path(path).read_text(errors="replace").strip().splitlines()
    except OSError:
        return ""
    return " | ".join(line.strip() for line in text[-lines:] if line.strip())


def read_plan(path: str) -> list[tuple[str, tuple[str, ...]]]:
    """Ground actions of a Fast Downward plan file (``(name arg ...)`` per line)."""
    actions = []
    for line in Path(path).read_text().splitlines():
        line = line.strip()
        if not line or line.startswith(";"):
            continue
        name, *args = line.strip("()").lower().split()
        actions.append((name, tuple(args)))
    return actions


def _last_plan(path: str) -> str | None:
    """The plan file, or the best of an anytime search's numbered ones (``sas_plan.N``)."""
    if os.path.exists(path):
        return path
    numbered = [p for p in Path(path).parent.glob(Path(path).name + ".*") if p.suffix[1:].isdigit()]
    return str(max(numbered, key=lambda p: int(p.suffix[1:]))) if numbered else None


class FastDownward:
    """The ``fd`` backend.  ``search`` is a key of :data:`SEARCHES` or a raw ``--search``
    string; ``keep_files`` leaves the temporary directory in place (its path in the message)."""

    def __init__(self, search: str = "default", *, keep_files: bool = False):
        self.search = search
        self.keep_files = keep_files
        self.name = "fd" if search == "default" else f"fd:{search}"
        self.capabilities = Capabilities(
            costs=True,
            axioms=True,
            negative_preconditions=True,
            disjunction=True,
            quantifiers=True,
            conditional_effects=True,
            optimal=search in OPTIMAL,
        )
        # Import the translator now, so that every forked call finds it loaded.
        import fast_downward.translate.main  # noqa: F401

        self.binary = search_binary()
        self.last_operators: int | None = None  # ground actions of the last translated task

    def _search_option(self, info: dict, cost_bound: float | None) -> str:
        template = SEARCHES.get(self.search, self.search)
        if self.search == "opt" and (info["axioms"] or info["conditional_effects"]):
            template = _OPT_FALLBACK
        bound = f",bound={math.ceil(cost_bound)}" if cost_bound is not None else ""
        if "{bound}" not in template and bound:
            raise ValueError("a raw search string needs a {bound} slot to take a cost bound")
        return template.replace("{bound}", bound)

    def solve(
        self,
        domain: Domain,
        problem: Problem,
        time_limit: float = 60.0,
        cost_bound: float | None = None,
    ) -> PlanResult:
        clock = Clock(time_limit)
        tmp = ""
        self.last_operators = None

        def result(status, message="", actions=None, cost=None):
            if self.keep_files and tmp:
                message = f"{message} [files in {tmp}]".strip()
            return PlanResult(status, actions, cost, clock.elapsed(), self.name, message)

        missing = unsupported(self.capabilities, domain, problem)
        if missing:
            return result(ERROR, f"{self.name} does not support " + ", ".join(missing))
        fractional = fractional_costs(domain, problem) if problem.metric is not None else []
        if fractional:
            return result(
                ERROR,
                "Fast Downward needs integer costs (scale and round them first): "
                + ", ".join(fractional[:3]),
            )
        tmp = tempfile.mkdtemp(prefix="ssr-fd-")
        try:
            paths = {k: os.path.join(tmp, k) for k in ("domain.pddl", "problem.pddl")}
            Path(paths["domain.pddl"]).write_text(to_text(domain))
            Path(paths["problem.pddl"]).write_text(to_text(problem))
            sas, log = os.path.join(tmp, "output.sas"), os.path.join(tmp, "translate.log")
            status, info = _TRANSLATOR.call(
                (paths["domain.pddl"], paths["problem.pddl"], sas),
                timeout=clock.remaining(),
                log_path=log,
            )
            if status == proc.TIMED_OUT:
                return result(TIMEOUT, f"translator exceeded the time limit of {time_limit:g} s")
            if status != proc.OK:
                detail = _log_tail(log, 3)
                return result(
                    ERROR, f"translator failed: {info}" + (f" ({detail})" if detail else "")
                )
            self.last_operators = info.get("operators")
            if info["unsolvable"]:
                return result(UNSOLVABLE, f"translator: {info['unsolvable']}")
            try:
                search = self._search_option(info, cost_bound)
            except ValueError as e:
                return result(ERROR, str(e))
            plan_path, log = os.path.join(tmp, "sas_plan"), os.path.join(tmp, "search.log")
            code = proc.run_command(
                [str(self.binary), "--search", search, "--internal-plan-file", plan_path],
                clock.remaining(),
                cwd=tmp,
                stdin_path=sas,
                log_path=log,
            )
            if code is None or code in _TIMEOUT_CODES:
                return result(TIMEOUT, f"search exceeded the time limit of {time_limit:g} s")
            if code in _UNSOLVABLE_CODES:
                why = _UNSOLVABLE_CODES[code]
                if cost_bound is not None and code != 11:
                    why += f" (cost bound {cost_bound:g})"
                return result(UNSOLVABLE, why)
            if code in _MEMORY_CODES:
                return result(ERROR, "out of memory")
            plan_path = _last_plan(plan_path)
            if code != 0 or plan_path is None:
                return result(ERROR, f"search failed with exit code {code}: {_log_tail(log)}")
            actions = read_plan(plan_path)
            return priced(result, domain, problem, actions, cost_bound)
        except Exception as e:  # noqa: BLE001 - a backend answers, it never crashes
            return result(ERROR, f"{type(e).__name__}: {e}")
        finally:
            if not self.keep_files:
                shutil.rmtree(tmp, ignore_errors=True)


def make_planner(variant: str | None = None, **options) -> FastDownward:
    """Entry-point factory: ``fd`` or ``fd:CONFIG`` (CONFIG a key of :data:`SEARCHES`)."""
    if variant is not None:
        options.setdefault("search", variant)
    search = options.get("search", "default")
    if search not in SEARCHES and "(" not in search:
        from ..errors import SSRError

        raise SSRError(
            f"unknown fd search {search!r}; choose one of {', '.join(SEARCHES)} "
            "or give a Fast Downward --search string"
        )
    return FastDownward(**options)


_DESCRIPTIONS = {
    "default": "Fast Downward, lazy weighted A* (w=5) with ff + landmarks, cost-aware",
    "lama-first": "Fast Downward, LAMA's first iteration (greedy, ignores costs)",
    "opt": "Fast Downward, A* with LM-cut (blind search for axioms/conditional effects)",
    "blind": "Fast Downward, A* with the blind heuristic",
}


def describe() -> list[dict]:
    return describe_variants(FastDownward, _DESCRIPTIONS)


make_planner.describe = describe
