"""The statistics of a sweep's table: per task × variant, the success rate with its Wilson
interval and the mean planning time of the successes with a seeded bootstrap interval."""

from __future__ import annotations

import math
import zlib
from collections.abc import Iterable
from dataclasses import dataclass

from ..catalog import TASKS, VARIANTS
from .journal import FINISHED, latest
from .paper import PAPER_TABLE1

Z95 = 1.959963984540054


def wilson(successes: int, n: int, z: float = Z95) -> tuple[float, float]:
    """The Wilson score interval of a binomial proportion (as fractions)."""
    if n == 0:
        return (0.0, 1.0)
    p = successes / n
    denom = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    lo = 0.0 if successes == 0 else max(0.0, centre - half)
    hi = 1.0 if successes == n else min(1.0, centre + half)
    return (lo, hi)


def bootstrap_mean(values: list[float], seed: int, resamples: int = 2000) -> tuple[float, float]:
    """A 95% percentile bootstrap interval of the mean (seeded: the same numbers, the same
    interval)."""
    import numpy as np

    if not values:
        return (math.nan, math.nan)
    x = np.asarray(values, dtype=float)
    if len(x) == 1:
        return (float(x[0]), float(x[0]))
    rng = np.random.default_rng(seed)
    means = x[rng.integers(0, len(x), size=(resamples, len(x)))].mean(axis=1)
    lo, hi = np.percentile(means, [2.5, 97.5])
    return (float(lo), float(hi))


@dataclass
class Cell:
    """One task × variant of the table."""

    task: str
    variant: str
    n: int
    successes: int
    rate: float  # fraction
    rate_ci: tuple[float, float]
    mean_time: float | None  # mean planning time of the successful episodes, s
    time_ci: tuple[float, float] | None
    harness_failures: int  # crashed, timed out, out of memory, lost

    @property
    def paper(self) -> tuple[float, float] | None:
        return PAPER_TABLE1.get(self.task, {}).get(self.variant)


def cell_seed(task: str, variant: str) -> int:
    return zlib.crc32(f"{task}/{variant}".encode())


def groups(recs: list[dict], tasks: list[str], variants: list[str]):
    """Per task and variant with episodes: the records, the successful ones and their
    planning times."""
    for t in tasks:
        for v in variants:
            group = [r for r in recs if r["task"] == t and r["variant"] == v]
            if not group:
                continue
            ok = [r for r in group if r.get("success")]
            times = [float(r["planning_time"]) for r in ok if r.get("planning_time") is not None]
            yield t, v, group, ok, times


def cells(records: Iterable[dict]) -> tuple[list[str], list[str], dict[tuple[str, str], Cell]]:
    """Tasks (kitchen tasks in the paper's order, then others as met), variants (Table I's
    order) and the cell of each (task, variant) with episodes."""
    recs = list(latest(records).values())
    tasks: list[str] = []
    for r in recs:
        if r["task"] not in tasks:
            tasks.append(r["task"])
    tasks.sort(key=lambda t: (TASKS.index(t) if t in TASKS else len(TASKS),))
    present = {r["variant"] for r in recs}
    variants = [v for v in VARIANTS if v in present] + sorted(present - set(VARIANTS))
    out: dict[tuple[str, str], Cell] = {}
    for t, v, group, ok, times in groups(recs, tasks, variants):
        mean = sum(times) / len(times) if times else None
        out[(t, v)] = Cell(
            t,
            v,
            len(group),
            len(ok),
            len(ok) / len(group),
            wilson(len(ok), len(group)),
            mean,
            bootstrap_mean(times, cell_seed(t, v)) if times else None,
            sum(r.get("status") not in (FINISHED, None) for r in group),
        )
    return tasks, variants, out
