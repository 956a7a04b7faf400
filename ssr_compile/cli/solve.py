"""``ssr-compile solve``: the Focused algorithm on a PDDLStream problem or an example folder."""

from __future__ import annotations

import argparse
import math
import re
import sys
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from .. import limits
from ..errors import SSRError, TimeLimitReached
from ..examples import ExampleSettings, read_settings, resolve_folder
from ..inputs import load_inputs
from ..json_output import document, dumps, to_json
from . import options
from .registry import register

_DEFAULTS_NOTE = (
    "With an example FOLDER, the settings in its example.toml (planner, time_limit, level, "
    "max_level, max_cost, defer, algorithm, resample) apply first, in place of the defaults below; an option given "
    "on the command line always wins.  -v prints the settings in force and where each came "
    "from (flag, example.toml, default)."
)


def _configure(p: argparse.ArgumentParser) -> None:
    p.description = (
        "Solve a PDDLStream problem with the Focused algorithm and Python streams.  "
        + _DEFAULTS_NOTE
    )
    p.add_argument(
        "inputs",
        nargs="+",
        metavar="INPUT",
        help="DOMAIN STREAM PROBLEM, or an example FOLDER holding domain.pddl, stream.pddl, its "
        "problems and example.toml (a shipped example may be named, e.g. tamp2d)",
    )
    p.add_argument(
        "--streams",
        metavar="MODULE",
        help="streams module: import path (ssr_compile.streams.tamp2d) or .py file",
    )
    p.add_argument(
        "--problem",
        metavar="NAME",
        help="with FOLDER: which problem file (default: all in example.toml)",
    )
    p.add_argument(
        "--planner",
        metavar="NAME",
        help=f"planner backend (default {DEFAULTS['planner']}, or example.toml's; see "
        "`ssr-compile planners`)",
    )
    p.add_argument(
        "--time-limit",
        type=options.seconds,
        metavar="S",
        help="time limit in seconds for each problem (default 60, or example.toml's)",
    )
    p.add_argument(
        "--max-cost",
        type=options.cost_bound,
        metavar="C",
        help="only accept plans cheaper than C, in the problem's cost units (the paper's c*; "
        "default: no bound)",
    )
    p.add_argument(
        "--level",
        type=options.level,
        metavar="N",
        help="first instantiation level (default 1, or example.toml's)",
    )
    p.add_argument(
        "--max-level",
        type=options.level,
        metavar="N",
        help="give up above this level (default 8, or example.toml's)",
    )
    p.add_argument(
        "--defer",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="defer deferrable streams not needed by the first action (paper §VII; default "
        "off, or example.toml's); --no-defer turns it off",
    )
    p.add_argument(
        "--algorithm",
        type=_check_algorithm,
        metavar="NAME",
        help="focused (default: evaluate each plan's streams once, then plan again) or adaptive "
        "(keep a queue of plan skeletons and sample their streams between planner calls; "
        "deterministic per seed); or example.toml's",
    )
    p.add_argument(
        "--resample",
        type=_check_resample,
        metavar="N",
        help="a generator whose draw was rejected by a test of the stream plan draws again at "
        "once, up to N times per other draw of the plan the test checks it against (a "
        "placement among six others: 6N; N more for each stream plan the tests rejected "
        "before), and one whose draw failed once, before the planner is called again "
        "(default 2; 0: off); or example.toml's",
    )
    p.add_argument(
        "--seed",
        type=options.seed,
        metavar="N",
        help="seed for the streams module's random numbers (default 0)",
    )
    p.add_argument(
        "--json",
        action="store_true",
        help="print the result as JSON (schema: README, ssr_compile/json_output.py)",
    )
    p.add_argument(
        "--full",
        action="store_true",
        help="with --json: every value in full (default: long paths summarised)",
    )
    p.add_argument(
        "-v",
        "--verbose",
        action="store_true",
        help="print the settings in force and progress: iterations, levels, stream plans",
    )
    p.epilog = _DEFAULTS_NOTE


# The settings of a solve: default value and flag (example.toml's values are checked as it is
# read: examples.check_table).  Every one of them can be given on the command line,
# example.toml, or neither.
DEFAULTS = {
    "planner": "fd",
    "time_limit": 60.0,
    "level": 1,
    "max_level": 8,
    "max_cost": math.inf,
    "defer": False,
    "algorithm": "focused",
    "resample": 2,  # solver.RESAMPLE (not imported here: the solver loads in ~0.4 s)
    "seed": 0,
}
_FLAGS = {
    "planner": "--planner",
    "time_limit": "--time-limit",
    "level": "--level",
    "max_level": "--max-level",
    "max_cost": "--max-cost",
    "defer": "--defer/--no-defer",
    "algorithm": "--algorithm",
    "resample": "--resample",
    "seed": "--seed",
}


def _check_algorithm(text: str) -> str:
    from ..solver import ALGORITHMS

    if text not in ALGORITHMS:
        raise argparse.ArgumentTypeError(f"expected one of {', '.join(ALGORITHMS)}, got '{text}'")
    return text


def _check_resample(text: str) -> int:
    return options.count(text, 0, what="a number of draws")


def resolve_settings(
    args: argparse.Namespace, example: ExampleSettings | Mapping[str, Any]
) -> dict[str, tuple[Any, str]]:
    """{name: (value, source)}: each setting from its flag, else example.toml, else the default
    (:meth:`ExampleSettings.resolve`, the resolution ``run`` shares).

    ``example``: the example's settings (a table as example.toml holds it is read, and
    checked, as one)."""
    if not isinstance(example, ExampleSettings):
        example = ExampleSettings.from_table(example)
    flags = {name: getattr(args, name, None) for name in DEFAULTS}
    return example.resolve(flags, DEFAULTS, _FLAGS)


def _format_setting(name: str, value) -> str:
    if name == "time_limit":
        return f"{value:g} s"
    if name == "max_cost":
        return "none" if math.isinf(value) else f"{value:g}"
    if name == "defer":
        return "on" if value else "off"
    return str(value)


def describe_settings(settings: dict) -> str:
    """One line per setting: its value and where it came from."""
    width = max(len(n) for n in settings)
    return "\n".join(
        f"  {name.replace('_', ' ').ljust(width)}  {_format_setting(name, v)}  ({src})"
        for name, (v, src) in settings.items()
    )


def jobs_from_args(args) -> tuple[list[tuple[Path, Path, Path]], ExampleSettings]:
    """(domain, stream, problem) triples to solve, and the folder's settings (none without
    a folder)."""
    if len(args.inputs) == 1:
        folder = resolve_folder(args.inputs[0])
        if folder is None:
            raise SSRError(
                f"'{args.inputs[0]}' is neither a folder nor a shipped example", file=args.inputs[0]
            )
        example = read_settings(folder)
        if args.problem:
            candidates = [
                folder / args.problem,
                folder / f"{args.problem}.pddl",
                folder / f"problem-{args.problem}.pddl",
            ]
            problem = next((c for c in candidates if c.exists()), None)
            if problem is None:
                raise SSRError(f"no problem '{args.problem}' in {folder}", file=str(folder))
            problems = [problem]
        elif example.problems is not None:
            problems = [folder / p for p in example.problems]
        else:
            problems = sorted(p for p in folder.glob("problem*.pddl"))
        if not problems:
            raise SSRError(f"no problem files in {folder}", file=str(folder))
        return [(folder / "domain.pddl", folder / "stream.pddl", p) for p in problems], example
    if len(args.inputs) != 3:
        raise SSRError("expected DOMAIN STREAM PROBLEM, or a single example FOLDER")
    if not args.streams:
        raise SSRError(
            "--streams MODULE is required with DOMAIN STREAM PROBLEM (it implements the streams)"
        )
    domain, stream, problem = (Path(x) for x in args.inputs)
    return [(domain, stream, problem)], ExampleSettings()


def run(args: argparse.Namespace) -> int:
    from ..solver import SolveOptions, print_solution, solve

    if args.full and not args.json:
        raise SSRError("--full goes with --json (it prints every value in full)")
    jobs, example = jobs_from_args(args)
    if not (args.streams or example.streams):
        raise SSRError('example.toml does not name a streams module (streams = "...")')
    settings = resolve_settings(args, example)
    if args.verbose:
        print("settings in force:", file=sys.stderr)
        print(describe_settings(settings), file=sys.stderr)
    planner, time_limit, level, max_level, max_cost, defer, seed, algorithm, resample = (
        settings[n][0]
        for n in (
            "planner",
            "time_limit",
            "level",
            "max_level",
            "max_cost",
            "defer",
            "seed",
            "algorithm",
            "resample",
        )
    )
    results = []
    status = 0
    for domain_path, stream_path, problem_path in jobs:
        warnings: list[str] = []
        start = time.monotonic()
        # The limit covers the whole problem: reading, the streams module, solving.  The solver
        # stops itself at its deadline; the alarm (a little later) stops whatever it is stuck
        # in, such as a stream that never returns.
        try:
            with limits.time_limit(time_limit + _GRACE):
                domain, streams, problem = load_inputs(
                    str(domain_path), str(stream_path), str(problem_path), warnings
                )
                module = example.streams_module(problem_path, seed, args.streams)
                module.check_against(streams, str(stream_path))
                progress = (lambda msg: print(msg, file=sys.stderr)) if args.verbose else None
                for w in warnings if args.verbose else ():
                    print(w, file=sys.stderr)
                left = time_limit - (time.monotonic() - start)
                if left <= 0:
                    raise TimeLimitReached(time_limit)
                options = SolveOptions(
                    planner=planner,
                    time_limit=left,
                    max_cost=max_cost,
                    defer=defer,
                    initial_level=level,
                    max_level=max_level,
                    progress=progress,
                    algorithm=algorithm,
                    resample=resample,
                )
                solution = solve(domain, streams, problem, module, options)
        except TimeLimitReached as e:
            status = 1
            message = f"time limit of {time_limit:g} s reached" + _where(e)
            if args.json:
                results.append(_timeout_json(problem_path, message, time.monotonic() - start))
            else:
                if len(jobs) > 1:
                    print(f"== {problem_path}")
                print(f"no plan: {message}")
            continue
        if not solution.solved:
            status = 1
            if not args.verbose:  # the likely cause, said even without -v
                for w in warnings:
                    if "can never fire" in w:
                        print(w, file=sys.stderr)
        if solution.message and not math.isinf(max_cost):
            solution.message = in_user_units(solution.message, max_cost)
        if args.json:
            results.append(_as_json(problem_path, solution, args.full))
        else:
            if len(jobs) > 1:
                print(f"== {problem_path}")
            print_solution(solution, out=sys.stdout)
    if args.json:
        shown = {n: {"value": to_json(v), "source": src} for n, (v, src) in settings.items()}
        print(dumps(document("solve", settings=shown, results=results)))
    return status


def in_user_units(message: str, max_cost: float) -> str:
    """The planner states the cost bound it was given in the compiler's integer units (costs
    scaled by 10^k): say the user's --max-cost instead."""
    return re.sub(r"cost bound -?[0-9][0-9.e+]*", f"cost bound {max_cost:g}", message)


# The solver stops itself at its deadline; the alarm that stops a stuck stream (or reading,
# or the streams module) fires this much later, so that it does not cut the solver short.
_GRACE = 1.0


def _where(e: BaseException) -> str:
    """Which stream was running when the time limit passed, as a phrase for the message."""
    from ..limits import overrunning_stream

    name = overrunning_stream(e)
    return f" while stream '{name}' was running (it overran the limit)" if name else ""


def _timeout_json(path, message: str, elapsed: float) -> dict:
    return {
        "problem": str(path),
        "status": "timeout",
        "message": message,
        "cost": None,
        "plan": [],
        "certificate": [],
        "stats": {"total_time": round(elapsed, 4)},
    }


def _as_json(path, solution, full: bool = False) -> dict:
    return {
        "problem": str(path),
        "status": solution.status,
        "message": solution.message,
        "cost": solution.cost,
        "plan": [
            {
                "action": s.name,
                "args": list(s.args),
                "values": [to_json(v, full) for v in s.values],
                "deferred": list(s.deferred),
            }
            for s in solution.plan or []
        ],
        "certificate": [str(f) for f in solution.certificate],
        "stats": solution.stats.as_dict(),
    }


register(
    "solve",
    "solve a PDDLStream problem with the Focused algorithm and Python streams",
    _configure,
    run,
)
