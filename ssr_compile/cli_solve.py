"""``ssr-compile solve``: the Focused algorithm on a PDDLStream problem or an example folder."""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

from .cli import register
from .errors import SSRError

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
        type=float,
        metavar="S",
        help="time limit in seconds for each problem (default 60)",
    )
    p.add_argument(
        "--max-cost",
        type=float,
        metavar="C",
        help="only accept plans cheaper than C (the paper's c*)",
    )
    p.add_argument("--level", type=int, metavar="N", help="first instantiation level (default 1)")
    p.add_argument(
        "--max-level", type=int, metavar="N", help="give up above this level (default 8)"
    )
    p.add_argument(
        "--defer",
        action="store_true",
        help="defer deferrable streams not needed by the first action (paper §VII)",
    )
    p.add_argument(
        "--seed",
        type=int,
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
    time_limit = args.time_limit or float(config.get("time_limit", 60.0))
    defer = args.defer or bool(config.get("defer", False))
    level = args.level if args.level is not None else int(config.get("level", 1))
    max_level = args.max_level if args.max_level is not None else int(config.get("max_level", 8))
    max_cost = args.max_cost if args.max_cost is not None else math.inf
    results = []
    status = 0
    for domain_path, stream_path, problem_path in jobs:
        warnings: list[str] = []
        ns = argparse.Namespace(
            domain=str(domain_path), stream=str(stream_path), problem=str(problem_path)
        )
        domain, streams, problem = load_inputs(ns, warnings)
        module = module_for_problem(module_spec, problem_path, args.seed)
        module.check_against(streams, str(stream_path))
        progress = (lambda msg: print(msg, file=sys.stderr)) if args.verbose else None
        for w in warnings if args.verbose else ():
            print(w, file=sys.stderr)
        solution = solve(
            domain,
            streams,
            problem,
            module,
            planner=planner,
            time_limit=time_limit,
            max_cost=max_cost,
            defer=defer,
            initial_level=level,
            max_level=max_level,
            progress=progress,
        )
        if not solution.solved:
            status = 1
        if args.json:
            results.append(_as_json(problem_path, solution))
        else:
            if len(jobs) > 1:
                print(f"== {problem_path}")
            print_solution(solution)
    if args.json:
        print(json.dumps(results if len(results) > 1 else results[0], indent=1, default=str))
    return status


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
                "values": [repr(v) for v in s.values],
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
