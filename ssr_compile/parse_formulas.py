"""The parser's transformer, part 1: typed lists, conditions, numeric expressions and effects.

Each method is named after a rule of ``grammar/pddlstream.lark`` and receives that rule's
children as named arguments (``v_args(inline=True)``); literal parentheses are dropped by Lark,
keyword tokens are kept (their position is the node's span).  The helpers here are shared with
the rules for whole files (:mod:`.parse_files`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from lark import Token, Transformer, v_args

from . import syntax as S


class BuildError(Exception):
    """Raised inside the transformer; turned into a PDDLSyntaxError with the file name."""

    def __init__(self, message: str, tok: Token | None):
        super().__init__(message)
        self.message = message
        self.line = getattr(tok, "line", None)
        self.col = getattr(tok, "column", None)


@dataclass(frozen=True)
class Part:
    """A block of a file or a field of a block, tagged with its keyword."""

    key: str
    value: object
    tok: Token


@dataclass(frozen=True)
class Marker:
    """The ``- type`` of a typed list (or, with type ``"stray"``, text outside any block)."""

    type: S.TypeRef
    tok: Token


def span(tok: Token) -> S.Span:
    return S.Span(tok.line, tok.column)


def low(tok: Token) -> str:
    return str(tok).lower()


def term(tok: Token) -> S.Term:
    if tok.type == "VARIABLE":
        return S.Var(low(tok), span=span(tok))
    return S.Const(low(tok), span=span(tok))


def num_expr(x) -> S.NumExpr:
    if isinstance(x, Token):
        if x.type == "NUMBER":
            return S.Num(number(x), span=span(x))
        return term(x)
    return x


def number(tok: Token) -> int | float:
    text = str(tok)
    try:
        return int(text)
    except ValueError:
        value = float(text)
    if not math.isfinite(value):
        # 1e999 would become inf, which no PDDL reader (nor our own printer's output) accepts.
        raise BuildError(f"the number {text} is too large; expected a finite number", tok)
    return value


def group(entries, what: str) -> tuple[S.Typed, ...]:
    """Group a flat typed list (names and ``- type`` markers) into typed names."""
    out: list[S.Typed] = []
    pending: list[Token] = []
    for entry in entries:
        if isinstance(entry, Marker):
            if not pending:
                raise BuildError(f"found '- type' with no {what} before it", entry.tok)
            out.extend(S.Typed(low(t), entry.type, span=span(t)) for t in pending)
            pending = []
        else:
            pending.append(entry)
    out.extend(S.Typed(low(t), None, span=span(t)) for t in pending)
    return tuple(out)


def fields(parts, block: str, tok: Token) -> dict[str, Part]:
    """Index the fields of a block by keyword, refusing duplicates."""
    seen: dict[str, Part] = {}
    for part in parts:
        if part.key in seen:
            raise BuildError(f"duplicate {part.key} in {block}", part.tok)
        seen[part.key] = part
    return seen


def value(found: dict[str, Part], key: str, default=None):
    part = found.get(key)
    return default if part is None else part.value


@v_args(inline=True)
class FormulaRules(Transformer):
    """Typed lists, conditions, numeric expressions and effects."""

    # ------------------------------------------------------------ typed lists
    def typed_names(self, *entries):
        return group(entries, "name")

    def typed_vars(self, *entries):
        return group(entries, "variable")

    def type_marker(self, minus, spec):
        return Marker(spec if isinstance(spec, S.Either) else low(spec), minus)

    def either(self, keyword, *names):
        return S.Either(tuple(low(t) for t in names))

    # ------------------------------------------------------------ conditions
    def atom(self, head, *args):
        return S.Atom(low(head), tuple(term(t) for t in args), span=span(head))

    def empty(self):
        return S.And(())

    def and_gd(self, keyword, *parts):
        return S.And(parts, span=span(keyword))

    def or_gd(self, keyword, *parts):
        return S.Or(parts, span=span(keyword))

    def not_gd(self, keyword, arg):
        return S.Not(arg, span=span(keyword))

    def imply_gd(self, keyword, left, right):
        return S.Imply(left, right, span=span(keyword))

    def exists_gd(self, keyword, params, body):
        return S.Exists(params, body, span=span(keyword))

    def forall_gd(self, keyword, params, body):
        return S.Forall(params, body, span=span(keyword))

    def comparison(self, op, left, right):
        names = ("NAME", "VARIABLE")
        if op == "=" and all(isinstance(x, Token) and x.type in names for x in (left, right)):
            return S.Atom("=", (term(left), term(right)), span=span(op))
        return S.Compare(str(op), num_expr(left), num_expr(right), span=span(op))

    # ------------------------------------------------------------ numeric expressions
    def f_head_call(self, head, *args):
        return S.FuncTerm(low(head), tuple(term(t) for t in args), span=span(head))

    def f_head_bare(self, head):
        return S.FuncTerm(low(head), (), span=span(head))

    def arith(self, op, *operands):
        args = tuple(num_expr(x) for x in operands)
        if str(op) != "-" and len(args) < 2:
            raise BuildError(f"'{op}' needs at least two arguments", op)
        return S.Arith(str(op), args, span=span(op))

    # ------------------------------------------------------------ effects
    and_effect = and_gd
    not_effect = not_gd
    forall_effect = forall_gd

    def when_effect(self, keyword, condition, effect):
        return S.When(condition, effect, span=span(keyword))

    def numeric_effect(self, op, fluent, amount):
        name = low(op)
        name = "increase" if name == "incr" else name
        return S.NumericEffect(name, fluent, num_expr(amount), span=span(op))

    # ------------------------------------------------------------ durative actions
    def timed_gd(self, spec, body):
        return S.Timed(" ".join(low(spec).split()), body, span=span(spec))

    timed_effect = timed_gd
    da_and_gd = and_gd
    da_and_effect = and_gd
    da_forall_gd = forall_gd
    da_forall_effect = forall_gd
    da_when_effect = when_effect
