"""The exceptions of ssr-compile, by whose fault they are.

Every error a user's *input* can cause is an :class:`SSRError` (exit 2).  Errors that point
into a file carry the file name, line and column and render the offending line with a caret, so
the CLI can print them as they are (docs/design.md §7).

A failure of *code* -- a planner backend that crashed, a user's stream implementation that
raised or misbehaved, a bug in ssr-compile itself -- is a :class:`Failure` (exit 3): one line
naming the backend or the stream, the traceback behind the CLI's ``--debug``.
"""

from __future__ import annotations


class SSRError(Exception):
    """Base class: an error caused by the user's input, reported without a traceback."""

    exit_code = 2

    def __init__(
        self,
        message: str,
        *,
        file: str | None = None,
        line: int | None = None,
        col: int | None = None,
        source: str | None = None,
    ):
        super().__init__(message)
        self.message = message
        self.file = file
        self.line = line
        self.col = col
        self.source = source

    @property
    def location(self) -> str:
        if self.file is None:
            # No file to name (an API call on trees built in code): say where, if known.
            if self.line is None:
                return "ssr-compile"
            return f"ssr-compile (line {self.line}" + (f", column {self.col})" if self.col else ")")
        parts = [self.file]
        if self.line is not None:
            parts.append(str(self.line))
            if self.col is not None:
                parts.append(str(self.col))
        return ":".join(parts)

    def __str__(self) -> str:
        text = f"{self.location}: {self.label}: {self.message}"
        caret = caret_lines(self.source, self.line, self.col)
        return f"{text}\n{caret}" if caret else text

    label = "error"


class PDDLSyntaxError(SSRError):
    """The text is not in the dialect's grammar."""

    label = "syntax error"


class CheckError(SSRError):
    """The text parses but is not a valid domain, problem or stream file."""


class UnsupportedError(SSRError):
    """A construct that a pass or a planner backend does not support."""

    label = "unsupported"


class InstanceCapReached(UnsupportedError):
    """Optimistic instantiation passed its cap on stream instances (a resource limit: the
    Focused solver stops raising the level there)."""


class StreamError(SSRError):
    """A streams module is missing, fails to import, or lacks a declared stream."""


class Failure(Exception):
    """Code failed, not the input: a planner backend crashed, a stream's code raised, or
    ssr-compile has a bug.  ``who`` names the culprit (``stream 'ik'``, ``planner fd``) and the
    one-line ``message`` names it too; ``detail`` is what the culprit left behind (a child
    process's traceback, a log's tail), shown with ``--debug``."""

    exit_code = 3

    def __init__(self, who: str, message: str, *, detail: str = ""):
        super().__init__(message)
        self.who = who
        self.message = message
        self.detail = detail

    def __str__(self) -> str:
        return f"ssr-compile: {self.message}"


class StreamFailure(Failure):
    """A stream implementation raised, exited, or produced something its declaration rules
    out: a bug in the streams module, not in the PDDL.  ``message`` names the stream."""

    def __init__(self, stream: str, message: str, *, detail: str = ""):
        super().__init__(f"stream '{stream}'", message, detail=detail)
        self.stream = stream


class PlannerFailure(Failure):
    """A planner backend crashed or answered with an error."""

    def __init__(self, planner: str, message: str, *, detail: str = ""):
        super().__init__(
            f"planner {planner}", f"planner {planner} failed: {message}", detail=detail
        )
        self.planner = planner


EXIT_CODES = {
    0: "success",
    1: "no plan within the limits",
    2: "bad input",
    3: "a planner, a stream's code, an environment's code or ssr-compile failed (not the "
    "input's fault)",
}


class Terminated(KeyboardInterrupt):
    """SIGTERM or SIGHUP, raised in the main thread like SIGINT's KeyboardInterrupt, so that
    every cleanup that runs on Ctrl-C (planner processes killed, temporary folders removed)
    runs for them too.  The CLI exits with 128 + the signal's number."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


class TimeLimitReached(BaseException):
    """A command's ``--time-limit`` passed (raised by the CLI's alarm in the main thread).

    A BaseException, like KeyboardInterrupt, so that no ``except Exception`` in a stream or a
    backend takes it for an error of its own: the cleanup that runs on Ctrl-C runs for it."""

    def __init__(self, seconds: float):
        super().__init__(seconds)
        self.seconds = seconds


def caret_lines(source: str | None, line: int | None, col: int | None) -> str:
    """The source line ``line`` and a caret under column ``col`` (both 1-based)."""
    if source is None or line is None:
        return ""
    lines = source.splitlines()
    if not 1 <= line <= len(lines):
        return ""
    text = _printable(lines[line - 1].expandtabs(1))
    if len(text) > 160:
        start = max(0, (col or 1) - 80)
        text = ("..." if start else "") + text[start : start + 160]
        col = (col or 1) - start + (3 if start else 0)
    pointer = " " * (max(col or 1, 1) - 1) + "^"
    return f"    {text}\n    {pointer}"


def _printable(text: str) -> str:
    """Replace control characters so that a caret line stays aligned and readable."""
    return "".join(ch if ch.isprintable() else "?" for ch in text)
