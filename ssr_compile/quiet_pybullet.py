"""Import PyBullet without its "pybullet build time: ..." banner.

PyBullet's C module prints the banner when it is initialised, on file descriptor 2 or 1
depending on the build (through C's own buffers: a piped command would print it at exit), which
no ``sys.stdout``/``sys.stderr`` redirection reaches.  :func:`import_pybullet` points fds 1 and
2 at ``/dev/null`` while the module initialises and flushes C's buffers before putting them
back (an import error is a Python exception, raised after they are back).
:func:`install` makes every later ``import pybullet`` (wherever it is written: ``sim/``, the
streams modules, user code) go through it; the command line installs it before any command.
"""

from __future__ import annotations

import contextlib
import importlib.abc
import importlib.machinery
import os
import sys


@contextlib.contextmanager
def output_fds_silenced():
    """Fds 1 and 2 go to /dev/null inside the block (Python's and C's buffers flushed)."""
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (AttributeError, ValueError, OSError):
            pass
    saved = {}
    for fd in (1, 2):
        try:
            saved[fd] = os.dup(fd)
        except OSError:  # no such fd: nothing to silence there
            pass
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        for fd in saved:
            os.dup2(devnull, fd)
        yield
    finally:
        _flush_c_stdout()
        for fd, copy in saved.items():
            os.dup2(copy, fd)
            os.close(copy)
        os.close(devnull)


def _flush_c_stdout() -> None:
    try:
        import ctypes

        ctypes.CDLL(None).fflush(None)
    except (OSError, AttributeError, TypeError):  # no C library to reach: nothing buffered
        pass


class _QuietLoader(importlib.abc.Loader):
    def __init__(self, loader):
        self.loader = loader

    def create_module(self, spec):
        with output_fds_silenced():
            return self.loader.create_module(spec)

    def exec_module(self, module):
        with output_fds_silenced():
            self.loader.exec_module(module)


class _QuietFinder(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path, target=None):
        if name != "pybullet":
            return None
        spec = importlib.machinery.PathFinder.find_spec(name, path)
        if spec is not None and spec.loader is not None:
            spec.loader = _QuietLoader(spec.loader)
        return spec


_FINDER = _QuietFinder()


def install() -> None:
    """Every later first ``import pybullet`` is quiet (idempotent)."""
    if _FINDER not in sys.meta_path:
        sys.meta_path.insert(0, _FINDER)


def import_pybullet():
    """The ``pybullet`` module, imported without its banner."""
    install()
    import pybullet

    return pybullet
