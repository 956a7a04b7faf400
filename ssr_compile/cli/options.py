"""The command line's numeric options: one validation for each kind of number."""

from __future__ import annotations

import argparse
import math

from ..catalog import SEED_MAX
from ..errors import SSRError

# One validation for every numeric option, by its destination name: the commands use these as
# argparse ``type=`` functions, and build_parser() applies them to any command's option of the
# same name, so that a bad number is bad input (exit 2, one line) everywhere.


def seconds(text: str) -> float:
    """A time limit: a finite number of seconds greater than 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number of seconds, got '{text}'") from None
    if not math.isfinite(value) or value <= 0:
        raise argparse.ArgumentTypeError(
            f"expected a finite number of seconds greater than 0, got '{text}'"
        )
    return value


def count(text: str, least: int = 0, most: int | None = None, what: str = "a whole number") -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected {what}, got '{text}'") from None
    if value < least or (most is not None and value > most):
        bound = f"from {least} to {most}" if most is not None else f"{least} or more"
        raise argparse.ArgumentTypeError(f"expected {what} {bound}, got '{text}'")
    return value


def level(text: str) -> int:
    """An instantiation level: 0 or more."""
    return count(text, 0, what="a level")


#: The one rule for seeds, in every command (``run``, ``solve``, ``render``, ``belief-plot``,
#: ``experiment --seeds``, example.toml's ``seed``): a whole number from 0 to 2**32 - 1.
#: numpy's ``default_rng`` would take larger ones, but a seed is handed to the user's own
#: environment and streams code, and 32 bits is what every seeding takes (``np.random.seed``,
#: ``RandomState``), so a seed that one command accepts is one that every command and every
#: environment can use.
SEED_RULE = f"seeds are whole numbers from 0 to {SEED_MAX} (2**32 - 1)"
#: At most this many seeds in one sweep (a larger sweep: a range at a time into one folder).
MAX_SEEDS = 10_000


def seed(text: str) -> int:
    """A random seed (:data:`SEED_MAX`)."""
    try:
        value = int(text)
    except ValueError:
        value = None
    if value is None or not 0 <= value <= SEED_MAX:
        raise argparse.ArgumentTypeError(f"expected a seed ({SEED_RULE}), got '{text}'")
    return value


def seed_list(text: str, option: str = "--seeds") -> list[int]:
    """``0-24``, ``0,3,5``, ``0-4,10-12`` -> the seeds in order, without repeats (each seed by
    the rule of :func:`seed`; at most :data:`MAX_SEEDS`, counted before any is listed)."""
    if not text.strip():
        raise SSRError(f"{option}: empty; expected a range such as 0-24 or a list such as 0,3,5")
    ranges: list[tuple[int, int]] = []
    for part in text.split(","):
        part = part.strip()
        lo, dash, hi = part.partition("-")
        try:
            a, b = (int(lo), int(hi)) if dash else (int(part), int(part))
        except ValueError:
            raise SSRError(
                f"{option}: '{part}' is not a seed or a range of seeds "
                f"(expected e.g. 0-24 or 0,3,5; {SEED_RULE})"
            ) from None
        if not (0 <= a <= SEED_MAX and 0 <= b <= SEED_MAX):
            raise SSRError(f"{option}: '{part}': {SEED_RULE}")
        if b < a:
            raise SSRError(f"{option}: '{part}' is an empty range (its end is below its start)")
        ranges.append((a, b))
    n = _union_size(ranges)
    if n > MAX_SEEDS:
        raise SSRError(
            f"{option}: {text.strip()} names {n} seeds; at most {MAX_SEEDS} in one sweep (run "
            "a range at a time into the same output folder: a sweep adds to the episodes on file)"
        )
    seen: set[int] = set()
    seeds: list[int] = []
    for a, b in ranges:
        for s in range(a, b + 1):
            if s not in seen:
                seen.add(s)
                seeds.append(s)
    return seeds


def _union_size(ranges: list[tuple[int, int]]) -> int:
    """How many whole numbers the closed ranges cover together."""
    total, end = 0, -1
    for a, b in sorted(ranges):
        if b > end:
            total += b - max(a, end + 1) + 1
            end = b
    return total


def positive_count(text: str) -> int:
    return count(text, 1)


def cost_bound(text: str) -> float:
    """A cost bound: a number greater than 0 (``inf``: no bound)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a cost, got '{text}'") from None
    if math.isnan(value) or value <= 0:
        raise argparse.ArgumentTypeError(f"expected a cost greater than 0, got '{text}'")
    return value


NUMERIC_OPTIONS = {
    "time_limit": seconds,
    "level": level,
    "max_level": level,
    "seed": seed,
    "max_cost": cost_bound,
    "particles": positive_count,
}


def validate_numbers(p: argparse.ArgumentParser) -> None:
    """Give each numeric option of ``p`` the validation of its name (NUMERIC_OPTIONS)."""
    for action in p._actions:  # argparse keeps no public list of a parser's options
        check = NUMERIC_OPTIONS.get(action.dest)
        if check is not None and action.type in (int, float, None) and action.option_strings:
            action.type = check
