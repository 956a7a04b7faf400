"""The layers point one way: ssr_compile (toolkit) <- sim/ (the world) <- streams/ (bindings).

Reads every import statement (in-function imports included) of the checkout's ``sim/`` and
``ssr_compile/`` and resolves relative imports, so a forbidden arrow cannot hide.
"""

from __future__ import annotations

import pytest
from importscan import ROOT, imported_modules


def _violations(folder: str, forbidden: tuple[str, ...]) -> list[str]:
    bad = []
    for path in sorted((ROOT / folder).rglob("*.py")):
        for line, name in imported_modules(path):
            top = name.split(".")
            if any(name == f or name.startswith(f + ".") for f in forbidden) or top[0] in (
                "sim",
                "streams",
            ):
                bad.append(f"{path.relative_to(ROOT)}:{line}: imports {name}")
    return bad


def test_sim_never_imports_streams():
    assert _violations("sim", ("ssr_compile.streams",)) == []


def test_toolkit_imports_neither_sim_nor_streams_at_module_level_of_core():
    # The toolkit's core (language, compiler, planners, solver, belief, policy) never imports
    # the world or the bindings; only the CLI's simulator commands may (inside functions).
    cli = ROOT / "ssr_compile" / "cli"
    core = [p for p in (ROOT / "ssr_compile").rglob("*.py") if cli not in p.parents]
    bad = []
    for path in core:
        for line, name in imported_modules(path):
            if name.startswith(("ssr_compile.sim", "ssr_compile.streams")) or name.split(".")[
                0
            ] in ("sim", "streams"):
                bad.append(f"{path.relative_to(ROOT)}:{line}: imports {name}")
    assert bad == []


def test_nothing_imports_the_generic_top_level_names():
    bad = []
    for folder in ("sim", "streams", "ssr_compile", "tests", "bench"):
        for path in (ROOT / folder).rglob("*.py"):
            for line, name in imported_modules(path):
                if name.split(".")[0] in ("sim", "streams"):
                    bad.append(f"{path.relative_to(ROOT)}:{line}: imports {name}")
    assert bad == []


def test_the_checker_sees_a_planted_forbidden_import(tmp_path, monkeypatch):
    planted = ROOT / "sim" / "_planted_for_test.py"
    planted.write_text("def f():\n    from ..streams import tamp2d\n    return tamp2d\n")
    try:
        assert _violations("sim", ("ssr_compile.streams",)) == [
            "sim/_planted_for_test.py:2: imports ssr_compile.streams"
        ]
    finally:
        planted.unlink()


@pytest.mark.parametrize("name", ["ssr_compile.sim.world", "ssr_compile.streams.tamp2d"])
def test_subpackages_import_under_the_toolkit_name(name):
    import importlib

    assert importlib.import_module(name).__name__ == name
