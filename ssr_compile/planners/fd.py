"""``fd``: Fast Downward without unified-planning's PDDL round trip.

One call writes the task as canonical PDDL into a fresh temporary directory, runs Fast
Downward's Python translator in a forked worker process (the translator modules are imported
once, in the parent, before the fork; the worker is kept between calls, so a call pays neither
an interpreter start nor a fork; it is killed and re-forked when a call times out), then runs the
``downward`` search binary shipped by the ``up_fast_downward`` package as a subprocess in its
own process group, reading the SAS file (started while the translator works, so that its own
start-up, a few milliseconds, overlaps the translation; ``prestart=False`` starts it after).
Both steps share the call's wall-clock limit and are killed when it passes.  Supports everything the translator does: negation, disjunction,
quantifiers, conditional effects, derived predicates (axioms), and costs given as numbers or
static functions.

The translator's invariant synthesis (mutex groups, hence multi-valued variables) is skipped
for a task constrained to a plan's structure (:mod:`..compile.constraints`: one action schema
per plan step, chained so that each state has exactly one applicable step): there it took a
quarter of the translation on the kitchen's replans and the search is a walk along the chain
either way (35 constrained replans of a Swap episode: translation 22 s -> 17 s, search 1.8 s ->
2.5 s, the same plans; ``bench/translate_bench.py``).  ``invariants="on"`` keeps it always,
``"off"`` drops it always.
"""

from __future__ import annotations

import atexit
import copy
import importlib.util
import math
import os
import time
from pathlib import Path

from ..compile.constraints import is_chained
from ..syntax import Domain, Problem
from . import proc
from .base import ERROR, TIMEOUT, UNSOLVABLE, Capabilities, describe_variants
from .costs import fractional_costs
from .external import ExternalPlanner, Job, Stop, log_tail, log_text, read_plan_file
from .fd_negation import negated_rules

# Translate again with the derived predicates' existentials split when the search's heuristics
# would build more negated axiom rules than this (:mod:`.fd_negation`).  The kitchen's Table I
# tasks stay below it and are searched as written; a cluttered kitchen's replans (six boxes
# around the block: 2.9 million rules, 45 s before the first state) go above.
NEGATED_RULES = 20_000

# The translator's modules load with this one (about 15 ms), as the reference implementation
# loads its own with its solver: every forked translation finds them loaded, and a first solve
# does not pay their import inside its call.  When they are missing, making an fd planner
# says so.
try:
    import fast_downward.translate.main  # noqa: F401
except ImportError:
    pass

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


_PARSED_OPTIONS: dict = {}  # per invariants setting: the translator's options, parsed once


def _set_options(options, domain_path: str, problem_path: str, sas_path: str, invariants: bool):
    """The translator's options for one call.  Its argument parser is built and run once per
    setting (a millisecond a call, a tenth of a small task's translation); later calls copy
    the parsed options with this call's files, where the translator keeps them (its
    ``options.options``, read through ``get_options()``)."""
    extra = () if invariants else ("--invariant-generation-max-candidates", "0")
    parsed = _PARSED_OPTIONS.get(extra)
    if parsed is None or not hasattr(options, "get_options"):
        options.set_options([domain_path, problem_path, "--sas-file", sas_path, *extra])
        if hasattr(options, "get_options"):
            _PARSED_OPTIONS[extra] = copy.copy(options.get_options())
        return
    ns = copy.copy(parsed)
    ns.domain, ns.problem, ns.sas_file = domain_path, problem_path, sas_path
    options.options = ns


def _translate(domain_path: str, problem_path: str, sas_path: str, invariants: bool = True) -> dict:
    """Run the translator in this (forked) process; a summary of the SAS task written."""
    from fast_downward.translate import main as translate_main
    from fast_downward.translate import normalize, options, pddl_parser

    _set_options(options, domain_path, problem_path, sas_path, invariants)
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
        "negated_rules": negated_rules(sas_task),
    }


# One translator process for all fd planners of this process, forked on first use.
_TRANSLATOR = proc.ForkedWorker(_translate)
atexit.register(_TRANSLATOR.close)


def read_plan(path: str) -> list[tuple[str, tuple[str, ...]]]:
    """Ground actions of a Fast Downward plan file (``(name arg ...)`` per line)."""
    return read_plan_file(path) or []


def _last_plan(path: str) -> str | None:
    """The plan file, or the best of an anytime search's numbered ones (``sas_plan.N``)."""
    if os.path.exists(path):
        return path
    numbered = [p for p in Path(path).parent.glob(Path(path).name + ".*") if p.suffix[1:].isdigit()]
    return str(max(numbered, key=lambda p: int(p.suffix[1:]))) if numbered else None


class FastDownward(ExternalPlanner):
    """The ``fd`` backend.  ``search`` is a key of :data:`SEARCHES` or a raw ``--search``
    string; ``keep_files`` leaves the temporary directory in place (its path in the message);
    ``invariants``: the translator's invariant synthesis, "auto" (not for plan-constrained
    tasks), "on" or "off"."""

    plain_names = False  # the translator reads any PDDL name, in separate namespaces

    def __init__(
        self,
        search: str = "default",
        *,
        keep_files: bool = False,
        invariants: str = "auto",
        prestart: bool = True,
    ):
        if invariants not in ("auto", "on", "off"):
            from ..errors import SSRError

            raise SSRError(f"fd invariants must be auto, on or off, got {invariants!r}")
        self.search = search
        self.keep_files = keep_files
        self.invariants = invariants
        self.prestart = prestart and proc.can_fork()
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
        import fast_downward.translate.main  # noqa: F401 - missing: fail here, not per call

        self.binary = search_binary()
        self.last_operators: int | None = None  # ground actions of the last translated task
        # the last task's negated axiom rules as written (estimated, .fd_negation), and as
        # written and split when it was split
        self.last_negated_rules: float | None = None
        self.last_split: tuple[float, float] | None = None

    def _search_option(self, info: dict, cost_bound: float | None) -> str:
        template = SEARCHES.get(self.search, self.search)
        if self.search == "opt" and (info["axioms"] or info["conditional_effects"]):
            template = _OPT_FALLBACK
        bound = f",bound={math.ceil(cost_bound)}" if cost_bound is not None else ""
        if "{bound}" not in template and bound:
            raise ValueError("a raw search string needs a {bound} slot to take a cost bound")
        return template.replace("{bound}", bound)

    def before(self, domain: Domain, problem: Problem) -> None:
        self.last_operators = None
        self.last_negated_rules = None
        self.last_split = None

    def refuse(self, domain: Domain, problem: Problem) -> str | None:
        refusal = super().refuse(domain, problem)
        if refusal:
            return refusal
        fractional = fractional_costs(domain, problem) if problem.metric is not None else []
        if fractional:
            return "Fast Downward needs integer costs (scale and round them first): " + ", ".join(
                fractional[:3]
            )
        return None

    def _expected_info(self, domain: Domain) -> dict:
        """What the translation will probably say about axioms and conditional effects (they
        choose ``opt``'s search), read from the task before it is translated."""
        from ..syntax import When, walk

        conditional = any(isinstance(n, When) for a in domain.actions for n in walk(a.effect))
        return {"axioms": bool(domain.axioms), "conditional_effects": conditional}

    def _check_translation(self, job: Job, status, info, log: str) -> None:
        if status == proc.TIMED_OUT:
            raise Stop(TIMEOUT, f"translator exceeded the time limit of {job.time_limit:g} s")
        if status != proc.OK:
            detail = log_tail(log, 3)
            raise Stop(
                ERROR,
                f"translator failed: {info}" + (f" ({detail})" if detail else ""),
                log_text(log),
            )

    def _translate_split(self, job: Job, info: dict, sas: str, log: str, invariants: bool):
        """The task translated again with its derived predicates' existentials split
        (:func:`~ssr_compile.compile.split_axioms.split_axioms`), when that changes the domain
        and leaves fewer negated rules; else the first translation's answer."""
        from ..compile.split_axioms import split_axioms
        from ..printer import to_text

        domain, problem = job.task
        split = split_axioms(domain, problem)
        if split.domain is domain:
            return proc.OK, info
        path = job.file("domain-split.pddl")
        Path(path).write_text(to_text(split.domain))
        first = job.file("output-unsplit.sas")
        os.replace(sas, first)
        status, again = _TRANSLATOR.call(
            (path, job.problem, sas, invariants),
            timeout=job.clock.remaining(),
            log_path=job.file("translate-split.log"),
        )
        self._check_translation(job, status, again, job.file("translate-split.log"))
        if again["negated_rules"] >= info["negated_rules"]:
            os.replace(first, sas)
            return proc.OK, info
        self.last_split = (info["negated_rules"], again["negated_rules"])
        return status, again

    def run(self, job: Job) -> list | None:
        """The translator in the forked worker, then the search binary on its SAS file.  The
        binary is started while the translator works, with the search string the task will
        most likely need, and fed the SAS file when it is written; when the translation
        calls for another search string, or fails, that process is killed unused."""
        sas, log = job.file("output.sas"), job.file("translate.log")
        plan_path, search_log = job.file("sas_plan"), job.file("search.log")
        invariants = self.invariants == "on" or (
            self.invariants == "auto" and not is_chained(job.task[0])
        )
        try:
            guess = self._search_option(self._expected_info(job.task[0]), job.cost_bound)
        except ValueError as e:
            raise Stop(ERROR, str(e)) from None
        started = None
        if self.prestart:
            started = proc.StartedCommand(
                self._command(guess, plan_path), cwd=job.dir, log_path=search_log
            )
        try:
            began = time.perf_counter()
            status, info = _TRANSLATOR.call(
                (job.domain, job.problem, sas, invariants),
                timeout=job.clock.remaining(),
                log_path=log,
            )
            self._check_translation(job, status, info, log)
            self.last_negated_rules = info["negated_rules"]
            if info["negated_rules"] > NEGATED_RULES:
                status, info = self._translate_split(job, info, sas, log, invariants)
            job.stages["translate"] = time.perf_counter() - began
            self.last_operators = info.get("operators")
            if info["unsolvable"]:
                raise Stop(UNSOLVABLE, f"translator: {info['unsolvable']}")
            search = self._search_option(info, job.cost_bound)
            began = time.perf_counter()
            try:
                if started is not None and search == guess:
                    code = started.finish(sas, job.clock.remaining())
                else:
                    if started is not None:
                        started.cancel()
                    code = proc.run_command(
                        self._command(search, plan_path),
                        job.clock.remaining(),
                        cwd=job.dir,
                        stdin_path=sas,
                        log_path=search_log,
                    )
            finally:
                job.stages["search"] = time.perf_counter() - began
        finally:
            if started is not None:
                started.cancel()
        if code is None or code in _TIMEOUT_CODES:
            raise Stop(TIMEOUT, f"search exceeded the time limit of {job.time_limit:g} s")
        if code in _UNSOLVABLE_CODES:
            why = _UNSOLVABLE_CODES[code]
            if job.cost_bound is not None and code != 11:
                why += f" (cost bound {job.cost_bound:g})"
            raise Stop(UNSOLVABLE, why)
        if code in _MEMORY_CODES:
            raise Stop(ERROR, "out of memory")
        plan_path = _last_plan(plan_path)
        if code != 0 or plan_path is None:
            why = f"search failed with exit code {code}: {log_tail(search_log)}"
            raise Stop(ERROR, why, log_text(search_log))
        return read_plan(plan_path)

    def _command(self, search: str, plan_path: str) -> list[str]:
        return [str(self.binary), "--search", search, "--internal-plan-file", plan_path]


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
