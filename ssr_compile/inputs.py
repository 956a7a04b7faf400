"""Reading the input files: domain, stream and problem files parsed and checked together.

Every error is an SSRError naming the file (and line and column where there is one): broken
input is reported, never a traceback.
"""

from __future__ import annotations

import sys

from . import syntax as S
from .errors import SSRError


def load_files(paths: list[str], warnings: list[str]) -> list[tuple[str, str, S.File]]:
    """Parse each path ('-': standard input); returns (path, source, tree) triples or raises
    the first SSRError.  Warnings of the parser are appended to ``warnings``."""
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


def load_inputs(
    domain_path: str, stream_path: str, problem_path: str | None, warnings: list[str]
) -> tuple[S.Domain, S.StreamFile, S.Problem | None]:
    """Parse and check a domain, its stream file and (if given) a problem; raises the first
    error.  The checker's warnings are appended to ``warnings``."""
    from .check import check_domain, check_problem, check_streams

    paths = [domain_path, stream_path] + ([problem_path] if problem_path else [])
    loaded = load_files(paths, warnings)
    (dp, dsrc, domain), (sp, ssrc, streams) = loaded[0], loaded[1]
    for path, node, want in ((dp, domain, S.Domain), (sp, streams, S.StreamFile)):
        if not isinstance(node, want):
            raise SSRError(
                f"expected a {want.kind} file, found a {node.kind} file", file=path, line=1, col=1
            )
    reports = [
        check_domain(domain, streams=streams, filename=dp, source=dsrc),
        check_streams(streams, domain, filename=sp, source=ssrc),
    ]
    problem = None
    if len(loaded) > 2:
        pp, psrc, problem = loaded[2]
        if not isinstance(problem, S.Problem):
            raise SSRError(
                f"expected a problem file, found a {problem.kind} file", file=pp, line=1, col=1
            )
        reports.append(check_problem(problem, domain, streams=streams, filename=pp, source=psrc))
    for r in reports:
        r.raise_first()
        warnings.extend(r.warnings)
    # Stream constructs the compiler refuses are reported against the stream file (the
    # compiler passes only know line and column, and would be attributed to the domain).
    from .compile.instantiate import refuse_unsupported

    try:
        refuse_unsupported(streams)
    except SSRError as e:
        e.file, e.source = sp, ssrc
        raise
    return domain, streams, problem
