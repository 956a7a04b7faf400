"""The README's "Writing an environment" section points to a complete environment, whose files
docs/guide.md shows ("The doors example in full") and which are the shipped example
``domains/pddl/doors/`` word for word; that folder, copied to a folder of the user's own, runs
with ``ssr-compile run FOLDER``; and the README and ``run --help`` name every exit code ``run``
returns."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def section(title: str, doc: str = "README.md") -> str:
    text = (ROOT / doc).read_text(encoding="utf-8")
    start = text.index(f"## {title}\n")
    end = text.find("\n## ", start + 1)
    return text[start : end if end >= 0 else None]


def readme_files() -> dict[str, str]:
    """The guide's code blocks of the example by the file their first line names
    (``; domain.pddl``)."""
    files = {}
    doors = section("The doors example in full", "docs/guide.md")
    for block in re.findall(r"```\w*\n(.*?)```", doors, re.S):
        first, _, body = block.partition("\n")
        name = re.fullmatch(r"[;#] ([\w.]+)", first.strip())
        if name:
            files[name.group(1)] = block if name.group(1).endswith(".pddl") else body
    return files


def test_the_readme_shows_the_shipped_example_word_for_word():
    from ssr_compile.resources import domains_dir

    files = readme_files()
    assert set(files) == {"domain.pddl", "stream.pddl", "example.toml", "doors_env.py"}
    shipped = domains_dir() / "doors"
    assert sorted(p.name for p in shipped.iterdir() if p.is_file()) == sorted(files)
    for name, text in files.items():
        assert (shipped / name).read_text(encoding="utf-8") == text, name
    assert "..." not in files["doors_env.py"]  # complete, problem() included


@pytest.fixture(scope="module")
def doors(tmp_path_factory) -> Path:
    """The shipped folder copied to a folder of the user's own, as the README says."""
    from ssr_compile.resources import domains_dir

    folder = tmp_path_factory.mktemp("copied") / "doors"
    shutil.copytree(domains_dir() / "doors", folder, ignore=shutil.ignore_patterns("__pycache__"))
    return folder


def run(folder: Path, *args: str) -> subprocess.CompletedProcess:
    # No PYTHONPATH: the folder is self-contained, its module imports from it.
    return subprocess.run(
        [sys.executable, "-m", "ssr_compile.cli", "run", str(folder), *args],
        capture_output=True,
        text=True,
        cwd=folder.parent,
        timeout=300,
    )


def test_the_readme_environment_runs_from_its_own_folder(doors):
    opened = run(doors, "--seed", "0", "--json")
    assert opened.returncode == 0, opened.stderr
    doc = json.loads(opened.stdout)
    assert doc["success"] and not any(c["failed"] for c in doc["trace"])
    jammed = run(doors, "--seed", "2", "--json")
    assert jammed.returncode == 0, jammed.stderr
    doc = json.loads(jammed.stdout)
    first = doc["trace"][0]
    assert first["action"] == "(open a hall lab)" and first["failed"] is True
    assert first["failure"] == "door a is jammed" and first["observation"]["ok"] is False
    assert [c["action"].split()[1] for c in doc["trace"][1:] if c["action"]] == list("bbcc")


def test_an_agent_that_learns_nothing_from_the_failure_gives_up(doors, tmp_path):
    # The README: without the agent's lesson the same door is tried again and again from the
    # same state, until --max-failures.
    forgetful = tmp_path / "doors"
    forgetful.mkdir()
    for f in (f for f in doors.iterdir() if f.is_file()):
        text = f.read_text()
        if f.name == "doors_env.py":
            text = text.replace("self.jammed.add(step.args[0])", "pass")
        (forgetful / f.name).write_text(text)
    out = run(forgetful, "--seed", "2", "--max-failures", "2")
    assert out.returncode == 1, out.stderr
    assert "(open a hall lab) failed 2 times from the same state" in out.stdout.splitlines()[-1]


def test_every_exit_code_of_run_is_documented():
    from ssr_compile.cli.app import build_parser

    help_text = " ".join(
        build_parser()._subparsers._group_actions[0].choices["run"].description.split()
    )
    readme = " ".join(section("Commands").split())
    for code in ("0", "1", "2", "3", "128+N"):
        assert re.search(
            rf"\b{re.escape(code)} (when|on|success|bad|killed|no plan|code)", help_text + " "
        ), code
    run_paragraph = readme[
        readme.index("**`run TASK|FOLDER|NAME`**") : readme.index("**`experiment`**")
    ]
    for code in ("Exit 0", "1 when", "2 on bad input", "3 when code failed"):
        assert code in run_paragraph, code
    assert "environment's or agent's code" in readme  # the exit codes' list
