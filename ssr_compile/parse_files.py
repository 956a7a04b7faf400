"""The parser's transformer, part 2: the blocks of domains, problems and stream files.

As in :mod:`.parse_formulas`, each method is named after a grammar rule and receives the rule's
children by name.  A block becomes a :class:`~.parse_formulas.Part` tagged with its keyword;
a file's rule gathers its parts, refusing duplicates, and returns ``(node, warnings)``.
"""

from __future__ import annotations

from lark import Token, Transformer, v_args

from . import syntax as S
from .parse_formulas import (
    BuildError,
    FormulaRules,
    Marker,
    Part,
    fields,
    low,
    num_expr,
    number,
    span,
    value,
)


def file_parts(items, kind: str) -> tuple[list[Part], list[str]]:
    """A file's blocks, and warnings for text after the last one (text before it is an
    error)."""
    blocks = [c for c in items if isinstance(c, Part)]
    strays = [(i, c.tok) for i, c in enumerate(items) if isinstance(c, Marker)]
    warnings: list[str] = []
    if strays:
        last_block = max((i for i, c in enumerate(items) if isinstance(c, Part)), default=-1)
        early = [tok for i, tok in strays if i < last_block]
        if early:
            raise BuildError(
                f"found text '{early[0]}' outside any block; expected '(' starting a block "
                f"or ')' closing the {kind}",
                early[0],
            )
        _, first = strays[0]
        text = " ".join(str(tok) for _, tok in strays)
        warnings.append(f"{first.line}:{first.column}: ignored text after the last block: {text!r}")
    return blocks, warnings


def _block_fields(parts, block: str, tok: Token) -> dict[str, Part]:
    return fields([p for p in parts if isinstance(p, Part)], block, tok)


@v_args(inline=True)
class DomainRules(Transformer):
    """A domain's blocks and the fields of its actions."""

    def requirements(self, keyword, *flags):
        return Part(":requirements", tuple(low(t) for t in flags), keyword)

    def types_def(self, keyword, types):
        return Part(":types", types, keyword)

    def constants_def(self, keyword, constants):
        return Part(":constants", constants, keyword)

    def predicate_decl(self, head, params):
        return S.PredicateDecl(low(head), params, span=span(head))

    def predicates_def(self, keyword, *decls):
        return Part(":predicates", decls, keyword)

    def function_decl(self, head, params):
        return S.FunctionDecl(low(head), params, span=span(head))

    def functions_def(self, keyword, *entries):
        out: list[S.FunctionDecl] = []
        pending: list[S.FunctionDecl] = []
        for entry in entries:
            if isinstance(entry, Marker):
                if not pending:
                    raise BuildError("found '- type' with no function before it", entry.tok)
                if not isinstance(entry.type, str):
                    raise BuildError("a function's type must be a name such as number", entry.tok)
                out.extend(
                    S.FunctionDecl(f.name, f.params, entry.type, span=f.span) for f in pending
                )
                pending = []
            else:
                pending.append(entry)
        out.extend(pending)
        return Part(":functions", tuple(out), keyword)

    def parameters(self, keyword, params):
        return Part(":parameters", params, keyword)

    def precondition(self, keyword, condition):
        return Part(":precondition", condition, keyword)

    def effect_field(self, keyword, effect):
        return Part(":effect", effect, keyword)

    def action_def(self, keyword, head, *parts):
        found = _block_fields(parts, f"action {head}", head)
        action = S.Action(
            low(head),
            value(found, ":parameters", ()),
            value(found, ":precondition"),
            value(found, ":effect"),
            span=span(head),
        )
        return Part(":action", action, keyword)

    def derived_def(self, keyword, head, params, body):
        return Part(":derived", S.Axiom(low(head), params, body, span=span(head)), keyword)

    def duration(self, keyword, constraint):
        return Part(":duration", constraint, keyword)

    def da_condition(self, keyword, condition):
        return Part(":condition", condition, keyword)

    def da_effect_field(self, keyword, effect):
        return Part(":effect", effect, keyword)

    def durative_def(self, keyword, head, *parts):
        found = _block_fields(parts, f"action {head}", head)
        action = S.DurativeAction(
            low(head),
            value(found, ":parameters", ()),
            value(found, ":duration"),
            value(found, ":condition"),
            value(found, ":effect"),
            span=span(head),
        )
        return Part(":durative-action", action, keyword)

    def stray(self, text):
        return Marker("stray", text)

    def domain(self, define, kind, name, *items):
        blocks, warnings = file_parts(items, "domain")
        singles = fields(
            [b for b in blocks if b.key not in (":action", ":derived", ":durative-action")],
            f"domain {name}",
            name,
        )
        node = S.Domain(
            low(name),
            value(singles, ":requirements"),
            value(singles, ":types", ()),
            value(singles, ":constants", ()),
            value(singles, ":predicates", ()),
            value(singles, ":functions", ()),
            tuple(b.value for b in blocks if b.key == ":derived"),
            tuple(b.value for b in blocks if b.key == ":action"),
            tuple(b.value for b in blocks if b.key == ":durative-action"),
            span=span(name),
        )
        return node, warnings


@v_args(inline=True)
class ProblemRules(Transformer):
    """A problem's blocks."""

    def problem_domain(self, keyword, name):
        return Part(":domain", low(name), keyword)

    def objects(self, keyword, objects):
        return Part(":objects", objects, keyword)

    def init_not(self, keyword, atom):
        return S.Not(atom, span=span(keyword))

    def init_value(self, op, fluent, amount):
        if str(op) != "=":
            raise BuildError(f"found '{op}' in :init; expected '=' giving a function's value", op)
        return S.InitValue(fluent, S.Num(number(amount), span=span(amount)), span=span(op))

    def init(self, keyword, *facts):
        return Part(":init", facts, keyword)

    def goal(self, keyword, condition):
        return Part(":goal", condition, keyword)

    def metric(self, keyword, direction, expr):
        metric = S.Metric(low(direction), num_expr(expr), span=span(direction))
        return Part(":metric", metric, keyword)

    def problem(self, define, kind, name, *items):
        blocks, warnings = file_parts(items, "problem")
        found = fields(blocks, f"problem {name}", name)
        node = S.Problem(
            low(name),
            value(found, ":domain"),
            value(found, ":requirements"),
            value(found, ":objects", ()),
            value(found, ":init", ()),
            value(found, ":goal"),
            value(found, ":metric"),
            span=span(name),
        )
        return node, warnings


def _declared(cls, keyword: Token, head: Token, params, rest, key: str) -> Part:
    """A stream file's ``(:function (F ?x) [:domain] gd)`` or ``(:predicate ...)``."""
    domain = next((x for x in rest if not isinstance(x, Token)), None)  # after :domain, if any
    return Part(key, cls(low(head), params, domain, span=span(head)), keyword)


def _opt_fields(parts, keyword: Token) -> tuple:
    found = [p for p in parts if isinstance(p, Part)]
    fields(found, "optimizer block", keyword)
    return tuple((p.key, p.value) for p in found)


@v_args(inline=True)
class StreamRules(Transformer):
    """A stream file's streams, functions, predicates, rules and optimizers."""

    def inputs(self, keyword, params):
        return Part(":inputs", params, keyword)

    def outputs(self, keyword, params):
        return Part(":outputs", params, keyword)

    def stream_domain(self, keyword, condition):
        return Part(":domain", condition, keyword)

    def certified(self, keyword, condition):
        return Part(":certified", condition, keyword)

    def fluents(self, keyword, *names):
        return Part(":fluents", tuple(low(t) for t in names), keyword)

    def opt_graph(self, keyword, condition):
        return Part(":graph", condition, keyword)

    def opt_necessary(self, keyword, condition):
        return Part(":necessary", condition, keyword)

    def stream_def(self, keyword, head, *parts):
        found = _block_fields(parts, f"stream {head}", head)
        stream = S.Stream(
            low(head),
            value(found, ":inputs", ()),
            value(found, ":domain"),
            value(found, ":fluents", ()),
            value(found, ":outputs", ()),
            value(found, ":certified"),
            span=span(head),
        )
        return Part(":stream", stream, keyword)

    def rule_def(self, keyword, *parts):
        found = _block_fields(parts, ":rule", keyword)
        for key in (":outputs", ":fluents"):
            if key in found:
                raise BuildError(f"a :rule has no {key}", found[key].tok)
        rule = S.Rule(
            value(found, ":inputs", ()),
            value(found, ":domain"),
            value(found, ":certified"),
            span=span(keyword),
        )
        return Part(":rule", rule, keyword)

    def stream_function(self, keyword, head, params, *rest):
        return _declared(S.StreamFunction, keyword, head, params, rest, ":function")

    def stream_predicate(self, keyword, head, params, *rest):
        return _declared(S.StreamPredicate, keyword, head, params, rest, ":predicate")

    def opt_variables(self, keyword, variables, *parts):
        opt = _opt_fields(parts, keyword)
        return S.OptimizerBlock("variables", variables, opt, span=span(keyword))

    def opt_constraint(self, keyword, atom, *parts):
        opt = _opt_fields(parts, keyword)
        return S.OptimizerBlock("constraint", atom, opt, span=span(keyword))

    def opt_objective(self, keyword, name):
        return S.OptimizerBlock("objective", low(name), (), span=span(keyword))

    def optimizer_def(self, keyword, head, *blocks):
        return Part(":optimizer", S.Optimizer(low(head), blocks, span=span(head)), keyword)

    def stream_file(self, define, kind, name, *items):
        blocks, warnings = file_parts(items, "stream file")

        def of(key):
            return tuple(b.value for b in blocks if b.key == key)

        node = S.StreamFile(
            low(name),
            of(":stream"),
            of(":function"),
            of(":predicate"),
            of(":rule"),
            of(":optimizer"),
            span=span(name),
        )
        return node, warnings


@v_args(inline=True)
class Build(FormulaRules, DomainRules, ProblemRules, StreamRules):
    """Builds syntax-tree nodes for all three kinds of file; stateless, so one instance
    serves every parse."""

    def start(self, file):
        return file
