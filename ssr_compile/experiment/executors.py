"""Executors of a sweep's episodes: ``process`` (local processes, ``workers`` at a time) and
``ray`` (the episodes as tasks of Ray, on a local instance or a cluster; each task runs its
episode in a process of its own in the same way, so failures are recorded alike)."""

from __future__ import annotations

import contextlib
import os
import threading
from collections import deque
from collections.abc import Callable
from typing import Any

from ..errors import SSRError
from .isolation import ACTIVE, run_isolated
from .journal import HARNESS, make_record
from .spec import EpisodeSpec


class ProcessExecutor:
    """``workers`` episodes at a time, each in a local process of its own."""

    def __init__(self, workers: int = 1):
        self.workers = workers

    def run(
        self,
        specs: list[EpisodeSpec],
        log_dir: str | None,
        on_result: Callable[[dict], None],
        tmp_root: str | None = None,
    ) -> None:
        """Run ``specs``, calling ``on_result`` with each record as it comes; the episodes'
        temporary folders go into ``tmp_root`` (default: the temporary directory)."""
        from concurrent.futures import FIRST_COMPLETED, ThreadPoolExecutor, wait

        stop = threading.Event()

        def one(spec: EpisodeSpec) -> dict | None:
            if stop.is_set():
                return None
            return run_isolated(spec, log_dir, tmp_root)

        ACTIVE.open()
        pool = ThreadPoolExecutor(max_workers=self.workers, thread_name_prefix="episode")
        todo = iter(specs)
        pending: dict = {}

        def fill() -> None:  # at most `workers` submitted at a time: no future per episode
            while len(pending) < self.workers:
                spec = next(todo, None)
                if spec is None:
                    return
                pending[pool.submit(one, spec)] = spec

        try:
            fill()
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
                fill()
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
        self,
        specs: list[EpisodeSpec],
        log_dir: str | None,
        on_result: Callable[[dict], None],
        tmp_root: str | None = None,
    ) -> None:
        """As :meth:`ProcessExecutor.run`.  A Ray instance started here keeps its files (its
        session folder, its workers' temporary files) in ``tmp_root`` too."""
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
                with _temporary_directory(None if self.address else tmp_root):
                    ray.init(**kwargs)
            except Exception as e:  # noqa: BLE001 - a cluster that cannot be reached: bad input
                raise SSRError(
                    f"cannot start or reach Ray{' at ' + self.address if self.address else ''}: {e}"
                ) from None
        try:
            limit = self.workers or max(int(ray.cluster_resources().get("CPU", 1)), 1)
            remote = ray.remote(num_cpus=1, max_retries=0)(run_isolated)
            todo = deque(specs)
            flight: dict[Any, EpisodeSpec] = {}
            while todo or flight:
                while todo and len(flight) < limit:
                    spec = todo.popleft()
                    # logs stay on the node that ran the episode only when it is this one
                    if self.address:  # another machine's folders are not ours to name
                        flight[remote.remote(spec, None)] = spec
                    else:
                        flight[remote.remote(spec, log_dir, tmp_root)] = spec
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


@contextlib.contextmanager
def _temporary_directory(folder: str | None):
    """``TMPDIR`` is ``folder`` inside the block (for the processes started in it, which keep
    it: Ray's, on Linux, put their session folder and temporary files there)."""
    if folder is None:
        yield
        return
    old = os.environ.get("TMPDIR")
    os.environ["TMPDIR"] = folder
    try:
        yield
    finally:
        if old is None:
            os.environ.pop("TMPDIR", None)
        else:
            os.environ["TMPDIR"] = old
