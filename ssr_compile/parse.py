"""Text -> syntax tree for domains, problems and stream files.

The Lark LALR parser is built once per process and reused; a transformer embedded in the
parser builds :mod:`ssr_compile.syntax` nodes straight from the grammar rules (no intermediate
parse tree): :mod:`.parse_formulas` (conditions, effects) and :mod:`.parse_files` (the blocks
of domains, problems and stream files).  Every Lark exception is turned into a
:class:`PDDLSyntaxError` that names file:line:col, shows the line with a caret, and says in
words what was found and what was expected (:mod:`.parse_errors`).  The transformer is
stateless, so a failed parse leaves the parser usable.
"""

from __future__ import annotations

import hashlib
import os
import re
import stat
import sys
from functools import lru_cache
from pathlib import Path

from lark import Lark
from lark.exceptions import UnexpectedInput

from . import syntax as S
from .errors import PDDLSyntaxError, SSRError
from .parse_errors import TOKEN, syntax_error
from .parse_files import Build, BuildError
from .resources import grammar_file

GRAMMAR = "pddlstream.lark"


@lru_cache(maxsize=1)
def parser() -> Lark:
    """The process-wide parser (built on first use, then reused)."""
    text = grammar_file(GRAMMAR).read_text(encoding="utf-8")
    # Lark can keep the parse tables in a file (a new process then starts in ~15 ms instead of
    # ~130 ms), but it *unpickles* that file: only a file in a private per-user folder may be
    # used, never one in a shared folder such as /tmp (Lark's own cache=True), where another
    # user could plant it.
    cache = _cache_file(text)
    return Lark(
        text,
        parser="lalr",
        lexer="contextual",
        transformer=Build(),
        maybe_placeholders=False,
        cache=str(cache) if cache is not None else False,
    )


def cache_dir() -> Path | None:
    """The private per-user cache folder (``$XDG_CACHE_HOME/ssr-compile`` or
    ``~/.cache/ssr-compile``), created 0700; None when it cannot be made safe.

    Safe means: a real folder (not a symlink) owned by this user and writable by nobody else,
    inside a folder that only this user or root can change.  Anything else: no cache.
    """
    if os.environ.get("SSR_COMPILE_NO_CACHE") or not hasattr(os, "getuid"):
        return None
    base = os.environ.get("XDG_CACHE_HOME", "")
    try:
        root = Path(base) if os.path.isabs(base) else Path.home() / ".cache"
    except (RuntimeError, KeyError):  # no home folder
        return None
    folder = root / "ssr-compile"
    try:
        root.mkdir(mode=0o700, parents=True, exist_ok=True)
        try:
            folder.mkdir(mode=0o700)
        except FileExistsError:
            pass
    except OSError:
        return None
    uid = os.getuid()
    if not (_private(folder, uid) and _guarded(root, uid)):
        return None
    return folder


def _private(path: Path, uid: int, *, directory: bool = True) -> bool:
    """Is ``path`` (not followed if a symlink) ours, of the right kind, and writable only by us?"""
    try:
        st = os.lstat(path)
    except OSError:
        return False
    kind = stat.S_ISDIR if directory else stat.S_ISREG
    return kind(st.st_mode) and st.st_uid == uid and not st.st_mode & (stat.S_IWGRP | stat.S_IWOTH)


def _guarded(path: Path, uid: int) -> bool:
    """Can only ``uid`` or root rename entries of folder ``path`` (or it is sticky)?"""
    try:
        st = os.stat(path)
    except OSError:
        return False
    if not stat.S_ISDIR(st.st_mode) or st.st_uid not in (uid, 0):
        return False
    return not st.st_mode & (stat.S_IWGRP | stat.S_IWOTH) or bool(st.st_mode & stat.S_ISVTX)


def _cache_file(grammar: str) -> Path | None:
    """Where Lark may keep this grammar's tables, or None (build without a cache)."""
    import lark

    folder = cache_dir()
    if folder is None:
        return None
    key = hashlib.sha256(
        f"{grammar}\0{lark.__version__}\0{sys.version_info[:2]}".encode()
    ).hexdigest()[:24]
    path = folder / f"lark-{key}.pickle"
    if os.path.lexists(path) and not _private(path, os.getuid(), directory=False):
        return None  # someone else's file, a link, or writable by others: never read it
    return path


# ---------------------------------------------------------------- public API


def parse_text(
    text: str,
    filename: str = "<string>",
    *,
    kind: str | None = None,
    warnings: list[str] | None = None,
) -> S.File:
    """Parse one domain, problem or stream file.

    ``kind`` ("domain", "problem" or "stream") makes any other kind an error.  Warnings (such as
    ignored trailing text) are appended to ``warnings`` as ``"file:line:col: message"``.
    """
    if text.startswith("\ufeff"):  # a UTF-8 byte-order mark: not part of the text
        text = text[1:]
    _refuse_control_characters(text, filename)
    _refuse_deep_nesting(text, filename)
    try:
        node, notes = parser().parse(text)
    except BuildError as p:
        raise PDDLSyntaxError(
            p.message, file=filename, line=p.line, col=p.col, source=text
        ) from None
    except UnexpectedInput as e:
        raise syntax_error(e, text, filename) from None
    except RecursionError:
        raise PDDLSyntaxError(
            "the file nests too deeply to be read", file=filename, line=1, col=1
        ) from None
    if kind is not None and node.kind != kind:
        span = node.span or S.Span(1, 1)
        raise PDDLSyntaxError(
            f"found a {node.kind} file; expected a {kind} file",
            file=filename,
            line=span.line,
            col=span.col,
            source=text,
        )
    if warnings is not None:
        warnings.extend(f"{filename}:{w}" for w in notes)
    return node


# Parentheses nested deeper than this are refused when reading: the passes that walk a formula
# (printing, checking, compiling) recurse once or more per level, and Python's recursion limit
# ends them at about 250 levels.  Real files nest less than 20 deep.
MAX_DEPTH = 100
_KEEP = b"();\n"  # parentheses, and what delimits comments
_DROP = bytes(i for i in range(256) if i not in _KEEP)
_COMMENT_PARENS = re.compile(rb";[^\n]*[()]")
_COMMENT = re.compile(rb";[^\n]*")


def _refuse_deep_nesting(text: str, filename: str) -> None:
    """A PDDLSyntaxError at the first '(' nested more than MAX_DEPTH deep, if there is one."""
    if text.count("(") <= MAX_DEPTH:
        return
    # Fast check (C string operations only): each pass removes the innermost pairs "()", so a
    # text whose parentheses nest at most MAX_DEPTH deep is left without pairs after that many.
    parens = text.encode("utf-8", "surrogatepass").translate(None, _DROP)
    if _COMMENT_PARENS.search(parens):  # parentheses in comments do not count
        parens = _COMMENT.sub(b"", parens)
    parens = parens.translate(None, b";\n")
    for _ in range(MAX_DEPTH):
        shorter = parens.replace(b"()", b"")
        if len(shorter) == len(parens):
            return
        parens = shorter
    if b"()" not in parens:
        return
    # Too deep: find where, scanning token by token.
    depth = 0
    for m in TOKEN.finditer(text):
        tok = m.group()
        if tok == "(":
            depth += 1
            if depth > MAX_DEPTH:
                pos = m.start()
                line = text.count("\n", 0, pos) + 1
                col = pos - (text.rfind("\n", 0, pos) + 1) + 1
                raise PDDLSyntaxError(
                    f"nested too deeply (limit {MAX_DEPTH}): this '(' opens level "
                    f"{MAX_DEPTH + 1} of parentheses",
                    file=filename,
                    line=line,
                    col=col,
                    source=text,
                )
        elif tok == ")":
            depth = max(depth - 1, 0)


_CONTROL = re.compile(r"[\x00-\x08\x0e-\x1f\x7f]")


def _refuse_control_characters(text: str, filename: str) -> None:
    """A PDDL file is plain text: control characters (even in comments) mean a damaged file."""
    m = _CONTROL.search(text)
    if m:
        pos = m.start()
        line = text.count("\n", 0, pos) + 1
        col = pos - (text.rfind("\n", 0, pos) + 1) + 1
        raise PDDLSyntaxError(
            f"found the control character {m.group()!r}; expected plain text (is this a binary file?)",
            file=filename,
            line=line,
            col=col,
            source=text,
        )


def read_source(path: str | Path) -> str:
    """Read a file as text; unreadable or binary files give an SSRError."""
    p = Path(path)
    try:
        data = p.read_bytes()
    except FileNotFoundError:
        raise SSRError("no such file", file=str(path)) from None
    except IsADirectoryError:
        raise SSRError("is a directory, expected a .pddl file", file=str(path)) from None
    except OSError as e:
        raise SSRError(f"cannot read: {e.strerror}", file=str(path)) from None
    return data.decode("utf-8", errors="replace")


def parse_file(
    path: str | Path, *, kind: str | None = None, warnings: list[str] | None = None
) -> S.File:
    return parse_text(read_source(path), str(path), kind=kind, warnings=warnings)


def parse_domain(text: str, filename: str = "<domain>") -> S.Domain:
    return parse_text(text, filename, kind="domain")


def parse_problem(text: str, filename: str = "<problem>") -> S.Problem:
    return parse_text(text, filename, kind="problem")


def parse_stream_file(text: str, filename: str = "<stream>") -> S.StreamFile:
    return parse_text(text, filename, kind="stream")
