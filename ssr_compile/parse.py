"""Text -> syntax tree for domains, problems and stream files.

The Lark LALR parser is built once per process and reused; a transformer embedded in the
parser builds :mod:`ssr_compile.syntax` nodes straight from the grammar rules (no intermediate
parse tree).  Every Lark exception is turned into a :class:`PDDLSyntaxError` that names
file:line:col, shows the line with a caret, and says in words what was found and what was
expected.  The transformer is stateless, so a failed parse leaves the parser usable.
"""

from __future__ import annotations

import hashlib
import math
import os
import re
import stat
import sys
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

from lark import Lark, Token, Transformer
from lark.exceptions import UnexpectedCharacters, UnexpectedInput, UnexpectedToken

from . import syntax as S
from .errors import PDDLSyntaxError, SSRError
from .resources import grammar_file

GRAMMAR = "pddlstream.lark"


# ---------------------------------------------------------------- transformer helpers


class _Problem(Exception):
    """Raised inside the transformer; turned into a PDDLSyntaxError with the file name."""

    def __init__(self, message: str, tok: Token | None):
        super().__init__(message)
        self.message = message
        self.line = getattr(tok, "line", None)
        self.col = getattr(tok, "column", None)


@dataclass(frozen=True)
class _Part:
    """A block of a file or a field of a block, tagged with its keyword."""

    key: str
    value: object
    tok: Token


@dataclass(frozen=True)
class _Marker:
    """The ``- type`` of a typed list."""

    type: S.TypeRef
    tok: Token


def _span(tok: Token) -> S.Span:
    return S.Span(tok.line, tok.column)


def _low(tok: Token) -> str:
    return str(tok).lower()


def _nodes(items) -> tuple:
    """The children that are syntax-tree nodes (keyword tokens dropped)."""
    return tuple(c for c in items if not isinstance(c, (Token, str)))


def _first(items, *types: str) -> Token:
    return next(c for c in items if isinstance(c, Token) and c.type in types)


def _term(tok: Token) -> S.Term:
    if tok.type == "VARIABLE":
        return S.Var(_low(tok), span=_span(tok))
    return S.Const(_low(tok), span=_span(tok))


def _num_expr(x) -> S.NumExpr:
    if isinstance(x, Token):
        if x.type == "NUMBER":
            return S.Num(_number(x), span=_span(x))
        return _term(x)
    return x


def _number(tok: Token) -> int | float:
    text = str(tok)
    try:
        return int(text)
    except ValueError:
        value = float(text)
    if not math.isfinite(value):
        # 1e999 would become inf, which no PDDL reader (nor our own printer's output) accepts.
        raise _Problem(f"the number {text} is too large; expected a finite number", tok)
    return value


def _group(items, what: str) -> tuple[S.Typed, ...]:
    """Group a flat typed list (names and ``- type`` markers) into typed names."""
    out: list[S.Typed] = []
    pending: list[Token] = []
    for item in items:
        if isinstance(item, _Marker):
            if not pending:
                raise _Problem(f"found '- type' with no {what} before it", item.tok)
            out.extend(S.Typed(_low(t), item.type, span=_span(t)) for t in pending)
            pending = []
        else:
            pending.append(item)
    out.extend(S.Typed(_low(t), None, span=_span(t)) for t in pending)
    return tuple(out)


def _fields(parts, block: str, tok: Token) -> dict[str, _Part]:
    """Index the fields of a block by keyword, refusing duplicates."""
    seen: dict[str, _Part] = {}
    for part in parts:
        if part.key in seen:
            raise _Problem(f"duplicate {part.key} in {block}", part.tok)
        seen[part.key] = part
    return seen


def _value(fields: dict[str, _Part], key: str, default=None):
    part = fields.get(key)
    return default if part is None else part.value


def _file_parts(items, kind: str) -> tuple[Token, list[_Part], list[str]]:
    """Split a file's children into its name, its blocks, and warnings for trailing text."""
    name = _first(items, "NAME", "NUMBER")  # a problem may be named by a number
    blocks = [c for c in items if isinstance(c, _Part)]
    strays = [i for i, c in enumerate(items) if isinstance(c, _Marker) and c.type == "stray"]
    warnings: list[str] = []
    if strays:
        last_block = max((i for i, c in enumerate(items) if isinstance(c, _Part)), default=-1)
        early = [i for i in strays if i < last_block]
        if early:
            tok = items[early[0]].tok
            raise _Problem(
                f"found text '{tok}' outside any block; expected '(' starting a block "
                f"or ')' closing the {kind}",
                tok,
            )
        first = items[strays[0]].tok
        text = " ".join(str(items[i].tok) for i in strays)
        warnings.append(f"{first.line}:{first.column}: ignored text after the last block: {text!r}")
    return name, blocks, warnings


class _Build(Transformer):
    """Builds syntax-tree nodes; method names are the grammar's rule names."""

    # ------------------------------------------------------------ typed lists
    def typed_names(self, items):
        return _group(items, "name")

    def typed_vars(self, items):
        return _group(items, "variable")

    def type_marker(self, items):
        spec = items[-1]
        type_ = spec if isinstance(spec, S.Either) else _low(spec)
        return _Marker(type_, _first(items, "MINUS"))

    def either(self, items):
        return S.Either(tuple(_low(t) for t in items if t.type == "NAME"))

    # ------------------------------------------------------------ conditions
    def atom(self, items):
        head = items[0]
        return S.Atom(_low(head), tuple(_term(t) for t in items[1:]), span=_span(head))

    def empty(self, items):
        return S.And(())

    def and_gd(self, items):
        return S.And(_nodes(items), span=_span(items[0]))

    def or_gd(self, items):
        return S.Or(_nodes(items), span=_span(items[0]))

    def not_gd(self, items):
        (arg,) = _nodes(items)
        return S.Not(arg, span=_span(items[0]))

    def imply_gd(self, items):
        left, right = _nodes(items)
        return S.Imply(left, right, span=_span(items[0]))

    def exists_gd(self, items):
        params, body = _nodes(items)
        return S.Exists(params, body, span=_span(items[0]))

    def forall_gd(self, items):
        params, body = _nodes(items)
        return S.Forall(params, body, span=_span(items[0]))

    def comparison(self, items):
        op_tok = items[0]
        left, right = items[1], items[2]
        op = str(op_tok)
        terms = ("NAME", "VARIABLE")
        if op == "=" and all(isinstance(x, Token) and x.type in terms for x in (left, right)):
            return S.Atom("=", (_term(left), _term(right)), span=_span(op_tok))
        return S.Compare(op, _num_expr(left), _num_expr(right), span=_span(op_tok))

    # ------------------------------------------------------------ numeric expressions
    def f_head_call(self, items):
        head = items[0]
        return S.FuncTerm(_low(head), tuple(_term(t) for t in items[1:]), span=_span(head))

    def f_head_bare(self, items):
        return S.FuncTerm(_low(items[0]), (), span=_span(items[0]))

    def arith(self, items):
        op_tok = items[0]
        args = tuple(_num_expr(x) for x in items[1:])
        if str(op_tok) != "-" and len(args) < 2:
            raise _Problem(f"'{op_tok}' needs at least two arguments", op_tok)
        return S.Arith(str(op_tok), args, span=_span(op_tok))

    # ------------------------------------------------------------ effects
    and_effect = and_gd

    def not_effect(self, items):
        (arg,) = _nodes(items)
        return S.Not(arg, span=_span(items[0]))

    def forall_effect(self, items):
        params, body = _nodes(items)
        return S.Forall(params, body, span=_span(items[0]))

    def when_effect(self, items):
        condition, effect = _nodes(items)
        return S.When(condition, effect, span=_span(items[0]))

    def numeric_effect(self, items):
        op_tok, fluent, value = items
        op = _low(op_tok)
        op = "increase" if op == "incr" else op
        return S.NumericEffect(op, fluent, _num_expr(value), span=_span(op_tok))

    def timed_gd(self, items):
        spec, body = items
        return S.Timed(" ".join(_low(spec).split()), body, span=_span(spec))

    timed_effect = timed_gd
    da_and_gd = and_gd
    da_and_effect = and_gd
    da_forall_gd = forall_gd
    da_forall_effect = forall_effect
    da_when_effect = when_effect

    # ------------------------------------------------------------ domain
    def requirements(self, items):
        flags = tuple(_low(t) for t in items if t.type == "REQ_FLAG")
        return _Part(":requirements", flags, items[0])

    def types_def(self, items):
        return _Part(":types", items[1], items[0])

    def constants_def(self, items):
        return _Part(":constants", items[1], items[0])

    def predicate_decl(self, items):
        head, params = items
        return S.PredicateDecl(_low(head), params, span=_span(head))

    def predicates_def(self, items):
        return _Part(":predicates", _nodes(items), items[0])

    def function_decl(self, items):
        head, params = items
        return S.FunctionDecl(_low(head), params, span=_span(head))

    def functions_def(self, items):
        out: list[S.FunctionDecl] = []
        pending: list[S.FunctionDecl] = []
        for item in items[1:]:
            if isinstance(item, _Marker):
                if not pending:
                    raise _Problem("found '- type' with no function before it", item.tok)
                if not isinstance(item.type, str):
                    raise _Problem("a function's type must be a name such as number", item.tok)
                out.extend(
                    S.FunctionDecl(f.name, f.params, item.type, span=f.span) for f in pending
                )
                pending = []
            else:
                pending.append(item)
        out.extend(pending)
        return _Part(":functions", tuple(out), items[0])

    def parameters(self, items):
        return _Part(":parameters", items[1], items[0])

    def precondition(self, items):
        return _Part(":precondition", items[1], items[0])

    def effect_field(self, items):
        return _Part(":effect", items[1], items[0])

    def action_def(self, items):
        head = _first(items, "NAME")
        fields = _fields([c for c in items if isinstance(c, _Part)], f"action {head}", head)
        return _Part(
            ":action",
            S.Action(
                _low(head),
                _value(fields, ":parameters", ()),
                _value(fields, ":precondition"),
                _value(fields, ":effect"),
                span=_span(head),
            ),
            items[0],
        )

    def derived_def(self, items):
        head = _first(items, "NAME")
        params, body = _nodes(items)
        return _Part(":derived", S.Axiom(_low(head), params, body, span=_span(head)), items[0])

    def duration(self, items):
        return _Part(":duration", items[1], items[0])

    def da_condition(self, items):
        return _Part(":condition", items[1], items[0])

    def da_effect_field(self, items):
        return _Part(":effect", items[1], items[0])

    def durative_def(self, items):
        head = _first(items, "NAME")
        fields = _fields([c for c in items if isinstance(c, _Part)], f"action {head}", head)
        action = S.DurativeAction(
            _low(head),
            _value(fields, ":parameters", ()),
            _value(fields, ":duration"),
            _value(fields, ":condition"),
            _value(fields, ":effect"),
            span=_span(head),
        )
        return _Part(":durative-action", action, items[0])

    def stray(self, items):
        return _Marker("stray", items[0])

    def domain(self, items):
        name, blocks, warnings = _file_parts(items, "domain")
        singles = _fields(
            [b for b in blocks if b.key not in (":action", ":derived", ":durative-action")],
            f"domain {name}",
            name,
        )
        node = S.Domain(
            _low(name),
            _value(singles, ":requirements"),
            _value(singles, ":types", ()),
            _value(singles, ":constants", ()),
            _value(singles, ":predicates", ()),
            _value(singles, ":functions", ()),
            tuple(b.value for b in blocks if b.key == ":derived"),
            tuple(b.value for b in blocks if b.key == ":action"),
            tuple(b.value for b in blocks if b.key == ":durative-action"),
            span=_span(name),
        )
        return node, warnings

    # ------------------------------------------------------------ problem
    def problem_domain(self, items):
        return _Part(":domain", _low(_first(items, "NAME")), items[0])

    def objects(self, items):
        return _Part(":objects", items[1], items[0])

    def init_not(self, items):
        (arg,) = _nodes(items)
        return S.Not(arg, span=_span(items[0]))

    def init_value(self, items):
        op_tok, fluent, value = items
        if str(op_tok) != "=":
            raise _Problem(
                f"found '{op_tok}' in :init; expected '=' giving a function's value", op_tok
            )
        return S.InitValue(fluent, S.Num(_number(value), span=_span(value)), span=_span(op_tok))

    def init(self, items):
        return _Part(":init", _nodes(items), items[0])

    def goal(self, items):
        return _Part(":goal", items[1], items[0])

    def metric(self, items):
        direction, expr = items[1], items[2]
        return _Part(
            ":metric", S.Metric(_low(direction), _num_expr(expr), span=_span(direction)), items[0]
        )

    def problem(self, items):
        name, blocks, warnings = _file_parts(items, "problem")
        fields = _fields(blocks, f"problem {name}", name)
        node = S.Problem(
            _low(name),
            _value(fields, ":domain"),
            _value(fields, ":requirements"),
            _value(fields, ":objects", ()),
            _value(fields, ":init", ()),
            _value(fields, ":goal"),
            _value(fields, ":metric"),
            span=_span(name),
        )
        return node, warnings

    # ------------------------------------------------------------ stream file
    def inputs(self, items):
        return _Part(":inputs", items[1], items[0])

    def outputs(self, items):
        return _Part(":outputs", items[1], items[0])

    def stream_domain(self, items):
        return _Part(":domain", items[1], items[0])

    def certified(self, items):
        return _Part(":certified", items[1], items[0])

    def fluents(self, items):
        return _Part(":fluents", tuple(_low(t) for t in items[1:]), items[0])

    def opt_graph(self, items):
        return _Part(":graph", items[1], items[0])

    def opt_necessary(self, items):
        return _Part(":necessary", items[1], items[0])

    def stream_def(self, items):
        head = _first(items, "NAME")
        fields = _fields([c for c in items if isinstance(c, _Part)], f"stream {head}", head)
        stream = S.Stream(
            _low(head),
            _value(fields, ":inputs", ()),
            _value(fields, ":domain"),
            _value(fields, ":fluents", ()),
            _value(fields, ":outputs", ()),
            _value(fields, ":certified"),
            span=_span(head),
        )
        return _Part(":stream", stream, items[0])

    def rule_def(self, items):
        fields = _fields([c for c in items if isinstance(c, _Part)], ":rule", items[0])
        for key in (":outputs", ":fluents"):
            if key in fields:
                raise _Problem(f"a :rule has no {key}", fields[key].tok)
        rule = S.Rule(
            _value(fields, ":inputs", ()),
            _value(fields, ":domain"),
            _value(fields, ":certified"),
            span=_span(items[0]),
        )
        return _Part(":rule", rule, items[0])

    def _declared(self, items, cls, key):
        head = _first(items, "NAME")
        params = next(c for c in items if isinstance(c, tuple))
        body = [c for c in items if not isinstance(c, (Token, tuple))]
        node = cls(_low(head), params, body[0] if body else None, span=_span(head))
        return _Part(key, node, items[0])

    def stream_function(self, items):
        return self._declared(items, S.StreamFunction, ":function")

    def stream_predicate(self, items):
        return self._declared(items, S.StreamPredicate, ":predicate")

    def _opt_fields(self, items):
        parts = [c for c in items if isinstance(c, _Part)]
        _fields(parts, "optimizer block", items[0])
        return tuple((p.key, p.value) for p in parts)

    def opt_variables(self, items):
        head = next(c for c in items if isinstance(c, tuple))
        return S.OptimizerBlock("variables", head, self._opt_fields(items), span=_span(items[0]))

    def opt_constraint(self, items):
        head = next(c for c in items if isinstance(c, S.Atom))
        return S.OptimizerBlock("constraint", head, self._opt_fields(items), span=_span(items[0]))

    def opt_objective(self, items):
        return S.OptimizerBlock("objective", _low(items[1]), (), span=_span(items[0]))

    def optimizer_def(self, items):
        head = _first(items, "NAME")
        blocks = tuple(c for c in items if isinstance(c, S.OptimizerBlock))
        return _Part(":optimizer", S.Optimizer(_low(head), blocks, span=_span(head)), items[0])

    def stream_file(self, items):
        name, blocks, warnings = _file_parts(items, "stream file")

        def of(key):
            return tuple(b.value for b in blocks if b.key == key)

        node = S.StreamFile(
            _low(name),
            of(":stream"),
            of(":function"),
            of(":predicate"),
            of(":rule"),
            of(":optimizer"),
            span=_span(name),
        )
        return node, warnings

    def start(self, items):
        return items[0]


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
        transformer=_Build(),
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
    except _Problem as p:
        raise PDDLSyntaxError(
            p.message, file=filename, line=p.line, col=p.col, source=text
        ) from None
    except UnexpectedInput as e:
        raise _syntax_error(e, text, filename) from None
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
    for m in _TOKEN.finditer(text):
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


# ---------------------------------------------------------------- error messages

# What each terminal is, in words.
_WORDS = {
    "LPAR": "'('",
    "RPAR": "')'",
    "NAME": "a name",
    "VARIABLE": "a variable such as ?x",
    "NUMBER": "a number",
    "MINUS": "'-'",
    "COMP": "a comparison (=, <, <=, >, >=)",
    "ARITH_OP": "an arithmetic operator (+, *, /)",
    "ASSIGN_OP": "a numeric effect (increase, decrease, assign, scale-up, scale-down)",
    "REQ_FLAG": "a requirement such as :strips",
    "TIME_SPEC": "'at start', 'at end' or 'over all'",
    "OPTIMIZATION": "'minimize' or 'maximize'",
    "$END": "the end of the file",
}
_KEYWORDS = {
    "DEFINE": "define",
    "DOMAIN": "domain",
    "PROBLEM": "problem",
    "STREAM": "stream",
    "AND": "and",
    "OR": "or",
    "NOT": "not",
    "IMPLY": "imply",
    "EXISTS": "exists",
    "FORALL": "forall",
    "WHEN": "when",
    "EITHER": "either",
}
# After these keywords, what must come next, in words.
_AFTER = {
    ":parameters": "a parameter list such as (?x ?y - type)",
    ":param": "a parameter list such as (?x ?y - type)",
    ":precondition": "a condition such as (and (p ?x) (not (q ?x)))",
    ":pre": "a condition such as (and (p ?x) (not (q ?x)))",
    ":effect": "an effect such as (and (p ?x) (not (q ?x)))",
    ":eff": "an effect such as (and (p ?x) (not (q ?x)))",
    ":inputs": "a variable list such as (?x ?y)",
    ":inp": "a variable list such as (?x ?y)",
    ":outputs": "a variable list such as (?y)",
    ":out": "a variable list such as (?y)",
    ":domain": "a condition such as (and (p ?x))",
    ":dom": "a condition such as (and (p ?x))",
    ":certified": "a condition such as (and (p ?x ?y))",
    ":cert": "a condition such as (and (p ?x ?y))",
    ":fluents": "a list of predicate names such as (atpose)",
    ":goal": "a goal condition such as (and (p a))",
    ":predicates": "predicate declarations such as (p ?x - type)",
    ":types": "type names",
    ":constants": "object names",
    ":objects": "object names",
    ":init": "initial facts such as (p a)",
    ":requirements": "requirement flags such as :strips",
    ":derived": "the derived predicate's head such as (p ?x)",
    ":action": "the action's name",
    ":stream": "the stream's name",
    "define": "'(' and the file's kind: (domain NAME), (problem NAME) or (stream NAME)",
    "either": "type names",
}


def _describe_expected(expected: set[str], prev: str | None) -> str:
    expected = {e for e in expected if e != "STRAY"}
    prev_l = (prev or "").lower()
    if prev_l in _AFTER and not (prev_l == ":domain" and expected <= {"NAME"}):
        return f"{_AFTER[prev_l]} after {prev}"
    words = []
    keywords = []
    for e in sorted(expected):
        if e in _WORDS:
            words.append(_WORDS[e])
        elif e in _KEYWORDS:
            keywords.append(_KEYWORDS[e])
        elif e.endswith("_KEY") or e.isupper():
            keywords.append(_keyword_text(e))
    if keywords:
        kw = ", ".join(keywords[:12]) + (", ..." if len(keywords) > 12 else "")
        words.insert(0, f"one of {kw}" if len(keywords) > 1 else keywords[0])
    if not words:
        return "something else"
    if len(words) == 1:
        text = words[0]
    else:
        text = ", ".join(words[:-1]) + " or " + words[-1]
    if prev:
        text += f" after {prev!r}" if prev in "()" else f" after {prev}"
    return text


def _keyword_text(terminal: str) -> str:
    """The spelling of a keyword terminal such as PRECONDITION -> :precondition."""
    base = terminal.removesuffix("_KEY").lower().replace("_", "-")
    return ":" + base


_TOKEN = re.compile(r";[^\n]*|[()]|[^\s();]+")


def _previous_token(text: str, pos: int) -> str | None:
    last = None
    for m in _TOKEN.finditer(text, 0, pos):
        if not m.group().startswith(";"):
            last = m.group()
    return last


def _found(text: str, pos: int) -> str:
    if pos >= len(text):
        return "the end of the file"
    m = re.compile(r"[^\s()]+|.").match(text, pos)
    word = m.group() if m else text[pos]
    if len(word) > 40:
        word = word[:40] + "..."
    if not word.isprintable():
        return f"the character {word[0]!r}" if len(word) == 1 else f"{word!r}"
    return f"'{word}'"


def _end_position(text: str) -> tuple[int, int]:
    stripped = text.rstrip()
    line = stripped.count("\n") + 1
    col = len(stripped) - (stripped.rfind("\n") + 1) + 1
    return line, col


def _syntax_error(e: UnexpectedInput, text: str, filename: str) -> PDDLSyntaxError:
    expected = _acceptable(e)
    if isinstance(e, UnexpectedToken) and e.token.type == "$END":
        if _previous_token(text, len(text)) is None:
            line, col = 1, 1
            return PDDLSyntaxError(
                "the file is empty (nothing but blanks and comments); expected "
                "(define (domain NAME) ...), (define (problem NAME) ...) or (define (stream NAME) ...)",
                file=filename,
                line=line,
                col=col,
                source=text,
            )
        line, col = _end_position(text)
        depth = _open_parens(text)
        hint = f" ({depth} unclosed '(')" if depth > 0 else ""
        message = f"found the end of the file{hint}; expected {_describe_expected(expected, None)}"
        return PDDLSyntaxError(message, file=filename, line=line, col=col, source=text)
    if isinstance(e, UnexpectedToken):
        pos = e.token.start_pos
    elif isinstance(e, UnexpectedCharacters):
        pos = e.pos_in_stream
    else:  # pragma: no cover - other Lark errors do not occur with LALR
        pos = getattr(e, "pos_in_stream", 0) or 0
    line, col = e.line, e.column
    if line is None or line < 1:
        line = text.count("\n", 0, pos) + 1
        col = pos - (text.rfind("\n", 0, pos) + 1) + 1
    prev = _previous_token(text, pos)
    found = _found(text, pos)
    if found.strip("'") == ")" and expected == {"$END"}:
        return PDDLSyntaxError(
            "found one ')' too many after the end of the file's (define ...)",
            file=filename,
            line=line,
            col=col,
            source=text,
        )
    if found.strip("'") == ")" and expected and "RPAR" not in expected:
        found = "')' too early"
    message = f"found {found}; expected {_describe_expected(expected, prev)}"
    return PDDLSyntaxError(message, file=filename, line=line, col=col, source=text)


def _acceptable(e: UnexpectedInput) -> set[str]:
    """The terminals the parser could really accept where it failed.

    LALR merges states, so the ``expected`` set of an error may list terminals that only other
    contexts accept; asking the interactive parser (which tries each one) gives the exact set.
    """
    fallback = set(getattr(e, "expected", None) or getattr(e, "allowed", None) or ())
    ip = getattr(e, "interactive_parser", None)
    if ip is None:
        return fallback
    try:
        return set(ip.accepts()) or fallback
    except Exception:  # a reduction on a copy of the parser refused its input
        return fallback


def _open_parens(text: str) -> int:
    depth = 0
    for m in _TOKEN.finditer(text):
        tok = m.group()
        if tok == "(":
            depth += 1
        elif tok == ")":
            depth -= 1
    return depth
