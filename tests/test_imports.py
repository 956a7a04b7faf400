"""The project's import graph has no cycle, its modules stay small, and a checkout imports the
same subpackages an install does.

The graph reads every import statement of ``ssr_compile/``, ``sim/``, ``streams/``,
``grammar/`` and ``domains/`` (in-function imports included, relative imports resolved; the
folders under their installed names, ``ssr_compile.sim`` etc.).  ``from pkg import name`` is an
edge to ``pkg.name`` when that is a module, else to ``pkg`` (the package's ``__init__``, which
re-exports the name); importing ``a.b.c`` also runs the packages ``a.b`` and ``a`` unless the
importer lives in them (its own package is initialised before it).
"""

from __future__ import annotations

import importlib
import re
import sys
from collections import deque
from pathlib import Path

import pytest
from importscan import MAPPED, ROOT, import_statements, module_name

FOLDERS = ("ssr_compile", *MAPPED)
MAX_LINES = 700
SMALL = ("ssr_compile", "sim", "streams")  # the folders whose modules must stay small

Edge = tuple[str, Path, int]  # (imported module, importing file, line)


def project_modules(root: Path = ROOT, folders=FOLDERS) -> dict[str, Path]:
    """Module name -> file, for every ``.py`` file of ``folders``."""
    out = {}
    for folder in folders:
        for path in sorted((root / folder).rglob("*.py")):
            if "__pycache__" not in path.parts:
                out[module_name(path, root)] = path
    return out


def _parents(name: str) -> list[str]:
    parts = name.split(".")
    return [".".join(parts[:k]) for k in range(1, len(parts))]


def import_graph(root: Path = ROOT, folders=FOLDERS) -> dict[str, list[Edge]]:
    """For each project module, the project modules its imports run (first import each)."""
    modules = project_modules(root, folders)
    graph: dict[str, list[Edge]] = {}
    for name, path in modules.items():
        own = {*_parents(name), name}  # packages initialised before this module runs
        seen: dict[str, Edge] = {}
        for line, base, names in import_statements(path, root):
            targets = []
            if not names:  # import a.b.c
                targets.append(base)
            for n in names:  # from pkg import n: the module pkg.n, or pkg's __init__
                targets.append(f"{base}.{n}" if f"{base}.{n}" in modules else base)
            for target in targets:
                for module in (*_parents(target), target):
                    if module in modules and module not in own and module not in seen:
                        seen[module] = (module, path, line)
        graph[name] = list(seen.values())
    return graph


def _components(graph: dict[str, list[Edge]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out = []
    for start in sorted(graph):
        if start in index:
            continue
        work = [(start, iter(graph[start]))]
        index[start] = low[start] = len(index)
        stack.append(start)
        on_stack.add(start)
        while work:
            node, edges = work[-1]
            for target, _, _ in edges:
                if target not in index:
                    index[target] = low[target] = len(index)
                    stack.append(target)
                    on_stack.add(target)
                    work.append((target, iter(graph[target])))
                    break
                if target in on_stack:
                    low[node] = min(low[node], index[target])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[node])
                if low[node] == index[node]:
                    component = []
                    while True:
                        m = stack.pop()
                        on_stack.discard(m)
                        component.append(m)
                        if m == node:
                            break
                    if len(component) > 1:
                        out.append(sorted(component))
    return sorted(out)


def _shortest_path(graph, source: str, target: str, within: set[str]) -> list[str]:
    previous = {source: None}
    queue = deque([source])
    while queue:
        node = queue.popleft()
        if node == target:
            break
        for nxt, _, _ in graph[node]:
            if nxt in within and nxt not in previous:
                previous[nxt] = node
                queue.append(nxt)
    path = [target]
    while previous[path[-1]] is not None:
        path.append(previous[path[-1]])
    return path[::-1]


def find_cycles(graph: dict[str, list[Edge]]) -> list[list[str]]:
    """Import cycles, each as modules ``[m0, m1, ..., m0]``: per circular component, for each
    import inside it, the shortest cycle through that import (so every circular import shows)."""
    cycles = []
    for component in _components(graph):
        within = set(component)
        found = set()
        for source in component:
            for target, _, _ in graph[source]:
                if target not in within:
                    continue
                back = _shortest_path(graph, target, source, within)
                cycle = [source, *back]  # source -> target ... -> source
                ring = cycle[:-1]
                k = ring.index(min(ring))
                ring = ring[k:] + ring[:k]
                if tuple(ring) not in found:
                    found.add(tuple(ring))
                    cycles.append([*ring, ring[0]])
    return sorted(cycles, key=lambda c: (len(c), c))


def describe(cycle: list[str], graph: dict[str, list[Edge]], root: Path = ROOT) -> str:
    """``a (ssr_compile/a.py:3) -> b (ssr_compile/b.py:9) -> a``: each module with the line
    that imports the next."""
    parts = []
    for here, nxt in zip(cycle, cycle[1:]):
        _, path, line = next(e for e in graph[here] if e[0] == nxt)
        parts.append(f"{here} ({path.relative_to(root)}:{line})")
    return " -> ".join([*parts, cycle[-1]])


def test_no_import_cycle():
    graph = import_graph()
    cycles = [describe(c, graph) for c in find_cycles(graph)]
    if cycles:
        pytest.fail("import cycles:\n" + "\n".join(cycles), pytrace=False)


def test_no_module_over_700_lines():
    long = []
    for folder in SMALL:
        for path in sorted((ROOT / folder).rglob("*.py")):
            n = len(path.read_text().splitlines())
            if n > MAX_LINES:
                long.append(f"{path.relative_to(ROOT)}: {n} lines")
    if long:
        pytest.fail(f"modules over {MAX_LINES} lines:\n" + "\n".join(long), pytrace=False)


def test_the_checker_sees_a_planted_cycle(tmp_path):
    files = {
        "ssr_compile/__init__.py": "",
        "ssr_compile/a.py": "import os\nfrom . import b\n",
        "ssr_compile/b.py": "def f():\n    from ssr_compile.sim import world\n",
        "ssr_compile/c.py": "from ssr_compile.belief import X\n",  # X: a re-export
        "ssr_compile/belief/__init__.py": "from .d import X\n",
        "ssr_compile/belief/d.py": "X = 1\nfrom .. import c\n",
        "sim/__init__.py": "",
        "sim/world.py": "\n\nfrom ..a import g\n",
        "sim/other.py": "from . import world\nfrom ssr_compile import sim\n",  # no cycle
    }
    for rel, text in files.items():
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_text(text)
    graph = import_graph(tmp_path, ("ssr_compile", "sim"))
    assert [describe(c, graph, tmp_path) for c in find_cycles(graph)] == [
        "ssr_compile.a (ssr_compile/a.py:2) -> ssr_compile.b (ssr_compile/b.py:2) -> "
        "ssr_compile.sim.world (sim/world.py:3) -> ssr_compile.a",
        "ssr_compile.belief (ssr_compile/belief/__init__.py:1) -> ssr_compile.belief.d "
        "(ssr_compile/belief/d.py:2) -> ssr_compile.c (ssr_compile/c.py:1) -> ssr_compile.belief",
    ]


# ---------------------------------------------------------------- the checkout's subpackages


def _package_dir() -> dict[str, str]:
    try:
        import tomllib
    except ModuleNotFoundError:  # Python 3.10
        import tomli as tomllib

    config = tomllib.loads((ROOT / "pyproject.toml").read_text())
    return config["tool"]["setuptools"]["package-dir"]


def test_the_mapped_folders_are_the_packages_pyproject_maps():
    import ssr_compile

    mapped = {f"ssr_compile.{name}": name for name in MAPPED}
    assert _package_dir() == mapped
    assert set(ssr_compile._MAPPED_FOLDERS) == set(MAPPED)


@pytest.mark.parametrize("name", [f"ssr_compile.{m}" for m in MAPPED])
def test_the_mapped_subpackages_import(name):
    import ssr_compile

    folder = Path(importlib.import_module(name).__file__).resolve().parent
    here = Path(ssr_compile.__file__).resolve().parent
    sub = name.split(".")[1]
    # the checkout's package: its top-level folder; an installed one: its own subfolder
    assert folder == (ROOT / sub if here == ROOT / "ssr_compile" else here / sub)


@pytest.mark.parametrize("name", ["tests", "bench", "tools"])
def test_other_top_level_folders_are_no_subpackages(name):
    assert f"ssr_compile.{name}" not in sys.modules
    with pytest.raises(ModuleNotFoundError):
        importlib.import_module(f"ssr_compile.{name}")


# A docstring or comment that cites a document of the repository (``docs/design.md §4``,
# ``tools/README.md``) names a file that exists; the first design document, DESIGN.md, is
# not in the repository and is cited by no one.
_CITED = re.compile(r"(?<![\w/])((?:docs|tools|bench|tests)/[\w./-]+\.md|README\.md|CHANGELOG\.md)")


def test_every_document_a_module_cites_exists():
    missing, design = [], []
    for folder in ("ssr_compile", "sim", "streams", "bench", "tools", "tests"):
        for path in sorted((ROOT / folder).rglob("*.py")):
            text = path.read_text(encoding="utf-8")
            rel = path.relative_to(ROOT)
            for number, line in enumerate(text.splitlines(), 1):
                for name in _CITED.findall(line):
                    if not (ROOT / name).exists():
                        missing.append(f"{rel}:{number}: {name}")
                if re.search(r"\bDESIGN(\.md| §)", line) and path.name != "test_imports.py":
                    if "not in" not in line:  # the README's own test asserts its absence
                        design.append(f"{rel}:{number}")
    assert missing == [], "cited documents that do not exist"
    assert design == [], "cites DESIGN, a document the repository does not hold"
