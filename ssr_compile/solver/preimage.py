"""The preimage of a plan: which static facts (and so which stream instances) it relies on.

The plan is simulated over the optimistic problem.  Each action's precondition (and the goal)
is evaluated with *support tracking*: a true atom is supported by itself; ``(not p)`` with
``p`` derived is supported by the facts that make every way of deriving ``p`` fail — e.g.
``(not (BOccluded ?o ?obs))`` rests on the ``BVis`` fact of every other object at its current
belief (paper §IV-A), and a placement free of collisions on its ``CFree`` tests.  The static
facts in the supports, and the optimistic objects in the plan's arguments and cost terms,
name the stream results the plan needs; back-chaining through their domain facts gives the
stream plan (PDDLStream's Focused algorithm, paper §VII).
"""

from __future__ import annotations

import itertools
from collections import defaultdict
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

from .. import syntax as S
from ..compile.formulas import substitute
from ..compile.instantiate import Instantiation, Result
from ..errors import SSRError
from ..formulas import unify

Plan = Sequence[tuple[str, Sequence[str]]]

# How deep a guard follows derived atoms into the axioms they rest on (:meth:`_guards`)
EXPAND_DEPTH = 4


class PlanInvalid(SSRError):
    """The plan does not apply to the problem (a precondition or the goal fails)."""


@dataclass
class Preimage:
    static_facts: set[S.Atom] = field(default_factory=set)
    cost_terms: set[S.FuncTerm] = field(default_factory=set)
    # For each plan step, the static facts its precondition needed.
    per_step: list[set[S.Atom]] = field(default_factory=list)
    per_step_costs: list[set[S.FuncTerm]] = field(default_factory=list)
    goal_facts: set[S.Atom] = field(default_factory=set)
    # Atoms of stream predicates not known yet whose absence the plan relies on
    negated: set[S.Atom] = field(default_factory=set)


class _SupportTracker:
    def __init__(self, domain: S.Domain, objects: list[str], static: set[str], unknown=frozenset()):
        self.axioms: dict[str, list[S.Axiom]] = defaultdict(list)
        for ax in domain.axioms:
            self.axioms[ax.name].append(ax)
        self.objects = objects
        self.static = static
        # Stream predicates false until evaluated: an absent atom of one is supported by its
        # negation (to be checked), and it binds no variable (absent atoms may hold later)
        self.unknown = unknown
        self.state: set[S.Atom] = set()
        # the state's atoms by predicate (insertion-ordered sets), kept up to date step by step
        self.index: dict[str, dict[S.Atom, None]] = defaultdict(dict)
        self.cache: dict[tuple[S.Atom, bool], tuple[bool, frozenset]] = {}
        self.guards: dict[tuple, list[S.Atom]] = {}  # (:meth:`bindings`; the state's atoms aside)
        # where each object first comes (a constant may also be an object): the product's order
        self.position: dict[str, int] = {}
        for i, name in enumerate(objects):
            self.position.setdefault(name, i)
        self.fresh = itertools.count()  # renamed quantified variables of expanded guards

    def set_state(self, state: set[S.Atom]) -> None:
        self.state = state
        self.index = defaultdict(dict)
        for a in state:
            self.index[a.pred][a] = None
        self.cache = {}

    def step(self, state: set[S.Atom], adds: set[S.Atom], dels: set[S.Atom]) -> None:
        """The state after a step that deleted ``dels`` and added ``adds`` (``state``)."""
        self.state = state
        for a in dels:
            self.index[a.pred].pop(a, None)
        for a in adds:
            self.index[a.pred][a] = None
        self.cache = {}

    # holds(f) -> (truth, support): support is a frozenset of static atoms the truth rests on.
    # ``env``: the objects of ``f``'s free variables (what substituting them first would give,
    # without building the substituted formula: the axioms' bodies are asked for each step).
    def holds(self, f, negate: bool = False, env: dict | None = None) -> tuple[bool, frozenset]:
        if f is None:
            return (not negate), frozenset()
        if isinstance(f, S.Atom):
            return self.atom(_ground(f, env) if env else f, negate)
        if isinstance(f, S.Not):
            return self.holds(f.arg, not negate, env)
        if isinstance(f, S.And | S.Or):
            conj = isinstance(f, S.And) != negate  # "all parts must be true (after negation)"
            support: set = set()
            if conj:
                for part in f.args:
                    ok, sup = self.holds(part, negate, env)
                    if not ok:
                        return False, frozenset()
                    support |= sup
                return True, frozenset(support)
            found = None
            for part in f.args:
                ok, sup = self.holds(part, negate, env)
                if ok and not (self.unknown and _checks(sup)):
                    return True, sup
                if ok and found is None:  # true only while unchecked values hold: the last resort
                    found = sup
            return (True, found) if found is not None else (False, frozenset())
        if isinstance(f, S.Imply):
            return self.holds(S.Or((S.Not(f.left), f.right)), negate, env)
        if isinstance(f, S.Exists | S.Forall):
            existential = isinstance(f, S.Exists) != negate
            support = set()
            # Only the bindings under which the body can decide the answer: for an
            # existential, those where it can hold; for a universal, those where it can fail
            # (the others hold trivially, with no support).
            polarity = negate if existential else not negate
            outer = _outer(env, f.params)
            for binding in self.bindings(f.params, f.body, polarity, outer, existential):
                ok, sup = self.holds(f.body, negate, {**outer, **binding} if outer else binding)
                if existential and ok:
                    return True, sup
                if not existential:
                    if not ok:
                        return False, frozenset()
                    support |= sup
            return (not existential), frozenset(support)
        if isinstance(f, S.Compare):
            raise SSRError("numeric conditions are not supported in plan preimages")
        raise SSRError(f"cannot evaluate {type(f).__name__} in a precondition")

    def atom(self, a: S.Atom, negate: bool) -> tuple[bool, frozenset]:
        if a.pred == "=":
            left, right = a.args
            return (left.name == right.name) != negate, frozenset()
        key = (a, negate)
        if key in self.cache:
            return self.cache[key]
        if a.pred in self.axioms:
            result = self.derived(a, negate)
        else:
            present = a in self.state
            truth = present != negate
            # A true static fact supports the condition; absent facts need no stream.
            support = frozenset({a}) if (present and a.pred in self.static) else frozenset()
            if negate and not present and a.pred in self.unknown:
                support = frozenset({S.Not(a)})
            result = (truth, support if truth else frozenset())
        self.cache[key] = result
        return result

    def derived(self, a: S.Atom, negate: bool) -> tuple[bool, frozenset]:
        support: set = set()
        for ax in self.axioms[a.pred]:
            binding = {p.name: arg for p, arg in zip(ax.parameters, a.args)}
            body = ax.body
            ok, sup = self.holds(body, False, binding)
            if ok and not negate:
                return True, sup
            if ok and negate:
                return False, frozenset()
            if negate:
                # Why the body fails: its negation holds, with a support.
                _, why = self.holds(body, True, binding)
                support |= why
        return negate, frozenset(support)

    def bindings(
        self, params: tuple[S.Typed, ...], body, negate: bool = False, env=None, only=False
    ):
        """Candidate bindings for quantified variables: those under which ``body`` (negated
        if ``negate``; its other free variables: ``env``) can be true, joined from the state
        atoms that must then hold; every object combination when those atoms do not bind all
        the variables.

        ``only``: the caller needs only the bindings under which ``body`` is true (an
        existential asks for the first, a conditional effect fires where its condition
        holds), not the support of those where it is false.  Then a derived atom and an
        existential of ``body`` guard it by what they must rest on (:meth:`_expanded`),
        and the bindings come in the order of every object combination: the Cook's
        ``press-on``, ``(forall (?o) (when (on ?o stove) ...))``, tried each of 16,000
        objects of a cluttered kitchen's optimistic problem for the derived ``on``."""
        names = [p.name for p in params]
        positives = self._guard_atoms(body, negate, False, env)
        covered = {t.name for x in positives for t in x.args if isinstance(t, S.Var)}
        if positives and set(names) <= covered:
            seen = set()
            for binding in self._join(positives, {}):
                key = tuple(binding.get(n) for n in names)
                if None in key or key in seen:
                    continue
                seen.add(key)
                yield {n: S.Const(v) for n, v in zip(names, key)}
            return
        if only:
            positives = self._guard_atoms(body, negate, True, env)
            covered = {t.name for x in positives for t in x.args if isinstance(t, S.Var)}
        if only and positives and set(names) <= covered:
            where = self.position
            keys = {tuple(b.get(n) for n in names) for b in self._join(positives, {})}
            # the order of itertools.product over the objects, among those it would give
            found = sorted(
                (tuple(where[v] for v in key), key)
                for key in keys
                if all(v in where for v in key)
            )  # fmt: skip
            for _order, key in found:
                yield {n: S.Const(v) for n, v in zip(names, key)}
            return
        for combo in itertools.product(self.objects, repeat=len(names)):
            yield {n: S.Const(v) for n, v in zip(names, combo)}

    def _guard_atoms(self, body, negate: bool, expand: bool, env) -> list[S.Atom]:
        key = (body, negate, expand)
        positives = self.guards.get(key)
        if positives is None:
            positives = self.guards[key] = self._guards(body, negate, [], expand)
        if env:
            positives = [_ground(a, env) for a in positives]
        return positives

    def _guards(self, f, negate: bool, out: list, expand: bool = False, depth: int = 0) -> list:
        """Atoms of the state (not derived, not equalities) that must all be true for ``f``
        (negated if ``negate``) to be true.  With ``expand``, also those a true derived atom
        of one axiom and a true existential rest on (:meth:`_expanded`)."""
        if isinstance(f, S.Atom):
            if negate or f.pred == "=" or f.pred in self.unknown:
                return out
            if f.pred not in self.axioms:
                out.append(f)
            elif expand and depth < EXPAND_DEPTH and len(self.axioms[f.pred]) == 1:
                out.extend(self._expanded(f, self.axioms[f.pred][0], depth))
        elif isinstance(f, S.Not):
            self._guards(f.arg, not negate, out, expand, depth)
        elif isinstance(f, S.And) and not negate or isinstance(f, S.Or) and negate:
            for part in f.args:
                self._guards(part, negate, out, expand, depth)
        elif isinstance(f, S.Imply) and negate:  # not (A -> B) = A and not B
            self._guards(f.left, False, out, expand, depth)
            self._guards(f.right, True, out, expand, depth)
        elif expand and isinstance(f, S.Exists | S.Forall) and isinstance(f, S.Exists) != negate:
            # some binding of its variables makes the body true: they become join variables
            fresh = {p.name: S.Var(f"{p.name}#{next(self.fresh)}") for p in f.params}
            self._guards(substitute(f.body, fresh), negate, out, expand, depth)
        return out

    def _expanded(self, atom: S.Atom, axiom: S.Axiom, depth: int) -> list[S.Atom]:
        """The state atoms that must be true for the derived ``atom`` to be true, as its one
        axiom's body rests on them: the axiom's parameters are ``atom``'s arguments, its
        quantified variables fresh ones (named with a ``#``, never a PDDL name)."""
        inner = self._guards(axiom.body, False, [], True, depth + 1)
        args = {p.name: t for p, t in zip(axiom.parameters, atom.args)}
        return [_ground(a, args) for a in inner]

    def _join(self, atoms, binding):
        if not atoms:
            yield binding
            return
        first, rest = atoms[0], atoms[1:]
        for fact in self.index.get(first.pred, ()):
            new = unify(first, fact, binding)
            if new is not None:
                yield from self._join(rest, new)


def _ground(atom: S.Atom, env: dict) -> S.Atom:
    """``atom`` with the variables ``env`` binds replaced (``substitute`` on one atom)."""
    return S.Atom(
        atom.pred,
        tuple(env.get(t.name, t) if isinstance(t, S.Var) else t for t in atom.args),
        span=atom.span,
    )


def _outer(env: dict | None, params) -> dict:
    """``env`` without the variables a quantifier over ``params`` binds anew (they shadow)."""
    if not env:
        return {}
    shadowed = [p.name for p in params if p.name in env]
    if not shadowed:
        return env
    return {k: v for k, v in env.items() if k not in shadowed}


def fluent_predicates(domain: S.Domain) -> set[str]:
    out = set()
    for a in domain.actions:
        _effect_atoms(a.effect, out)
    return out


def _effect_atoms(effect, out: set[str]) -> None:
    if isinstance(effect, S.Atom):
        out.add(effect.pred)
    elif isinstance(effect, S.Not):
        _effect_atoms(effect.arg, out)
    elif isinstance(effect, S.And):
        for e in effect.args:
            _effect_atoms(e, out)
    elif isinstance(effect, S.Forall):
        _effect_atoms(effect.body, out)
    elif isinstance(effect, S.When):
        _effect_atoms(effect.effect, out)


def _apply(
    effect, state: set[S.Atom], ev: _SupportTracker, adds: set, dels: set, costs: list
) -> None:
    if effect is None:
        return
    if isinstance(effect, S.And):
        for e in effect.args:
            _apply(e, state, ev, adds, dels, costs)
    elif isinstance(effect, S.Atom):
        adds.add(effect)
    elif isinstance(effect, S.Not):
        dels.add(effect.arg)
    elif isinstance(effect, S.When):
        ok, _ = ev.holds(effect.condition)
        if ok:
            _apply(effect.effect, state, ev, adds, dels, costs)
    elif isinstance(effect, S.Forall):
        # A conditional effect fires where its condition holds; an unconditional one everywhere.
        guard = effect.body.condition if isinstance(effect.body, S.When) else None
        for binding in ev.bindings(effect.params, guard, only=True):
            _apply(substitute(effect.body, binding), state, ev, adds, dels, costs)
    elif isinstance(effect, S.NumericEffect):
        if isinstance(effect.value, S.FuncTerm):
            costs.append(effect.value)


def plan_preimage(
    domain: S.Domain, problem: S.Problem, plan: Plan, unknown: frozenset[str] = frozenset()
) -> Preimage:
    """Simulate ``plan`` and collect the static facts its preconditions and goal rest on
    (and the absent atoms of the stream predicates ``unknown`` they rest on)."""
    schemas = {a.name: a for a in domain.actions}
    static = {p.name for p in domain.predicates} - fluent_predicates(domain)
    static |= {f.pred for f in problem.init if isinstance(f, S.Atom)} - fluent_predicates(domain)
    objects = [o.name for o in problem.objects] + [c.name for c in domain.constants]
    ev = _SupportTracker(domain, objects, static, unknown)
    state = {f for f in problem.init if isinstance(f, S.Atom)}
    ev.set_state(state)
    out = Preimage()
    for i, (name, args) in enumerate(plan, start=1):
        schema = schemas.get(name)
        if schema is None:
            raise PlanInvalid(f"step {i}: unknown action '{name}'")
        if len(args) != len(schema.parameters):
            raise PlanInvalid(
                f"step {i}: '{name}' takes {len(schema.parameters)} arguments, got {len(args)}"
            )
        binding = {p.name: S.Const(v) for p, v in zip(schema.parameters, args)}
        ok, support = ev.holds(schema.precondition, False, binding)
        if not ok:
            raise PlanInvalid(
                f"step {i}: the precondition of ({name} {' '.join(args)}) does not hold"
            )
        support = _split(support, out)
        out.per_step.append(set(support))
        out.static_facts |= support
        adds: set = set()
        dels: set = set()
        costs: list = []
        _apply(substitute(schema.effect, binding), state, ev, adds, dels, costs)
        out.cost_terms.update(costs)
        out.per_step_costs.append(set(costs))
        state = (state - dels) | adds
        ev.step(state, adds, dels)
    ok, support = ev.holds(problem.goal)
    if not ok:
        raise PlanInvalid("the goal does not hold at the end of the plan")
    support = _split(support, out)
    out.goal_facts = set(support)
    out.static_facts |= support
    return out


def _checks(support: frozenset) -> bool:
    """Whether ``support`` relies on the absence of atoms not known yet."""
    return any(isinstance(x, S.Not) for x in support)


def _split(support: frozenset, out: Preimage) -> frozenset:
    """The atoms of ``support``; its negations go to ``out.negated``."""
    negated = {x for x in support if isinstance(x, S.Not)}
    out.negated.update(x.arg for x in negated)
    return support - negated if negated else support


def stream_plan(inst: Instantiation, pre: Preimage, plan: Plan) -> list[Result]:
    """The optimistic stream results a plan needs, producers before consumers.

    Needed: results certifying a static fact of the preimage, results making an optimistic
    object that appears in the plan, and optimistic cost-function terms; then, recursively,
    the producers of the optimistic objects and facts in their inputs and domains.  An object
    that several instances output (equal stand-in values: ``inst.merged``) is made by the
    instance whose facts the plan uses, where it uses one.
    """
    needed: list[Result] = []
    seen: set[int] = set()
    planned = _plan_producers(inst, pre)

    shared = inst.shared
    waiting: list[Result] = []  # results with a shared input, placed after its producers

    def need(res: Result) -> None:
        if id(res) in seen or not res.optimistic:
            return
        seen.add(id(res))
        if any(x in shared for x in res.instance.inputs):
            # A shared input's values come from the producers the plan needs elsewhere.
            for fact in res.domain:
                if not any(t.name in shared for t in fact.args):
                    for producer in inst.facts.get(fact, ())[:1]:
                        need(producer)
            waiting.append(res)
            return
        for obj in res.instance.inputs:
            if obj in inst.objects:
                need(planned.get(obj) or inst.objects[obj])
        for fact in res.domain:
            for made in _first_producer(inst, fact, planned):
                need(made)
        needed.append(res)

    for fact in sorted(pre.static_facts, key=lambda a: (a.pred, str(a))):
        for producer in inst.facts.get(fact, ())[:1]:
            need(producer)
    for _, args in plan:
        for v in args:
            if v in inst.objects:
                need(planned.get(v) or inst.objects[v])
    for atom in sorted(pre.negated, key=str):  # the absences the plan relies on, checked
        res = inst.negated.get(atom)
        if res is not None:
            need(res)
    for term in sorted(pre.cost_terms, key=str):
        res = inst.functions.get(term)
        if res is not None:
            need(res)
    # Shared inputs: at least one producer of each (the first), then the waiting results.
    while waiting:
        res = waiting.pop(0)
        for obj in res.instance.inputs:
            producers = shared.get(obj)
            if producers and not any(id(p) in seen for p in producers):
                need(producers[0])
        needed.append(res)
    return needed


def _plan_producers(inst: Instantiation, pre: Preimage) -> dict[str, Result]:
    """Each merged object's producer whose certified facts the plan uses (its static facts'
    first producers, in their order)."""
    if not inst.merged:
        return {}
    out: dict[str, Result] = {}
    for fact in sorted(pre.static_facts, key=lambda a: (a.pred, str(a))):
        for res in inst.facts.get(fact, ())[:1]:
            for o in res.outputs:
                if o in inst.merged:
                    out.setdefault(o, res)
    return out


def _first_producer(inst: Instantiation, fact: S.Atom, producer: dict[str, Result]) -> list:
    """The producer a domain fact is taken from: the first that certifies it, or, for a
    fact over a merged object, the object's producer in the plan when that certifies it."""
    made = inst.facts.get(fact, ())
    if len(made) > 1 and producer:
        for t in fact.args:
            chosen = producer.get(t.name)
            if chosen is not None and any(r is chosen for r in made):
                return [chosen]
    return list(made[:1])


def results_by_object(results: Iterable[Result]) -> dict[str, Result]:
    return {o: r for r in results for o in r.outputs}
