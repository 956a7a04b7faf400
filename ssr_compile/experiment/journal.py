"""``DIR/episodes.jsonl``: one JSON line per finished episode (:func:`make_record`), appended
and flushed as it finishes (:class:`Journal`), read back for resuming and for the report."""

from __future__ import annotations

import json
import math
import os
import socket
import time
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..errors import SSRError
from .revision import provenance
from .spec import EpisodeSpec

EPISODES_FILE = "episodes.jsonl"

# Outcome kinds of an episode (the ``status`` field of its JSON line).
FINISHED = "finished"  # the policy ran to its end (success or not)
CRASHED = "crashed"  # an exception, os._exit or a signal in the episode's process
TIMEOUT = "timeout"  # killed at its wall limit
OOM = "oom"  # out of memory (MemoryError, or killed by the kernel)
HARNESS = "harness"  # the executor itself lost the episode (e.g. a Ray worker died)


def make_record(
    spec: EpisodeSpec, status: str, payload: Any, wall: float, log_path: str | None = None
) -> dict:
    """One JSON line: identity, outcome, the policy's counts, times, provenance."""
    rec: dict[str, Any] = {
        "task": spec.task.label,
        "variant": spec.variant,
        "seed": spec.seed,
        "example": Path(spec.task.folder).name,
        "problem": spec.task.problem,
        "status": status,
        "success": False,
        "failure": None,
        "planning_time": None,
        "cycles": None,
        "constrained_held": None,
        "fallbacks": None,
        "stream_calls": None,
        "planner_calls": None,
    }
    if status == FINISHED:
        res = dict(payload)
        rec.update(res)
        rec["status"] = FINISHED
        if not res["success"]:
            rec["failure"] = res["reason"] + (
                "; the goal belief was reached but the goal does not hold in the true state"
                if res.get("believed")
                else ""
            )
    else:
        rec["failure"] = f"{status}: {payload}"
    rec["wall_time"] = round(wall, 4)
    rec["settings"] = spec.settings.policy_key()
    rec["wall_limit"] = spec.settings.wall
    rec["memory_mb"] = spec.settings.memory_mb
    rec.update(provenance())
    rec["host"] = socket.gethostname()
    rec["log"] = log_path
    rec["finished_at"] = time.strftime("%Y-%m-%dT%H:%M:%S%z")
    return rec


@dataclass(frozen=True)
class SkippedLine:
    """A line of ``episodes.jsonl`` that is not an episode's record, and why."""

    line: int  # 1-based
    reason: str


def _number(value, whole: bool) -> bool:
    if isinstance(value, bool):
        return False
    if whole:
        return isinstance(value, int) and value >= 0
    return isinstance(value, (int, float)) and math.isfinite(value) and value >= 0


# What the report and a resumed sweep read of a record: field -> (check, what is expected).
# A field absent or null is allowed, but for the three that name the episode.
_FIELDS = {
    "task": (lambda v: isinstance(v, str) and v != "", "a task name (text)"),
    "variant": (lambda v: isinstance(v, str) and v != "", "a variant name (text)"),
    "seed": (lambda v: _number(v, True), "a whole number >= 0"),
    "status": (lambda v: isinstance(v, str), "text"),
    "success": (lambda v: isinstance(v, bool), "true or false"),
    "failure": (lambda v: isinstance(v, str), "text"),
    "planning_time": (lambda v: _number(v, False), "a number of seconds >= 0"),
    "wall_time": (lambda v: _number(v, False), "a number of seconds >= 0"),
    "cycles": (lambda v: _number(v, True), "a whole number >= 0"),
    "constrained_held": (lambda v: _number(v, True), "a whole number >= 0"),
    "fallbacks": (lambda v: _number(v, True), "a whole number >= 0"),
    "commit": (lambda v: isinstance(v, str), "text"),
    "settings": (
        lambda v: _settings_ok(v),
        "an object with budget, max_cycles, constrained_time, unconstrained_time, planner",
    ),
}
_IDENTITY = ("task", "variant", "seed")
_SETTINGS = {
    "budget": False,
    "max_cycles": True,
    "constrained_time": False,
    "unconstrained_time": False,
}


def _settings_ok(value) -> bool:
    if not isinstance(value, dict) or not isinstance(value.get("planner"), str):
        return False
    return all(_number(value.get(k), whole) for k, whole in _SETTINGS.items())


def record_problem(rec) -> str | None:
    """Why a parsed JSON line is not an episode's record (None: it is one)."""
    if not isinstance(rec, dict):
        return f"not a JSON object but {type(rec).__name__}"
    for name, (check, expected) in _FIELDS.items():
        value = rec.get(name)
        if value is None:
            if name in _IDENTITY:
                return f"no '{name}' (expected {expected})"
            continue
        if not check(value):
            shown = json.dumps(value)
            shown = shown if len(shown) <= 40 else shown[:37] + "..."
            return f"'{name}' is {shown} (expected {expected})"
    return None


def read_records(path: Path) -> tuple[list[dict], list[SkippedLine]]:
    """The records of ``path`` (a missing file: none) and the lines skipped: cut short by a
    killed sweep (not JSON), or JSON that is not a record the report can read (a field of the
    wrong type, e.g. ``"seed": "x"``; see :func:`record_problem`)."""
    records: list[dict] = []
    skipped: list[SkippedLine] = []
    if not path.exists():
        return records, skipped
    with open(path, encoding="utf-8", errors="replace") as f:
        for number, line in enumerate(f, 1):
            line = line.strip()
            if not line:
                continue
            try:
                rec = json.loads(line)
            except (json.JSONDecodeError, RecursionError):
                skipped.append(SkippedLine(number, "not a complete JSON line"))
                continue
            problem = record_problem(rec)
            if problem is None:
                records.append(rec)
            else:
                skipped.append(SkippedLine(number, problem))
    return records, skipped


def describe_skipped(path: Path, skipped: list[SkippedLine], what: str, most: int = 10) -> str:
    """``PATH: 2 line(s) skipped (WHAT):`` and a ``PATH:LINE: why`` line for each (at most
    ``most``, then how many more)."""
    lines = [f"{path}: {len(skipped)} unreadable line(s) skipped ({what}):"]
    lines += [f"{path}:{s.line}: {s.reason}" for s in skipped[:most]]
    if len(skipped) > most:
        lines.append(f"{path}: and {len(skipped) - most} more")
    return "\n".join(lines)


def latest(records: Iterable[dict]) -> dict[tuple[str, str, int], dict]:
    """One record per (task, variant, seed): the last on file."""
    out: dict[tuple[str, str, int], dict] = {}
    for r in records:
        out[(r["task"], r["variant"], int(r["seed"]))] = r
    return out


class Journal:
    """``DIR/episodes.jsonl``, appended and flushed one line per finished episode, under a
    lock so that two sweeps never write the same folder."""

    def __init__(self, out_dir: Path):
        self.dir = out_dir
        self.path = out_dir / EPISODES_FILE
        self._lock_file = None
        self._file = None

    def __enter__(self) -> Journal:
        import fcntl

        try:
            self.dir.mkdir(parents=True, exist_ok=True)
        except (FileExistsError, NotADirectoryError):
            raise SSRError(
                "is not a folder (the sweep's output goes into it)", file=str(self.dir)
            ) from None
        except OSError as e:
            raise SSRError(f"cannot create the folder: {e.strerror}", file=str(self.dir)) from None
        try:
            self._lock_file = open(self.dir / ".lock", "w")  # noqa: SIM115
        except OSError as e:
            raise SSRError(
                f"cannot write into the folder: {e.strerror}", file=str(self.dir)
            ) from None
        try:
            fcntl.flock(self._lock_file, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            self._lock_file.close()
            raise SSRError(
                "another sweep is writing this folder (wait for it or choose another -o)",
                file=str(self.dir),
            ) from None
        if self.path.exists() and not self.path.is_file():
            raise SSRError("is not a regular file", file=str(self.path))
        needs_newline = False
        if self.path.exists() and self.path.stat().st_size:
            with open(self.path, "rb") as f:
                f.seek(-1, os.SEEK_END)
                needs_newline = f.read(1) != b"\n"
        self._file = open(self.path, "a", encoding="utf-8")  # noqa: SIM115
        if needs_newline:  # a line cut short by a killed sweep stays on its own
            self._file.write("\n")
        return self

    def append(self, record: dict) -> None:
        self._file.write(json.dumps(record, sort_keys=False) + "\n")
        self._file.flush()
        os.fsync(self._file.fileno())

    def __exit__(self, *exc) -> None:
        if self._file:
            self._file.close()
        if self._lock_file:
            self._lock_file.close()
