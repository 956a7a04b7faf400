"""The tree is ruff-clean: ``ruff check .`` and ``ruff format --check .`` from the repository
root pass, with the settings of pyproject.toml's ``[tool.ruff]``."""

from __future__ import annotations

import subprocess
import sys

import pytest
from importscan import ROOT


@pytest.mark.parametrize("command", [["check"], ["format", "--check"]], ids=["check", "format"])
def test_ruff(command):
    done = subprocess.run(
        [sys.executable, "-m", "ruff", *command, "--no-cache", "."],
        cwd=ROOT,
        capture_output=True,
        text=True,
    )
    if done.returncode != 0:
        shown = " ".join(["ruff", *command, "."])
        pytest.fail(f"{shown} failed:\n{done.stdout}{done.stderr}", pytrace=False)
