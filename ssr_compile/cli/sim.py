"""``ssr-compile render`` and ``belief-plot``: pictures of the kitchen tasks and of beliefs."""

from __future__ import annotations

import argparse
import os
from pathlib import Path

from ..catalog import TASKS
from ..errors import SSRError
from ..files import check_output, write_atomically
from . import options
from .registry import register


def _task(text: str) -> str:
    """A kitchen task's name, or a task file's path (checked by :func:`_check_task`)."""
    if text.lower() in TASKS:
        return text.lower()
    if text.endswith(".toml"):
        return text
    raise argparse.ArgumentTypeError(
        f"invalid choice: '{text}' (choose from {', '.join(TASKS)}, or a task file FILE.toml)"
    )


def _check_task(task: str) -> None:
    """A task file is bad input before anything is drawn (file and key named)."""
    if task.endswith(".toml"):
        from ssr_compile.sim.task_file import load_task_file

        load_task_file(task)


def _task_args(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "task", metavar="TASK", type=_task, help="one of: " + ", ".join(TASKS) + "; or FILE.toml"
    )
    p.add_argument(
        "--seed",
        type=options.seed,
        default=0,
        metavar="N",
        help="task seed (default 0): random poses within the supports",
    )
    p.add_argument("-o", "--output", required=True, metavar="PNG", help="the picture to write")


def _check_png(output: str) -> Path:
    """OUTPUT, checked before any work: a .png path that can be written."""
    out = Path(output)
    if out.suffix.lower() != ".png":
        raise SSRError(f"the output must be a .png file, got '{output}'")
    check_output(out, "-o")
    return out


def _write_png(output: str, draw) -> str:
    """Draw into a temporary file beside OUTPUT, then move it in place (nothing half-written)."""
    out = _check_png(output)
    write_atomically(out, draw)
    return str(out)


def _configure_render(p: argparse.ArgumentParser) -> None:
    _task_args(p)
    p.add_argument(
        "--gui",
        action="store_true",
        help="also open PyBullet's window on the scene (needs a display) until it is closed",
    )
    p.add_argument(
        "--view",
        choices=("camera", "top"),
        default="camera",
        help="from the fixed camera, or from above with the prior belief's particles (default camera)",
    )


def run_render(args: argparse.Namespace) -> int:
    from ssr_compile.sim.render import render_task

    _check_task(args.task)
    path = _write_png(
        args.output, lambda tmp: render_task(args.task, args.seed, tmp, view=args.view)
    )
    print(f"wrote {path} ({args.task}, seed {args.seed}, {args.view} view)")
    if args.gui:
        _show(args.task, args.seed)
    return 0


def _show(task_name: str, seed: int) -> None:
    """Keep a GUI window on the task's scene until the user closes it (or presses Ctrl-C)."""
    import time

    import pybullet as p

    from ssr_compile.sim.tasks import make_task

    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        raise SSRError("--gui needs a display (DISPLAY is not set); the PNG was written")
    task = make_task(task_name, seed, gui=True)
    print("showing the scene; close the window or press Ctrl-C to quit")
    try:
        while p.isConnected(task.world.client):
            time.sleep(0.1)
    except KeyboardInterrupt:
        pass
    finally:
        task.close()


def _configure_belief_plot(p: argparse.ArgumentParser) -> None:
    _task_args(p)
    p.add_argument(
        "--particles", type=int, default=300, metavar="N", help="particles per object (default 300)"
    )


def run_belief_plot(args: argparse.Namespace) -> int:
    """The prior pose beliefs of a task's objects, drawn like the paper's Fig. 3 (left)."""
    import numpy as np

    from ssr_compile.belief.particles import PoseBelief
    from ssr_compile.belief.plot import plot_belief
    from ssr_compile.sim.tasks import make_task

    if args.particles < 1:
        raise SSRError("--particles must be at least 1")
    _check_png(args.output)  # before the task is built
    _check_task(args.task)
    task = make_task(args.task, args.seed)
    try:
        rng = np.random.default_rng(args.seed)
        priors = task.prior_surfaces()
        beliefs = {}
        surfaces = {}
        for obj, entries in priors.items():
            surf = [s for s, _ in entries]
            beliefs[obj] = PoseBelief.uniform(obj, surf, args.particles, rng)
            surfaces.update({s.name: s for s in surf})
        title = f"{args.task} (seed {args.seed}): prior pose beliefs"
        path = _write_png(
            args.output, lambda tmp: plot_belief(beliefs, list(surfaces.values()), tmp, title=title)
        )
    finally:
        task.close()
    print(f"wrote {path} ({', '.join(sorted(beliefs))})")
    return 0


def _configure_tasks(p: argparse.ArgumentParser) -> None:
    p.description = (
        "Kitchen task files.  'generate' writes a member of the family of harder kitchens: "
        "N movable objects, K boxes that may hide the block (the episode's seed picks the one "
        "in front of it), the other blocks on the counter or in the drawers as the seed draws "
        "them; Cook-like (cook the block) or Inspect-like (the block into the bottom drawer)."
    )
    sub = p.add_subparsers(dest="action", required=True, metavar="ACTION")
    g = sub.add_parser("generate", help="write a task file of the family (N objects, K hiders)")
    g.add_argument("--kind", choices=("cook", "inspect"), default="cook", help="default cook")
    g.add_argument("--objects", type=int, default=3, metavar="N", help="2 to 12 (default 3)")
    g.add_argument("--hiders", type=int, default=2, metavar="K", help="1 to 6, < N (default 2)")
    g.add_argument("-o", "--output", metavar="FILE.toml", help="write here (default: print)")


def run_tasks(args: argparse.Namespace) -> int:
    from ssr_compile.sim.task_family import generate

    try:
        text = generate(args.kind, args.objects, args.hiders)
    except ValueError as e:
        raise SSRError(f"tasks generate: {e}") from None
    if args.output is None:
        print(text, end="")
        return 0
    out = Path(args.output)
    if out.suffix != ".toml":
        raise SSRError(f"the output must be a .toml file, got '{args.output}'")
    check_output(out, "-o")
    write_atomically(out, text)
    print(f"wrote {out} ({args.kind}, {args.objects} objects, {args.hiders} hiders)")
    return 0


register(
    "tasks",
    "kitchen task files: generate a harder kitchen (N objects, K that may hide the block)",
    _configure_tasks,
    run_tasks,
)
register(
    "render",
    "draw a kitchen task's scene (camera or top view) as a PNG",
    _configure_render,
    run_render,
)
register(
    "belief-plot",
    "draw a kitchen task's prior pose beliefs as a PNG (one colour per object, weight as "
    "opacity and size; stacked surfaces such as the drawers in panels of their own)",
    _configure_belief_plot,
    run_belief_plot,
)
