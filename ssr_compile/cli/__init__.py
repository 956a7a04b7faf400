"""The ``ssr-compile`` command line (console script ``ssr_compile.cli:main``).

The top of the house: it imports the library, nothing in the library imports it.  Inside,
imports go one way: ``app`` (parser, exit codes, error reporting) -> the command modules
(``check``, ``compile``, ``solve``, ``run``, ``sim``, ``experiment``) -> ``options`` and
``registry``.
"""

from .app import build_parser, main
from .registry import COMMANDS, register

__all__ = ["COMMANDS", "build_parser", "main", "register"]
