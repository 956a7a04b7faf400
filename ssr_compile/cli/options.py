"""The command line's numeric options: one validation for each kind of number."""

from __future__ import annotations

import argparse
import math

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


def seed(text: str) -> int:
    """A random seed: 0 .. 2**32 - 1 (what numpy's generators accept)."""
    return count(text, 0, 2**32 - 1, what="a seed")


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
