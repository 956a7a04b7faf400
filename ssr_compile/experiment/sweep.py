"""A sweep: the episodes not yet on file run by an executor, each appended to the journal as
it finishes, with a progress bar; the same sweep run again resumes."""

from __future__ import annotations

import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from ..errors import SSRError
from .executors import ProcessExecutor, RayExecutor
from .isolation import warm_fork_server
from .journal import FINISHED, Journal, latest, read_records
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
        records, bad = read_records(journal.path)
        if bad:
            say(f"{journal.path}: {bad} unreadable line(s) ignored (their episodes run again)")
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

        try:
            if todo:
                # The commit of the code the episodes run: read now, as the fork server loads
                # it (read at the first record, it named a commit made while the sweep ran).
                provenance()
                warm_fork_server(s.task for s in todo)
                executor.run(todo, str(out / "logs") if keep_logs else None, on_result)
        finally:
            if bar:
                bar.close()
    return SweepOutcome(ran, skipped, ok, records)
