"""The ``ssr-compile`` command line: its parser, exit codes and error reporting.

Exit codes (README, "Exit codes"): 0 success, 1 no plan within the limits, 2 bad input (the
message names file:line:col; never a traceback), 3 a planner's, a stream's, an environment's
or ssr-compile's own code failed, 128+N killed by signal N.  Subcommands register themselves in
``COMMANDS`` (``registry``); heavy imports (planners, PyBullet) happen inside the commands that
need them, so ``check`` and ``fmt`` start fast.
"""

from __future__ import annotations

import argparse
import errno
import signal
import sys
import threading

from .. import __version__
from ..errors import Failure, SSRError, TimeLimitReached
from . import check  # noqa: F401 - registers check and fmt, the first commands
from .options import validate_numbers
from .registry import COMMANDS


def build_parser() -> argparse.ArgumentParser:
    _load_command_modules()
    parser = argparse.ArgumentParser(
        prog="ssr-compile",
        description=(
            "A toolkit for the PDDLStream dialect of 'Online Replanning in Belief Space for "
            "Partially Observable Task and Motion Problems': parse and check files, compile "
            "optimistic stream instantiation to plain cost-PDDL for classical planners, and "
            "solve with the Focused algorithm."
        ),
        epilog=(
            "Exit codes: 0 success, 1 no plan within the limits, 2 bad input (the message names "
            "file:line:col), 3 a planner, a stream's code, an environment's code or "
            "ssr-compile failed (not the input's fault; the message names the backend, the "
            "stream or the module and method, --debug shows the traceback), 128+N killed by "
            "signal N."
        ),
    )
    parser.add_argument("--version", action="version", version=f"ssr-compile {__version__}")
    parser.add_argument("--debug", action="store_true", help=_DEBUG_HELP)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, (configure, _run, help_text) in COMMANDS.items():
        p = sub.add_parser(name, help=help_text, description=help_text)
        configure(p)
        p.add_argument("--debug", action="store_true", default=argparse.SUPPRESS, help=_DEBUG_HELP)
        validate_numbers(p)
    return parser


_DEBUG_HELP = "on a failure of a planner, a stream or ssr-compile, print the traceback too"


def _load_command_modules() -> None:
    """Import the modules that register further subcommands (each is optional)."""
    import importlib

    for module in (
        "ssr_compile.cli.compile",
        "ssr_compile.cli.map_plan",
        "ssr_compile.cli.solve",
        "ssr_compile.cli.sim",
        "ssr_compile.cli.run",
        "ssr_compile.cli.experiment",
    ):
        try:
            importlib.import_module(module)
        except ModuleNotFoundError as e:
            if e.name != module:
                raise


class _signals_as_interrupts:
    """SIGTERM and SIGHUP raise :class:`Terminated` (a KeyboardInterrupt) in the main thread
    while a command runs, so they clean up as SIGINT does: planner processes killed, temporary
    folders removed.  A signal the process was started ignoring (nohup) stays ignored."""

    def __enter__(self):
        self.saved = {}
        if threading.current_thread() is not threading.main_thread():
            return self
        for name in ("SIGTERM", "SIGHUP"):
            signum = getattr(signal, name, None)
            if signum is None or signal.getsignal(signum) == signal.SIG_IGN:
                continue
            self.saved[signum] = signal.signal(signum, _terminate)
        return self

    def __exit__(self, *exc):
        for signum, handler in self.saved.items():
            signal.signal(signum, handler)
        return False


def _terminate(signum, frame):
    from ..errors import Terminated

    # Once: the cleanup that the exception starts is not itself interrupted by a second one.
    for other in (signal.SIGTERM, signal.SIGHUP):
        signal.signal(other, signal.SIG_IGN)
    raise Terminated(signum)


def main(argv: list[str] | None = None) -> int:
    from ..quiet_pybullet import install

    install()  # PyBullet's "build time" banner is not printed by any command
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser()
    debug = bool(argv) and argv[0] == "--debug"
    if debug:
        argv.pop(0)
    # The bare form `ssr-compile DOMAIN STREAM [PROBLEM] -o DIR` means `compile`.
    if argv and argv[0] not in COMMANDS and not argv[0].startswith("-") and "compile" in COMMANDS:
        argv.insert(0, "compile")
    args = parser.parse_args(argv)
    debug = debug or getattr(args, "debug", False)
    if not args.command:
        parser.print_help()
        return 2
    _configure, run, _help = COMMANDS[args.command]
    try:
        with _signals_as_interrupts():
            return run(args)
    except SSRError as e:
        print(str(e), file=sys.stderr)
        return e.exit_code
    except Failure as e:  # a planner's or a stream's code, not the input
        _print_failure(str(e), e, debug, e.detail)
        return e.exit_code
    except TimeLimitReached as e:
        print(f"ssr-compile: time limit of {e.seconds:g} s reached", file=sys.stderr)
        return 1
    except KeyboardInterrupt as e:
        signum = getattr(e, "signum", signal.SIGINT)
        if signum == signal.SIGINT:
            print("ssr-compile: interrupted", file=sys.stderr)
        else:
            print(f"ssr-compile: terminated ({signal.Signals(signum).name})", file=sys.stderr)
        return 128 + signum
    except BrokenPipeError:
        return 0
    except OSError as e:
        if e.errno not in (errno.ENOSPC, errno.EDQUOT, errno.EIO, errno.EROFS):
            _print_failure(f"ssr-compile: internal error: {type(e).__name__}: {e}", e, debug)
            return Failure.exit_code
        # the output could not be written (a full disk, /dev/full): the environment's fault
        where = f" {e.filename}" if e.filename else " the output"
        print(f"ssr-compile: cannot write{where}: {e.strerror}", file=sys.stderr)
        return 1
    except Exception as e:  # noqa: BLE001 - a bug of ssr-compile: one line, exit 3
        _print_failure(f"ssr-compile: internal error: {type(e).__name__}: {e}", e, debug)
        return Failure.exit_code


def _print_failure(line: str, e: BaseException, debug: bool, detail: str = "") -> None:
    """One line on stderr; with --debug the traceback (and what the culprit left) first."""
    if debug:
        import traceback

        traceback.print_exception(e, file=sys.stderr)
        if detail:
            print(detail.rstrip(), file=sys.stderr)
        print(" ".join(line.split()), file=sys.stderr)
    else:
        print(" ".join(line.split()) + " (--debug shows the traceback)", file=sys.stderr)
