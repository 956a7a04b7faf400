"""A sweep: the episodes not yet on file run by an executor, each appended to the journal as
it finishes, with a progress bar; the same sweep run again resumes."""

from __future__ import annotations

import fcntl
import os
import shutil
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from ..errors import SSRError
from .executors import ProcessExecutor, RayExecutor
from .isolation import warm_fork_server
from .journal import FINISHED, Journal, describe_skipped, latest, read_records
from .revision import provenance
from .spec import EpisodeSpec


@dataclass
class SweepOutcome:
    ran: int
    skipped: int
    successes: int  # among the episodes run now
    records: list[dict]  # every record on file after the sweep


def check_resumable(existing: dict[tuple[str, str, int], dict], specs: list[EpisodeSpec]) -> None:
    """Episodes on file that this sweep would reuse must have been run with its settings."""
    for spec in specs:
        rec = existing.get(spec.key)
        if rec is None:
            continue
        theirs = rec.get("settings")
        ours = spec.settings.policy_key()
        if theirs is not None and theirs != ours:
            diff = ", ".join(
                f"{k} {theirs.get(k)!r} (this run: {ours[k]!r})"
                for k in ours
                if theirs.get(k) != ours[k]
            )
            raise SSRError(
                f"the episodes on file were run with other settings: {diff}; run with the same "
                "settings to resume, or choose another -o folder"
            )


def run_sweep(
    out_dir: str | Path,
    specs: list[EpisodeSpec],
    executor: ProcessExecutor | RayExecutor,
    *,
    progress: bool = True,
    keep_logs: bool = True,
    say: Callable[[str], None] | None = None,
) -> SweepOutcome:
    """Run the episodes of ``specs`` not yet in ``out_dir/episodes.jsonl``; append each as it
    finishes; show a progress bar."""
    out = Path(out_dir)
    say = say or (lambda msg: print(msg, file=sys.stderr, flush=True))
    with Journal(out) as journal:
        records, skipped = read_records(journal.path)
        if skipped:
            say(describe_skipped(journal.path, skipped, "their episodes run again"))
        existing = latest(records)
        check_resumable(existing, specs)
        todo = [s for s in specs if s.key not in existing]
        skipped = len(specs) - len(todo)
        if skipped:
            say(
                f"resuming: {skipped} of {len(specs)} episodes already in {journal.path}; "
                f"{len(todo)} to run"
            )
        ran = ok = 0
        bar = None
        if progress and todo:
            from tqdm import tqdm

            bar = tqdm(
                total=len(todo),
                unit="ep",
                file=sys.stderr,
                dynamic_ncols=True,
                desc="episodes",
                smoothing=0.1,
            )
            bar.set_postfix_str("success 0/0")

        def on_result(rec: dict) -> None:
            nonlocal ran, ok
            journal.append(rec)
            records.append(rec)
            ran += 1
            ok += bool(rec.get("success"))
            if rec["status"] != FINISHED:
                line = f"{rec['task']}/{rec['variant']}/seed {rec['seed']}: {rec['failure']}"
                (bar.write if bar else say)(line)
            if bar:
                bar.set_postfix_str(f"success {ok}/{ran}", refresh=False)
                bar.update(1)

        # The episodes' temporary folders (their planners', the robot's files), and a local
        # Ray's, go into one folder of the sweep's, removed however the sweep ends (an
        # interrupted sweep kills its episodes before they could remove their own).
        tmp_root, tmp_lock = _make_tmp_root() if todo else (None, None)
        try:
            if todo:
                # The commit of the code the episodes run: read now, as the fork server loads
                # it (read at the first record, it named a commit made while the sweep ran).
                provenance()
                warm_fork_server(s.task for s in todo)
                executor.run(todo, str(out / "logs") if keep_logs else None, on_result, tmp_root)
        finally:
            if bar:
                bar.close()
            if tmp_root:
                _remove_folder(tmp_root)
                os.close(tmp_lock)
    return SweepOutcome(ran, skipped, ok, records)


_TMP_PREFIX = "ssr-sweep-"
_TMP_LOCK = ".sweep.lock"


def _make_tmp_root() -> tuple[str, int]:
    """A temporary folder for the sweep, locked while the sweep runs; first, the folders of
    sweeps that were killed (SIGKILL, the kernel's out-of-memory killer) are removed: their
    locks are free."""
    _remove_stale_tmp_roots()
    root = tempfile.mkdtemp(prefix=_TMP_PREFIX)
    fd = os.open(os.path.join(root, _TMP_LOCK), os.O_WRONLY | os.O_CREAT, 0o600)
    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    return root, fd


def _remove_stale_tmp_roots(min_age: float = 60.0) -> None:
    for folder in Path(tempfile.gettempdir()).glob(_TMP_PREFIX + "*"):
        try:
            if time.time() - folder.stat().st_mtime < min_age:
                continue  # perhaps a sweep that is just starting
            fd = os.open(folder / _TMP_LOCK, os.O_WRONLY)
        except OSError:
            continue  # not a sweep's folder, or not ours to open
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            continue  # a sweep that runs
        else:
            shutil.rmtree(folder, ignore_errors=True)
        finally:
            os.close(fd)


def _remove_folder(folder: str) -> None:
    """Remove ``folder`` and what is in it (again for a moment, if processes that are being
    stopped still write into it)."""
    for _ in range(20):
        shutil.rmtree(folder, ignore_errors=True)
        if not os.path.lexists(folder):
            return
        time.sleep(0.1)
