"""What `pip install .` installs: every package of the checkout, mapped as pyproject.toml says.

A package left out of ``[tool.setuptools] packages`` imports from a checkout (the tests run
there) but is missing from an installed copy, where ``ssr-compile`` would fail at its import.
"""

from __future__ import annotations

import sys
from pathlib import Path

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

ROOT = Path(__file__).resolve().parent.parent
CONFIG = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]


def _packages_on_disk() -> set[str]:
    roots = {"ssr_compile": ROOT / "ssr_compile"}
    roots.update({name: ROOT / folder for name, folder in CONFIG["package-dir"].items()})
    found = set()
    for name, folder in roots.items():
        for init in folder.rglob("__init__.py"):
            rel = init.parent.relative_to(folder).parts
            found.add(".".join((name, *rel)))
    return found


def test_every_package_of_the_checkout_is_installed():
    missing = _packages_on_disk() - set(CONFIG["packages"])
    assert not missing, f"add to [tool.setuptools] packages in pyproject.toml: {sorted(missing)}"


def test_every_installed_package_exists():
    listed = set(CONFIG["packages"])
    assert listed - _packages_on_disk() == set()
