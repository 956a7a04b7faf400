"""``ssr-compile solve``: the Focused algorithm on a PDDLStream problem or an example folder."""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

from . import cli
from .cli import register
from .errors import SSRError, TimeLimitReached

try:  # Python 3.11+
    import tomllib
except ModuleNotFoundError:  # pragma: no cover - Python 3.10
    import tomli as tomllib  # type: ignore[no-redef]


def _configure(p: argparse.ArgumentParser) -> None:
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
        "--planner", metavar="NAME", help="planner backend (default fd; see `ssr-compile planners`)"
    )
    p.add_argument(
        "--time-limit",
        type=cli.seconds,
        metavar="S",
        help="time limit in seconds for each problem (default 60)",
    )
    p.add_argument(
        "--max-cost",
        type=cli.cost_bound,
        metavar="C",
        help="only accept plans cheaper than C (the paper's c*)",
    )
    p.add_argument(
        "--level", type=cli.level, metavar="N", help="first instantiation level (default 1)"
    )
    p.add_argument(
        "--max-level", type=cli.level, metavar="N", help="give up above this level (default 8)"
    )
    p.add_argument(
        "--defer",
        action="store_true",
        help="defer deferrable streams not needed by the first action (paper §VII)",
    )
    p.add_argument(
        "--seed",
        type=cli.seed,
        default=0,
        metavar="N",
        help="seed for the streams module's random numbers (default 0)",
    )
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.add_argument(
        "-v",
        "--verbose",
        action="store_true",
        help="print progress: iterations, levels, stream plans",
    )


def _folder_config(folder: Path) -> dict:
    config_file = folder / "example.toml"
    if not config_file.exists():
        raise SSRError(
            f'no example.toml in {folder} (it names the streams module: streams = "ssr_compile.streams.x")',
            file=str(folder),
        )
    try:
        return tomllib.loads(config_file.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as e:
        raise SSRError(f"not valid TOML: {e}", file=str(config_file)) from None


def resolve_folder(name: str) -> Path | None:
    path = Path(name)
    if path.is_dir():
        return path
    from .resources import domains_dir

    shipped = domains_dir() / name
    return shipped if shipped.is_dir() else None


def jobs_from_args(args) -> tuple[list[tuple[Path, Path, Path]], dict]:
    """(domain, stream, problem) triples to solve, and the folder's settings."""
    if len(args.inputs) == 1:
        folder = resolve_folder(args.inputs[0])
        if folder is None:
            raise SSRError(
                f"'{args.inputs[0]}' is neither a folder nor a shipped example", file=args.inputs[0]
            )
        config = _folder_config(folder)
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
        elif "problems" in config:
            problems = [folder / p for p in config["problems"]]
        else:
            problems = sorted(p for p in folder.glob("problem*.pddl"))
        if not problems:
            raise SSRError(f"no problem files in {folder}", file=str(folder))
        return [(folder / "domain.pddl", folder / "stream.pddl", p) for p in problems], config
    if len(args.inputs) != 3:
        raise SSRError("expected DOMAIN STREAM PROBLEM, or a single example FOLDER")
    if not args.streams:
        raise SSRError(
            "--streams MODULE is required with DOMAIN STREAM PROBLEM (it implements the streams)"
        )
    domain, stream, problem = (Path(x) for x in args.inputs)
    return [(domain, stream, problem)], {}


def run(args: argparse.Namespace) -> int:
    from .cli_compile import load_inputs
    from .focused import print_solution, solve
    from .stream import module_for_problem

    jobs, config = jobs_from_args(args)
    module_spec = args.streams or config.get("streams")
    if not module_spec:
        raise SSRError('example.toml does not name a streams module (streams = "...")')
    planner = args.planner or config.get("planner", "fd")

    def setting(name, default, check):
        value = getattr(args, name)
        if value is not None:
            return value
        if name not in config:
            return default
        try:  # example.toml's numbers pass the same validation as the options
            return check(str(config[name]))
        except argparse.ArgumentTypeError as e:
            raise SSRError(f"{name} = {config[name]!r}: {e}", file="example.toml") from None

    time_limit = setting("time_limit", 60.0, cli.seconds)
    defer = args.defer or bool(config.get("defer", False))
    level = setting("level", 1, cli.level)
    max_level = setting("max_level", 8, cli.level)
    max_cost = args.max_cost if args.max_cost is not None else math.inf
    results = []
    status = 0
    for domain_path, stream_path, problem_path in jobs:
        warnings: list[str] = []
        ns = argparse.Namespace(
            domain=str(domain_path), stream=str(stream_path), problem=str(problem_path)
        )
        start = time.monotonic()
        # The limit covers the whole problem: reading, the streams module, solving.  The solver
        # stops itself at its deadline; the alarm (a little later) stops whatever it is stuck
        # in, such as a stream that never returns.
        try:
            with cli.time_limit(time_limit + _GRACE):
                domain, streams, problem = load_inputs(ns, warnings)
                module = module_for_problem(module_spec, problem_path, args.seed)
                module.check_against(streams, str(stream_path))
                progress = (lambda msg: print(msg, file=sys.stderr)) if args.verbose else None
                for w in warnings if args.verbose else ():
                    print(w, file=sys.stderr)
                left = time_limit - (time.monotonic() - start)
                if left <= 0:
                    raise TimeLimitReached(time_limit)
                solution = solve(
                    domain,
                    streams,
                    problem,
                    module,
                    planner=planner,
                    time_limit=left,
                    max_cost=max_cost,
                    defer=defer,
                    initial_level=level,
                    max_level=max_level,
                    progress=progress,
                )
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
        if args.json:
            results.append(_as_json(problem_path, solution))
        else:
            if len(jobs) > 1:
                print(f"== {problem_path}")
            print_solution(solution, out=sys.stdout)
    if args.json:
        print(json.dumps(results if len(results) > 1 else results[0], indent=1, default=str))
    return status


# The solver stops itself at its deadline; the alarm that stops a stuck stream (or reading,
# or the streams module) fires this much later, so that it does not cut the solver short.
_GRACE = 1.0


def _where(e: BaseException) -> str:
    """Which stream was running when the time limit passed (from the traceback), if any."""
    from . import stream as stream_module

    name = None
    tb = e.__traceback__
    while tb is not None:
        frame = tb.tb_frame
        if frame.f_code.co_filename == stream_module.__file__:
            local = frame.f_locals
            found = local.get("name")
            if found is None and isinstance(local.get("self"), stream_module.Generator):
                found = local["self"].name
            if isinstance(found, str):
                name = found
        tb = tb.tb_next
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


def to_json(value):
    """A stream value as JSON: numbers as numbers, None as null, numpy arrays and tuples as
    lists, mappings as objects; anything else as its repr."""
    if value is None or isinstance(value, (bool, int, str)):
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else repr(value)
    kind = type(value)
    if kind.__module__ == "numpy":
        if hasattr(value, "tolist"):  # arrays and numpy scalars
            return to_json(value.tolist())
    if isinstance(value, (list, tuple)):
        return [to_json(v) for v in value]
    if isinstance(value, dict):
        return {str(k): to_json(v) for k, v in value.items()}
    return repr(value)


def _as_json(path, solution) -> dict:
    return {
        "problem": str(path),
        "status": solution.status,
        "message": solution.message,
        "cost": solution.cost,
        "plan": [
            {
                "action": s.name,
                "args": list(s.args),
                "values": [to_json(v) for v in s.values],
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
