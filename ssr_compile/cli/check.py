"""``ssr-compile check`` and ``fmt``: parse and check files, print them as canonical text."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .. import syntax as S
from ..errors import SSRError
from ..files import write_atomically
from ..inputs import load_files
from .registry import register


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


def expand_example_files(files: list[str]) -> list[str]:
    """FILE arguments with each example folder (or shipped example's name) replaced by its
    domain, stream and problem files."""
    from ..examples import example_files, resolve_folder

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


def run_check(args: argparse.Namespace) -> int:
    from ..check import check_domain, check_problem, check_streams

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
    from ..printer import to_text

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
