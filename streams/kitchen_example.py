"""The streams module of the folder ``domains/pddl/kitchen`` for ``ssr-compile solve``.

The kitchen's streams need a PyBullet world, so this module binds them per problem: the
folder's problem files (``problem-inspect.pddl``, ...) are the initial problems of the paper's
tasks generated with seed 0 by :func:`ssr_compile.sim.problem.task_problem`, and :func:`for_problem`
rebuilds that task's world and returns :func:`ssr_compile.streams.kitchen_module.make_module` for it.
Regenerate the files with ``python -m ssr_compile.streams.kitchen_example DIR``.
"""

from __future__ import annotations

import atexit
import sys
from pathlib import Path

import numpy as np
from ssr_compile.sim.tasks import TASKS

STREAMS: dict = {}  # bound per problem by for_problem()
TASK_SEED = 0


def task_name(problem_path: str | Path) -> str:
    """The task a kitchen problem file states: its problem name ``kitchen-<task>-<seed>`` (so
    a copy under any file name works), else its file name ``problem-<task>.pddl``."""
    from ssr_compile.parse import parse_file

    try:
        name = parse_file(problem_path).name
    except Exception:  # noqa: BLE001 - unreadable here: the caller reports the file itself
        name = ""
    parts = name.split("-")
    if len(parts) >= 2 and parts[0] == "kitchen" and parts[1] in TASKS:
        return parts[1]
    stem = Path(problem_path).stem.removeprefix("problem-")
    if stem in TASKS:
        return stem
    raise ValueError(
        f"{problem_path}: a kitchen problem names its task -- (problem kitchen-<task>-<seed>) "
        f"or a file problem-<task>.pddl -- with a task among {', '.join(TASKS)}"
    )


def for_problem(problem_path: str | Path, seed: int = 0):
    """The streams module for one of the folder's problem files (``seed``: the streams' RNG)."""
    from ssr_compile.sim.problem import task_problem
    from ssr_compile.sim.tasks import make_task

    from .kitchen_module import make_module

    task = make_task(task_name(problem_path), TASK_SEED)
    atexit.register(task.close)
    _, values = task_problem(task)
    return make_module(task, np.random.default_rng(seed), values)


def problem_text(name: str) -> str:
    from ssr_compile.sim.problem import task_problem
    from ssr_compile.sim.tasks import make_task

    from ssr_compile.printer import to_text

    task = make_task(name, TASK_SEED)
    try:
        return to_text(task_problem(task)[0])
    finally:
        task.close()


if __name__ == "__main__":  # pragma: no cover - a maintenance command
    folder = Path(sys.argv[1] if len(sys.argv) > 1 else "domains/pddl/kitchen")
    for name in TASKS:
        (folder / f"problem-{name}.pddl").write_text(problem_text(name))
        print(f"wrote {folder / f'problem-{name}.pddl'}")
