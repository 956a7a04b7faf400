"""The syntax tree of the PDDLStream dialect: domains, problems and stream files.

Every node is a frozen dataclass.  Source positions (``span``) are carried for error messages
but ignored by equality and hashing, so ``parse(print(tree)) == tree`` holds.  Names are
normalised to lower case by the parser (PDDL names are case-insensitive); variables keep their
leading ``?``.  Hashes are computed once and cached, because atoms end up in large sets during
compilation (the same habit as Fast Downward's immutable conditions).
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from operator import attrgetter
from typing import Union


@dataclass(frozen=True, slots=True)
class Span:
    """A 1-based line and column in the file a node was read from."""

    line: int
    col: int

    def __str__(self) -> str:
        return f"{self.line}:{self.col}"


def cached_hash(cls):
    """Replace a frozen dataclass's ``__hash__`` with one computed once per instance."""
    keys = tuple(f.name for f in fields(cls) if f.compare)
    name = cls.__name__
    # One C-level getter for the compared fields: a new atom's hash is taken on every insert
    # into a set while compiling, and a generator per hash cost a third of it.
    if len(keys) == 1:
        single = attrgetter(keys[0])

        def values(self):
            return (name, single(self))

    else:
        several = attrgetter(*keys)

        def values(self):
            return (name, *several(self))

    def __hash__(self):
        try:
            return self._hash
        except AttributeError:
            h = hash(values(self))
            object.__setattr__(self, "_hash", h)
            return h

    def __getstate__(self):
        # The cached hash depends on the process's string hashing seed: never pickle it.
        return {k: v for k, v in self.__dict__.items() if k != "_hash"}

    def __setstate__(self, state):
        for k, v in state.items():
            object.__setattr__(self, k, v)

    cls.__hash__ = __hash__
    cls.__getstate__ = __getstate__
    cls.__setstate__ = __setstate__
    return cls


def node(cls):
    """Decorator for syntax-tree classes: frozen dataclass, span ignored, hash cached."""
    cls.__annotations__ = {**cls.__annotations__}
    if "span" not in cls.__annotations__:
        cls.__annotations__["span"] = "Span | None"
        cls.span = field(default=None, compare=False, repr=False, kw_only=True)
    return cached_hash(dataclass(frozen=True)(cls))


# ---------------------------------------------------------------- terms


@node
class Var:
    """A variable such as ``?x`` (the name keeps its ``?``)."""

    name: str

    def __str__(self) -> str:
        return self.name


@node
class Const:
    """An object or constant name."""

    name: str

    def __str__(self) -> str:
        return self.name


Term = Union[Var, Const]

_CONSTS: dict[str, Const] = {}


def const(name: str) -> Const:
    """The :class:`Const` named ``name``, one object per name (its hash computed once): the
    compiler grounds hundreds of thousands of atoms over a few thousand names."""
    c = _CONSTS.get(name)
    if c is None:
        if len(_CONSTS) >= 1_000_000:  # a bound, for processes that live long
            _CONSTS.clear()
        c = _CONSTS[name] = Const(name)
    return c


@node
class Num:
    """A number in a numeric expression (int when written without a point)."""

    value: int | float


@node
class FuncTerm:
    """A function application ``(f a b)``, including ``(total-cost)``."""

    name: str
    args: tuple[Term, ...] = ()


@node
class Arith:
    """Arithmetic ``(+ a b)``, ``(- a b)``, ``(- a)``, ``(* a b)``, ``(/ a b)``."""

    op: str
    args: tuple[NumExpr, ...]


NumExpr = Union[Num, FuncTerm, Arith, Var, Const]


# ---------------------------------------------------------------- types and declarations


@node
class Either:
    """A union type ``(either a b)``."""

    types: tuple[str, ...]


TypeRef = Union[str, Either, None]


@node
class Typed:
    """A name or variable with an optional type (``None`` means untyped)."""

    name: str
    type: TypeRef = None


@node
class PredicateDecl:
    name: str
    params: tuple[Typed, ...] = ()


@node
class FunctionDecl:
    name: str
    params: tuple[Typed, ...] = ()
    type: str | None = None


# ---------------------------------------------------------------- formulas


@node
class Atom:
    """A literal's positive part ``(p a ?x)``; equality is the predicate ``=``."""

    pred: str
    args: tuple[Term, ...] = ()

    def __str__(self) -> str:
        return "(" + " ".join([self.pred, *(str(a) for a in self.args)]) + ")"


@node
class Not:
    arg: Formula


@node
class And:
    args: tuple[Formula, ...] = ()


@node
class Or:
    args: tuple[Formula, ...] = ()


@node
class Imply:
    left: Formula
    right: Formula


@node
class Exists:
    params: tuple[Typed, ...]
    body: Formula


@node
class Forall:
    """Universal quantification; used for conditions and for effects."""

    params: tuple[Typed, ...]
    body: Formula


@node
class Compare:
    """A numeric comparison ``(op left right)`` with op in ``= < <= > >=``."""

    op: str
    left: NumExpr
    right: NumExpr


@node
class When:
    """A conditional effect."""

    condition: Formula
    effect: Formula


@node
class NumericEffect:
    """``(increase (f ...) v)`` and friends; op is the long form (``incr`` -> ``increase``)."""

    op: str
    fluent: FuncTerm
    value: NumExpr


@node
class Timed:
    """A durative-action condition or effect ``(at start X)``, ``(at end X)``, ``(over all X)``."""

    when: str
    body: Formula


Formula = Union[Atom, Not, And, Or, Imply, Exists, Forall, Compare, When, NumericEffect, Timed]


# ---------------------------------------------------------------- domains


@node
class Action:
    name: str
    parameters: tuple[Typed, ...] = ()
    precondition: Formula | None = None
    effect: Formula | None = None


@node
class Axiom:
    """A derived predicate ``(:derived (p ?x) body)``."""

    name: str
    parameters: tuple[Typed, ...]
    body: Formula


@node
class DurativeAction:
    name: str
    parameters: tuple[Typed, ...] = ()
    duration: Formula | None = None
    condition: Formula | None = None
    effect: Formula | None = None


@node
class Domain:
    name: str
    requirements: tuple[str, ...] | None = None
    types: tuple[Typed, ...] = ()
    constants: tuple[Typed, ...] = ()
    predicates: tuple[PredicateDecl, ...] = ()
    functions: tuple[FunctionDecl, ...] = ()
    axioms: tuple[Axiom, ...] = ()
    actions: tuple[Action, ...] = ()
    durative_actions: tuple[DurativeAction, ...] = ()

    kind = "domain"


# ---------------------------------------------------------------- problems


@node
class InitValue:
    """A numeric initial value ``(= (f a) 3)``."""

    fluent: FuncTerm
    value: Num


@node
class Metric:
    direction: str
    expr: NumExpr


@node
class Problem:
    name: str
    domain_name: str | None = None
    requirements: tuple[str, ...] | None = None
    objects: tuple[Typed, ...] = ()
    init: tuple[Atom | Not | InitValue, ...] = ()
    goal: Formula | None = None
    metric: Metric | None = None

    kind = "problem"


# ---------------------------------------------------------------- stream files


@node
class Stream:
    """A stream (paper §IV): inputs, domain, fluents, outputs, certified facts.

    A stream without outputs is a *test*.
    """

    name: str
    inputs: tuple[Typed, ...] = ()
    domain: Formula | None = None
    fluents: tuple[str, ...] = ()
    outputs: tuple[Typed, ...] = ()
    certified: Formula | None = None

    @property
    def is_test(self) -> bool:
        return not self.outputs


@node
class StreamFunction:
    """A cost function ``(:function (F ?args) domain)``, such as ``ObsCost``."""

    name: str
    params: tuple[Typed, ...]
    domain: Formula | None = None


@node
class StreamPredicate:
    """An external predicate ``(:predicate (P ?args) domain)`` evaluated by Python."""

    name: str
    params: tuple[Typed, ...]
    domain: Formula | None = None


@node
class Rule:
    """A rule: a stream without outputs or implementation (domain implies certified)."""

    inputs: tuple[Typed, ...] = ()
    domain: Formula | None = None
    certified: Formula | None = None


@node
class OptimizerBlock:
    """One block of an ``:optimizer``: ``:variables``, ``:constraint`` or ``:objective``.

    ``head`` is the variable list, the constraint atom or the objective name; ``fields`` are
    the remaining ``(key, value)`` pairs in source order.
    """

    kind: str
    head: tuple[Typed, ...] | Atom | str
    fields: tuple[tuple[str, Formula | tuple[Typed, ...] | tuple[str, ...]], ...] = ()


@node
class Optimizer:
    name: str
    blocks: tuple[OptimizerBlock, ...] = ()


@node
class StreamFile:
    name: str
    streams: tuple[Stream, ...] = ()
    functions: tuple[StreamFunction, ...] = ()
    predicates: tuple[StreamPredicate, ...] = ()
    rules: tuple[Rule, ...] = ()
    optimizers: tuple[Optimizer, ...] = ()

    kind = "stream"


File = Union[Domain, Problem, StreamFile]


# ---------------------------------------------------------------- helpers


def conjuncts(f: Formula | None) -> tuple[Formula, ...]:
    """The top-level conjuncts of a formula (``None`` and ``(and)`` give none)."""
    if f is None:
        return ()
    if isinstance(f, And):
        out: list[Formula] = []
        for a in f.args:
            out.extend(conjuncts(a))
        return tuple(out)
    return (f,)


def children(node) -> tuple:
    """The direct sub-nodes of a formula, effect or numeric expression (terms included)."""
    if isinstance(node, Atom | FuncTerm | Arith | And | Or):
        return node.args
    if isinstance(node, Not):
        return (node.arg,)
    if isinstance(node, Imply):
        return (node.left, node.right)
    if isinstance(node, Exists | Forall | Timed):
        return (node.body,)
    if isinstance(node, Compare):
        return (node.left, node.right)
    if isinstance(node, When):
        return (node.condition, node.effect)
    if isinstance(node, NumericEffect):
        return (node.fluent, node.value)
    return ()


def walk(node):
    """Every node of a formula in pre-order (``None`` gives nothing)."""
    if node is None:
        return
    stack = [node]
    while stack:
        x = stack.pop()
        yield x
        stack.extend(reversed(children(x)))


def names(typed: tuple[Typed, ...]) -> tuple[str, ...]:
    return tuple(t.name for t in typed)
