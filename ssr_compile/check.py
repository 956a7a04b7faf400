"""Semantic checks of domains, problems and stream files.

Errors: undeclared predicates, functions, types and constants; wrong numbers of arguments;
free variables; a stream's certified facts mentioning variables that are neither inputs nor
outputs; outputs used in a stream's domain; duplicate names.  Warnings (as pddlstream itself
only warns): requirements used but not declared, predicates a stream file uses that the domain
does not declare, cost functions used without a declaration.

A problem or stream file is checked against its domain when one is given.  Every finding
carries file:line:col from the node's source span.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from . import syntax as S
from .errors import CheckError
from .formulas import (
    atoms,
    changed_atoms,
    domain_requirements,
    free_variables,
    undeclared_requirements,
)

BUILTIN_TYPES = frozenset({"object", "number"})
COST = "total-cost"


@dataclass
class Report:
    """What checking one file found."""

    filename: str
    source: str | None = None
    errors: list[CheckError] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)

    def error(self, message: str, span: S.Span | None) -> None:
        # One error per position: two checks that trip over the same token (a variable that
        # is neither input nor output is also free) would otherwise say it twice.
        if span is not None and any(e.line == span.line and e.col == span.col for e in self.errors):
            return
        self.errors.append(
            CheckError(
                message,
                file=self.filename,
                line=span.line if span else None,
                col=span.col if span else None,
                source=self.source,
            )
        )

    def warn(self, message: str, span: S.Span | None = None) -> None:
        where = f"{self.filename}:{span}" if span else self.filename
        self.warnings.append(f"{where}: warning: {message}")

    @property
    def ok(self) -> bool:
        return not self.errors

    def raise_first(self) -> None:
        if self.errors:
            raise sorted(self.errors, key=lambda e: (e.line or 0, e.col or 0))[0]


# ---------------------------------------------------------------- the vocabulary of a domain


@dataclass
class Vocabulary:
    """Declared names and arities, from a domain (and, optionally, its stream file)."""

    predicates: dict[str, int] = field(default_factory=dict)
    functions: dict[str, int] = field(default_factory=dict)
    constants: dict[str, S.TypeRef] = field(default_factory=dict)
    types: set[str] = field(default_factory=set)
    typed: bool = False
    # Predicates certified or declared only by the stream file: name -> arity.
    stream_predicates: dict[str, int] = field(default_factory=dict)
    stream_functions: dict[str, int] = field(default_factory=dict)

    @classmethod
    def of(cls, domain: S.Domain | None, streams: S.StreamFile | None = None) -> Vocabulary:
        v = cls()
        if domain is not None:
            v.predicates = {p.name: len(p.params) for p in domain.predicates}
            for ax in domain.axioms:
                v.predicates.setdefault(ax.name, len(ax.parameters))
            v.functions = {f.name: len(f.params) for f in domain.functions}
            v.constants = {c.name: c.type for c in domain.constants}
            v.types = {t.name for t in domain.types} | {
                t.type for t in domain.types if isinstance(t.type, str)
            }
            v.typed = bool(domain.types)
        if streams is not None:
            for name, arity in _stream_file_predicates(streams).items():
                if name not in v.predicates:
                    v.stream_predicates.setdefault(name, arity)
            v.stream_functions = {f.name: len(f.params) for f in streams.functions}
        return v

    def predicate_arity(self, name: str) -> int | None:
        if name in self.predicates:
            return self.predicates[name]
        return self.stream_predicates.get(name)


def _stream_file_predicates(f: S.StreamFile) -> dict[str, int]:
    """Predicates a stream file mentions (certified, in domains, declared), with arities."""
    out: dict[str, int] = {}
    for s in f.streams:
        for formula in (s.domain, s.certified):
            for a in atoms(formula):
                out.setdefault(a.pred, len(a.args))
    for r in f.rules:
        for formula in (r.domain, r.certified):
            for a in atoms(formula):
                out.setdefault(a.pred, len(a.args))
    for p in f.predicates:
        out.setdefault(p.name, len(p.params))
        for a in atoms(p.domain):
            out.setdefault(a.pred, len(a.args))
    for fn in f.functions:
        for a in atoms(fn.domain):
            out.setdefault(a.pred, len(a.args))
    out.pop("=", None)
    return out


# ---------------------------------------------------------------- formulas


class _FormulaChecker:
    """Walks a formula or effect with the variables in scope, reporting into ``report``."""

    def __init__(
        self,
        report: Report,
        vocab: Vocabulary,
        objects: dict[str, S.TypeRef] | None = None,
        *,
        constants_known: bool = True,
    ):
        self.r = report
        self.constants_known = constants_known
        self.v = vocab
        self.objects = objects if objects is not None else {}
        self.typed = False  # does a parameter, constant or type name a type?
        # checking a domain: names it uses without declaring them (-> first use)
        self.domain_names: dict[str, S.Span | None] | None = None

    def formula(self, f, scope: frozenset[str], where: str) -> None:
        """Check a condition or effect (requirement flags: see formulas.domain_requirements)."""
        kind = type(f)
        if kind is S.Atom:
            self.atom(f, scope, where)
        elif kind is S.Exists or kind is S.Forall:
            self.params(f.params, where)
            self.formula(f.body, scope | {p.name for p in f.params}, where)
        elif kind is S.Compare:
            self.num(f.left, scope, where)
            self.num(f.right, scope, where)
        elif kind is S.NumericEffect:
            self.fluent(f.fluent, scope, where)
            self.num(f.value, scope, where, cost=f.fluent.name == COST)
        else:  # and, or, not, imply, when, timed
            for part in S.children(f):
                self.formula(part, scope, where)

    def atom(self, a: S.Atom, scope: frozenset[str], where: str) -> None:
        if a.pred != "=":
            arity = self.v.predicate_arity(a.pred)
            if arity is None:
                self.r.error(f"undeclared predicate '{a.pred}' in {where}", a.span)
            elif arity != len(a.args):
                self.r.error(
                    f"'{a.pred}' takes {arity} argument{'s' * (arity != 1)}, "
                    f"found {len(a.args)} in {where}",
                    a.span,
                )
        for t in a.args:
            self.term(t, scope, where)

    def term(self, t: S.Term, scope: frozenset[str], where: str) -> None:
        if isinstance(t, S.Var):
            if t.name not in scope:
                self.r.error(
                    f"free variable {t.name} in {where}: not a parameter or quantified", t.span
                )
        elif (
            self.constants_known
            and t.name not in self.v.constants
            and t.name not in self.objects
            and not _numeric(t.name)
        ):
            if self.domain_names is not None:
                # A domain may name an object its problems declare (the paper writes
                # (AtConf base ?bq) with `base` an object): Fast Downward accepts it; the
                # problem's check says whether it is declared there.
                if t.name not in self.domain_names:
                    self.domain_names[t.name] = t.span
                    self.r.warn(
                        f"'{t.name}' in {where} is not declared in the domain's :constants; "
                        f"it must be an object of every problem (declare it with "
                        f"(:constants {t.name}) to make the domain stand alone)",
                        t.span,
                    )
            else:
                self.r.error(f"undeclared constant '{t.name}' in {where}", t.span)

    def fluent(self, f: S.FuncTerm, scope: frozenset[str], where: str, cost: bool = False) -> None:
        if f.name == COST:
            if f.args:
                self.r.error(f"total-cost takes no arguments, found {len(f.args)}", f.span)
        else:
            arity = self.v.functions.get(f.name, self.v.stream_functions.get(f.name))
            if arity is None:
                if cost:
                    # Real files use cost and duration functions without declaring them
                    # (pddlstream evaluates them through stream functions and only warns).
                    self.r.warn(f"function '{f.name}' is not declared in :functions", f.span)
                else:
                    self.r.error(f"undeclared function '{f.name}' in {where}", f.span)
            elif arity != len(f.args):
                self.r.error(
                    f"'{f.name}' takes {arity} arguments, found {len(f.args)} in {where}", f.span
                )
        for t in f.args:
            self.term(t, scope, where)

    def num(self, e, scope, where, cost: bool = False) -> None:
        if isinstance(e, S.FuncTerm):
            self.fluent(e, scope, where, cost)
        elif isinstance(e, S.Arith):
            for a in e.args:
                self.num(a, scope, where, cost)
        elif isinstance(e, S.Const) and self._function_name(e.name):
            # PDDL allows a 0-ary function without parentheses: (:metric minimize total-cost).
            self.fluent(S.FuncTerm(e.name, (), span=e.span), scope, where, cost)
        elif isinstance(e, (S.Var, S.Const)):
            if not (isinstance(e, S.Var) and e.name == "?duration"):
                self.term(e, scope, where)

    def _function_name(self, name: str) -> bool:
        return (
            (
                name == COST
                or self.v.functions.get(name) == 0
                or self.v.stream_functions.get(name) == 0
            )
            and name not in self.v.constants
            and name not in self.objects
        )

    def params(self, params: tuple[S.Typed, ...], where: str) -> None:
        seen: set[str] = set()
        for p in params:
            if p.name in seen:
                self.r.error(f"duplicate parameter {p.name} in {where}", p.span)
            seen.add(p.name)
            self.type_ref(p.type, p.span, where)

    def type_ref(self, t: S.TypeRef, span, where: str) -> None:
        if t is None:
            return
        self.typed = True
        for name in t.types if isinstance(t, S.Either) else (t,):
            if name not in BUILTIN_TYPES and name not in self.v.types:
                self.r.error(f"undeclared type '{name}' in {where}", span)


def _numeric(name: str) -> bool:
    try:
        float(name)
    except ValueError:
        return False
    return True


def _duplicates(report: Report, items, what: str) -> None:
    seen: set[str] = set()
    for item in items:
        if item.name in seen:
            report.error(f"duplicate {what} '{item.name}'", item.span)
        seen.add(item.name)


def _duplicate_declarations(report: Report, decls: tuple[S.PredicateDecl, ...]) -> None:
    """Two declarations of one predicate: a warning when they agree, an error otherwise."""
    seen: dict[str, S.PredicateDecl] = {}
    for d in decls:
        first = seen.get(d.name)
        if first is None:
            seen[d.name] = d
        elif len(first.params) == len(d.params):
            report.warn(f"predicate '{d.name}' is declared twice (first at {first.span})", d.span)
        else:
            report.error(
                f"predicate '{d.name}' is declared again with {len(d.params)} arguments "
                f"(first with {len(first.params)} at {first.span})",
                d.span,
            )


# ---------------------------------------------------------------- files


def check_domain(
    domain: S.Domain,
    *,
    streams: S.StreamFile | None = None,
    filename: str = "<domain>",
    source: str | None = None,
) -> Report:
    report = Report(filename, source)
    vocab = Vocabulary.of(domain, streams)
    fc = _FormulaChecker(report, vocab)
    fc.domain_names = {}
    _duplicates(report, domain.types, "type")
    _duplicates(report, domain.constants, "constant")
    _duplicate_declarations(report, domain.predicates)
    _duplicates(report, domain.functions, "function")
    _duplicates(report, (*domain.actions, *domain.durative_actions), "action")
    for t in domain.types:
        fc.type_ref(t.type, t.span, "the :types section")
    for c in domain.constants:
        fc.type_ref(c.type, c.span, "the :constants section")
    for p in domain.predicates:
        fc.params(p.params, f"the declaration of predicate '{p.name}'")
    for f in domain.functions:
        fc.params(f.params, f"the declaration of function '{f.name}'")
    derived_heads: set[str] = set()
    for ax in domain.axioms:
        where = f"derived predicate '{ax.name}'"
        declared = domain.predicates and ax.name in {p.name for p in domain.predicates}
        if ax.name not in derived_heads and not declared and domain.predicates:
            report.warn(f"derived predicate '{ax.name}' is not declared in :predicates", ax.span)
        derived_heads.add(ax.name)
        fc.params(ax.parameters, where)
        arity = vocab.predicate_arity(ax.name)
        if arity is not None and arity != len(ax.parameters):
            report.error(
                f"'{ax.name}' takes {arity} arguments, its :derived head has {len(ax.parameters)}",
                ax.span,
            )
        head = frozenset(p.name for p in ax.parameters)
        extra = []
        for v in free_variables(ax.body):
            if v.name not in head and v.name not in extra:
                extra.append(v.name)
                report.warn(
                    f"variable {v.name} in {where} is not a parameter; it is read as "
                    "existentially quantified (as Fast Downward reads axiom bodies)",
                    v.span,
                )
        fc.formula(ax.body, head | frozenset(extra), where)
        _unbound_head(report, ax, where)
    for a in domain.actions:
        where = f"action '{a.name}'"
        fc.params(a.parameters, where)
        scope = frozenset(p.name for p in a.parameters)
        fc.formula(a.precondition, scope, f"the precondition of {where}")
        fc.formula(a.effect, scope, f"the effect of {where}")
        for atom in changed_atoms(a.effect):
            if atom.pred in derived_heads:
                report.error(
                    f"the effect of {where} changes derived predicate '{atom.pred}'", atom.span
                )
    for a in domain.durative_actions:
        where = f"durative action '{a.name}'"
        fc.params(a.parameters, where)
        scope = frozenset(p.name for p in a.parameters) | {"?duration"}
        if isinstance(a.duration, S.Compare):
            fc.num(a.duration.left, scope, f"the duration of {where}", cost=True)
            fc.num(a.duration.right, scope, f"the duration of {where}", cost=True)
        else:
            fc.formula(a.duration, scope, f"the duration of {where}")
        fc.formula(a.condition, scope, f"the condition of {where}")
        fc.formula(a.effect, scope, f"the effect of {where}")
    if domain.requirements is not None:
        sections = {
            ":typing": fc.typed,
            ":derived-predicates": bool(domain.axioms),
            ":durative-actions": bool(domain.durative_actions),
        }
        used = domain_requirements(domain) | {flag for flag, on in sections.items() if on}
        missing = undeclared_requirements(domain.requirements, used)
        if missing:
            report.warn("uses requirements it does not declare: " + " ".join(missing), domain.span)
    if streams is not None:
        for name in sorted(vocab.stream_predicates):
            used_in_domain = any(
                a.pred == name
                for x in (*domain.actions, *domain.axioms)
                for f in (
                    getattr(x, "precondition", None),
                    getattr(x, "effect", None),
                    getattr(x, "body", None),
                )
                for a in atoms(f)
            )
            if used_in_domain:
                report.warn(
                    f"predicate '{name}' is used by the domain but declared only by the stream file"
                )
    return report


def check_problem(
    problem: S.Problem,
    domain: S.Domain | None = None,
    *,
    streams: S.StreamFile | None = None,
    filename: str = "<problem>",
    source: str | None = None,
) -> Report:
    report = Report(filename, source)
    _duplicates(report, problem.objects, "object")
    if domain is None:
        # Without the domain, only what the file says about itself can be checked.
        for fact in problem.init:
            for a in atoms(fact) if not isinstance(fact, S.InitValue) else ():
                for t in a.args:
                    if isinstance(t, S.Var):
                        report.error(f"variable {t.name} in :init; expected an object", t.span)
        _free_variables(report, problem.goal, frozenset(), "the goal")
        return report
    if problem.domain_name is not None and problem.domain_name != domain.name:
        report.warn(
            f"the problem is for domain '{problem.domain_name}', checked against '{domain.name}'",
            problem.span,
        )
    vocab = Vocabulary.of(domain, streams)
    objects = {o.name: o.type for o in problem.objects}
    fc = _FormulaChecker(report, vocab, objects)
    for name, span in undeclared_domain_names(domain).items():
        if name not in objects:
            report.error(
                f"the domain uses '{name}' (at {span}), which neither its :constants nor this "
                "problem's :objects declare",
                problem.span,
            )
    for name, span in undeclared_stream_names(streams, domain).items() if streams else ():
        if name not in objects:
            report.error(
                f"the stream file uses '{name}' (at {span}), which neither the domain's "
                ":constants nor this problem's :objects declare",
                problem.span,
            )
    for o in problem.objects:
        fc.type_ref(o.type, o.span, "the :objects section")
    for fact in problem.init:
        if isinstance(fact, S.InitValue):
            fc.fluent(fact.fluent, frozenset(), "the initial state")
        else:
            fc.formula(fact, frozenset(), "the initial state")
    fc.formula(problem.goal, frozenset(), "the goal")
    if problem.metric is not None:
        fc.num(problem.metric.expr, frozenset(), "the metric", cost=True)
    return report


def check_streams(
    f: S.StreamFile,
    domain: S.Domain | None = None,
    *,
    filename: str = "<stream>",
    source: str | None = None,
) -> Report:
    report = Report(filename, source)
    _duplicates(report, f.streams, "stream")
    _duplicates(report, f.functions, "function")
    _duplicates(report, f.predicates, "predicate")
    declared = Vocabulary.of(domain) if domain is not None else None
    own = _stream_file_predicates(f)
    # Inside a stream file, every predicate the file mentions is in its vocabulary; a domain
    # adds constants and checks that arities agree.
    vocab = Vocabulary(
        predicates={**own, **(declared.predicates if declared else {})},
        functions=declared.functions if declared else {},
        constants=declared.constants if declared else {},
        types=declared.types if declared else set(),
    )
    arities: dict[str, tuple[int, S.Span | None]] = {}
    # Constants can only be judged against a domain.  A name the domain does not declare is
    # a warning, as in the domain itself: the paper's (Conf base ?bq) names a problem object
    # (the problem's check says whether it declares it).
    fc = _FormulaChecker(report, vocab, constants_known=declared is not None)
    if declared is not None:
        fc.domain_names = {}

    def consistent(formula, where):
        for a in atoms(formula):
            if a.pred == "=":
                continue
            if a.pred in arities and arities[a.pred][0] != len(a.args) and not declared:
                first = arities[a.pred]
                report.error(
                    f"'{a.pred}' has {len(a.args)} arguments in {where} but {first[0]} at {first[1]}",
                    a.span,
                )
            arities.setdefault(a.pred, (len(a.args), a.span))

    for s in f.streams:
        where = f"stream '{s.name}'"
        fc.params(s.inputs, f"the inputs of {where}")
        fc.params(s.outputs, f"the outputs of {where}")
        inputs = {p.name for p in s.inputs}
        for o in s.outputs:
            if o.name in inputs:
                report.error(f"{o.name} is both an input and an output of {where}", o.span)
        for v in free_variables(s.domain):
            if v.name in {o.name for o in s.outputs}:
                report.error(
                    f"output {v.name} is used in the domain of {where}; the domain may only use inputs",
                    v.span,
                )
            elif v.name not in inputs:
                report.error(
                    f"free variable {v.name} in the domain of {where}: not an input", v.span
                )
        scope = frozenset(inputs | {o.name for o in s.outputs})
        for v in free_variables(s.certified):
            if v.name not in scope:
                report.error(
                    f"variable {v.name} in the certified facts of {where} is neither an input nor an output",
                    v.span,
                )
        checker_scope = scope | frozenset(v.name for v in free_variables(s.domain))
        fc.formula(s.domain, checker_scope, f"the domain of {where}")
        fc.formula(s.certified, checker_scope, f"the certified facts of {where}")
        consistent(s.domain, f"the domain of {where}")
        consistent(s.certified, f"the certified facts of {where}")
        if declared is not None:
            for fl in s.fluents:
                if declared.predicate_arity(fl) is None:
                    report.error(
                        f"fluent '{fl}' of {where} is not a predicate of the domain", s.span
                    )
    for r in f.rules:
        scope = frozenset(p.name for p in r.inputs)
        for formula, what in ((r.domain, "domain"), (r.certified, "certified facts")):
            for v in free_variables(formula):
                if v.name not in scope:
                    report.error(
                        f"variable {v.name} in the {what} of a :rule is not an input", v.span
                    )
        consistent(r.domain, "a :rule")
        consistent(r.certified, "a :rule")
    for group, kind in ((f.functions, "function"), (f.predicates, "predicate")):
        for d in group:
            scope = frozenset(p.name for p in d.params)
            fc.params(d.params, f"{kind} '{d.name}'")
            for v in free_variables(d.domain):
                if v.name not in scope:
                    report.error(
                        f"free variable {v.name} in the domain of {kind} '{d.name}'", v.span
                    )
            consistent(d.domain, f"{kind} '{d.name}'")
    if declared is not None:
        missing = sorted(p for p in own if declared.predicate_arity(p) is None)
        if missing:
            report.warn(
                "predicates used by the stream file but not declared by the domain: "
                + " ".join(missing),
                arities.get(missing[0], (0, None))[1],
            )
        # A stream whose domain needs a fact that neither the domain's vocabulary (the
        # problem's facts) nor any stream's certified facts can provide never fires: usually
        # a typo such as Blok for Block.
        certified = {a.pred for s in f.streams for a in atoms(s.certified)}
        certified |= {a.pred for r in f.rules for a in atoms(r.certified)}
        for s in f.streams:
            for a in atoms(s.domain):
                if a.pred == "=" or a.pred in certified:
                    continue
                if declared.predicate_arity(a.pred) is None:
                    report.warn(
                        f"stream '{s.name}' can never fire: its domain needs '{a.pred}', which "
                        "the domain does not declare and no stream certifies",
                        a.span,
                    )
        for name, (arity, span) in sorted(arities.items()):
            want = declared.predicate_arity(name)
            if want is not None and want != arity:
                report.error(f"'{name}' takes {want} arguments in the domain, found {arity}", span)
    return report


def undeclared_domain_names(domain: S.Domain) -> dict[str, S.Span | None]:
    """Names the domain's formulas use without declaring them as constants (-> first use)."""
    fc = _FormulaChecker(Report("<domain>"), Vocabulary.of(domain))
    fc.domain_names = {}
    for a in (*domain.actions,):
        scope = frozenset(p.name for p in a.parameters)
        fc.formula(a.precondition, scope, "a precondition")
        fc.formula(a.effect, scope, "an effect")
    for ax in domain.axioms:
        fc.formula(ax.body, frozenset(p.name for p in ax.parameters), "an axiom")
    return fc.domain_names


def undeclared_stream_names(streams: S.StreamFile, domain: S.Domain) -> dict[str, S.Span | None]:
    """Names a stream file's formulas use that the domain does not declare as constants (->
    first use): they must be objects of the problem."""
    fc = _FormulaChecker(Report("<stream>"), Vocabulary.of(domain, streams))
    fc.domain_names = {}
    for s in streams.streams:
        scope = frozenset(p.name for p in (*s.inputs, *s.outputs))
        fc.formula(s.domain, scope, "a stream")
        fc.formula(s.certified, scope, "a stream")
    for r in streams.rules:
        scope = frozenset(p.name for p in r.inputs)
        fc.formula(r.domain, scope, "a rule")
        fc.formula(r.certified, scope, "a rule")
    for d in (*streams.functions, *streams.predicates):
        fc.formula(d.domain, frozenset(p.name for p in d.params), "a function")
    return fc.domain_names


def _unbound_head(report: Report, ax: S.Axiom, where: str) -> None:
    """Warn when a disjunct of an axiom body leaves an untyped head parameter without a
    positive atom to bind it: a grounding translator (Fast Downward's) then instantiates the
    derived atom over every object of the problem -- on a compiled optimistic problem, over
    thousands of optimistic values."""
    untyped = [p.name for p in ax.parameters if p.type in (None, "object")]
    if not untyped:
        return
    body = ax.body
    disjuncts = body.args if isinstance(body, S.Or) else (body,)
    for i, d in enumerate(disjuncts, 1):
        while isinstance(d, S.Exists):
            d = d.body
        bound = {
            t.name
            for c in S.conjuncts(d)
            if isinstance(c, S.Atom) and c.pred != "="
            for t in c.args
            if isinstance(t, S.Var)
        }
        missing = [v for v in untyped if v not in bound]
        if missing:
            part = f"disjunct {i} of {where}" if len(disjuncts) > 1 else where
            report.warn(
                f"{part} does not bind {', '.join(missing)} with a positive atom: a grounding "
                "planner instantiates it over every object (add an atom that names "
                f"{', '.join(missing)})",
                getattr(d, "span", None) or ax.span,
            )


def _free_variables(report: Report, f, scope: frozenset[str], where: str) -> None:
    for v in free_variables(f):
        if v.name not in scope:
            report.error(f"free variable {v.name} in {where}", v.span)
