"""``DIR/episodes.jsonl``: one JSON line per finished episode (:func:`make_record`), appended
and flushed as it finishes (:class:`Journal`), read back for resuming and for the report."""

from __future__ import annotations

import json
import os
import socket
import time
from collections.abc import Iterable
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


def read_records(path: Path) -> tuple[list[dict], int]:
    """The JSON lines of ``path`` (a missing file: none) and how many lines were unreadable
    (a line cut short by a killed sweep)."""
    records, bad = [], 0
    if not path.exists():
        return records, bad
    with open(path, encoding="utf-8") as f:
        for line in f:
            line = line.strip()
            if not line:
                continue
            try:
                rec = json.loads(line)
            except json.JSONDecodeError:
                bad += 1
                continue
            if isinstance(rec, dict) and {"task", "variant", "seed"} <= rec.keys():
                records.append(rec)
            else:
                bad += 1
    return records, bad


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
