"""Time limits that hold even when a stream never returns.

The solver and the planners stop themselves at their deadlines; a stream is user code that may
not.  :class:`time_limit` arms an alarm in the main thread that raises
:class:`~ssr_compile.errors.TimeLimitReached` wherever the program is (compiling, calling a
stream, waiting for a planner, whose processes are then killed as on Ctrl-C);
:func:`overrunning_stream` names the stream it interrupted.  Used by the CLI commands and by
the online policy (each planning attempt of an episode).
"""

from __future__ import annotations

import math
import signal
import threading
import time


class time_limit:
    """Bound a block of the main thread by ``limit`` seconds: when they pass, raise
    :class:`TimeLimitReached` wherever the block is (compiling, calling a stream, waiting for
    a planner, whose processes are then killed as on Ctrl-C).  No-op outside the main thread or
    without ``setitimer``; ``limit`` None or infinite: no bound."""

    def __init__(self, limit: float | None):
        self.limit = limit
        self.active = False

    def __enter__(self):
        if (
            self.limit is None
            or not math.isfinite(self.limit)
            or not hasattr(signal, "setitimer")
            or threading.current_thread() is not threading.main_thread()
        ):
            return self
        self.saved = signal.signal(signal.SIGALRM, self._fire)
        outer = signal.setitimer(signal.ITIMER_REAL, max(self.limit, 0.001))[0]
        self.outer_deadline = time.monotonic() + outer if outer > 0 else None
        if outer > 0 and outer < self.limit:  # an enclosing limit that passes first
            signal.setitimer(signal.ITIMER_REAL, outer)
        self.active = True
        return self

    def _fire(self, signum, frame):
        from .errors import TimeLimitReached

        raise TimeLimitReached(self.limit)

    def __exit__(self, *exc):
        if self.active:
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, self.saved)
            if self.outer_deadline is not None:  # an enclosing limit: let it run on
                left = self.outer_deadline - time.monotonic()
                signal.setitimer(signal.ITIMER_REAL, max(left, 0.001))
            self.active = False
        return False


def overrunning_stream(e: BaseException) -> str | None:
    """The stream that was running when a time limit passed (from the traceback), if any."""
    from . import stream as stream_module

    name = None
    tb = e.__traceback__
    while tb is not None:
        frame = tb.tb_frame
        if frame.f_code.co_filename == stream_module.__file__:
            local = frame.f_locals
            found = local.get("name")
            if found is None and isinstance(local.get("self"), stream_module.Generator):
                found = local["self"].name
            if isinstance(found, str):
                name = found
        tb = tb.tb_next
    return name
