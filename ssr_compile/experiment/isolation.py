"""One episode in a process of its own (:func:`run_isolated`).

The episode's process is forked from a *fork server* that has already imported the toolkit
(multiprocessing's ``forkserver``), so the harness's overhead is a fork, not a Python start and
its imports.  The process runs in a session of its own under an address-space limit; a crash
(an exception, ``os._exit``, a signal), a hang past the wall limit or running out of memory
becomes the record's ``status`` and ``failure``, never an exception of the sweep.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import sys
import tempfile
import threading
import time
import traceback
from collections.abc import Iterable
from dataclasses import replace
from functools import lru_cache
from pathlib import Path

from .. import quiet_pybullet
from ..files import current_umask
from ..planners.proc import _descendants
from ..policy import run_policy
from .journal import CRASHED, FINISHED, OOM, TIMEOUT, make_record
from .spec import EpisodeSpec, Task, load_task


def run_episode_here(spec: EpisodeSpec) -> dict:
    """Build the episode's world and run the policy in *this* process (what the child does)."""
    settings = replace(spec.settings.policy, variant=spec.variant)
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


def _child(
    spec: EpisodeSpec, conn, log_path: str | None, started: float, tmpdir: str, umask: int
) -> None:
    """The episode's process: its own session (so the whole tree can be killed), output to
    its log, its temporary files in ``tmpdir`` (which the harness removes, however the
    episode ends), an address-space limit; sends ``(status, payload)`` back."""
    entered = time.time()
    try:
        os.setsid()
    except OSError:
        pass
    _die_with_parent()
    for name in ("SIGTERM", "SIGHUP", "SIGINT"):
        signal.signal(getattr(signal, name), signal.SIG_DFL)
    os.umask(umask)  # the sweep's now, not the fork server's when it started
    _use_tmpdir(tmpdir)
    quiet_pybullet.install()  # a fork server started elsewhere may not have it
    if log_path:
        fd = os.open(log_path, os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o666)  # the umask's
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


def _use_tmpdir(tmpdir: str) -> None:
    """Temporary files of this process (``tempfile``) and of the programs it starts
    (``TMPDIR``) go to ``tmpdir``."""
    os.environ["TMPDIR"] = tmpdir
    tempfile.tempdir = tmpdir


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


# What the fork server imports once; importing the last, this module, also warms it (below).
_PRELOAD = [
    "ssr_compile.policy",
    "ssr_compile.solver",
    "numpy",
    "ssr_compile.experiment.isolation",
]
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
    quiet_pybullet.install()  # PyBullet's banner, printed here, landed in the progress bar
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


def run_isolated(
    spec: EpisodeSpec, log_dir: str | None = None, tmp_root: str | None = None
) -> dict:
    """Run one episode in a process of its own and return its JSON record (never raises for
    the episode's failures: they are the record's ``status`` and ``failure``).

    The episode's temporary files (its planners' folders, the kitchen's robot files, those of
    the programs it starts) go to a folder of its own in ``tmp_root`` (default: the temporary
    directory), removed when the episode ends -- finished, crashed, killed at its limit or
    by an interrupted sweep."""
    ctx = _context()
    log_path = None
    if log_dir:
        Path(log_dir).mkdir(parents=True, exist_ok=True)
        safe = "".join(c if c.isalnum() or c in "-_." else "_" for c in spec.task.label)
        log_path = str(Path(log_dir) / f"{safe}-{spec.variant}-{spec.seed}.log")
        Path(log_path).unlink(missing_ok=True)
    tmpdir = tempfile.mkdtemp(prefix="ssr-episode-", dir=tmp_root)
    try:
        return _run_in_child(ctx, spec, log_path, tmpdir)
    finally:
        shutil.rmtree(tmpdir, ignore_errors=True)


def _run_in_child(ctx, spec: EpisodeSpec, log_path: str | None, tmpdir: str) -> dict:
    reader, writer = ctx.Pipe(duplex=False)
    t0 = time.monotonic()
    started = time.time()
    args = (spec, writer, log_path, started, tmpdir, current_umask())
    proc = ctx.Process(target=_child, args=args, daemon=False)
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


_warm_from_environment()  # a no-op but in the fork server
