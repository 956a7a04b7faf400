"""``ssr-compile run``: one episode of the online replanning policy (paper §VI, Algorithm 1)."""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import sys
from pathlib import Path

from ..catalog import TASKS as KITCHEN_TASKS
from ..errors import SSRError
from ..files import check_output, write_atomically
from ..json_output import SCHEMA_VERSION
from .options import cost_bound, positive_count, seconds, seed
from .registry import register


def _positive(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number of seconds, got '{text}'") from None
    if not (value > 0 and math.isfinite(value)):
        raise argparse.ArgumentTypeError(f"expected a positive number of seconds, got '{text}'")
    return value


def _count(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got '{text}'") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected a number >= 0, got '{text}'")
    return value


def _configure(p: argparse.ArgumentParser) -> None:
    p.description = (
        "Run one episode of the online replanning policy (paper §VI, Algorithm 1): plan, "
        "execute the first action, observe, update the belief, replan, until the goal belief "
        "is reached.  Success is judged on the environment's true state.  Exit 0 when the "
        "goal holds in the true state at the end; 1 when the policy failed (no plan after "
        "--max-looks looks again, no plan "
        "cheaper than --max-cost, budget or cycles exhausted, an action failed --max-failures "
        "times from the same state, an execute past --execute-time, or the goal does not "
        "truly hold); 2 on bad input (the example, its example.toml, the environment module "
        "that does not import, a factory that rejects the problem with ValueError); 3 when "
        "code failed: the environment's or the agent's code raised or broke the contract "
        "(the message names the module and method; the cycles run so far are logged and the "
        "outcome printed), a planner or a stream failed, or ssr-compile did; 128+N killed "
        "by signal N."
    )
    p.add_argument(
        "target",
        metavar="TASK|FOLDER|NAME",
        help=f"a kitchen task ({', '.join(KITCHEN_TASKS)}) or task file (FILE.toml), "
        "a shipped example with an "
        "environment (progress, belief-detect), or an example folder whose example.toml "
        'names one (environment = "module:function")',
    )
    p.add_argument(
        "--problem", metavar="P", help="which problem of the example (its factory decides)"
    )
    p.add_argument(
        "--seed", type=seed, metavar="N", help="episode seed (default 0, or example.toml's)"
    )
    p.add_argument(
        "--variant",
        choices=("both", "constraints", "deferred", "neither"),
        default="both",
        help="plan constraints and/or deferred streams, as Table I's columns (default both)",
    )
    p.add_argument(
        "--time-limit",
        type=_positive,
        default=600.0,
        metavar="S",
        help="total planning time of the episode in seconds (default 600, as the paper)",
    )
    p.add_argument(
        "--constrained-time",
        type=_positive,
        default=30.0,
        metavar="S",
        help="limit of each constrained planning attempt (default 30)",
    )
    p.add_argument(
        "--unconstrained-time",
        type=_positive,
        default=300.0,
        metavar="S",
        help="limit of each unconstrained planning attempt (default 300); one out of time "
        "with budget left looks again (--max-looks)",
    )
    p.add_argument(
        "--max-cycles", type=_count, default=100, metavar="N", help="at most N cycles (default 100)"
    )
    p.add_argument(
        "--max-cost",
        type=cost_bound,
        default=None,
        metavar="C",
        help="c*: plans must cost less than C (the problem's cost units); when none does, the "
        "episode ends (default: no bound, or example.toml's)",
    )
    p.add_argument(
        "--execute-time",
        type=seconds,
        default=60.0,
        metavar="S",
        help="limit of each action's execution (the environment's execute, and observe and "
        "goal_holds); past it the episode ends (default 60)",
    )
    p.add_argument(
        "--max-failures",
        type=positive_count,
        default=3,
        metavar="N",
        help="end the episode when an action failed N times from the same state (the agent's "
        "problem unchanged by the failures; default 3)",
    )
    p.add_argument(
        "--max-looks",
        type=_count,
        default=2,
        metavar="N",
        help="when no plan is found (or an unconstrained attempt ran out of its own time "
        "with budget left), observe again without acting and replan, at most N times in a "
        "row, before the episode ends (a first estimate can be far off; default 2; 0: end "
        "at once; never with --max-cost)",
    )
    p.add_argument(
        "--planner", metavar="NAME", help="planner backend (default fd, or example.toml's)"
    )
    p.add_argument(
        "--resample",
        type=_count,
        default=None,
        metavar="N",
        help="the solver draws a rejected draw again at once up to N times per other draw of "
        "the stream plan it is tested against (default 2; 0: off, the Focused loop as the "
        "paper has it); or example.toml's",
    )
    p.add_argument(
        "--cheaper-rises",
        type=_count,
        default=1,
        metavar="N",
        help="when a planning attempt keeps a plan and the next is no cheaper, while a plan "
        "planned cheaper failed only on the values its level drew, the level rises up to N "
        "times for a cheaper plan before the kept plan is taken (default 1; 0: off, the "
        "Focused loop as the paper has it)",
    )
    p.add_argument("--log", metavar="FILE.jsonl", help="write one JSON line per cycle to FILE")
    p.add_argument("--gif", metavar="FILE", help="an animation of the episode (kitchen tasks)")
    p.add_argument("--json", action="store_true", help="print the outcome as JSON (no cycle lines)")
    p.add_argument("-v", "--verbose", action="store_true", help="also print the solver's progress")


def resolve(target: str, problem: str | None):
    """(example, problem) for a kitchen task name, a shipped example or a folder."""
    from ..examples import load_example

    if target.endswith(".toml") and Path(target).name != "example.toml":
        from ssr_compile.sim.task_file import load_task_file

        if problem:
            raise SSRError(f"'{target}' is a kitchen task file; --problem {problem} contradicts it")
        load_task_file(target)  # bad input before anything runs
        return load_example("kitchen"), target
    if target.lower() in KITCHEN_TASKS:
        if problem and problem.lower() != target.lower():
            raise SSRError(f"'{target}' is a kitchen task; --problem {problem} contradicts it")
        return load_example("kitchen"), target.lower()
    example = load_example(target)
    if problem is None and example.name == "kitchen":
        raise SSRError(
            f"the kitchen needs a task: ssr-compile run TASK, or run {target} --problem TASK, "
            f"with TASK one of {', '.join(KITCHEN_TASKS)}"
        )
    return example, problem


def make_episode(example, problem: str | None, seed: int):
    """The example's episode from its environment factory; the factory's faults named."""
    from ..episode_record import UserCodeError, origin
    from ..policy import Episode

    spec = example.settings.environment
    try:
        factory = example.environment_factory()
    except SSRError:
        raise
    except (Exception, SystemExit) as e:  # the module raised while being imported
        raise SSRError(
            f"the environment module of '{example.name}' ({spec}) failed to import: "
            f"{type(e).__name__}: {e}{'' if isinstance(e, SyntaxError) else origin(e)}",
            file=_error_file(e) or str(example.folder / "example.toml"),
            line=getattr(e, "lineno", None) if isinstance(e, SyntaxError) else None,
        ) from None
    name = f"environment factory {spec}"
    try:
        episode = factory(problem, seed)
    except SSRError:  # a task file the seed cannot place: bad input, named
        raise
    except TypeError as e:
        raise SSRError(f"the environment factory of '{example.name}' failed: {e}") from None
    except ValueError as e:
        raise SSRError(f"{example.name}: {e}") from None
    except (Exception, SystemExit) as e:
        raise UserCodeError(name, e) from e
    if not isinstance(episode, Episode):
        raise UserCodeError(
            name,
            message=f"{name} returned {type(episode).__name__} {_short(episode)}, not an "
            "ssr_compile.policy.Episode(environment, agent)",
        )
    return episode


def _error_file(e: BaseException) -> str | None:
    return e.filename if isinstance(e, SyntaxError) and e.filename else None


def _short(value) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def run(args: argparse.Namespace) -> int:
    from ..episode_record import UserCodeError
    from ..policy import PolicySettings, run_policy

    if args.max_cycles < 1:
        raise SSRError("--max-cycles must be at least 1")
    example, problem = resolve(args.target, args.problem)
    # example.toml's planner, resample, seed and max_cost, as `solve` reads them (a flag wins)
    chosen = example.settings.resolve(
        {"planner": args.planner, "resample": args.resample, "seed": args.seed,
         "max_cost": args.max_cost},
        {"planner": "fd", "resample": None, "seed": 0, "max_cost": math.inf},
    )  # fmt: skip
    args.planner, args.resample, args.seed, args.max_cost = (
        chosen[n][0] for n in ("planner", "resample", "seed", "max_cost")
    )
    settings = PolicySettings(
        variant=args.variant,
        budget=args.time_limit,
        constrained_time=args.constrained_time,
        unconstrained_time=args.unconstrained_time,
        max_cycles=args.max_cycles,
        planner=args.planner,
        max_cost=args.max_cost,
        execute_time=args.execute_time,
        max_failures=args.max_failures,
        max_looks=args.max_looks,
        cheaper_rises=args.cheaper_rises,
        **({} if args.resample is None else {"resample": args.resample}),
    )
    from ..planners import get_planner

    get_planner(args.planner)  # bad input before anything runs
    # Every output is checked before any is opened: a bad --gif leaves no empty --log.
    gif = Path(args.gif) if args.gif else None
    if gif is not None:
        if gif.exists() and not gif.is_file():
            raise SSRError(f"--gif {args.gif}: not a regular file", file=args.gif)
        if not gif.parent.is_dir():
            raise SSRError(f"--gif {args.gif}: no folder {gif.parent}", file=args.gif)
        check_output(gif, "--gif")  # before the episode, not after it
    log_file = None
    if args.log:
        log_path = Path(args.log)
        if log_path.exists() and not log_path.is_file():
            raise SSRError(f"--log {args.log}: not a regular file", file=args.log)
        try:
            log_file = open(log_path, "w", encoding="utf-8")  # noqa: SIM115
        except OSError as e:
            raise SSRError(f"--log {args.log}: {e.strerror}", file=args.log) from None
    try:
        episode = make_episode(example, problem, args.seed)
    except BaseException:
        if log_file is not None:
            log_file.close()
        raise
    frames: list = []

    def render(caption: str) -> None:
        try:
            frames.append(episode.render(caption))
        except (Exception, SystemExit) as e:
            raise UserCodeError(
                f"the episode's render ({_callable_name(episode.render)})", e
            ) from e

    if gif is not None:
        if getattr(episode, "render", None) is None:
            episode.close()
            raise SSRError(f"--gif: the '{example.name}' environment draws no pictures")
        try:
            render(f"{example.name} {problem or ''} seed {args.seed}: start")
        except UserCodeError:
            episode.close()
            raise
    say = (lambda msg: print(msg, file=sys.stderr)) if args.verbose else None

    def on_cycle(cycle) -> None:
        if gif is not None and cycle.action is not None:
            render(f"cycle {cycle.index}: {cycle.action}")
        if not args.json:
            print(cycle.line(), flush=True)
        if log_file is not None:
            log_file.write(json.dumps(cycle.as_dict()) + "\n")
            log_file.flush()

    if not args.json:
        print(
            f"episode: {example.name}{' / ' + problem if problem else ''}, seed {args.seed}, "
            f"variant {args.variant}, planning budget {args.time_limit:g} s",
            flush=True,
        )
    error: UserCodeError | None = None
    try:
        try:
            result = run_policy(episode, settings, on_cycle=on_cycle, progress=say)
        except UserCodeError as e:
            if e.result is None:
                raise
            result, error = e.result, e
        if gif is not None and error is None:
            truth = "goal holds" if result.success else "goal does NOT hold"
            render(f"end: {result.reason}; {truth} in the true world")
            _write_gif(gif, frames)
    except BaseException:
        with contextlib.suppress(Exception):
            episode.close()
        raise
    finally:
        if log_file is not None:
            log_file.close()
    try:
        episode.close()
    except (Exception, SystemExit) as e:
        close = getattr(episode.environment, "close", episode.close)
        error = error or UserCodeError(f"environment {_callable_name(close)}", e)
    outcome = {
        "schema_version": SCHEMA_VERSION,  # README, "JSON output"; ssr_compile/json_output.py
        "command": "run",
        "example": example.name,
        "problem": problem,
        "seed": args.seed,
        "variant": args.variant,
        **result.as_dict(),
    }
    if error is not None:
        outcome["error"] = error.message
    if args.json:
        outcome["trace"] = [c.as_dict() for c in result.cycles]
        print(json.dumps(outcome, indent=1))
    else:
        truth = "holds" if result.success else "does NOT hold"
        print(
            f"outcome: {result.reason}; the goal {truth} in the true state; "
            f"{len(result.cycles)} cycles, {len(result.actions)} actions, planning "
            f"{result.planning_time:.2f} s (constrained held {result.constrained_held}, "
            f"fell back {result.fallbacks}), wall {result.wall_time:.1f} s",
            flush=True,
        )
    if error is not None:
        raise error
    return 0 if result.success else 1


def _callable_name(fn) -> str:
    owner = getattr(fn, "__self__", None)
    if owner is not None:
        return f"{type(owner).__module__}.{type(owner).__qualname__}.{fn.__name__}"
    return f"{getattr(fn, '__module__', '?')}.{getattr(fn, '__qualname__', repr(fn))}"


def _write_gif(path: Path, frames: list) -> None:
    """An animated GIF of the frames (1.2 s each, the last held 3 s), written atomically."""
    from PIL import Image

    images = [Image.fromarray(f) for f in frames]
    durations = [1200] * (len(images) - 1) + [3000]
    write_atomically(
        path,
        lambda tmp: images[0].save(
            tmp, save_all=True, append_images=images[1:], duration=durations, loop=0
        ),
    )
    print(f"wrote {path} ({len(images)} frames)")


register(
    "run",
    "run one episode of the online replanning policy (Algorithm 1) in an environment",
    _configure,
    run,
)
