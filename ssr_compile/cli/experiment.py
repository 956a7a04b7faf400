"""``ssr-compile experiment`` and ``ssr-compile report``: Table I of the paper (§VIII)."""

from __future__ import annotations

import argparse
import math
import shlex
import sys

from ..errors import SSRError
from . import options
from .registry import register


def _seconds(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number of seconds, got '{text}'") from None
    if not (value > 0 and math.isfinite(value)):
        raise argparse.ArgumentTypeError(
            f"expected a finite number of seconds greater than 0, got '{text}'"
        )
    return value


def _whole(least: int):
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a whole number, got '{text}'") from None
        if value < least:
            raise argparse.ArgumentTypeError(f"expected a whole number >= {least}, got '{text}'")
        return value

    return parse


def _configure_experiment(p: argparse.ArgumentParser) -> None:
    from ..experiment import KITCHEN_TASKS, VARIANTS

    p.description = (
        "Run Table I of the paper (§VIII): the online policy on every task × variant × seed, "
        "each episode in a process of its own (a crash, a hang past its wall limit or running "
        "out of memory is recorded as a failure).  DIR/episodes.jsonl gets one line per "
        "episode as it finishes; running the same command again resumes.  DIR/table.md and "
        "DIR/table1.png compare the outcome with the paper's numbers.  Exit 0 when the sweep "
        "ran (whatever its success rate), 2 on bad input."
    )
    p.add_argument(
        "--tasks",
        metavar="T1,T2",
        help=f"tasks (rows): kitchen tasks ({','.join(KITCHEN_TASKS)}; the default once the "
        "kitchen has a closed-loop environment), shipped examples with an environment "
        "(progress, belief-detect[:occluded|clear]), example folders ([FOLDER][:PROBLEM]) "
        "or kitchen task files (FILE.toml)",
    )
    p.add_argument(
        "--variants",
        default=",".join(VARIANTS),
        metavar="V1,V2",
        help=f"variants (columns) among {','.join(VARIANTS)} (default all four)",
    )
    p.add_argument(
        "--seeds", default="0-24", metavar="SEEDS", help="e.g. 0-24 (default) or 0,3,5 or 0-4,10"
    )
    p.add_argument(
        "--budget",
        type=_seconds,
        default=600.0,
        metavar="S",
        help="planning time per episode in seconds (default 600, the paper's 10 minutes)",
    )
    p.add_argument(
        "--max-cycles",
        type=_whole(1),
        default=100,
        metavar="N",
        help="at most N cycles (default 100)",
    )
    p.add_argument(
        "--constrained-time",
        type=_seconds,
        default=30.0,
        metavar="S",
        help="limit of each constrained planning attempt (default 30)",
    )
    p.add_argument(
        "--unconstrained-time",
        type=_seconds,
        default=300.0,
        metavar="S",
        help="limit of each unconstrained planning attempt (default 300)",
    )
    p.add_argument("--planner", default="fd", metavar="NAME", help="planner backend (default fd)")
    p.add_argument(
        "--wall-limit",
        type=_seconds,
        metavar="S",
        help="kill an episode's process after S seconds of wall time (default 2 × budget + 120)",
    )
    p.add_argument(
        "--memory-limit",
        type=_whole(0),
        default=4096,
        metavar="MB",
        help="address-space limit of an episode's process in MiB (default 4096; 0: none)",
    )
    p.add_argument(
        "--workers",
        type=_whole(1),
        metavar="N",
        help="episodes at a time (default 1; with --ray-address: the cluster's CPUs)",
    )
    p.add_argument(
        "--executor",
        choices=("process", "ray"),
        default="process",
        help='local processes (default) or Ray tasks (pip install "ssr-compile[ray]")',
    )
    p.add_argument(
        "--ray-address",
        metavar="ADDR",
        help="the Ray cluster to run on (e.g. ray://head:10001 or auto); implies --executor ray",
    )
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("-o", "--output", required=True, metavar="DIR", help="the sweep's folder")


def run_experiment(args: argparse.Namespace) -> int:
    from .. import experiment as X
    from ..planners import get_planner

    if args.tasks is None:
        if not X.kitchen_has_environment():
            raise SSRError(
                "--tasks: the kitchen has no closed-loop environment yet (no 'environment' in "
                "its example.toml), so Table I's tasks cannot run; name tasks, e.g. "
                "--tasks progress,belief-detect"
            )
        args.tasks = ",".join(X.KITCHEN_TASKS)
    X.check_report_outputs(args.output)  # the folder can be written, before any episode
    variants = X.parse_variants(args.variants)
    seeds = options.seed_list(args.seeds)
    tasks = X.parse_tasks(args.tasks)
    for task in tasks:
        if task.problem is not None and task.problem.endswith(".toml"):
            from ssr_compile.sim.task_file import load_task_file

            load_task_file(task.problem)  # a bad kitchen task file: bad input, before any episode
    get_planner(args.planner)  # bad input before anything runs
    executor_name = "ray" if args.ray_address else args.executor
    from ssr_compile.policy import PolicySettings

    policy = PolicySettings(
        budget=args.budget,
        max_cycles=args.max_cycles,
        constrained_time=args.constrained_time,
        unconstrained_time=args.unconstrained_time,
        planner=args.planner,
    )
    settings = X.Settings(policy, wall_limit=args.wall_limit, memory_mb=args.memory_limit)
    if executor_name == "ray":
        try:
            import ray  # noqa: F401
        except ImportError:
            raise SSRError('--executor ray needs Ray: pip install "ssr-compile[ray]"') from None
        executor = X.RayExecutor(args.workers, args.ray_address)
    else:
        executor = X.ProcessExecutor(args.workers or 1)
    specs = X.episode_specs(tasks, variants, seeds, settings)
    print(
        f"sweep: {len(tasks)} task(s) × {len(variants)} variant(s) × {len(seeds)} seed(s) = "
        f"{len(specs)} episodes, planning budget {policy.budget:g} s each, wall limit "
        f"{settings.wall:g} s, executor {executor_name}"
        + (f" ({args.workers} workers)" if args.workers else ""),
        file=sys.stderr,
        flush=True,
    )
    outcome = X.run_sweep(args.output, specs, executor, progress=not args.no_progress)
    command = "ssr-compile experiment " + " ".join(
        shlex.quote(a) for a in _command_args(args, tasks, variants)
    )
    table, plot, text = X.write_report(args.output, command)
    print(text)
    print(
        f"ran {outcome.ran} episode(s) ({outcome.successes} successes), {outcome.skipped} already "
        f"on file; wrote {table} and {plot}",
        file=sys.stderr,
    )
    return 0


def _command_args(args, tasks, variants) -> list[str]:
    out = [
        "--tasks",
        ",".join(t.label for t in tasks),
        "--variants",
        ",".join(variants),
        "--seeds",
        args.seeds,
        "--budget",
        f"{args.budget:g}",
    ]
    if args.max_cycles != 100:
        out += ["--max-cycles", str(args.max_cycles)]
    if args.constrained_time != 30.0:
        out += ["--constrained-time", f"{args.constrained_time:g}"]
    if args.unconstrained_time != 300.0:
        out += ["--unconstrained-time", f"{args.unconstrained_time:g}"]
    if args.planner != "fd":
        out += ["--planner", args.planner]
    if args.wall_limit is not None:
        out += ["--wall-limit", f"{args.wall_limit:g}"]
    if args.memory_limit != 4096:
        out += ["--memory-limit", str(args.memory_limit)]
    return out + ["-o", args.output]


def _configure_report(p: argparse.ArgumentParser) -> None:
    p.description = (
        "Rebuild DIR/table.md and DIR/table1.png from DIR/episodes.jsonl alone (the JSON lines "
        "of `ssr-compile experiment`), and print the table.  With several DIRs and -o OUT: "
        "one table of all their episodes (a task, variant and seed run in more than one: the "
        "last DIR's), written to OUT with the merged episodes.jsonl."
    )
    p.add_argument("dirs", nargs="+", metavar="DIR", help="a sweep's folder")
    p.add_argument(
        "-o",
        "--output",
        metavar="OUT",
        help="write the table (and, for several DIRs, their merged episodes) here instead",
    )
    p.add_argument(
        "--into",
        action="append",
        default=[],
        metavar="PAGE",
        help="also publish the table in this Markdown page (repeatable), between its lines "
        "'<!-- table-of-record -->' and '<!-- /table-of-record -->' (the rest of the page is "
        "kept), with table1.png written beside the first PAGE; e.g. --into "
        "docs/experiments.md --into README.md",
    )


def run_report(args: argparse.Namespace) -> int:
    from .. import experiment as X
    from ..experiment import write_report

    if len(args.dirs) > 1 and args.output is None:
        print(
            "ssr-compile report: error: several sweep folders need -o OUT, the folder of "
            "their merged table",
            file=sys.stderr,
        )
        return 2
    from pathlib import Path

    alone = len(args.dirs) == 1 and (
        args.output is None or Path(args.output).resolve() == Path(args.dirs[0]).resolve()
    )
    X.check_report_outputs(args.dirs[0] if alone else args.output, journal=not alone)
    if alone:
        table, plot, text = write_report(args.dirs[0], into=args.into)
    else:
        command = " ".join(["ssr-compile report", *args.dirs, "-o", args.output])
        table, plot, text = write_report(args.output, command, sources=args.dirs, into=args.into)
    print(text)
    print(f"wrote {table} and {plot}", file=sys.stderr)
    for page in args.into:
        print(f"published the table in {page}", file=sys.stderr)
    return 0


register(
    "experiment",
    "run Table I: the policy on tasks × variants × seeds, each episode in its own process",
    _configure_experiment,
    run_experiment,
)
register(
    "report",
    "rebuild a sweep's table.md and table1.png from its episodes.jsonl",
    _configure_report,
    run_report,
)
