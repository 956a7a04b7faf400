"""The subcommands of ``ssr-compile``: each command module registers its own here."""

from __future__ import annotations

import argparse
from collections.abc import Callable

COMMANDS: dict[
    str, tuple[Callable[[argparse.ArgumentParser], None], Callable[[argparse.Namespace], int], str]
] = {}


def register(name: str, help: str, configure, run) -> None:
    """Register a subcommand: ``configure(parser)`` adds its options, ``run(args)`` runs it."""
    COMMANDS[name] = (configure, run, help)
