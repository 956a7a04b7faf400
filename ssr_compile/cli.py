"""The ``ssr-compile`` command line.

Exit codes (README, "Commands"): 0 success, 1 no plan within the limits, 2 bad input (the message names
file:line:col; never a traceback).  Subcommands register themselves in ``COMMANDS``; heavy
imports (planners, PyBullet) happen inside the commands that need them, so ``check`` and
``fmt`` start fast.
"""

from __future__ import annotations

import argparse
import errno
import math
import os
import signal
import sys
import tempfile
import threading
from collections.abc import Callable
from pathlib import Path

from . import __version__
from . import syntax as S
from .errors import Failure, SSRError, TimeLimitReached
from .limits import time_limit  # noqa: F401 (cli.time_limit: the commands bound themselves)

COMMANDS: dict[
    str, tuple[Callable[[argparse.ArgumentParser], None], Callable[[argparse.Namespace], int], str]
] = {}


def register(name: str, help: str, configure, run) -> None:
    """Register a subcommand: ``configure(parser)`` adds its options, ``run(args)`` runs it."""
    COMMANDS[name] = (configure, run, help)


def write_atomically(path: str | Path, text: str) -> None:
    """Write ``text`` to ``path`` through a temporary file, so nothing is left half-written."""
    write_files_atomically({Path(path): text})


def write_files_atomically(files: dict[Path, str]) -> None:
    """Write several files as a unit: all of them, or (on any error) none of them.

    Each file goes through a temporary file beside it and is then moved in place.  Only a
    regular file is ever replaced: a symlink, FIFO, device or folder at an output path is bad
    input (an SSRError, exit 2), never written through nor replaced.  A new file gets the mode
    the umask gives (like ``open``); an existing file keeps its mode.  Filesystem errors are
    reported as SSRErrors naming the path (exit 1 for a full disk).
    """
    files = {Path(p): t for p, t in files.items()}
    for path in files:
        _check_parents(path)
        _refuse_non_regular(path)
    temps: dict[Path, str] = {}
    backups: dict[Path, str | None] = {}  # path -> hard link to its old content (None: new)
    done: list[Path] = []
    try:
        for path, text in files.items():
            _make_parent(path)
            fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
            temps[path] = tmp
            with os.fdopen(fd, "w", encoding="utf-8") as fh:
                fh.write(text)
            os.chmod(tmp, _mode_for(path))
        for path in files:
            _refuse_non_regular(path)  # again, just before replacing
            backups[path] = _backup(path)
        for path, tmp in temps.items():
            os.replace(tmp, path)
            done.append(path)
    except BaseException as e:
        for path in reversed(done):  # put back what was there
            old = backups.get(path)
            try:
                if old is None:
                    path.unlink()
                else:
                    os.replace(old, path)
                    backups[path] = None
            except OSError:
                pass
        for tmp in temps.values():
            Path(tmp).unlink(missing_ok=True)
        for old in backups.values():
            if old is not None:
                Path(old).unlink(missing_ok=True)
        if isinstance(e, OSError):
            raise _write_error(e, e.filename or next(iter(files))) from None
        raise
    for old in backups.values():
        if old is not None:
            Path(old).unlink(missing_ok=True)


def _refuse_non_regular(path: Path) -> None:
    import stat

    try:
        st = os.lstat(path)
    except FileNotFoundError:
        return
    except OSError as e:
        raise _write_error(e, path) from None
    if stat.S_ISREG(st.st_mode):
        return
    kinds = [
        (stat.S_ISLNK, "a symbolic link"),
        (stat.S_ISDIR, "a folder"),
        (stat.S_ISFIFO, "a FIFO (named pipe)"),
        (stat.S_ISCHR, "a character device"),
        (stat.S_ISBLK, "a block device"),
        (stat.S_ISSOCK, "a socket"),
    ]
    kind = next((word for test, word in kinds if test(st.st_mode)), "not a regular file")
    raise SSRError(
        f"the output path is {kind}; only a regular file is replaced "
        "(remove it or choose another output path)",
        file=str(path),
    )


def _check_parents(path: Path) -> None:
    """The nearest existing folder above ``path`` must be a folder (not a file)."""
    for parent in path.parents:
        if os.path.lexists(parent):
            if not parent.is_dir():
                raise SSRError(
                    "is not a folder (an output is to be written into it)", file=str(parent)
                )
            return


def _make_parent(path: Path) -> None:
    _check_parents(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except FileExistsError:
        raise SSRError(
            "is not a folder (an output is to be written into it)", file=str(path.parent)
        ) from None


def _umask() -> int:
    try:
        with open("/proc/self/status", encoding="ascii") as f:
            for line in f:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    mask = os.umask(0o022)  # no way to read it without setting it (not thread-safe)
    os.umask(mask)
    return mask


def _mode_for(path: Path) -> int:
    """An existing file's mode, or the mode ``open`` would give a new file."""
    import stat

    try:
        return stat.S_IMODE(os.stat(path).st_mode)
    except FileNotFoundError:
        return 0o666 & ~_umask()


def _backup(path: Path) -> str | None:
    """A hard link to ``path``'s present content beside it (None if there is no file)."""
    if not os.path.lexists(path):
        return None
    for i in range(100):
        name = str(path.parent / f".{path.name}.{os.getpid()}.{i}.bak")
        try:
            os.link(path, name)
            return name
        except FileExistsError:
            continue
        except OSError:  # no hard links here: a copy
            import shutil

            shutil.copy2(path, name)
            return name
    raise SSRError("cannot make a backup before replacing it", file=str(path))


def _write_error(e: OSError, path) -> SSRError:
    import errno

    err = SSRError(f"cannot write: {e.strerror or e}", file=str(path))
    if e.errno in (errno.ENOSPC, errno.EDQUOT):
        err.exit_code = 1
    return err


# ---------------------------------------------------------------- numeric options

# One validation for every numeric option, by its destination name: the commands use these as
# argparse ``type=`` functions, and build_parser() applies them to any command's option of the
# same name, so that a bad number is bad input (exit 2, one line) everywhere.


def seconds(text: str) -> float:
    """A time limit: a finite number of seconds greater than 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number of seconds, got '{text}'") from None
    if not math.isfinite(value) or value <= 0:
        raise argparse.ArgumentTypeError(
            f"expected a finite number of seconds greater than 0, got '{text}'"
        )
    return value


def count(text: str, least: int = 0, most: int | None = None, what: str = "a whole number") -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected {what}, got '{text}'") from None
    if value < least or (most is not None and value > most):
        bound = f"from {least} to {most}" if most is not None else f"{least} or more"
        raise argparse.ArgumentTypeError(f"expected {what} {bound}, got '{text}'")
    return value


def level(text: str) -> int:
    """An instantiation level: 0 or more."""
    return count(text, 0, what="a level")


def seed(text: str) -> int:
    """A random seed: 0 .. 2**32 - 1 (what numpy's generators accept)."""
    return count(text, 0, 2**32 - 1, what="a seed")


def positive_count(text: str) -> int:
    return count(text, 1)


def cost_bound(text: str) -> float:
    """A cost bound: a number greater than 0 (``inf``: no bound)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a cost, got '{text}'") from None
    if math.isnan(value) or value <= 0:
        raise argparse.ArgumentTypeError(f"expected a cost greater than 0, got '{text}'")
    return value


NUMERIC_OPTIONS = {
    "time_limit": seconds,
    "level": level,
    "max_level": level,
    "seed": seed,
    "max_cost": cost_bound,
    "particles": positive_count,
}


def _validate_numbers(p: argparse.ArgumentParser) -> None:
    for action in p._actions:  # argparse keeps no public list of a parser's options
        check = NUMERIC_OPTIONS.get(action.dest)
        if check is not None and action.type in (int, float, None) and action.option_strings:
            action.type = check


# ---------------------------------------------------------------- check


def _configure_check(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "files",
        nargs="+",
        metavar="FILE",
        help="domain, problem and stream files (.pddl), or an example folder or shipped "
        "example's name (e.g. kitchen): all its files",
    )
    p.add_argument(
        "--domain",
        metavar="D",
        help="domain file to check problem and stream files against "
        "(default: the domain file given among FILE); a file that is not a domain is bad input",
    )


def _summary(node: S.File) -> str:
    def n(count: int, word: str) -> str:
        return f"{count} {word}{'' if count == 1 else 's'}"

    if isinstance(node, S.Domain):
        parts = [
            n(len(node.actions), "action"),
            n(len(node.axioms), "axiom"),
            n(len(node.predicates), "predicate"),
            n(len(node.functions), "function"),
        ]
        if node.durative_actions:
            parts.append(n(len(node.durative_actions), "durative action"))
        if node.types:
            parts.append(n(len(node.types), "type"))
        if node.constants:
            parts.append(n(len(node.constants), "constant"))
    elif isinstance(node, S.Problem):
        parts = [n(len(node.objects), "object"), n(len(node.init), "initial fact")]
        parts.append("a goal" if node.goal is not None else "no goal")
        if node.metric is not None:
            parts.append(f"metric {node.metric.direction}")
    else:
        tests = sum(1 for s in node.streams if s.is_test)
        parts = [n(len(node.streams), "stream") + (f" ({tests} tests)" if tests else "")]
        if node.functions:
            parts.append(n(len(node.functions), "function"))
        if node.predicates:
            parts.append(n(len(node.predicates), "predicate"))
        if node.rules:
            parts.append(n(len(node.rules), "rule"))
        if node.optimizers:
            parts.append(n(len(node.optimizers), "optimizer"))
    return f"{node.kind} {node.name}: " + ", ".join(parts)


def load_files(paths: list[str], warnings: list[str]) -> list[tuple[str, str, S.File]]:
    """Parse each path; returns (path, source, tree) triples or raises the first SSRError."""
    from .parse import parse_text, read_source

    out = []
    for path in paths:
        if path == "-":  # standard input
            data = sys.stdin.buffer.read() if hasattr(sys.stdin, "buffer") else sys.stdin.read()
            source = data.decode("utf-8", errors="replace") if isinstance(data, bytes) else data
            out.append((path, source, parse_text(source, "<stdin>", warnings=warnings)))
            continue
        source = read_source(path)
        out.append((path, source, parse_text(source, path, warnings=warnings)))
    return out


def expand_example_files(files: list[str]) -> list[str]:
    """FILE arguments with each example folder (or shipped example's name) replaced by its
    domain, stream and problem files."""
    from .examples import resolve_folder

    out: list[str] = []
    for name in files:
        if Path(name).is_file() or name == "-":
            out.append(name)
            continue
        folder = resolve_folder(name)
        if folder is None or not (folder / "domain.pddl").is_file():
            out.append(name)  # reported as a file that cannot be read
            continue
        out.extend(str(p) for p in example_files(folder))
    return out


def example_files(folder: Path) -> list[Path]:
    """An example folder's domain, stream and problem files, in that order."""
    rest = sorted(p for p in folder.glob("*.pddl") if p.name not in ("domain.pddl", "stream.pddl"))
    return [folder / "domain.pddl", folder / "stream.pddl", *rest]


def run_check(args: argparse.Namespace) -> int:
    from .check import check_domain, check_problem, check_streams

    warnings: list[str] = []
    args.files = expand_example_files(args.files)
    paths = list(args.files)
    if args.domain and args.domain not in paths:
        paths.insert(0, args.domain)
    loaded = []
    failed = False
    for path in paths:
        try:
            loaded.extend(load_files([path], warnings))
        except SSRError as e:
            if path == args.domain:
                raise  # nothing can be checked against a domain that does not parse
            print(str(e), file=sys.stderr)
            failed = True
    if args.domain:
        role = next((x[2] for x in loaded if x[0] == args.domain), None)
        if role is not None and not isinstance(role, S.Domain):
            raise SSRError(
                f"--domain names a {role.kind} file; expected a domain file", file=args.domain
            )
    domains = [x for x in loaded if isinstance(x[2], S.Domain)]
    streams = [x for x in loaded if isinstance(x[2], S.StreamFile)]

    def domain_for(path: str):
        if args.domain:
            return next((d for d in domains if d[0] == args.domain), None)
        if len(domains) == 1:
            return domains[0]
        near = [d for d in domains if Path(d[0]).parent == Path(path).parent]
        return near[0] if len(near) == 1 else None

    def streams_for(domain_path: str):
        if len(streams) == 1:
            return streams[0][2]
        near = [s for s in streams if Path(s[0]).parent == Path(domain_path).parent]
        return near[0][2] if len(near) == 1 else None

    for path, source, node in loaded:
        if isinstance(node, S.Domain):
            report = check_domain(node, streams=streams_for(path), filename=path, source=source)
        elif isinstance(node, S.Problem):
            d = domain_for(path)
            s = streams_for(d[0]) if d else None
            if d and node.domain_name is not None and node.domain_name != d[2].name:
                # Said first: the errors that follow come from checking against another domain.
                print(
                    f"{path}: the problem is for domain '{node.domain_name}', but is checked "
                    f"against domain '{d[2].name}' ({d[0]})",
                    file=sys.stderr,
                )
            report = check_problem(
                node, d[2] if d else None, streams=s, filename=path, source=source
            )
        else:
            d = domain_for(path)
            report = check_streams(node, d[2] if d else None, filename=path, source=source)
        if path == args.domain and path not in args.files:
            if report.errors:
                failed = True
                for e in sorted(report.errors, key=lambda e: (e.line or 0, e.col or 0)):
                    print(str(e), file=sys.stderr)
            continue
        for w in report.warnings:
            warnings.append(w)
        if report.errors:
            failed = True
            for e in sorted(report.errors, key=lambda e: (e.line or 0, e.col or 0)):
                print(str(e), file=sys.stderr)
            print(
                f"{path}: {len(report.errors)} error{'s' * (len(report.errors) != 1)}",
                file=sys.stderr,
            )
        else:
            print(f"{path}: {_summary(node)}")
    for w in warnings:
        print(w, file=sys.stderr)
    return 2 if failed else 0


# ---------------------------------------------------------------- fmt


def _configure_fmt(p):
    p.add_argument(
        "file", metavar="FILE", help="domain, problem or stream file ('-': standard input)"
    )
    p.add_argument("-o", "--output", metavar="OUT", help="write to OUT instead of standard output")
    p.add_argument(
        "--shorthand",
        action="store_true",
        help="print the paper's shorthand (:param :pre :eff :inp :dom :out :cert, incr)",
    )


def run_fmt(args: argparse.Namespace) -> int:
    from .printer import to_text

    warnings: list[str] = []
    ((_, _, node),) = load_files([args.file], warnings)
    text = to_text(node, shorthand=args.shorthand)
    for w in warnings:
        print(w, file=sys.stderr)
    if args.output:
        write_atomically(args.output, text)
    else:
        sys.stdout.write(text)
    return 0


register("check", "parse and check domain, problem and stream files", _configure_check, run_check)
register(
    "fmt",
    "print a file as canonical text (long keywords, or the paper's shorthand)",
    _configure_fmt,
    run_fmt,
)


# ---------------------------------------------------------------- main


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
            "file:line:col), 3 a planner, a stream's code or ssr-compile failed (not the "
            "input's fault; the message names the backend or the stream, --debug shows the "
            "traceback), 128+N killed by signal N."
        ),
    )
    parser.add_argument("--version", action="version", version=f"ssr-compile {__version__}")
    parser.add_argument("--debug", action="store_true", help=_DEBUG_HELP)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, (configure, _run, help_text) in COMMANDS.items():
        p = sub.add_parser(name, help=help_text, description=help_text)
        configure(p)
        p.add_argument("--debug", action="store_true", default=argparse.SUPPRESS, help=_DEBUG_HELP)
        _validate_numbers(p)
    return parser


_DEBUG_HELP = "on a failure of a planner, a stream or ssr-compile, print the traceback too"


def _load_command_modules() -> None:
    """Import the modules that register further subcommands (each is optional)."""
    import importlib

    for module in (
        "ssr_compile.cli_compile",
        "ssr_compile.cli_solve",
        "ssr_compile.cli_sim",
        "ssr_compile.cli_run",
        "ssr_compile.cli_experiment",
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
    from .errors import Terminated

    # Once: the cleanup that the exception starts is not itself interrupted by a second one.
    for other in (signal.SIGTERM, signal.SIGHUP):
        signal.signal(other, signal.SIG_IGN)
    raise Terminated(signum)


def main(argv: list[str] | None = None) -> int:
    from .quiet_pybullet import install

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


if __name__ == "__main__":
    # Run as `python -m ssr_compile.cli`: use the module the subcommands register in (this
    # file, imported as __main__, is a second copy of it with an empty COMMANDS).
    from ssr_compile.cli import main as _main

    sys.exit(_main())
