"""``ssr-compile compile``, ``plan`` and ``planners``: PDDLStream -> plain cost-PDDL -> planners."""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from .. import limits
from .. import syntax as S
from ..errors import PlannerFailure, SSRError
from ..files import check_output, write_files_atomically
from ..inputs import load_inputs
from ..json_output import document, dumps
from . import options
from .registry import register


def _add_inputs(p: argparse.ArgumentParser, problem_optional: bool, level_help: str) -> None:
    p.add_argument(
        "domain",
        metavar="DOMAIN",
        help="domain file, or an example folder or shipped example's name (e.g. kitchen) in "
        "place of DOMAIN STREAM PROBLEM (with --problem to choose among its problems)",
    )
    p.add_argument("stream", metavar="STREAM", nargs="?", help="stream file (PDDLStream)")
    p.add_argument("problem", metavar="PROBLEM", nargs="?", help="problem file")
    p.add_argument(
        "--problem",
        dest="problem_name",
        metavar="NAME",
        help="with an example: which of its problems (e.g. stow for problem-stow.pddl)",
    )
    p.add_argument("--level", type=options.level, default=3, metavar="N", help=level_help)
    p.set_defaults(problem_optional=problem_optional)


def resolve_inputs(args: argparse.Namespace) -> None:
    """DOMAIN STREAM [PROBLEM], or an example's name/folder (its files, and its problem chosen
    by --problem): set args.domain, args.stream, args.problem to file paths."""
    if args.stream is None:
        from ..examples import example_files, resolve_folder

        folder = resolve_folder(args.domain)
        if folder is None:
            raise SSRError(
                f"'{args.domain}' is neither an example folder nor a shipped example; expected "
                "DOMAIN STREAM" + (" [PROBLEM]" if args.problem_optional else " PROBLEM"),
                file=args.domain,
            )
        problems = example_files(folder)[2:]
        if args.problem_name:
            names = [
                args.problem_name,
                f"{args.problem_name}.pddl",
                f"problem-{args.problem_name}.pddl",
            ]
            chosen = next((folder / n for n in names if (folder / n).is_file()), None)
            if chosen is None:
                raise SSRError(
                    f"no problem '{args.problem_name}' in {folder} (its problems: "
                    f"{', '.join(_short(p) for p in problems)})",
                    file=str(folder),
                )
        elif len(problems) == 1:
            chosen = problems[0]
        elif args.problem_optional and not problems:
            chosen = None
        else:
            raise SSRError(
                f"{folder.name} has {len(problems)} problems; choose one with --problem "
                f"({', '.join(_short(p) for p in problems)})"
            )
        args.domain = str(folder / "domain.pddl")
        args.stream = str(folder / "stream.pddl")
        args.problem = str(chosen) if chosen else None
        return
    if args.problem_name:
        raise SSRError("--problem chooses among an example's problems; give it with a NAME only")
    if args.problem is None and not args.problem_optional:
        raise SSRError("expected DOMAIN STREAM PROBLEM, or an example's NAME [--problem P]")


def _short(path: Path) -> str:
    return path.stem.removeprefix("problem-") if path.stem != "problem" else "problem"


def attach_domain_file(e: SSRError, domain_path: str) -> SSRError:
    """Errors of the compiler passes point into the domain: name the file and show the line."""
    if e.file is None and e.line is not None:
        from ..parse import read_source

        e.file = domain_path
        try:
            e.source = read_source(domain_path)
        except SSRError:
            pass
    return e


def _caps_for(spec: str | None):
    from ..compile.capabilities import Capabilities

    if not spec:
        return Capabilities()
    from ..planners import get_planner

    return get_planner(spec).capabilities


# ---------------------------------------------------------------- compile


def _configure_compile(p: argparse.ArgumentParser) -> None:
    _add_inputs(
        p,
        problem_optional=True,
        level_help="optimistic instantiation depth: stream instances whose inputs need more "
        "than N chained instances are not made (default 3)",
    )
    p.add_argument(
        "-o",
        "--output",
        required=True,
        metavar="DIR",
        help="folder for domain.pddl, problem.pddl, actions.json (the map back to your "
        "actions: `ssr-compile map-plan`), objects.json",
    )
    p.add_argument(
        "--for",
        dest="backend",
        metavar="BACKEND",
        help="lower to what this planner supports (e.g. fd, pyperplan, up:fast-downward); "
        "default: keep everything (axioms, quantifiers, costs), which Fast Downward reads; "
        "unified-planning's PDDL reader needs --for up:... (it has no derived predicates)",
    )
    p.add_argument(
        "--task",
        choices=("auto", "lifted", "ground"),
        default="auto",
        help="auto (the default): for a planner that takes a ground task in `plan` (--for up:*, "
        "pyperplan), the lifted task where it reads it (no derived predicates, no "
        "quantifiers, few groundings), else the ground task; lifted, ground: always that one",
    )
    p.add_argument(
        "--unit-cost", action="store_true", help="drop action costs (every action costs 1)"
    )
    p.add_argument("--shorthand", action="store_true", help="write the paper's shorthand keywords")
    p.add_argument(
        "--split-axioms",
        action="store_true",
        help="write each derived predicate a condition reads false with its existential split "
        "at the object its fluent atom is about (what the fd backend does when Fast Downward's "
        "negated axioms would be many: a cluttered kitchen's 2.9 million rules -> 4,126; on "
        "small tasks it can add a few); a logical identity, plans unchanged",
    )


def run_compile(args: argparse.Namespace) -> int:
    resolve_inputs(args)
    try:
        return _run_compile(args)
    except SSRError as e:
        raise attach_domain_file(e, args.domain) from None


def _run_compile(args: argparse.Namespace) -> int:
    from ..artifact import actions_document
    from ..compile.lower import lower
    from ..compile.pipeline import declare_stream_predicates
    from ..compile.split_axioms import split_axioms
    from ..printer import to_text

    warnings: list[str] = []
    out = Path(args.output)
    names = ("domain.pddl", "problem.pddl", "objects.json") if args.problem else ("domain.pddl",)
    for name in names:
        check_output(out / name, "-o")  # before the work, not after it
    domain, streams, problem = load_inputs(args.domain, args.stream, args.problem, warnings)
    caps = _caps_for(args.backend)
    files: dict[str, str] = {}
    if problem is None:
        # Domain level: derived predicates and cost functions, no stream instances.
        dom = declare_stream_predicates(domain, streams)
        empty = S.Problem("domain-level", dom.name, init=(), goal=S.And(()))
        lowered = lower(
            dom,
            empty,
            caps,
            cost_functions={f.name for f in streams.functions},
            unit_cost=args.unit_cost,
        )
        dom = lowered.domain
        if args.split_axioms:
            dom = split_axioms(dom, None).domain
        files["domain.pddl"] = to_text(dom, shorthand=args.shorthand)
        note = "compiled the domain only (derived predicates, costs); give a PROBLEM to instantiate streams"
        summary = {"level": None, "scale": lowered.scale, "note": note}
    else:
        # Files for any planner: every optimistic object keeps its own name, so objects.json
        # maps each one in a plan back to its stream instance (no shared leaf objects).
        compiled, task = _compile_artifact(domain, streams, problem, caps, args)
        dom, prob = compiled.domain, compiled.problem
        if args.split_axioms:
            dom = split_axioms(dom, prob).domain
        files["domain.pddl"] = to_text(dom, shorthand=args.shorthand)
        files["problem.pddl"] = to_text(prob, shorthand=args.shorthand)
        inst = compiled.instantiation
        objects = {
            name: {"stream": r.instance.stream, "inputs": list(r.instance.inputs), "level": r.level}
            for name, r in sorted(inst.objects.items())
        }
        files["objects.json"] = json.dumps(
            {
                "level": args.level,
                "saturated": inst.saturated,
                "scale": compiled.scale,
                "objects": objects,
                "facts": {
                    str(f): [str(r.instance) for r in rs]
                    for f, rs in sorted(inst.facts.items(), key=lambda x: str(x[0]))
                },
            },
            indent=1,
        )
        source = {k: str(Path(getattr(args, k)).resolve()) for k in ("domain", "stream", "problem")}
        files["actions.json"] = actions_document(
            compiled, task=task, level=args.level, source=source
        )
        summary = {
            "task": task,
            "actions": len(compiled.domain.actions),
            "level": args.level,
            "scale": compiled.scale,
            "instances": len(inst.results),
            "optimistic objects": len(inst.objects),
        }
    # The outputs are one unit: all written, or (on any error) none of them.
    write_files_atomically({out / name: text for name, text in files.items()})
    for w in warnings:
        print(w, file=sys.stderr)
    print(f"wrote {', '.join(str(out / n) for n in files)}")
    print("; ".join(f"{k}: {v}" for k, v in summary.items() if v is not None))
    return 0


#: ``--task auto`` writes the lifted task for a ground-task target when its predicates have at
#: most this many groundings over the typed objects: unified-planning's PDDL writer (which its
#: engines use to call their planners) lists every grounding of every predicate.
LIFTED_GROUNDINGS = 200_000


def _compile_artifact(domain, streams, problem, caps, args):
    """Compile for ``compile``: ``(compiled, "lifted" | "ground")``.  Targets that take a
    ground task in ``plan`` (``up:*``, ``pyperplan``) get the lifted task where it is typed,
    quantifier-free and axiom-free and its groundings are few (``--task auto``): their readers
    read it, and it is orders of magnitude smaller than the ground task."""
    from dataclasses import replace

    from ..compile.pipeline import compile_problem
    from ..errors import UnsupportedError

    def run(c):
        # Every optimistic object keeps its own name, so objects.json maps each one in a plan
        # back to its stream instance (no shared leaf objects).
        return compile_problem(
            domain, streams, problem, caps=c, level=args.level, unit_cost=args.unit_cost,
            leaves=False,
        )  # fmt: skip

    ground = replace(caps, ground=True)
    if args.task == "ground":
        return run(ground), "ground"
    if not caps.ground or args.task == "lifted":
        return run(replace(caps, ground=False)), "lifted"
    if not _liftable(domain, problem):
        return run(ground), "ground"
    try:
        compiled = run(replace(caps, ground=False))
    except UnsupportedError:
        return run(ground), "ground"
    if _groundings(compiled.domain, compiled.problem) > LIFTED_GROUNDINGS:
        return run(ground), "ground"
    return compiled, "lifted"


def _liftable(domain: S.Domain, problem: S.Problem) -> bool:
    """No derived predicates and no quantifiers: the lifted lowering adds none."""
    from ..compile.formulas import has

    if domain.axioms:
        return False
    formulas = [problem.goal] + [f for a in domain.actions for f in (a.precondition, a.effect)]
    return not any(f is not None and has(f, S.Exists, S.Forall) for f in formulas)


def _groundings(domain: S.Domain, problem: S.Problem) -> int:
    """How many ground atoms the task's predicates have over its typed objects."""
    from math import prod

    from ..compile.quantifiers import objects_by_type

    of = objects_by_type(domain, problem)
    return sum(prod(len(of(p.type)) for p in d.params) for d in domain.predicates)


# ---------------------------------------------------------------- plan


def _configure_plan(p: argparse.ArgumentParser) -> None:
    _add_inputs(
        p,
        problem_optional=False,
        level_help="first optimistic instantiation depth (default 3); when there is no plan, "
        "the level is raised (as solve does) up to --max-level",
    )
    p.add_argument(
        "--max-level",
        type=options.level,
        metavar="N",
        help="the last level tried (default 8, or --level when it is higher)",
    )
    p.add_argument(
        "--planner",
        default=DEFAULT_PLANNER,
        metavar="NAME",
        help=f"planner backend (default {DEFAULT_PLANNER}; see `ssr-compile planners`)",
    )
    p.add_argument(
        "--time-limit",
        type=options.seconds,
        default=60.0,
        metavar="S",
        help="time limit in seconds for the whole command: reading, compiling, planning "
        "(default 60)",
    )
    p.add_argument("--unit-cost", action="store_true", help="ignore action costs")
    p.add_argument(
        "--json",
        action="store_true",
        help="print the result as JSON (schema: README, ssr_compile/json_output.py)",
    )


#: the planner of `plan` (README, "Default planners": chosen by bench/planner_choice_bench.py)
DEFAULT_PLANNER = "fd:opt"
LEVEL_LIMIT = "level_limit"  # no plan up to the last level, and instances were cut off


def run_plan(args: argparse.Namespace) -> int:
    resolve_inputs(args)
    top = args.max_level if args.max_level is not None else max(8, args.level)
    if top < args.level:
        raise SSRError(f"--max-level {top} is below --level {args.level}")
    args.max_level = top
    try:
        return _run_plan(args)
    except SSRError as e:
        raise attach_domain_file(e, args.domain) from None


def _run_plan(args: argparse.Namespace) -> int:
    from ..compile.pipeline import compile_problem
    from ..errors import TimeLimitReached
    from ..planners import get_planner
    from ..planners.base import TIMEOUT, UNSOLVABLE, PlanResult
    from ..solver.preimage import plan_preimage, stream_plan

    warnings: list[str] = []
    start = time.monotonic()
    phase = "reading the files"
    level = args.level
    compiled = None
    # The limit bounds the whole command; the planner gets what is left of it and stops on its
    # own, the alarm (a little later) stops reading and compiling.
    try:
        with limits.time_limit(args.time_limit + _GRACE):
            domain, streams, problem = load_inputs(args.domain, args.stream, args.problem, warnings)
            backend = get_planner(args.planner)
            while True:
                phase = "compiling"
                compiled = compile_problem(
                    domain,
                    streams,
                    problem,
                    caps=backend.capabilities,
                    level=level,
                    unit_cost=args.unit_cost,
                )
                phase = "planning"
                left = args.time_limit - (time.monotonic() - start)
                if left <= 0:
                    raise TimeLimitReached(args.time_limit)
                result = backend.solve(compiled.domain, compiled.problem, time_limit=left)
                if result.status != UNSOLVABLE or compiled.instantiation.saturated:
                    break  # solved, out of time, failed, or no plan with every instance made
                if level >= args.max_level:
                    result.status = LEVEL_LIMIT
                    result.message = (
                        f"no optimistic plan up to level {level}, where stream instances were "
                        f"cut off ({result.message}); try --max-level {level + 2}"
                    )
                    break
                level += 1
    except TimeLimitReached:
        for w in warnings:
            print(w, file=sys.stderr)
        message = f"time limit of {args.time_limit:g} s reached while {phase}"
        result = PlanResult(TIMEOUT, None, None, time.monotonic() - start, args.planner, message)
    else:
        for w in warnings:
            print(w, file=sys.stderr)
        if result.status == "error":
            raise PlannerFailure(args.planner, result.message, detail=result.detail or "")
        if result.status == UNSOLVABLE:
            result.message = (
                f"no optimistic plan at any level: every stream instance was made by level "
                f"{level} ({result.message})"
            )
    report: dict = {
        "problem": str(args.problem),
        "status": result.status,
        "planner": args.planner,
        "time": round(time.monotonic() - start, 4),
        "level": level,
        "message": None if result.solved else result.message,
        "cost": None,
        "scale": compiled.scale if compiled is not None else None,
        "plan": [],
        "stream_plan": [],
    }
    if result.solved:
        plan = compiled.map_plan(result.actions or [])
        pre = plan_preimage(compiled.source_domain, compiled.source_problem, plan)
        needed = stream_plan(compiled.instantiation, pre, plan)
        report.update(
            plan=[{"action": n, "args": list(a)} for n, a in plan],
            cost=(result.cost or 0) / compiled.scale,
            stream_plan=[
                {
                    "stream": r.instance.stream,
                    "inputs": list(r.instance.inputs),
                    "outputs": list(r.outputs),
                }
                for r in needed
            ],
        )
    if args.json:
        print(dumps(document("plan", results=[report])))
    elif result.solved:
        print(
            f"optimistic plan ({len(report['plan'])} actions, cost {report['cost']:g}, planner "
            f"{args.planner}, level {level}, {report['time']:.3f} s):"
        )
        for i, step in enumerate(report["plan"], 1):
            print(f"  {i:2d}. ({' '.join([step['action'], *step['args']])})")
        print(f"stream instances it relies on ({len(report['stream_plan'])}):")
        for r in report["stream_plan"]:
            outs = f" -> {', '.join(r['outputs'])}" if r["outputs"] else ""
            print(f"  {r['stream']}({', '.join(r['inputs'])}){outs}")
    else:
        print(f"no plan ({result.status}) at level {level}: {result.message}")
    return 0 if result.solved else 1


# A backend stops itself at its limit (within about a second); the alarm that bounds reading
# and compiling fires this much later, so that it does not cut a backend's own answer short.
_GRACE = 1.0


# ---------------------------------------------------------------- planners


def _configure_planners(p: argparse.ArgumentParser) -> None:
    p.add_argument("--json", action="store_true", help="print as JSON")


def run_planners(args: argparse.Namespace) -> int:
    from ..planners import describe_planners

    rows = describe_planners()
    if args.json:
        print(dumps(document("planners", planners=rows)))
        return 0
    features = [
        "costs",
        "axioms",
        "negative_preconditions",
        "disjunction",
        "quantifiers",
        "conditional_effects",
        "optimal",
    ]
    short = ["costs", "axioms", "neg", "or", "quant", "cond-eff", "optimal"]
    width = max((len(r.get("name", "")) for r in rows), default=4) + 2
    print("planner".ljust(width) + " ".join(s.ljust(8) for s in short) + " notes")
    for r in rows:
        caps = r.get("capabilities") or {}
        marks = " ".join(("yes" if caps.get(f) else "-").ljust(8) for f in features)
        note = r.get("description") or r.get("error") or ""
        print(r.get("name", "?").ljust(width) + marks + " " + note)
    return 0


register(
    "compile",
    "compile DOMAIN STREAM [PROBLEM] to plain cost-PDDL (also the bare form: ssr-compile DOMAIN STREAM PROBLEM -o DIR)",
    _configure_compile,
    run_compile,
)
register(
    "plan",
    "compile and plan optimistically; print the plan and the stream instances it relies on",
    _configure_plan,
    run_plan,
)
register(
    "planners",
    "list the installed planner backends and what each supports",
    _configure_planners,
    run_planners,
)
