"""Syntax tree -> canonical PDDL text.

The output depends only on the tree: sections in a fixed order, names in lower case, the long
keywords (``:parameters``, ``:inputs``, ``increase``...) or, on request, the paper's shorthand.
A formula stays on one line when it fits in the width, otherwise its parts go one per line.
Printing is therefore idempotent, and ``parse(to_text(t)) == t`` for every parsed tree.
"""

from __future__ import annotations

from functools import singledispatch

from . import syntax as S

WIDTH = 92
INDENT = "  "

_SHORT = {
    ":parameters": ":param",
    ":precondition": ":pre",
    ":effect": ":eff",
    ":inputs": ":inp",
    ":domain": ":dom",
    ":outputs": ":out",
    ":certified": ":cert",
    "increase": "incr",
}


class _Style:
    def __init__(self, shorthand: bool):
        self.shorthand = shorthand

    def key(self, word: str) -> str:
        return _SHORT.get(word, word) if self.shorthand else word


def to_text(node, *, shorthand: bool = False) -> str:
    """Canonical text of a domain, problem or stream file (or of any formula or term)."""
    style = _Style(shorthand)
    if isinstance(node, S.Domain):
        return _domain(node, style)
    if isinstance(node, S.Problem):
        return _problem(node, style)
    if isinstance(node, S.StreamFile):
        return _stream_file(node, style)
    return _block(node, style, 0)


# ---------------------------------------------------------------- terms and lists


def typed_list(items: tuple[S.Typed, ...]) -> str:
    """``?x ?y - t ?z`` with consecutive names of one type grouped."""
    out: list[str] = []
    i = 0
    while i < len(items):
        j = i
        while j + 1 < len(items) and items[j + 1].type == items[i].type:
            j += 1
        out.extend(t.name for t in items[i : j + 1])
        if items[i].type is not None:
            out.extend(["-", _type(items[i].type)])
        i = j + 1
    return " ".join(out)


def _type(t: S.TypeRef) -> str:
    if isinstance(t, S.Either):
        return "(either " + " ".join(t.types) + ")"
    return str(t)


def _num(value: int | float) -> str:
    if isinstance(value, float) and value.is_integer() and abs(value) < 1e15:
        return f"{value:.1f}"
    return repr(value)


def _call(head: str, args) -> str:
    return "(" + " ".join([head, *args]) + ")"


# ---------------------------------------------------------------- formulas

# _flat renders a node on one line; _parts gives (head, children) for breaking it over lines.


@singledispatch
def _flat(node, style: _Style) -> str:
    raise TypeError(f"cannot print {type(node).__name__}")


@_flat.register
def _(node: S.Var, style):
    return node.name


@_flat.register
def _(node: S.Const, style):
    return node.name


@_flat.register
def _(node: S.Num, style):
    return _num(node.value)


@_flat.register
def _(node: S.FuncTerm, style):
    return _call(node.name, [a.name for a in node.args])


@_flat.register
def _(node: S.Arith, style):
    return _call(node.op, [_flat(a, style) for a in node.args])


@_flat.register
def _(node: S.Atom, style):
    return _call(node.pred, [a.name for a in node.args])


@_flat.register
def _(node: S.Compare, style):
    return _call(node.op, [_flat(node.left, style), _flat(node.right, style)])


@_flat.register(S.Not)
@_flat.register(S.And)
@_flat.register(S.Or)
@_flat.register(S.Imply)
@_flat.register(S.Exists)
@_flat.register(S.Forall)
@_flat.register(S.When)
@_flat.register(S.Timed)
@_flat.register(S.NumericEffect)
def _(node, style):
    head, kids = _parts(node, style)
    return (
        "("
        + " ".join([head, *(_flat(k, style) if not isinstance(k, str) else k for k in kids)])
        + ")"
    )


def _parts(node, style: _Style) -> tuple[str, list]:
    """The head text and the children (nodes, or ready strings) of a compound formula."""
    if isinstance(node, S.Not):
        return "not", [node.arg]
    if isinstance(node, S.And):
        return "and", list(node.args)
    if isinstance(node, S.Or):
        return "or", list(node.args)
    if isinstance(node, S.Imply):
        return "imply", [node.left, node.right]
    if isinstance(node, (S.Exists, S.Forall)):
        word = "exists" if isinstance(node, S.Exists) else "forall"
        return f"{word} ({typed_list(node.params)})", [node.body]
    if isinstance(node, S.When):
        return "when", [node.condition, node.effect]
    if isinstance(node, S.Timed):
        return node.when, [node.body]
    if isinstance(node, S.NumericEffect):
        return style.key(node.op), [_flat(node.fluent, style), _flat(node.value, style)]
    raise TypeError(f"cannot print {type(node).__name__}")


def _block(node, style: _Style, depth: int) -> str:
    """A formula at indentation ``depth``: one line if it fits, else one part per line."""
    flat = _flat(node, style)
    if len(flat) + len(INDENT) * depth <= WIDTH or isinstance(
        node, (S.Atom, S.FuncTerm, S.Compare)
    ):
        return flat
    head, kids = _parts(node, style)
    if not kids:
        return flat
    pad = "\n" + INDENT * (depth + 1)
    body = pad.join(k if isinstance(k, str) else _block(k, style, depth + 1) for k in kids)
    return f"({head}{pad}{body})"


# ---------------------------------------------------------------- files


def _section(key: str, items: list[str], depth: int = 1) -> str:
    """``(:key item item ...)`` on one line if short, else one item per line."""
    pad = INDENT * depth
    one = f"({key}" + "".join(" " + i for i in items) + ")"
    if len(one) + len(pad) <= WIDTH and "\n" not in one:
        return pad + one
    inner = "".join(f"\n{pad}{INDENT}{i}" for i in items)
    return f"{pad}({key}{inner})"


def _field(key: str, value: str | None, depth: int = 2) -> str:
    return f"\n{INDENT * depth}{key} {value}"


def _domain(d: S.Domain, style: _Style) -> str:
    parts = [f"(define (domain {d.name})"]
    if d.requirements is not None:
        parts.append(_section(":requirements", list(d.requirements)))
    if d.types:
        parts.append(_section(":types", [typed_list(d.types)]))
    if d.constants:
        parts.append(_section(":constants", [typed_list(d.constants)]))
    if d.predicates:
        parts.append(_section(":predicates", [_decl(p.name, p.params) for p in d.predicates]))
    if d.functions:
        parts.append(_section(":functions", _functions(d.functions)))
    for ax in d.axioms:
        head = _decl(ax.name, ax.parameters)
        parts.append(f"{INDENT}(:derived {head}\n{INDENT * 2}{_block(ax.body, style, 2)})")
    for a in d.actions:
        text = f"{INDENT}(:action {a.name}"
        text += _field(style.key(":parameters"), f"({typed_list(a.parameters)})")
        if a.precondition is not None:
            text += _field(style.key(":precondition"), _block(a.precondition, style, 2))
        if a.effect is not None:
            text += _field(style.key(":effect"), _block(a.effect, style, 2))
        parts.append(text + ")")
    for a in d.durative_actions:
        text = f"{INDENT}(:durative-action {a.name}"
        text += _field(style.key(":parameters"), f"({typed_list(a.parameters)})")
        for key, value in (
            (":duration", a.duration),
            (":condition", a.condition),
            (":effect", a.effect),
        ):
            if value is not None:
                text += _field(style.key(key), _block(value, style, 2))
        parts.append(text + ")")
    return "\n".join(parts) + ")\n"


def _decl(name: str, params: tuple[S.Typed, ...]) -> str:
    inner = typed_list(params)
    return f"({name} {inner})" if inner else f"({name})"


def _functions(decls: tuple[S.FunctionDecl, ...]) -> list[str]:
    out: list[str] = []
    i = 0
    while i < len(decls):
        j = i
        while j + 1 < len(decls) and decls[j + 1].type == decls[i].type:
            j += 1
        group = " ".join(_decl(f.name, f.params) for f in decls[i : j + 1])
        out.append(group + (f" - {decls[i].type}" if decls[i].type is not None else ""))
        i = j + 1
    return out


def _problem(p: S.Problem, style: _Style) -> str:
    parts = [f"(define (problem {p.name})"]
    if p.domain_name is not None:
        parts.append(f"{INDENT}(:domain {p.domain_name})")
    if p.requirements is not None:
        parts.append(_section(":requirements", list(p.requirements)))
    if p.objects:
        parts.append(_section(":objects", [typed_list(p.objects)]))
    inits = []
    for fact in p.init:
        if isinstance(fact, S.InitValue):
            inits.append(f"(= {_flat(fact.fluent, style)} {_num(fact.value.value)})")
        else:
            inits.append(_flat(fact, style))
    parts.append(_section(":init", inits) if inits else f"{INDENT}(:init)")
    if p.goal is not None:
        parts.append(f"{INDENT}(:goal {_block(p.goal, style, 2)})")
    if p.metric is not None:
        parts.append(f"{INDENT}(:metric {p.metric.direction} {_flat(p.metric.expr, style)})")
    return "\n".join(parts) + ")\n"


def _stream_file(f: S.StreamFile, style: _Style) -> str:
    parts = [f"(define (stream {f.name})"]
    for s in f.streams:
        text = f"{INDENT}(:stream {s.name}"
        text += _field(style.key(":inputs"), f"({typed_list(s.inputs)})")
        if s.domain is not None:
            text += _field(style.key(":domain"), _block(s.domain, style, 2))
        if s.fluents:
            text += _field(":fluents", "(" + " ".join(s.fluents) + ")")
        text += _field(style.key(":outputs"), f"({typed_list(s.outputs)})")
        if s.certified is not None:
            text += _field(style.key(":certified"), _block(s.certified, style, 2))
        parts.append(text + ")")
    for fn in f.functions:
        parts.append(_declared(":function", fn, style))
    for pr in f.predicates:
        parts.append(_declared(":predicate", pr, style))
    for r in f.rules:
        text = f"{INDENT}(:rule"
        text += _field(style.key(":inputs"), f"({typed_list(r.inputs)})")
        if r.domain is not None:
            text += _field(style.key(":domain"), _block(r.domain, style, 2))
        if r.certified is not None:
            text += _field(style.key(":certified"), _block(r.certified, style, 2))
        parts.append(text + ")")
    for o in f.optimizers:
        parts.append(_optimizer(o, style))
    return "\n".join(parts) + ")\n"


def _declared(key: str, node, style: _Style) -> str:
    text = f"{INDENT}({key} {_decl(node.name, node.params)}"
    if node.domain is not None:
        text += f"\n{INDENT * 2}{_block(node.domain, style, 2)}"
    return text + ")"


def _optimizer(o: S.Optimizer, style: _Style) -> str:
    lines = [f"{INDENT}(:optimizer {o.name}"]
    for b in o.blocks:
        if b.kind == "objective":
            lines.append(f"{INDENT * 2}(:objective {b.head})")
            continue
        head = f"({typed_list(b.head)})" if b.kind == "variables" else _flat(b.head, style)
        text = f"{INDENT * 2}(:{b.kind} {head}"
        for key, value in b.fields:
            if key in (":inputs", ":outputs"):
                shown = f"({typed_list(value)})"
            elif key == ":fluents":
                shown = "(" + " ".join(value) + ")"
            else:
                shown = _block(value, style, 3)
            text += _field(style.key(key), shown, 3)
        lines.append(text + ")")
    return "\n".join(lines) + ")"
