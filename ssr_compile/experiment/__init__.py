"""Table I of the paper (§VIII): sweeps of the online policy over tasks × variants × seeds.

A sweep runs every episode (one task, one variant, one seed) **in a process of its own**: a
crash (an exception, ``os._exit``, a signal), a hang past the episode's wall limit or running
out of memory is recorded as a failure with its reason, and the sweep goes on.  Each finished
episode is one JSON line of ``DIR/episodes.jsonl``, written and flushed as it finishes; the
same sweep run again resumes (episodes already on file are not re-run).  ``DIR/table.md`` and
``DIR/table1.png`` are rebuilt from the JSON lines alone (:func:`write_report`).

The modules, in the order they build on each other:

* :mod:`.spec` -- tasks and variants from the command line (seeds: ``cli/options.py``); the sweep's
  :class:`Settings` (a :class:`~ssr_compile.policy.PolicySettings` and the process limits);
  the episodes;
* :mod:`.revision` -- the toolkit's version and git commit each record names;
* :mod:`.journal` -- the JSON line of an episode and ``DIR/episodes.jsonl``;
* :mod:`.isolation` -- one episode in a process of its own, forked from a fork server;
* :mod:`.executors` -- ``process`` (local processes, ``workers`` at a time) and ``ray``;
* :mod:`.sweep` -- the episodes not yet on file, run and journalled, resumable;
* :mod:`.paper`, :mod:`.statistics`, :mod:`.report` -- Table I as published, the intervals
  of ours, ``table.md`` and ``table1.png``.
"""

from __future__ import annotations

from ..catalog import TASKS as KITCHEN_TASKS
from ..catalog import VARIANTS
from .executors import ProcessExecutor, RayExecutor
from .isolation import run_isolated
from .paper import PAPER_TABLE1
from .report import (
    check_report_outputs,
    fmt_time,
    median,
    render_plot,
    render_table,
    seed_list,
    write_report,
)
from .revision import provenance
from .spec import (
    EpisodeSpec,
    Settings,
    Task,
    episode_specs,
    kitchen_has_environment,
    parse_tasks,
    parse_variants,
)
from .statistics import bootstrap_mean, cell_seed, cells, wilson
from .sweep import run_sweep

__all__ = [
    "VARIANTS",
    "KITCHEN_TASKS",
    "PAPER_TABLE1",
    "Task",
    "Settings",
    "EpisodeSpec",
    "parse_tasks",
    "parse_variants",
    "kitchen_has_environment",
    "episode_specs",
    "run_isolated",
    "run_sweep",
    "ProcessExecutor",
    "RayExecutor",
    "provenance",
    "wilson",
    "bootstrap_mean",
    "cell_seed",
    "cells",
    "fmt_time",
    "median",
    "seed_list",
    "render_table",
    "render_plot",
    "write_report",
    "check_report_outputs",
]
