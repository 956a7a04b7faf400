"""Reading the import statements of the project's modules (tests/test_layers.py and
tests/test_imports.py): every statement, in-function imports included, relative imports
resolved against the module's package under its installed name (``sim/world.py`` is
``ssr_compile.sim.world``)."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
# top-level folders installed as subpackages of ssr_compile (pyproject.toml's package-dir)
MAPPED = ("grammar", "domains", "sim", "streams")


def module_name(path: Path, root: Path = ROOT) -> str:
    """The dotted name ``path`` imports as (a package's ``__init__.py``: the package)."""
    parts = list(path.relative_to(root).with_suffix("").parts)
    if parts[0] in MAPPED:
        parts = ["ssr_compile", *parts]
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _package_of(path: Path, root: Path = ROOT) -> str:
    rel = path.relative_to(root).with_suffix("")
    parts = list(rel.parts)
    if parts[0] in MAPPED:
        parts = ["ssr_compile", *parts]
    return ".".join(parts[:-1])


def _from_module(node: ast.ImportFrom, package: str) -> str:
    """The module a ``from ... import`` statement reads, relative imports resolved."""
    if not node.level:
        return node.module or ""
    base = package.split(".")
    base = base[: len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def imported_modules(path: Path, root: Path = ROOT) -> list[tuple[int, str]]:
    """``(line, module)`` per import: ``from a import x`` is ``a``, but ``from . import x``
    is ``package.x`` (each ``x`` taken for a module of that package)."""
    tree = ast.parse(path.read_text(), filename=str(path))
    package = _package_of(path, root)
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out.extend((node.lineno, a.name) for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            name = _from_module(node, package)
            if node.module is None:  # from . import x: each x is a module of that package
                out.extend((node.lineno, f"{name}.{a.name}") for a in node.names)
            else:
                out.append((node.lineno, name))
    return out


def import_statements(path: Path, root: Path = ROOT) -> list[tuple[int, str, tuple[str, ...]]]:
    """``(line, module, names)`` per statement and module: ``import a.b, c`` gives ``(line,
    "a.b", ())`` and ``(line, "c", ())``; ``from a import x, y`` gives ``(line, "a", ("x",
    "y"))``, relative ``a`` resolved."""
    tree = ast.parse(path.read_text(), filename=str(path))
    package = _package_of(path, root)
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out.extend((node.lineno, a.name, ()) for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            out.append(
                (node.lineno, _from_module(node, package), tuple(a.name for a in node.names))
            )
    return sorted(out)
