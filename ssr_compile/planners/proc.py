"""Running planner work under a wall-clock limit that is really enforced (docs/design.md §7).

Two tools: :func:`run_command` runs a planner binary as a subprocess in its own process group
and kills the whole group when the limit passes; :func:`run_forked` runs a Python function in a
forked child (its own session, so helpers it spawns die with it) and returns the function's
value through a pipe; :class:`ForkedWorker` keeps such a child alive between calls.  Forking
keeps the modules the parent has already imported (Fast
Downward's translator, unified-planning), which is what makes per-call overhead small.
"""

from __future__ import annotations

import contextlib
import gc
import os
import pickle
import select
import signal
import subprocess
import sys
import threading
import time
import traceback
from collections.abc import Callable
from typing import Any

OK = "ok"
TIMED_OUT = "timeout"
FAILED = "error"


def _descendants(pid: int) -> list[int]:
    """Processes below ``pid`` (Linux ``/proc``; empty elsewhere).  Needed because some
    planner wrappers (unified-planning's) start their planner in a session of its own, out of
    reach of a kill of our child's process group."""
    parents: dict[int, list[int]] = {}
    try:
        entries = os.listdir("/proc")
    except OSError:
        return []
    for entry in entries:
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat", "rb") as f:
                stat = f.read()
        except OSError:
            continue
        ppid = int(stat[stat.rindex(b")") + 2 :].split()[1])
        parents.setdefault(ppid, []).append(int(entry))
    out, todo = [], [pid]
    while todo:
        for child in parents.get(todo.pop(), []):
            out.append(child)
            todo.append(child)
    return out


# Write ends of pipes the parent alone must hold (a :class:`StartedCommand`'s input): a child
# forked meanwhile (the translator's worker, started or restarted during a call) would keep
# such a pipe open, and the command reading it would never see its end.
_PARENT_ONLY_FDS: set[int] = set()


def _drop_parent_fds() -> None:
    """In a forked child: point the parent-only descriptors at /dev/null (not closed, so that
    the number stays taken and no object of the parent's closes an unrelated file later)."""
    if not _PARENT_ONLY_FDS:
        return
    null = os.open(os.devnull, os.O_WRONLY)
    for fd in list(_PARENT_ONLY_FDS):
        try:
            os.dup2(null, fd)
        except OSError:
            pass
    os.close(null)


def _child_setup(tmpdir: str | None) -> None:
    """In a forked child: SIGTERM and SIGHUP kill it (the parent's handlers, which turn them
    into exceptions for its own cleanup, are not wanted here), and temporary files of the
    work it does (and of the programs it starts) go to ``tmpdir``, which the parent removes
    whatever happens to the child."""
    _drop_parent_fds()
    for name in ("SIGTERM", "SIGHUP"):
        signum = getattr(signal, name, None)
        if signum is not None:
            signal.signal(signum, signal.SIG_DFL)
    if tmpdir:
        _use_tmpdir(tmpdir)


def _use_tmpdir(tmpdir: str) -> None:
    import tempfile

    os.environ["TMPDIR"] = tmpdir
    tempfile.tempdir = tmpdir


def _private_tmpdir() -> str:
    import tempfile

    return tempfile.mkdtemp(prefix="ssr-work-")


def _remove(tmpdir: str | None) -> None:
    if tmpdir:
        import shutil

        shutil.rmtree(tmpdir, ignore_errors=True)


def _kill_tree(pid: int) -> None:
    """Kill ``pid``'s process group and every process below it, with their groups."""
    below = _descendants(pid)
    _kill_group(pid)
    for p in below:
        _kill_group(p)


def _kill_group(pid: int) -> None:
    try:
        os.killpg(pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        # The child may not have become a group leader yet: kill it alone.
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass


def run_command(
    cmd: list[str],
    timeout: float,
    *,
    cwd: str,
    stdin_path: str | None = None,
    log_path: str | None = None,
) -> int | None:
    """Run ``cmd`` in a new process group; its exit code, or ``None`` if it was killed at
    ``timeout`` seconds.  Output goes to ``log_path`` (or is discarded)."""
    stdin = open(stdin_path, "rb") if stdin_path else subprocess.DEVNULL
    log = open(log_path, "wb") if log_path else subprocess.DEVNULL
    try:
        proc = subprocess.Popen(
            cmd, stdin=stdin, stdout=log, stderr=subprocess.STDOUT, cwd=cwd, start_new_session=True
        )
        try:
            return _wait(proc, max(timeout, 0.0))
        except subprocess.TimeoutExpired:
            _kill_group(proc.pid)
            proc.wait()
            return None
        except BaseException:  # KeyboardInterrupt: never leave a planner running
            _kill_group(proc.pid)
            proc.wait()
            raise
    finally:
        for f in (stdin, log):
            if not isinstance(f, int):
                f.close()


class StartedCommand:
    """A command started before its input exists, reading it from a pipe.

    Fast Downward's search binary spends a few milliseconds starting (loading, registering
    its plugins, parsing the search string) before it reads the task; started while the
    translator works, that start costs no wall-clock time.  :meth:`finish` feeds it a file
    and waits under a limit like :func:`run_command`; :meth:`cancel` kills it unused.  Its
    own process group, killed at the limit, as :func:`run_command`'s."""

    def __init__(self, cmd: list[str], *, cwd: str, log_path: str | None = None):
        self._log = open(log_path, "wb") if log_path else subprocess.DEVNULL
        try:
            self.proc = subprocess.Popen(
                cmd,
                stdin=subprocess.PIPE,
                stdout=self._log,
                stderr=subprocess.STDOUT,
                cwd=cwd,
                start_new_session=True,
            )
        except BaseException:
            self._close_log()
            raise
        self._stdin_fd = self.proc.stdin.fileno()
        _PARENT_ONLY_FDS.add(self._stdin_fd)
        self._done = False

    def _close_stdin(self) -> None:
        _PARENT_ONLY_FDS.discard(self._stdin_fd)
        try:
            self.proc.stdin.close()
        except OSError:
            pass

    def _close_log(self) -> None:
        if not isinstance(self._log, int):
            self._log.close()

    def _end(self) -> None:
        _kill_group(self.proc.pid)
        self.proc.wait()

    def _feed(self, path: str) -> None:
        # A command that stops reading (it failed, or was killed at the limit) ends the feed:
        # its exit code or the limit says what happened, not this thread.
        try:
            with contextlib.suppress(OSError, ValueError), open(path, "rb") as f:
                while chunk := f.read(1 << 16):
                    self.proc.stdin.write(chunk)
        finally:
            self._close_stdin()

    def finish(self, stdin_path: str, timeout: float) -> int | None:
        """Feed ``stdin_path`` to the command and wait; its exit code, or ``None`` if it was
        killed at ``timeout`` seconds."""
        self._done = True
        feeder = threading.Thread(target=self._feed, args=(stdin_path,), daemon=True)
        feeder.start()
        try:
            return _wait(self.proc, max(timeout, 0.0))
        except subprocess.TimeoutExpired:
            self._end()
            return None
        except BaseException:  # KeyboardInterrupt: never leave a planner running
            self._end()
            raise
        finally:
            feeder.join()
            self._close_log()

    def cancel(self) -> None:
        """Kill the command unused (a no-op once :meth:`finish` ran)."""
        if self._done:
            return
        self._done = True
        self._end()
        self._close_stdin()
        self._close_log()


def _wait(proc: subprocess.Popen, timeout: float) -> int:
    """``proc.wait(timeout)`` that returns as soon as the process exits.  (Popen's own wait
    with a timeout polls, sleeping up to 50 ms between looks: on tamp2d, whose searches take a
    few milliseconds each, the sleeps were a sixth of the solve.)  Linux's process file
    descriptors make the exit something to ``select`` on; elsewhere Popen's wait."""
    pidfd_open = getattr(os, "pidfd_open", None)
    fd = None
    if pidfd_open is not None:
        try:
            fd = pidfd_open(proc.pid)
        except OSError:  # an old kernel, or the process already reaped
            fd = None
    if fd is None:
        return proc.wait(timeout=timeout)
    try:
        ready, _, _ = select.select([fd], [], [], timeout)
    finally:
        os.close(fd)
    if not ready:
        raise subprocess.TimeoutExpired(proc.args, timeout)
    return proc.wait()


def can_fork() -> bool:
    return hasattr(os, "fork")


def run_forked(
    fn: Callable[..., Any], args: tuple = (), *, timeout: float, log_path: str | None = None
) -> tuple[str, Any]:
    """Call ``fn(*args)`` in a forked child killed after ``timeout`` seconds.

    Returns ``("ok", value)``, ``("timeout", None)`` or ``("error", message)`` where the message
    names the exception the function raised.  ``value`` must be picklable.  The child's stdout and
    stderr go to ``log_path`` (or are discarded).  Without ``os.fork`` the call runs in-process
    and the limit is not enforced.
    """
    if not can_fork():
        try:
            return OK, fn(*args)
        except Exception as e:  # noqa: BLE001 - reported as a planner error
            return FAILED, f"{type(e).__name__}: {e}"
    tmpdir = _private_tmpdir()
    try:
        return _run_forked(fn, args, timeout, log_path, tmpdir)
    finally:
        _remove(tmpdir)


def _run_forked(fn, args, timeout: float, log_path: str | None, tmpdir: str) -> tuple[str, Any]:
    read_fd, write_fd = os.pipe()
    pid = os.fork()
    if pid == 0:  # child: never return into the caller's code
        code = 0
        try:
            os.close(read_fd)
            os.setsid()
            _child_setup(tmpdir)
            gc.freeze()  # the parent's objects: never scanned here (nor copied on write)
            out = os.open(log_path or os.devnull, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
            os.dup2(out, 1)
            os.dup2(out, 2)
            try:
                payload = (OK, fn(*args))
            except BaseException as e:  # noqa: BLE001
                traceback.print_exc()  # into the log, for whoever keeps it
                payload = (FAILED, " ".join(f"{type(e).__name__}: {e}".split()))
            data = pickle.dumps(payload)
            view = memoryview(data)
            while view:
                view = view[os.write(write_fd, view) :]
        except BaseException:  # noqa: BLE001
            code = 1
        finally:
            os._exit(code)
    os.close(write_fd)
    deadline = time.monotonic() + max(timeout, 0.0)
    chunks: list[bytes] = []
    timed_out = False
    try:
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                timed_out = True
                break
            ready, _, _ = select.select([read_fd], [], [], left)
            if not ready:
                continue
            chunk = os.read(read_fd, 1 << 16)
            if not chunk:
                break
            chunks.append(chunk)
    except BaseException:
        _kill_tree(pid)
        os.waitpid(pid, 0)
        os.close(read_fd)
        raise
    os.close(read_fd)
    if timed_out:
        _kill_tree(pid)
        os.waitpid(pid, 0)
        return TIMED_OUT, None
    # Helpers the child started and left behind go with its group (killed before the child is
    # reaped, so that its process id cannot have been reused).
    _kill_group(pid)
    _, status = os.waitpid(pid, 0)
    if not chunks:
        return FAILED, f"worker process died (wait status {status})"
    try:
        return pickle.loads(b"".join(chunks))
    except Exception as e:  # noqa: BLE001
        return FAILED, f"unreadable worker result: {e}"


def _send(fd: int, obj) -> None:
    data = pickle.dumps(obj)
    view = memoryview(len(data).to_bytes(8, "little") + data)
    while view:
        view = view[os.write(fd, view) :]


def _recv_blocking(fd: int):
    """One length-prefixed message, or ``None`` at end of file."""
    buf = b""
    while len(buf) < 8:
        chunk = os.read(fd, 8 - len(buf))
        if not chunk:
            return None
        buf += chunk
    size, data = int.from_bytes(buf, "little"), b""
    while len(data) < size:
        chunk = os.read(fd, min(size - len(data), 1 << 16))
        if not chunk:
            return None
        data += chunk
    return pickle.loads(data)


class ForkedWorker:
    """A forked child that runs ``fn`` once per request and stays alive between requests.

    Compared with :func:`run_forked`, the child's copy-on-write memory is paid for once, not
    per call (for Fast Downward's translator this halves the CPU time of a small call).  A
    request that exceeds its time limit kills the worker (and everything it started); the next
    request forks a fresh one.  The worker exits when the parent closes its end of the pipe,
    including when the parent dies.

    Python's cyclic garbage collector: the objects inherited from the parent are frozen in the
    child (never scanned, so their pages are not copied for it), and it is off during a call,
    which collects its garbage after its answer is sent, while the parent reads it: the
    kitchen's Stow spent 7.5 s in 21 planner calls, 5.0 s so.
    """

    def __init__(self, fn: Callable[..., Any], *, max_calls: int = 500):
        self.fn = fn
        self.max_calls = max_calls  # then a fresh worker, so no state builds up for ever
        self.pid: int | None = None
        self._calls = 0
        self._lock = threading.Lock()

    def _start(self) -> None:
        req_r, req_w = os.pipe()
        res_r, res_w = os.pipe()
        pid = os.fork()
        if pid == 0:
            try:
                os.close(req_w)
                os.close(res_r)
                os.setsid()
                _child_setup(None)
                gc.freeze()  # what the parent made: never scanned here (nor copied on write)
                self._serve(req_r, res_w)
            finally:
                os._exit(0)
        os.close(req_r)
        os.close(res_w)
        self.pid, self._req, self._res = pid, req_w, res_r

    def _serve(self, req: int, res: int) -> None:
        while True:
            message = _recv_blocking(req)
            if message is None:
                return
            args, log_path, tmpdir = message
            _use_tmpdir(tmpdir)
            out = os.open(log_path or os.devnull, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
            os.dup2(out, 1)
            os.dup2(out, 2)
            os.close(out)
            gc.disable()
            try:
                payload = (OK, self.fn(*args))
            except BaseException as e:  # noqa: BLE001
                traceback.print_exc()
                payload = (FAILED, " ".join(f"{type(e).__name__}: {e}".split()))
            sys.stdout.flush()
            sys.stderr.flush()
            _send(res, payload)
            gc.collect()  # the call's garbage, once the answer is on its way
            gc.enable()

    def _stop(self) -> None:
        if self.pid is None:
            return
        _kill_tree(self.pid)
        os.waitpid(self.pid, 0)
        os.close(self._req)
        os.close(self._res)
        self.pid = None

    def close(self) -> None:
        """Stop the worker and reap it (registered with :mod:`atexit` by its users, so that no
        finished worker lingers as a zombie)."""
        with self._lock:
            self._stop()

    def call(self, args: tuple, *, timeout: float, log_path: str | None = None) -> tuple[str, Any]:
        """Like :func:`run_forked`: ``("ok", value)``, ``("timeout", None)`` or
        ``("error", message)``."""
        if not can_fork():
            return run_forked(self.fn, args, timeout=timeout, log_path=log_path)
        with self._lock:
            if self.pid is not None and os.waitpid(self.pid, os.WNOHANG) != (0, 0):
                # died since the last call (already reaped by the check): its pipes go too
                os.close(self._req)
                os.close(self._res)
                self.pid = None
            if self.pid is not None and self._calls >= self.max_calls:
                self._stop()
            if self.pid is None:
                self._start()
                self._calls = 0
            self._calls += 1
            tmpdir = _private_tmpdir()
            try:
                return self._call(args, timeout, log_path, tmpdir)
            finally:
                _remove(tmpdir)

    def _call(self, args: tuple, timeout: float, log_path: str | None, tmpdir: str):
        """One request to the running worker (the lock is held by :meth:`call`)."""
        deadline = time.monotonic() + max(timeout, 0.0)
        try:
            _send(self._req, (args, log_path, tmpdir))
            buf = b""
            size = None
            while size is None or len(buf) < 8 + size:
                left = deadline - time.monotonic()
                if left <= 0:
                    self._stop()
                    return TIMED_OUT, None
                ready, _, _ = select.select([self._res], [], [], left)
                if not ready:
                    continue
                chunk = os.read(self._res, 1 << 16)
                if not chunk:
                    self._stop()
                    return FAILED, "worker process died"
                buf += chunk
                if size is None and len(buf) >= 8:
                    size = int.from_bytes(buf[:8], "little")
            return pickle.loads(buf[8:])
        except BaseException:
            self._stop()
            raise
