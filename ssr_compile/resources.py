"""Where the package data lives: the grammar and the shipped domains.

Installed, they are the packages ``ssr_compile.grammar`` and ``ssr_compile.domains`` (mapped from
the top-level ``grammar/`` and ``domains/`` folders by pyproject.toml).  Run from a checkout
that shadows the installed package, they are those top-level folders themselves.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

_CHECKOUT = Path(__file__).resolve().parent.parent


def _package_dir(package: str, checkout_name: str) -> Path:
    try:
        path = Path(str(resources.files(package)))
        if path.is_dir():
            return path
    except ModuleNotFoundError:
        pass
    return _CHECKOUT / checkout_name


def grammar_file(name: str = "pddlstream.lark") -> Path:
    return _package_dir("ssr_compile.grammar", "grammar") / name


def domains_dir() -> Path:
    """The folder holding one sub-folder per shipped domain (``domains/pddl``)."""
    return _package_dir("ssr_compile.domains", "domains") / "pddl"
