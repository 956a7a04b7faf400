"""Compile pass — optimistic stream instantiation (paper §IV, §VII; PDDLStream's Focused
algorithm).

From the problem's facts (plus stream results already evaluated), instantiate every stream whose
domain holds, giving each instance fresh optimistic output objects and its certified facts;
repeat to a fixed point bounded by a *level*: real facts have level 0, and an instance has
level ``1 + max(levels of its domain facts)``; instances above the level limit are not made.
Test streams are optimistically true; ``:function`` terms take an optimistic value (from the
stream info, else the documented default :data:`DEFAULT_FUNCTION_VALUE`).

:func:`instantiate` returns an :class:`Instantiation`: the domain (with the predicates only the
stream file declares) and the optimistic problem, and the provenance of every optimistic object
and fact -- the stream instance that produced it -- so a plan over the compiled problem can be
traced back to the stream instances it relies on (its stream plan).  Actions are untouched, so
plans map back unchanged.
"""

from __future__ import annotations

import itertools
from collections import Counter
from collections.abc import Container, Iterable, Mapping
from dataclasses import dataclass, field, replace
from typing import Any

from .. import syntax as S
from ..errors import InstanceCapReached, UnsupportedError
from ..formulas import atoms
from .join import FactIndex, _eq_holds, _matches, facts_by_predicate
from .predicates import optimistic_truth, predicate_tests
from .relevance import distinct_inputs
from .result import PassResult
from .standins import StandIns, value_key

# The optimistic value of a cost function whose stream info gives none: the lower bound 1,
# because planners need strictly positive action costs to make progress (paper §III: c_a > 0).
DEFAULT_FUNCTION_VALUE = 1.0
# Safety cap on the stream instances of one compilation that make objects or certify facts
# some stream, rule or function domain joins over: their chains are what grows level by level.
MAX_INSTANCES = 20000
# Cap on the instances of *leaf tests* (:func:`leaf_tests`) and *leaf streams*
# (:func:`leaf_streams`): each adds facts (and objects) only actions read and enables no other
# instance, so they are counted apart (pddlstream gives tests no complexity).  Pairwise tests
# grow with the square of the beliefs: issue 40's kitchen of 8 objects has 22,921 instances at
# level 4, 19,691 of them leaf tests (test-cfree 9,292, test-afree 7,492, test-vis 1,900,
# test-vis-robot 1,007); 100,000 leaf tests take some 175 MiB (tamp2d, 316 blocks, level 1:
# 99,540 test-cfree).  The base motions, one per pair of base configurations, are leaf
# streams: counted with the others, they alone passed MAX_INSTANCES as the level climbed
# (19,456 of them when N = 8, seed 0 ended at the cap).
MAX_LEAF_TESTS = 100000


@S.cached_hash  # looked up in large sets while instantiating
@dataclass(frozen=True)
class Instance:
    """One stream (or function) applied to input objects."""

    stream: str
    inputs: tuple[str, ...]
    kind: str = "stream"  # "stream", "test" or "function"

    def __str__(self) -> str:
        return f"{self.stream}({', '.join(self.inputs)})"


@dataclass
class Result:
    """What one instance certifies: its (optimistic or real) outputs and facts."""

    instance: Instance
    outputs: tuple[str, ...]
    certified: tuple[S.Atom, ...]
    domain: tuple[S.Atom, ...]
    level: int
    optimistic: bool = True
    value: float | None = None  # for functions
    # A real result's complexity (PDDLStream's): the largest of its domain facts' plus the
    # number of draws its instance had made before it (a first draw: its inputs'); the solver
    # shows the planner only the real results whose complexity is at most the level
    complexity: int = 0


@dataclass
class Instantiation(PassResult):
    """The instantiation pass's result: the optimistic problem and where each of its objects
    and facts came from."""

    results: list[Result] = field(default_factory=list)
    # optimistic object name -> the result that makes it
    objects: dict[str, Result] = field(default_factory=dict)
    # certified fact -> the optimistic result(s) that certify it (real facts are absent)
    facts: dict[S.Atom, list[Result]] = field(default_factory=dict)
    # function term -> result (optimistic value)
    functions: dict[S.FuncTerm, Result] = field(default_factory=dict)
    level: int = 0
    saturated: bool = True  # False when the level limit cut instantiation short
    # shared optimistic object -> every result that outputs it (``share=True``)
    shared: dict[str, list[Result]] = field(default_factory=dict)
    # stream predicates optimistically false: each instance whose domain holds and whose value
    # is not known yet, by its atom (a plan relying on the atom's absence has it checked)
    negated: Any = field(default_factory=dict)  # S.Atom -> Result (:class:`NegatedChecks`)
    unknown: frozenset[str] = frozenset()  # the names of those predicates
    # optimistic object -> its stand-in value (``standins``: :mod:`.standins`), and the
    # objects that several instances output (equal stand-in values): object -> those results
    standins: dict[str, Any] = field(default_factory=dict)
    merged: dict[str, list[Result]] = field(default_factory=dict)

    def optimistic_objects(self) -> set[str]:
        return set(self.objects)


def declare_stream_predicates(domain: S.Domain, streams: S.StreamFile | None) -> S.Domain:
    """Declare, in the domain, the predicates that only the stream file mentions."""
    if streams is None:
        return domain
    declared = {p.name for p in domain.predicates} | {ax.name for ax in domain.axioms}
    extra: dict[str, int] = {}
    for s in streams.streams:
        for formula in (s.domain, s.certified):
            for a in atoms(formula):
                if a.pred not in declared and a.pred != "=":
                    extra.setdefault(a.pred, len(a.args))
    for p in streams.predicates:
        if p.name not in declared:
            extra.setdefault(p.name, len(p.params))
    for r in streams.rules:
        for a in atoms(r.certified):
            if a.pred not in declared and a.pred != "=":
                extra.setdefault(a.pred, len(a.args))
    if not extra:
        return domain
    new = tuple(
        S.PredicateDecl(name, tuple(S.Typed(f"?x{i}") for i in range(arity)))
        for name, arity in sorted(extra.items())
    )
    return replace(domain, predicates=domain.predicates + new)


def optimistic_name(var: str, index: int) -> str:
    """A fresh object name, accepted by Fast Downward, unified-planning and pyperplan."""
    return f"opt{index}-{var.lstrip('?')}"


def instantiate(
    domain: S.Domain,
    streams: S.StreamFile,
    problem: S.Problem,
    *,
    level: int = 3,
    evaluated: Iterable[Result] = (),
    disabled: Iterable[Instance] = (),
    function_values: Mapping[str, float] | None = None,
    real_function_values: Mapping[S.FuncTerm, float] | None = None,
    exhausted: Iterable[Instance] = (),
    share: bool = False,
    standins: StandIns | None = None,
    real_only: Container[str] = frozenset(),
) -> Instantiation:
    """Optimistically instantiate ``streams`` over ``problem`` up to ``level``.

    With ``share``, instances with an optimistic input do not get fresh outputs: all of them
    share one optimistic object per stream output (PDDLStream's shared optimistic values), so
    the optimistic problem grows with the real objects, not with chains of optimistic ones;
    instances over real inputs keep their own outputs.  ``shared`` lists the producers of each
    shared object (the solver evaluates consumers for every real value bound to it).

    ``standins``: the streams' optimistic stand-ins (:class:`~.standins.StandIns`).  An
    instance of a stream that has one, all of whose inputs have values (real, or stand-in
    values of optimistic objects), takes its outputs' stand-in values from it (none: no
    instance), and outputs with equal stand-in values are one optimistic object
    (``merged``); a test's instance is made only when its stand-in holds; a cost function's
    term takes its stand-in's value.  (An instance sharing its outputs, with ``share``, gets
    no output stand-ins: its outputs stand for every value.)

    ``real_only``: streams instantiated over real inputs only (``StreamInfo.p_success`` 0,
    pddlstream's infinite effort: a test that never holds for a value drawn for a plan, such
    as continuous_tamp's ``t-region`` of a placement drawn in another region).

    ``evaluated`` are real results (their facts join the initial state at level 0);
    ``disabled`` instances are not instantiated optimistically (they failed at this level);
    ``exhausted`` instances have no more outputs (their real results stay, no optimistic one
    is added); ``function_values`` maps a function name to its optimistic value;
    ``real_function_values`` gives evaluated function terms their real value.
    """
    refuse_unsupported(streams)
    disabled = set(disabled) | set(exhausted)
    function_values = dict(function_values or {})
    real_function_values = dict(real_function_values or {})
    taken = {o.name for o in problem.objects} | {c.name for c in domain.constants}
    levels: dict[S.Atom, int] = {}
    index = FactIndex()
    position: dict[S.Atom, int] = {}  # where each fact sits in its index list

    def add_fact(atom: S.Atom, lvl: int) -> bool:
        if atom in levels and levels[atom] <= lvl:
            return False
        if atom not in levels:
            position[atom] = len(index[atom.pred])
            index.add(atom)
        levels[atom] = lvl
        return True

    for fact in problem.init:
        if isinstance(fact, S.Atom):
            add_fact(fact, 0)
    evaluated = list(evaluated)
    real_objects: list[S.Typed] = []
    known = set(taken)
    for res in evaluated:
        for atom in res.certified:
            add_fact(atom, 0)
            for a in atom.args:
                if a.name not in known:
                    known.add(a.name)
                    real_objects.append(S.Typed(a.name))
    taken |= known
    _apply_rules(streams, index, add_fact, levels)

    out = Instantiation(declare_stream_predicates(domain, streams), problem, [], level=level)
    new_objects: list[S.Typed] = []
    new_facts: list[S.Atom] = []
    counter = itertools.count(1)
    seen: set[Instance] = set()
    shared_names: dict[tuple[str, str], str] = {}
    by_standin: dict[Any, str] = {}  # a stand-in value's key -> its optimistic object
    standin_of = _standin_values(standins, out)
    for res in evaluated:
        out.results.append(res)

    schemas = [(s, "test" if s.is_test else "stream") for s in streams.streams]
    # Stream predicates: those optimistically true are tests certifying their atom
    truth = optimistic_truth(domain, streams, problem)
    schemas += [(p, "test") for p in predicate_tests(streams) if truth[p.name]]
    # Semi-naive: an instance first possible at depth d has its deepest domain fact at level
    # d - 1, so depth d only joins through the facts that reached level d - 1 (``fresh``);
    # the first depth joins through every real fact.
    leaves = leaf_tests(streams, [s for s, kind in schemas if kind == "test"])
    # leaf tests' instances whose facts the domain never reads (pairs of an object with itself)
    apart = distinct_inputs(domain, problem, [s for s, _k in schemas if s.name in leaves])
    # counted against MAX_LEAF_TESTS: the leaf tests and the generators no domain joins over
    leaves |= leaf_streams(streams, [s for s, kind in schemas if kind == "stream"])

    def unread(stream, binding) -> bool:
        return any(binding[a] == binding[b] for a, b in apart.get(stream.name, ()))

    counts: Counter[str] = Counter()  # instances made, by stream
    made_leaves = 0
    fresh: list[S.Atom] | None = None
    for depth in range(1, level + 1):
        made = []
        for stream, kind in schemas:
            found = []
            for binding, dom_facts in _matches(stream.inputs, stream.domain, index, levels, fresh):
                inst = Instance(stream.name, tuple(binding[p.name] for p in stream.inputs), kind)
                if inst in seen or inst in disabled or unread(stream, binding):
                    continue
                if stream.name in real_only and any(x in out.objects for x in inst.inputs):
                    continue  # p_success 0: never planned over an optimistic input
                inst_level = 1 + max((levels[f] for f in dom_facts), default=0)
                if inst_level > depth:
                    continue
                seen.add(inst)
                counts[inst.stream] += 1
                made_leaves += stream.name in leaves
                # while building, not after the whole depth
                if len(seen) - made_leaves > MAX_INSTANCES:
                    raise InstanceCapReached(
                        f"optimistic instantiation made more than {MAX_INSTANCES} stream "
                        f"instances at level {depth}; lower the level or restrict the stream "
                        f"domains{_most(counts, leaves, False)}"
                    )
                if made_leaves > MAX_LEAF_TESTS:
                    raise InstanceCapReached(
                        f"optimistic instantiation made more than {MAX_LEAF_TESTS} instances "
                        f"of tests and streams no stream domain uses at level {depth}; lower "
                        f"the level or restrict their domains{_most(counts, leaves, True)}"
                    )
                key = tuple(position[f] for f in dom_facts)
                found.append((key, (stream, inst, binding, dom_facts, inst_level)))
            if fresh is not None:
                # The order of a full nested-loop join over the index (deterministic names).
                found.sort(key=lambda x: x[0])
            made.extend(m for _k, m in found)
        for stream, inst, binding, dom_facts, inst_level in made:
            outputs = []
            full = dict(binding)
            sharing = share and any(x in out.objects for x in inst.inputs)
            stand = None
            if standins is not None and stream.name in standins:
                args = standin_of(inst.inputs)
                if args is not None and inst.kind == "test":
                    if not standins.test(stream.name, args):
                        continue
                elif args is not None and not sharing:
                    stand = standins.outputs(stream.name, args, len(stream.outputs))
                    if stand is None:
                        continue
            for i, o in enumerate(stream.outputs):
                name = shared_names.get((stream.name, o.name)) if sharing else None
                key = None if stand is None else value_key(stand[i])
                if key is not None and key in by_standin:
                    name = by_standin[key]
                if name is None:
                    name = optimistic_name(o.name, next(counter))
                    while name in taken:
                        name = optimistic_name(o.name, next(counter))
                    taken.add(name)
                    new_objects.append(S.Typed(name, o.type))
                    if sharing:
                        shared_names[(stream.name, o.name)] = name
                    if stand is not None:
                        out.standins[name] = stand[i]
                        if key is not None:
                            by_standin[key] = name
                full[o.name] = name
                outputs.append(name)
            certified = tuple(
                ground_atom(a, full) for a in S.conjuncts(stream.certified) if isinstance(a, S.Atom)
            )
            res = Result(inst, tuple(outputs), certified, tuple(dom_facts), inst_level)
            out.results.append(res)
            for name in outputs:
                if name in out.objects and stand is not None and out.objects[name] is not res:
                    out.merged.setdefault(name, [out.objects[name]]).append(res)
                out.objects.setdefault(name, res)
                if sharing:
                    out.shared.setdefault(name, []).append(res)
            for atom in certified:
                if atom not in levels or levels[atom] > 0:
                    out.facts.setdefault(atom, []).append(res)
                if add_fact(atom, inst_level):
                    new_facts.append(atom)
        _apply_rules(streams, index, add_fact, levels)
        if not made:
            break
        fresh = facts_by_predicate(a for a, lvl in levels.items() if lvl == depth)
    else:
        # The loop ran to the limit: were more instances possible (through the facts of the
        # last depth)?
        made_or_disabled = seen | disabled
        out.saturated = not any(
            True
            for stream, kind in schemas
            for binding, _f in _matches(stream.inputs, stream.domain, index, levels, fresh)
            if not unread(stream, binding)
            and Instance(stream.name, tuple(binding[p.name] for p in stream.inputs), kind)
            not in made_or_disabled
        )

    # Cost functions: every term whose domain holds gets a value (real, else optimistic).
    values: list[S.InitValue] = []
    for fn in streams.functions:
        for binding, dom_facts in _matches(fn.params, fn.domain, index, levels):
            args = tuple(binding[p.name] for p in fn.params)
            term = S.FuncTerm(fn.name, tuple(S.Const(a) for a in args))
            if term in real_function_values:
                value, optimistic = real_function_values[term], False
            elif standins is not None and fn.name in standins and standin_of(args) is not None:
                value, optimistic = standins.cost(fn.name, standin_of(args)), True
            else:
                value, optimistic = function_values.get(fn.name, DEFAULT_FUNCTION_VALUE), True
            lvl = max((levels[f] for f in dom_facts), default=0)
            res = Result(
                Instance(fn.name, args, "function"),
                (),
                (),
                tuple(dom_facts),
                lvl,
                optimistic,
                value,
            )
            out.functions[term] = res
            values.append(S.InitValue(term, S.Num(value)))

    _negated_predicates(streams, truth, index, levels, disabled, out)

    initial = {f for f in problem.init if isinstance(f, S.Atom)}
    all_facts = [a for a in levels if a not in initial]
    init = list(problem.init) + sorted(all_facts, key=_fact_order) + values
    objects = problem.objects + tuple(real_objects) + tuple(new_objects)
    out.problem = replace(problem, objects=objects, init=tuple(init))
    return out


def leaf_tests(streams: S.StreamFile, tests: Iterable[S.Stream]) -> frozenset[str]:
    """The names of the ``tests`` (streams without outputs) whose certified predicates no
    stream, stream predicate, rule or function domain of ``streams`` mentions: their instances
    add facts only the actions and axioms read, and never enable another instance."""
    return leaf_streams(streams, [t for t in tests if not t.outputs])


def leaf_streams(streams: S.StreamFile, candidates: Iterable[S.Stream]) -> frozenset[str]:
    """The names of the ``candidates`` whose certified predicates no stream, stream
    predicate, rule or function domain of ``streams`` mentions, outputs or not: their
    instances never enable another instance (an output is only ever typed by those
    predicates, so no stream takes it as an input).  A generator among them makes objects
    only actions read: the kitchen's base motions, one per pair of base configurations."""
    used = {
        a.pred
        for block in (*streams.streams, *streams.predicates, *streams.rules, *streams.functions)
        for a in atoms(block.domain)
    }
    return frozenset(
        t.name for t in candidates if not any(a.pred in used for a in atoms(t.certified))
    )


def _most(counts: Counter[str], leaves: frozenset[str], leaf: bool, k: int = 4) -> str:
    """The ``k`` streams with most instances (leaf tests or the others), for a cap message."""
    top = [(n, c) for n, c in counts.most_common() if (n in leaves) == leaf][:k]
    return " (most: " + ", ".join(f"{n} {c}" for n, c in top) + ")" if top else ""


def _standin_values(standins: StandIns | None, out: Instantiation):
    """A function giving the values of some objects for the stand-ins: real objects' values,
    optimistic objects' stand-in values; None when one has none."""

    def values(names: tuple[str, ...]) -> tuple | None:
        found = []
        for n in names:
            if n in out.objects:
                if n not in out.standins:
                    return None
                found.append(out.standins[n])
            else:
                found.append(standins.value(n))
        return tuple(found)

    return values


def _negated_predicates(streams, truth, index, levels, disabled, out: Instantiation) -> None:
    """The instances of the stream predicates optimistically false whose domain holds (at any
    level) and whose value is unknown (``disabled``: evaluated): nothing is certified, but a
    plan relying on the absence of one of their atoms has them checked.  Made when the plan's
    preimage asks for one (:class:`NegatedChecks`): a lazy test's complement has one per pair
    of poses, and a plan relies on a few."""
    out.unknown = frozenset(name for name, value in truth.items() if not value)
    preds = {p.name: p for p in streams.predicates if not truth[p.name]}
    if preds:
        out.negated = NegatedChecks(preds, levels, disabled)


class NegatedChecks:
    """``atom -> Result``: the instance of an optimistically false stream predicate that a
    plan relying on ``atom``'s absence has checked, when its domain holds in the optimistic
    problem and its value is not known yet (else ``get`` gives the default)."""

    def __init__(self, preds: dict[str, S.StreamPredicate], levels, disabled) -> None:
        self.preds = preds
        self.levels = levels
        self.disabled = disabled
        self.made: dict[S.Atom, Result | None] = {}

    def get(self, atom: S.Atom, default=None) -> Result | None:
        if atom not in self.made:
            self.made[atom] = self._make(atom)
        found = self.made[atom]
        return default if found is None else found

    def _make(self, atom: S.Atom) -> Result | None:
        p = self.preds.get(atom.pred)
        if p is None or len(atom.args) != len(p.params):
            return None
        binding = {t.name: a.name for t, a in zip(p.params, atom.args)}
        dom = [a for a in S.conjuncts(p.domain) if isinstance(a, S.Atom)]
        mentioned = {t.name for a in dom if a.pred != "=" for t in a.args if isinstance(t, S.Var)}
        if not all(t.name in mentioned for t in p.params):
            return None  # a parameter no atom binds: no instance (as _matches)
        facts = []
        for a in dom:
            if a.pred == "=":
                if not _eq_holds(a, binding):
                    return None
                continue
            fact = ground_atom(a, binding)
            if fact not in self.levels:
                return None
            facts.append(fact)
        inst = Instance(p.name, tuple(binding[t.name] for t in p.params), "test")
        if inst in self.disabled:
            return None
        lvl = 1 + max((self.levels[f] for f in facts), default=0)
        return Result(inst, (), (), tuple(facts), lvl)


def real_function_terms(
    streams: S.StreamFile,
    problem: S.Problem,
    evaluated: Iterable[Result] = (),
    names: Iterable[str] | None = None,
) -> list[Instance]:
    """The cost-function terms (of the functions ``names``, default all) whose domain holds
    in the real facts alone: the problem's and those of the ``evaluated`` results."""
    return real_instances(streams, problem, evaluated, functions=names, tests=())


def real_instances(
    streams: S.StreamFile,
    problem: S.Problem,
    evaluated: Iterable[Result] = (),
    *,
    functions: Iterable[str] | None = None,
    tests: Iterable[str] | None = None,
    streams_with_outputs: Iterable[str] = (),
    predicates: bool = False,
) -> list[Instance]:
    """The instances of the cost functions ``functions`` and of the tests ``tests`` (``None``:
    all of them), and of the streams with outputs named in ``streams_with_outputs`` (and with
    ``predicates``, of the stream predicates, as tests), whose domain holds in the real facts
    alone: the problem's and those of the ``evaluated`` results.  Functions first, each in the
    order of a join over the facts."""
    levels: dict[S.Atom, int] = {}
    index = FactIndex()

    def add_fact(atom: S.Atom, lvl: int) -> bool:
        if atom in levels:
            return False
        levels[atom] = lvl
        index.add(atom)
        return True

    for fact in problem.init:
        if isinstance(fact, S.Atom):
            add_fact(fact, 0)
    for res in evaluated:
        for atom in res.certified:
            add_fact(atom, 0)
    _apply_rules(streams, index, add_fact, levels)
    parts = real_parts(streams, functions, tests, streams_with_outputs, predicates)
    return [
        Instance(name, tuple(binding[p.name] for p in params), kind)
        for name, params, domain, kind in parts
        for binding, _facts in _matches(params, domain, index, levels)
    ]


def real_parts(
    streams: S.StreamFile,
    functions: Iterable[str] | None = None,
    tests: Iterable[str] | None = None,
    streams_with_outputs: Iterable[str] = (),
    predicates: bool = False,
) -> list[tuple[str, tuple, S.Formula, str]]:
    """What :func:`real_instances` joins, in its order: ``(name, parameters, domain, kind)``
    of the cost functions ``functions`` (``None``: all), then of the tests ``tests`` (``None``:
    all) and the streams ``streams_with_outputs`` in the stream file's order, then (with
    ``predicates``) of the stream predicates, as tests."""
    wanted_functions = None if functions is None else set(functions)
    wanted_tests = None if tests is None else set(tests)
    wanted_streams = set(streams_with_outputs)
    parts = [
        (fn.name, fn.params, fn.domain, "function")
        for fn in streams.functions
        if wanted_functions is None or fn.name in wanted_functions
    ]
    for stream in streams.streams:
        if stream.is_test:
            if wanted_tests is not None and stream.name not in wanted_tests:
                continue
        elif stream.name not in wanted_streams:
            continue
        kind = "test" if stream.is_test else "stream"
        parts.append((stream.name, stream.inputs, stream.domain, kind))
    if predicates:
        parts += [(p.name, p.params, p.domain, "test") for p in streams.predicates]
    return parts


def _fact_order(a: S.Atom):
    return (a.pred, tuple(t.name for t in a.args))


def refuse_unsupported(streams: S.StreamFile) -> None:
    """Raise :class:`UnsupportedError` (with line and column) for :fluents and :optimizer."""
    for s in streams.streams:
        if s.fluents:
            raise UnsupportedError(
                f"stream '{s.name}' declares :fluents; streams conditioned on the state are not "
                "supported by optimistic compilation",
                line=s.span.line if s.span else None,
                col=s.span.col if s.span else None,
            )
    if streams.optimizers:
        o = streams.optimizers[0]
        raise UnsupportedError(
            f":optimizer '{o.name}' is read and printed, but not compiled",
            line=o.span.line if o.span else None,
            col=o.span.col if o.span else None,
        )


def _apply_rules(streams, index, add_fact, levels) -> None:
    """``:rule`` blocks: their certified facts hold wherever their domain holds."""
    changed = True
    while changed and streams.rules:
        changed = False
        for rule in streams.rules:
            for binding, dom_facts in _matches(rule.inputs, rule.domain, index, levels):
                lvl = max((levels[f] for f in dom_facts), default=0)
                for a in S.conjuncts(rule.certified):
                    if isinstance(a, S.Atom) and add_fact(ground_atom(a, binding), lvl):
                        changed = True


def ground_atom(atom: S.Atom, binding: Mapping[str, str]) -> S.Atom:
    """``atom`` with its variables replaced by the objects ``binding`` gives them (the one
    grounding of stream facts: optimistic here, real in the Focused solver)."""
    return S.Atom(
        atom.pred,
        tuple(
            S.const(binding.get(t.name, t.name)) if isinstance(t, S.Var) else t for t in atom.args
        ),
    )
