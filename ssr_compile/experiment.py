"""Table I of the paper (§VIII): sweeps of the online policy over tasks × variants × seeds.

A sweep runs every episode (one task, one variant, one seed) **in a process of its own**: a
crash (an exception, ``os._exit``, a signal), a hang past the episode's wall limit or running
out of memory is recorded as a failure with its reason, and the sweep goes on.  Each finished
episode is one JSON line of ``DIR/episodes.jsonl``, written and flushed as it finishes; the
same sweep run again resumes (episodes already on file are not re-run).  ``DIR/table.md`` and
``DIR/table1.png`` are rebuilt from the JSON lines alone (:func:`write_report`).

Executors: ``process`` (local processes, ``workers`` at a time) and ``ray`` (the episodes as
tasks of Ray, on a local instance or a cluster; each task runs its episode in a process of its
own in the same way, so failures are recorded alike).

Per episode the child process is forked from a *fork server* that has already imported the
toolkit (multiprocessing's ``forkserver``), so the harness's overhead is a fork, not a Python
start and its imports.
"""

from __future__ import annotations

import json
import math
import os
import signal
import sys
import threading
import time
import traceback
import zlib
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Any

from .errors import SSRError
from .planners.proc import _descendants

VARIANTS = ("neither", "constraints", "deferred", "both")  # Table I's column order
KITCHEN_TASKS = ("inspect", "stow", "swap", "cook")  # Table I's row order

# Table I of the paper: task -> variant -> (success %, mean planning time of successes, s).
PAPER_TABLE1: dict[str, dict[str, tuple[float, float]]] = {
    "inspect": {
        "neither": (96, 41),
        "constraints": (100, 45),
        "deferred": (100, 32),
        "both": (100, 26),
    },
    "stow": {
        "neither": (80, 124),
        "constraints": (88, 226),
        "deferred": (88, 92),
        "both": (88, 108),
    },
    "swap": {
        "neither": (52, 190),
        "constraints": (40, 484),
        "deferred": (60, 105),
        "both": (80, 232),
    },
    "cook": {
        "neither": (20, 375),
        "constraints": (40, 406),
        "deferred": (56, 249),
        "both": (100, 203),
    },
}
PAPER_EPISODES = 25  # problems per task in the paper

EPISODES_FILE = "episodes.jsonl"
TABLE_FILE = "table.md"
PLOT_FILE = "table1.png"

# Outcome kinds of an episode (the ``status`` field of its JSON line).
FINISHED = "finished"  # the policy ran to its end (success or not)
CRASHED = "crashed"  # an exception, os._exit or a signal in the episode's process
TIMEOUT = "timeout"  # killed at its wall limit
OOM = "oom"  # out of memory (MemoryError, or killed by the kernel)
HARNESS = "harness"  # the executor itself lost the episode (e.g. a Ray worker died)


# ---------------------------------------------------------------- parsing the sweep


@dataclass(frozen=True)
class Task:
    """One row of the table: an example folder with an environment and one of its problems."""

    label: str  # as given on the command line (``inspect``, ``progress``, ``belief-detect:clear``)
    folder: str  # the example folder, absolute
    problem: str | None

    @property
    def title(self) -> str:
        return self.label.capitalize() if self.label in KITCHEN_TASKS else self.label


def parse_seeds(text: str) -> list[int]:
    """``0-24``, ``0,3,5``, ``0-4,10-12`` -> the seeds in order, without repeats."""
    seeds: list[int] = []
    if not text.strip():
        raise SSRError("--seeds: empty; expected a range such as 0-24 or a list such as 0,3,5")
    for part in text.split(","):
        part = part.strip()
        lo, dash, hi = part.partition("-")
        try:
            if dash:
                a, b = int(lo), int(hi)
            else:
                a = b = int(part)
        except ValueError:
            raise SSRError(
                f"--seeds: '{part}' is not a seed or a range of seeds "
                "(expected e.g. 0-24 or 0,3,5; seeds are whole numbers >= 0)"
            ) from None
        if a < 0 or b < 0:
            raise SSRError(f"--seeds: '{part}': seeds are whole numbers >= 0")
        if b < a:
            raise SSRError(f"--seeds: '{part}' is an empty range (its end is below its start)")
        if b >= 2**32:
            raise SSRError(f"--seeds: '{part}': seeds are below 2**32")
        seeds.extend(s for s in range(a, b + 1) if s not in seeds)
    return seeds


def parse_variants(text: str) -> list[str]:
    names = [v.strip().lower() for v in text.split(",") if v.strip()]
    if not names:
        raise SSRError(f"--variants: empty; expected some of {','.join(VARIANTS)}")
    for v in names:
        if v not in VARIANTS:
            raise SSRError(
                f"--variants: unknown variant '{v}'; expected some of {','.join(VARIANTS)}"
            )
    return list(dict.fromkeys(names))


def kitchen_has_environment() -> bool:
    """Whether the kitchen example names a closed-loop environment (then Table I's tasks are
    the default of ``--tasks``)."""
    try:
        from .examples import read_settings, resolve_folder

        folder = resolve_folder("kitchen")
        return folder is not None and bool(read_settings(folder).environment)
    except SSRError:
        return False


def parse_tasks(text: str) -> list[Task]:
    """``inspect,stow`` (kitchen tasks), ``progress``, ``belief-detect:clear`` (an example with
    an environment, ``:PROBLEM`` optional), or an example folder's path."""
    tasks: list[Task] = []
    names = [t.strip() for t in text.split(",") if t.strip()]
    if not names:
        raise SSRError("--tasks: empty; expected e.g. inspect,stow,swap,cook or progress")
    for name in names:
        tasks.append(resolve_task(name))
    labels = [t.label for t in tasks]
    dup = next((x for x in labels if labels.count(x) > 1), None)
    if dup:
        raise SSRError(f"--tasks: '{dup}' is named twice")
    return tasks


def resolve_task(name: str) -> Task:
    from .examples import resolve_folder

    if name.lower() in KITCHEN_TASKS:
        target, problem = "kitchen", name.lower()
        label = name.lower()
    else:
        target, problem = name, None
        if ":" in name and not Path(name).exists():
            target, problem = name.rsplit(":", 1)
            problem = problem or None
        label = name
    folder = resolve_folder(target)
    if folder is None:
        known = ", ".join(KITCHEN_TASKS)
        raise SSRError(
            f"--tasks: unknown task '{name}'; expected a kitchen task ({known}), a shipped "
            "example with an environment (progress, belief-detect[:PROBLEM]) or an example "
            "folder"
        )
    task = Task(label, str(folder.resolve()), problem)
    try:
        load_task(task)
    except SSRError as e:
        raise SSRError(f"--tasks: '{name}': {e.message}") from None
    return task


def load_task(task: Task):
    """(example, environment factory) of a task; an example folder that is not shipped is put
    on ``sys.path`` first, so that its environment module may sit beside its files."""
    from .examples import load_example
    from .resources import domains_dir

    folder = Path(task.folder)
    if folder.parent.resolve() != domains_dir().resolve() and str(folder) not in sys.path:
        sys.path.insert(0, str(folder))
    example = load_example(folder)
    return example, example.environment_factory()


@dataclass(frozen=True)
class Settings:
    """What every episode of a sweep shares (stored in each JSON line: a resumed sweep must
    use the same)."""

    budget: float = 600.0  # planning time per episode, s (the paper's 10 minutes)
    max_cycles: int = 100
    constrained_time: float = 30.0
    unconstrained_time: float = 300.0
    planner: str = "fd"
    wall_limit: float | None = None  # s; None: 2 × budget + 120
    memory_mb: int = 4096  # address-space limit of an episode's process; 0: none

    @property
    def wall(self) -> float:
        return self.wall_limit if self.wall_limit is not None else 2 * self.budget + 120

    def policy_key(self) -> dict:
        """The settings that change an episode's outcome (compared on resume)."""
        return {
            "budget": self.budget,
            "max_cycles": self.max_cycles,
            "constrained_time": self.constrained_time,
            "unconstrained_time": self.unconstrained_time,
            "planner": self.planner,
        }


@dataclass(frozen=True)
class EpisodeSpec:
    task: Task
    variant: str
    seed: int
    settings: Settings = field(default_factory=Settings)

    @property
    def key(self) -> tuple[str, str, int]:
        return (self.task.label, self.variant, self.seed)

    def name(self) -> str:
        return f"{self.task.label}/{self.variant}/seed {self.seed}"


def episode_specs(
    tasks: list[Task], variants: list[str], seeds: list[int], settings: Settings
) -> list[EpisodeSpec]:
    """Seed-major order, so that a partial sweep has every cell of the table about equally far."""
    return [EpisodeSpec(t, v, s, settings) for s in seeds for t in tasks for v in variants]


# ---------------------------------------------------------------- one episode, isolated


@lru_cache(maxsize=1)
def provenance() -> dict:
    """The toolkit's version and, from a git checkout, its commit (with ``dirty`` when the
    working tree differs from it)."""
    import subprocess

    from . import __version__

    out: dict[str, Any] = {"version": __version__, "commit": None, "dirty": None}
    root = Path(__file__).resolve().parent.parent
    try:
        head = subprocess.run(
            ["git", "-C", str(root), "rev-parse", "HEAD"],
            capture_output=True,
            text=True,
            timeout=10,
        )
        if head.returncode == 0:
            out["commit"] = head.stdout.strip()
            status = subprocess.run(
                ["git", "-C", str(root), "status", "--porcelain", "--untracked-files=no"],
                capture_output=True,
                text=True,
                timeout=10,
            )
            out["dirty"] = bool(status.stdout.strip()) if status.returncode == 0 else None
    except (OSError, subprocess.SubprocessError):
        pass
    return out


def run_episode_here(spec: EpisodeSpec) -> dict:
    """Build the episode's world and run the policy in *this* process (what the child does)."""
    from .policy import PolicySettings, run_policy

    s = spec.settings
    settings = PolicySettings(
        variant=spec.variant,
        budget=s.budget,
        constrained_time=s.constrained_time,
        unconstrained_time=s.unconstrained_time,
        max_cycles=s.max_cycles,
        planner=s.planner,
    )
    t0 = time.monotonic()
    _example, factory = load_task(spec.task)
    episode = factory(spec.task.problem, spec.seed)
    build = time.monotonic() - t0
    try:
        # One line per cycle in the episode's log (DIR/logs/), to read why an episode failed.
        result = run_policy(episode, settings, on_cycle=lambda c: print(c.line(), flush=True))
        print(f"outcome: {result.reason}; success {result.success}", flush=True)
    finally:
        episode.close()
    out = result.as_dict()
    out["episode_time"] = out.pop("wall_time")
    out["build_time"] = round(build, 4)
    return out


def _child(spec: EpisodeSpec, conn, log_path: str | None, started: float) -> None:
    """The episode's process: its own session (so the whole tree can be killed), output to
    its log, an address-space limit; sends ``(status, payload)`` back."""
    entered = time.time()
    try:
        os.setsid()
    except OSError:
        pass
    _die_with_parent()
    for name in ("SIGTERM", "SIGHUP", "SIGINT"):
        signal.signal(getattr(signal, name), signal.SIG_DFL)
    if log_path:
        fd = os.open(log_path, os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o644)
        os.dup2(fd, 1)
        os.dup2(fd, 2)
        os.close(fd)
    if spec.settings.memory_mb > 0:
        import resource

        limit = spec.settings.memory_mb * 2**20
        _soft, hard = resource.getrlimit(resource.RLIMIT_AS)
        if hard != resource.RLIM_INFINITY:
            limit = min(limit, hard)
        resource.setrlimit(resource.RLIMIT_AS, (limit, hard))
    start_time = entered - started
    try:
        record = run_episode_here(spec)
        record["start_time"] = round(start_time, 4)
        record["cpu_time"] = _cpu_time()
        msg = (FINISHED, record)
    except MemoryError:
        traceback.print_exc()
        msg = (OOM, "out of memory (MemoryError in the episode's process)")
    except BaseException as e:  # noqa: BLE001 - everything is the episode's failure
        traceback.print_exc()
        text = str(e).strip().splitlines()
        msg = (CRASHED, f"{type(e).__name__}: {text[0] if text else ''}".rstrip(": "))
    sys.stdout.flush()
    sys.stderr.flush()
    try:
        conn.send(msg)
    except Exception:  # noqa: BLE001 - the parent is gone or the result does not pickle
        pass
    conn.close()


def _die_with_parent() -> None:
    """Linux: be killed when the fork server that made us exits (it exits when the sweep's
    process does, even on SIGKILL), so that no episode outlives its sweep."""
    if not sys.platform.startswith("linux"):
        return
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        parent = os.getppid()
        libc.prctl(1, int(signal.SIGKILL))  # PR_SET_PDEATHSIG
        if os.getppid() != parent:  # it is gone already
            os._exit(1)
    except (OSError, AttributeError):
        return
    # The fork server lives on while any of its children holds its "alive" pipe (each child
    # inherits one); let ours go, so that the server exits with the sweep, and we with it.
    try:
        from multiprocessing import forkserver

        server = forkserver._forkserver
        fd = server._forkserver_alive_fd
        if fd is not None:
            os.close(fd)
            server._forkserver_alive_fd = None
    except (AttributeError, OSError):
        pass


def _cpu_time() -> float | None:
    """CPU seconds (user + system) of this process since its fork, and of the children it
    waited for (planners)."""
    try:
        import resource

        me = resource.getrusage(resource.RUSAGE_SELF)
        kids = resource.getrusage(resource.RUSAGE_CHILDREN)
        return round(me.ru_utime + me.ru_stime + kids.ru_utime + kids.ru_stime, 3)
    except (ImportError, OSError):  # pragma: no cover - not POSIX
        return None


_PRELOAD = ["ssr_compile.policy", "ssr_compile.focused", "numpy", "ssr_compile.experiment"]
_WARM = "SSR_EXPERIMENT_WARM"  # example folders whose files and modules the fork server loads


@lru_cache(maxsize=1)
def _context():
    import multiprocessing as mp

    if "forkserver" in mp.get_all_start_methods():
        ctx = mp.get_context("forkserver")
        ctx.set_forkserver_preload(_PRELOAD)
        return ctx
    return mp.get_context("spawn")  # pragma: no cover - not on Linux


def warm_fork_server(tasks: Iterable[Task]) -> None:
    """Start the fork server now, having it parse these tasks' examples and import their
    environment modules once, so that each episode's process starts with them loaded.  No
    effect once the server runs."""
    if _context().get_start_method() != "forkserver":
        return  # pragma: no cover - not on Linux
    from multiprocessing import forkserver

    folders = sorted({t.folder for t in tasks})
    with _WARM_LOCK:
        old = os.environ.get(_WARM)
        os.environ[_WARM] = json.dumps(folders)  # read by the server's preload of this module
        try:
            forkserver.ensure_running()
        finally:
            if old is None:
                os.environ.pop(_WARM, None)
            else:
                os.environ[_WARM] = old


_WARM_LOCK = threading.Lock()


def _warm_from_environment() -> None:
    """In the fork server (this module is preloaded there): load what ``warm_fork_server``
    named.  Never raises: a failure here shows in the episode instead."""
    names = os.environ.get(_WARM)
    if not names or "multiprocessing.forkserver" not in sys.modules:
        return
    try:
        for folder in json.loads(names):
            try:
                load_task(Task(folder, folder, None))
            except BaseException:  # noqa: BLE001
                pass
    except BaseException:  # noqa: BLE001
        pass


class _Active:
    """The episode processes running now (so that an interrupted sweep kills them)."""

    def __init__(self):
        self.lock = threading.Lock()
        self.pids: set[int] = set()
        self.closed = False  # set by kill_all: episodes that start later are killed at once

    def open(self) -> None:
        with self.lock:
            self.closed = False

    def add(self, pid: int) -> bool:
        with self.lock:
            if not self.closed:
                self.pids.add(pid)
                return True
        kill_tree(pid)
        return False

    def kill_all(self) -> None:
        with self.lock:
            self.closed = True
            pids = list(self.pids)
        for pid in pids:
            kill_tree(pid)


ACTIVE = _Active()


def kill_tree(pid: int) -> None:
    """Kill ``pid``'s process group and every process below it (planners that start their
    own sessions included)."""
    below = _descendants(pid)
    for p in [pid, *below]:
        try:
            os.killpg(p, signal.SIGKILL)
        except (ProcessLookupError, PermissionError):
            try:
                os.kill(p, signal.SIGKILL)
            except (ProcessLookupError, PermissionError):
                pass


def _exit_reason(exitcode: int | None) -> tuple[str, str]:
    if exitcode is None:
        return CRASHED, "the episode's process ended without a result"
    if exitcode < 0:
        try:
            name = signal.Signals(-exitcode).name
        except ValueError:
            name = f"signal {-exitcode}"
        if -exitcode == signal.SIGKILL:
            return OOM, f"killed by {name} (out of memory?)"
        return CRASHED, f"killed by {name}"
    return CRASHED, f"the episode's process exited with code {exitcode} without a result"


def run_isolated(spec: EpisodeSpec, log_dir: str | None = None) -> dict:
    """Run one episode in a process of its own and return its JSON record (never raises for
    the episode's failures: they are the record's ``status`` and ``failure``)."""
    ctx = _context()
    log_path = None
    if log_dir:
        Path(log_dir).mkdir(parents=True, exist_ok=True)
        safe = "".join(c if c.isalnum() or c in "-_." else "_" for c in spec.task.label)
        log_path = str(Path(log_dir) / f"{safe}-{spec.variant}-{spec.seed}.log")
        Path(log_path).unlink(missing_ok=True)
    reader, writer = ctx.Pipe(duplex=False)
    t0 = time.monotonic()
    started = time.time()
    proc = ctx.Process(target=_child, args=(spec, writer, log_path, started), daemon=False)
    proc.start()
    writer.close()
    ACTIVE.add(proc.pid)
    status, payload = None, None
    try:
        deadline = t0 + spec.settings.wall
        if reader.poll(max(deadline - time.monotonic(), 0)):
            try:
                status, payload = reader.recv()
            except (EOFError, OSError):
                pass  # died without a result
        else:
            status, payload = TIMEOUT, f"wall limit of {spec.settings.wall:g} s reached (killed)"
            kill_tree(proc.pid)
        proc.join(10)
        if proc.is_alive():
            kill_tree(proc.pid)
            proc.join(5)
    except BaseException:
        kill_tree(proc.pid)
        proc.join(5)
        raise
    finally:
        with ACTIVE.lock:
            ACTIVE.pids.discard(proc.pid)
        reader.close()
        try:  # what the episode left running in its process group
            os.killpg(proc.pid, signal.SIGKILL)
        except (ProcessLookupError, PermissionError):
            pass
    wall = time.monotonic() - t0
    if status is None:
        status, payload = _exit_reason(proc.exitcode)
    return make_record(spec, status, payload, wall, log_path)


def make_record(
    spec: EpisodeSpec, status: str, payload: Any, wall: float, log_path: str | None = None
) -> dict:
    """One JSON line: identity, outcome, the policy's counts, times, provenance."""
    import socket

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


# ---------------------------------------------------------------- the journal


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
        self._lock_file = open(self.dir / ".lock", "w")  # noqa: SIM115
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


# ---------------------------------------------------------------- executors


class ProcessExecutor:
    """``workers`` episodes at a time, each in a local process of its own."""

    def __init__(self, workers: int = 1):
        self.workers = workers

    def run(
        self, specs: list[EpisodeSpec], log_dir: str | None, on_result: Callable[[dict], None]
    ) -> None:
        from concurrent.futures import FIRST_COMPLETED, ThreadPoolExecutor, wait

        stop = threading.Event()

        def one(spec: EpisodeSpec) -> dict | None:
            if stop.is_set():
                return None
            return run_isolated(spec, log_dir)

        ACTIVE.open()
        pool = ThreadPoolExecutor(max_workers=self.workers, thread_name_prefix="episode")
        try:
            pending = {pool.submit(one, s): s for s in specs}
            while pending:
                done, _ = wait(list(pending), timeout=0.5, return_when=FIRST_COMPLETED)
                for fut in done:
                    spec = pending.pop(fut)
                    try:
                        rec = fut.result()
                    except Exception as e:  # noqa: BLE001 - the harness lost it: record it
                        rec = make_record(spec, HARNESS, f"{type(e).__name__}: {e}", 0.0)
                    if rec is not None:
                        on_result(rec)
        except BaseException:
            stop.set()
            pool.shutdown(wait=False, cancel_futures=True)
            ACTIVE.kill_all()
            raise
        finally:
            pool.shutdown(wait=True, cancel_futures=True)


class RayExecutor:
    """The episodes as Ray tasks (one CPU each), at most ``workers`` in flight (default: the
    cluster's CPUs).  Each task runs its episode in a process of its own on its node, so a
    crash, hang or out-of-memory is recorded as with the process executor."""

    def __init__(self, workers: int | None = None, address: str | None = None):
        self.workers = workers
        self.address = address

    def run(
        self, specs: list[EpisodeSpec], log_dir: str | None, on_result: Callable[[dict], None]
    ) -> None:
        try:
            import ray
        except ImportError:
            raise SSRError('--executor ray needs Ray: pip install "ssr-compile[ray]"') from None
        import logging

        started_here = not ray.is_initialized()
        if started_here:
            kwargs: dict[str, Any] = {
                "include_dashboard": False,
                "log_to_driver": False,
                "logging_level": logging.ERROR,
                "configure_logging": True,
            }
            if self.address:
                kwargs["address"] = self.address
            else:
                kwargs["num_cpus"] = self.workers or os.cpu_count() or 1
            try:
                ray.init(**kwargs)
            except Exception as e:  # noqa: BLE001 - a cluster that cannot be reached: bad input
                raise SSRError(
                    f"cannot start or reach Ray{' at ' + self.address if self.address else ''}: {e}"
                ) from None
        try:
            limit = self.workers or max(int(ray.cluster_resources().get("CPU", 1)), 1)
            remote = ray.remote(num_cpus=1, max_retries=0)(run_isolated)
            todo = list(specs)
            flight: dict[Any, EpisodeSpec] = {}
            while todo or flight:
                while todo and len(flight) < limit:
                    spec = todo.pop(0)
                    # logs stay on the node that ran the episode only when it is this one
                    flight[remote.remote(spec, log_dir if not self.address else None)] = spec
                ready, _ = ray.wait(list(flight), num_returns=1, timeout=0.5)
                for ref in ready:
                    spec = flight.pop(ref)
                    try:
                        rec = ray.get(ref)
                    except Exception as e:  # noqa: BLE001 - a worker or node lost: record it
                        first = str(e).strip().splitlines()
                        rec = make_record(
                            spec,
                            HARNESS,
                            f"ray: {type(e).__name__}: {first[0] if first else ''}",
                            0.0,
                        )
                    on_result(rec)
        except BaseException:
            for ref in list(locals().get("flight", {})):
                try:
                    ray.cancel(ref, force=True)
                except Exception:  # noqa: BLE001
                    pass
            raise
        finally:
            if started_here:
                ray.shutdown()


# ---------------------------------------------------------------- the sweep


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
                f"resuming: {skipped} of {len(specs)} episodes already in {journal.path}; {len(todo)} to run"
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


# ---------------------------------------------------------------- statistics


Z95 = 1.959963984540054


def wilson(successes: int, n: int, z: float = Z95) -> tuple[float, float]:
    """The Wilson score interval of a binomial proportion (as fractions)."""
    if n == 0:
        return (0.0, 1.0)
    p = successes / n
    denom = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    lo = 0.0 if successes == 0 else max(0.0, centre - half)
    hi = 1.0 if successes == n else min(1.0, centre + half)
    return (lo, hi)


def bootstrap_mean(values: list[float], seed: int, resamples: int = 2000) -> tuple[float, float]:
    """A 95% percentile bootstrap interval of the mean (seeded: the same numbers, the same
    interval)."""
    import numpy as np

    if not values:
        return (math.nan, math.nan)
    x = np.asarray(values, dtype=float)
    if len(x) == 1:
        return (float(x[0]), float(x[0]))
    rng = np.random.default_rng(seed)
    means = x[rng.integers(0, len(x), size=(resamples, len(x)))].mean(axis=1)
    lo, hi = np.percentile(means, [2.5, 97.5])
    return (float(lo), float(hi))


@dataclass
class Cell:
    """One task × variant of the table."""

    task: str
    variant: str
    n: int
    successes: int
    rate: float  # fraction
    rate_ci: tuple[float, float]
    mean_time: float | None  # mean planning time of the successful episodes, s
    time_ci: tuple[float, float] | None
    harness_failures: int  # crashed, timed out, out of memory, lost

    @property
    def paper(self) -> tuple[float, float] | None:
        return PAPER_TABLE1.get(self.task, {}).get(self.variant)


def cell_seed(task: str, variant: str) -> int:
    return zlib.crc32(f"{task}/{variant}".encode())


def _groups(recs: list[dict], tasks: list[str], variants: list[str]):
    """Per task and variant with episodes: the records, the successful ones and their
    planning times."""
    for t in tasks:
        for v in variants:
            group = [r for r in recs if r["task"] == t and r["variant"] == v]
            if not group:
                continue
            ok = [r for r in group if r.get("success")]
            times = [float(r["planning_time"]) for r in ok if r.get("planning_time") is not None]
            yield t, v, group, ok, times


def cells(records: Iterable[dict]) -> tuple[list[str], list[str], dict[tuple[str, str], Cell]]:
    """Tasks (kitchen tasks in the paper's order, then others as met), variants (Table I's
    order) and the cell of each (task, variant) with episodes."""
    recs = list(latest(records).values())
    tasks: list[str] = []
    for r in recs:
        if r["task"] not in tasks:
            tasks.append(r["task"])
    tasks.sort(
        key=lambda t: (KITCHEN_TASKS.index(t) if t in KITCHEN_TASKS else len(KITCHEN_TASKS),)
    )
    present = {r["variant"] for r in recs}
    variants = [v for v in VARIANTS if v in present] + sorted(present - set(VARIANTS))
    out: dict[tuple[str, str], Cell] = {}
    for t, v, group, ok, times in _groups(recs, tasks, variants):
        mean = sum(times) / len(times) if times else None
        out[(t, v)] = Cell(
            t,
            v,
            len(group),
            len(ok),
            len(ok) / len(group),
            wilson(len(ok), len(group)),
            mean,
            bootstrap_mean(times, cell_seed(t, v)) if times else None,
            sum(r.get("status") not in (FINISHED, None) for r in group),
        )
    return tasks, variants, out


# ---------------------------------------------------------------- the report


def _title(task: str) -> str:
    return task.capitalize() if task in KITCHEN_TASKS else task


def _fmt_time(t: float) -> str:
    return f"{t:.0f}" if t >= 100 else f"{t:.1f}" if t >= 1 else f"{t:.2f}"


def render_table(records: Iterable[dict], command: str | None = None) -> str:
    """Markdown in Table I's layout: a row per task (ours, then the paper's), per variant the
    success % [95% Wilson interval] and the mean planning time of the successful trials
    [95% bootstrap interval]."""
    records = list(records)
    tasks, variants, table = cells(records)
    head = (
        "| Task | | "
        + " | ".join(f"{v.capitalize()} % | {v.capitalize()} t (s)" for v in variants)
        + " |"
    )
    rule = "|---|---|" + "---:|---:|" * len(variants)
    lines = [
        "# Table I: success rate and mean total planning time of successful trials",
        "",
        "Ours: success % [95% Wilson interval] and mean planning time in seconds of the "
        "successful episodes [95% bootstrap interval of the mean, seeded]; n episodes per "
        f"cell. Paper: Table I of Garrett et al. (ICRA 2020), {PAPER_EPISODES} problems per "
        "task, 10 minutes of planning per episode.",
        "",
        head,
        rule,
    ]
    for t in tasks:
        row = [f"**{_title(t)}**", "ours"]
        for v in variants:
            c = table.get((t, v))
            if c is None:
                row += ["–", "–"]
                continue
            lo, hi = c.rate_ci
            row.append(f"{100 * c.rate:.0f} [{100 * lo:.0f}, {100 * hi:.0f}] (n={c.n})")
            if c.mean_time is None:
                row.append("–")
            else:
                a, b = c.time_ci
                row.append(f"{_fmt_time(c.mean_time)} [{_fmt_time(a)}, {_fmt_time(b)}]")
        lines.append("| " + " | ".join(row) + " |")
        if t in PAPER_TABLE1:
            prow = ["", "paper"]
            for v in variants:
                p = PAPER_TABLE1[t].get(v)
                prow += [f"{p[0]:g}", f"{p[1]:g}"] if p else ["–", "–"]
            lines.append("| " + " | ".join(prow) + " |")
    recs = list(latest(records).values())
    lines += ["", *render_details(recs)]
    lost = [r for r in recs if r.get("status") not in (FINISHED, None)]
    lines += ["", f"{len(recs)} episodes, {sum(bool(r.get('success')) for r in recs)} successes."]
    if lost:
        kinds: dict[str, int] = {}
        for r in lost:
            kinds[r["status"]] = kinds.get(r["status"], 0) + 1
        lines.append(
            "Counted as failures, the episodes the harness lost: "
            + ", ".join(f"{n} {k}" for k, n in sorted(kinds.items()))
            + " (their reasons are in episodes.jsonl)."
        )
    settings = {json.dumps(r.get("settings"), sort_keys=True) for r in recs if r.get("settings")}
    if len(settings) == 1:
        s = json.loads(settings.pop())
        lines.append(
            f"Settings: planning budget {s['budget']:g} s per episode, at most "
            f"{s['max_cycles']} cycles, constrained attempts {s['constrained_time']:g} s, "
            f"unconstrained {s['unconstrained_time']:g} s, planner {s['planner']}."
        )
    commits = sorted(
        {(r.get("commit") or "?")[:12] + ("+dirty" if r.get("dirty") else "") for r in recs}
    )
    versions = sorted({str(r.get("version")) for r in recs})
    lines.append(f"Toolkit {', '.join(versions)}, commit {', '.join(commits)}.")
    if command:
        lines += ["", "Command:", "", "```bash", command, "```"]
    return "\n".join(lines) + "\n"


def _median(values: list[float]) -> float | None:
    if not values:
        return None
    v = sorted(values)
    n = len(v)
    return v[n // 2] if n % 2 else (v[n // 2 - 1] + v[n // 2]) / 2


def _seed_list(seeds: Iterable[int]) -> str:
    """``0-4,7``: sorted seeds with runs folded."""
    out: list[str] = []
    run: list[int] = []
    for s in sorted(set(seeds)):
        if run and s == run[-1] + 1:
            run.append(s)
            continue
        if run:
            out.append(f"{run[0]}-{run[-1]}" if len(run) > 1 else str(run[0]))
        run = [s]
    if run:
        out.append(f"{run[0]}-{run[-1]}" if len(run) > 1 else str(run[0]))
    return ",".join(out) or "–"


def render_details(recs: list[dict]) -> list[str]:
    """Per task × variant, what Table I does not show: the seeds run and those that failed,
    the median planning time of the successes, the mean cycles, the constrained attempts
    (Algorithm 2) that held and those that fell back to an unconstrained replan (totals over
    the cell's episodes), and the commits the episodes ran at."""
    tasks, variants, _ = cells(recs)
    lines = [
        "Per cell: seeds run, seeds that failed, median planning time of the successes (s), "
        "mean cycles per episode, constrained attempts that held / fell back (all episodes), "
        "commit.",
        "",
        "| Task | Variant | Seeds | Failed | Median t (s) | Cycles | Held / fell back | Commit |",
        "|---|---|---|---|---:|---:|---:|---|",
    ]
    for t, v, group, _ok, times in _groups(recs, tasks, variants):
        med = _median(times)
        cycles = [float(r["cycles"]) for r in group if r.get("cycles") is not None]
        held = sum(int(r.get("constrained_held") or 0) for r in group)
        fell = sum(int(r.get("fallbacks") or 0) for r in group)
        commits = sorted({(r.get("commit") or "?")[:7] for r in group})
        lines.append(
            "| "
            + " | ".join(
                [
                    _title(t),
                    v,
                    _seed_list(int(r["seed"]) for r in group),
                    _seed_list(int(r["seed"]) for r in group if not r.get("success")),
                    "–" if med is None else _fmt_time(med),
                    f"{sum(cycles) / len(cycles):.1f}" if cycles else "–",
                    f"{held} / {fell}",
                    ", ".join(commits),
                ]
            )
            + " |"
        )
    return lines


def render_plot(records: Iterable[dict], path: str | Path) -> None:
    """Success % and mean planning time per task and variant, ours (with 95% intervals) next
    to the paper's (hatched)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    tasks, variants, table = cells(records)
    fig, axes = plt.subplots(1, 2, figsize=(max(7, 2.6 * len(tasks) + 3), 4.2))
    colors = plt.get_cmap("tab10")
    width = 0.8 / max(len(variants), 1)
    x = np.arange(len(tasks))
    for panel, ax in enumerate(axes):
        for j, v in enumerate(variants):
            ours, err, paper = [], [[], []], []
            for t in tasks:
                c = table.get((t, v))
                if panel == 0:
                    val = 100 * c.rate if c else np.nan
                    ci = (100 * c.rate_ci[0], 100 * c.rate_ci[1]) if c else (np.nan, np.nan)
                    p = PAPER_TABLE1.get(t, {}).get(v)
                    paper.append(p[0] if p else np.nan)
                else:
                    val = c.mean_time if c and c.mean_time is not None else np.nan
                    ci = c.time_ci if c and c.time_ci else (np.nan, np.nan)
                    p = PAPER_TABLE1.get(t, {}).get(v)
                    paper.append(p[1] if p else np.nan)
                ours.append(val)
                err[0].append(max(val - ci[0], 0) if np.isfinite(val) else 0)
                err[1].append(max(ci[1] - val, 0) if np.isfinite(val) else 0)
            pos = x - 0.4 + width * (j + 0.5)
            half = width / 2
            has_paper = any(np.isfinite(paper))
            ax.bar(
                pos - (half / 2 if has_paper else 0),
                ours,
                half if has_paper else width * 0.9,
                yerr=err,
                capsize=2,
                color=colors(j),
                label=f"{v} (ours)",
            )
            if has_paper:
                ax.bar(
                    pos + half / 2,
                    paper,
                    half,
                    color=colors(j),
                    alpha=0.35,
                    hatch="//",
                    edgecolor=colors(j),
                    label=f"{v} (paper)",
                )
        ax.set_xticks(x)
        ax.set_xticklabels([_title(t) for t in tasks])
        if panel == 0:
            ax.set_ylabel("success (%)")
            ax.set_ylim(0, 105)
            ax.set_title("Success rate, 95% Wilson interval")
        else:
            ax.set_ylabel("mean planning time of successes (s)")
            ax.set_title("Planning time, 95% bootstrap interval")
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(
        handles, labels, loc="lower center", ncol=min(len(labels), 4), fontsize=8, frameon=False
    )
    fig.tight_layout(rect=(0, 0.08 + 0.04 * (len(labels) > 4), 1, 1))
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write_report(
    out_dir: str | Path, command: str | None = None, sources: list[str | Path] | None = None
) -> tuple[Path, Path, str]:
    """Rebuild ``table.md`` and ``table1.png`` from ``episodes.jsonl`` alone.  With
    ``sources`` (sweep folders), their episodes merged -- the last folder's record of a task,
    variant and seed wins -- are written to ``out_dir/episodes.jsonl`` first, so that the
    merged folder is a report of its own; the commands recorded in the sources' tables are
    kept in the new one."""
    from .files import write_atomically

    out = Path(out_dir)
    if sources:
        records, commands = [], []
        for src in map(Path, sources):
            if src.resolve() == out.resolve() and len(sources) > 1:
                raise SSRError(
                    "is one of the sweeps to merge: name a new folder with -o "
                    "(its episodes.jsonl would be overwritten)",
                    file=str(out),
                )
            records += _records_of(src)
            old = src / TABLE_FILE
            found = _command_of(old.read_text(encoding="utf-8")) if old.is_file() else None
            if found and found not in commands:
                commands.append(found)
        merged = list(latest(records).values())
        if command is not None:
            commands.append(command)
        command = "\n".join(commands) or None
        out.mkdir(parents=True, exist_ok=True)
        write_atomically(
            out / EPISODES_FILE, "".join(json.dumps(r, sort_keys=True) + "\n" for r in merged)
        )
        records = merged
    else:
        records = _records_of(out)
    if command is None:
        old = out / TABLE_FILE
        command = _command_of(old.read_text(encoding="utf-8")) if old.is_file() else None
    text = render_table(records, command)
    write_atomically(out / TABLE_FILE, text)
    render_plot(records, out / PLOT_FILE)
    return out / TABLE_FILE, out / PLOT_FILE, text


def _records_of(folder: Path) -> list[dict]:
    path = folder / EPISODES_FILE
    if not path.is_file():
        raise SSRError(
            f"no {EPISODES_FILE} in this folder (run `ssr-compile experiment -o {folder}` first)",
            file=str(folder),
        )
    records, _bad = read_records(path)
    if not records:
        raise SSRError("holds no episode records", file=str(path))
    return records


def _command_of(table: str) -> str | None:
    """The command recorded in an earlier table.md (kept when the report is rebuilt)."""
    marker = "Command:\n\n```bash\n"
    i = table.find(marker)
    if i < 0:
        return None
    rest = table[i + len(marker) :]
    j = rest.find("\n```")
    return rest[:j] if j >= 0 else None


__all__ = [
    "VARIANTS",
    "KITCHEN_TASKS",
    "PAPER_TABLE1",
    "Task",
    "Settings",
    "EpisodeSpec",
    "parse_seeds",
    "parse_tasks",
    "parse_variants",
    "episode_specs",
    "run_isolated",
    "run_sweep",
    "ProcessExecutor",
    "RayExecutor",
    "wilson",
    "bootstrap_mean",
    "cells",
    "render_table",
    "render_plot",
    "write_report",
]


_warm_from_environment()
