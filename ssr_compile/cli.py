"""The ``ssr-compile`` command line.

Exit codes (DESIGN §7): 0 success, 1 no plan within the limits, 2 bad input (the message names
file:line:col; never a traceback).  Subcommands register themselves in ``COMMANDS``; heavy
imports (planners, PyBullet) happen inside the commands that need them, so ``check`` and
``fmt`` start fast.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path

from . import __version__
from . import syntax as S
from .errors import SSRError

COMMANDS: dict[
    str, tuple[Callable[[argparse.ArgumentParser], None], Callable[[argparse.Namespace], int], str]
] = {}


def register(name: str, help: str, configure, run) -> None:
    """Register a subcommand: ``configure(parser)`` adds its options, ``run(args)`` runs it."""
    COMMANDS[name] = (configure, run, help)


def write_atomically(path: str | Path, text: str) -> None:
    """Write ``text`` to ``path`` through a temporary file, so nothing is left half-written."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(text)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


# ---------------------------------------------------------------- check


def _configure_check(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "files", nargs="+", metavar="FILE", help="domain, problem and stream files (.pddl)"
    )
    p.add_argument(
        "--domain",
        metavar="D",
        help="domain file to check problem and stream files against "
        "(default: the domain file given among FILE)",
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
        source = read_source(path)
        out.append((path, source, parse_text(source, path, warnings=warnings)))
    return out


def run_check(args: argparse.Namespace) -> int:
    from .check import check_domain, check_problem, check_streams

    warnings: list[str] = []
    paths = list(args.files)
    if args.domain and args.domain not in paths:
        paths.insert(0, args.domain)
    loaded = []
    failed = False
    for path in paths:
        try:
            loaded.extend(load_files([path], warnings))
        except SSRError as e:
            print(str(e), file=sys.stderr)
            failed = True
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
    p.add_argument("file", metavar="FILE", help="domain, problem or stream file")
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
        epilog="Exit codes: 0 success, 1 no plan within the limits, 2 bad input.",
    )
    parser.add_argument("--version", action="version", version=f"ssr-compile {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, (configure, _run, help_text) in COMMANDS.items():
        p = sub.add_parser(name, help=help_text, description=help_text)
        configure(p)
    return parser


def _load_command_modules() -> None:
    """Import the modules that register further subcommands (each is optional)."""
    import importlib

    for module in (
        "ssr_compile.cli_compile",
        "ssr_compile.cli_solve",
        "ssr_compile.cli_sim",
        "ssr_compile.cli_run",
    ):
        try:
            importlib.import_module(module)
        except ModuleNotFoundError as e:
            if e.name != module:
                raise


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser()
    # The bare form `ssr-compile DOMAIN STREAM [PROBLEM] -o DIR` means `compile`.
    if argv and argv[0] not in COMMANDS and not argv[0].startswith("-") and "compile" in COMMANDS:
        argv.insert(0, "compile")
    args = parser.parse_args(argv)
    if not args.command:
        parser.print_help()
        return 2
    _configure, run, _help = COMMANDS[args.command]
    try:
        return run(args)
    except SSRError as e:
        print(str(e), file=sys.stderr)
        return e.exit_code
    except KeyboardInterrupt:
        print("ssr-compile: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        return 0


if __name__ == "__main__":
    sys.exit(main())
