"""Lowering pass — grounding: a lifted task -> a ground task for planners without quantifiers
or axioms.

For backends that cannot take the lifted compiled output (pyperplan: STRIPS only; unified-
planning, whose writer enumerates every grounding of every predicate over all objects), this
pass grounds the task over what can happen:

1. derived predicates are inlined (:func:`.derived.compile_away`) — after grounding, a negated
   derived predicate over *static* facts is a conjunction over the few objects that statically
   collide or occlude, not a huge lifted disjunction;
2. **relaxed reachability**: from the initial state, action instances whose precondition can
   hold when deletes are ignored add their effects, until nothing new is reachable.  Bindings
   come from joining the precondition's positive atoms with the static and reachable facts;
   quantified variables likewise (``exists``) or through the negated body (``forall``), so
   quantifiers never range over all objects unless nothing constrains them;
3. each reachable action instance becomes one ground action: static atoms are evaluated
   (true/false), unreachable fluent atoms are false, equality is decided, quantifiers are
   expanded over their matching bindings only; what remains is a formula over ground fluent
   atoms, each a 0-ary predicate ``<pred>-<k>``;
4. action costs ``(increase (total-cost) (F c1 ...))`` take the problem's value of the ground
   term; an instance whose cost is undefined is not applicable and is dropped.

The output keeps negation and disjunction over ground atoms; the lowering pass then splits and
complements them as the backend needs.  :func:`ground` returns a :class:`Grounded` result,
whose :meth:`~Grounded.map_plan` turns a plan of ground actions back into the lifted actions
and their arguments.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field, replace

from .. import syntax as S
from ..errors import UnsupportedError
from ..formulas import match
from .derived import compile_away
from .formulas import nnf
from .result import PassResult, Plan

Fact = tuple[str, tuple[str, ...]]
TRUE, FALSE = True, False
MAX_GROUND_ACTIONS = 500_000
MAX_FREE_ENUMERATION = 100_000


class GroundingTooLarge(UnsupportedError):
    """The ground task would exceed the size limits."""


@dataclass
class Grounded(PassResult):
    """The grounding pass's result."""

    # ground action name -> (lifted action name, arguments)
    actions: dict[str, tuple[str, tuple[str, ...]]] = field(default_factory=dict)
    # 0-ary predicate name -> the fact it stands for
    facts: dict[str, Fact] = field(default_factory=dict)

    def map_plan(self, plan: Plan) -> Plan:
        return [self.actions.get(name, (name, tuple(args))) for name, args in plan]


# ---------------------------------------------------------------- joins


class _Index:
    """Facts by predicate, for joins; rows keep the order they were added in (a set's order
    would depend on the process's string hashing, and the ground task -- so the planner's tie
    breaking and the plan -- with it)."""

    def __init__(self, facts: Iterable[Fact] = ()):
        self.by_pred: dict[str, dict[tuple[str, ...], None]] = {}
        for f in facts:
            self.add(f)

    def add(self, fact: Fact) -> bool:
        rows = self.by_pred.setdefault(fact[0], {})
        if fact[1] in rows:
            return False
        rows[fact[1]] = None
        return True

    def __contains__(self, fact: Fact) -> bool:
        return fact[1] in self.by_pred.get(fact[0], ())

    def rows(self, pred: str):
        return self.by_pred.get(pred, {}).keys()


def _positive_atoms(f) -> list[S.Atom]:
    """The positive atoms among the top-level conjuncts of an NNF formula (binders)."""
    if isinstance(f, S.Atom):
        return [f] if f.pred != "=" else []
    if isinstance(f, S.And):
        return [a for x in f.args for a in _positive_atoms(x)]
    return []


def _join(
    variables: list[str],
    atoms: list[S.Atom],
    binding: dict[str, str],
    lookup: Callable[[str], set[tuple[str, ...]]],
    domain_of: Callable[[str], list[str]],
) -> Iterator[dict[str, str]]:
    """Extensions of ``binding`` to ``variables`` that match every atom in ``atoms``
    (atoms over other variables are ignored); unconstrained variables range over their type."""
    wanted = set(variables)
    atoms = [a for a in atoms if any(isinstance(t, S.Var) and t.name in wanted for t in a.args)]

    def rec(todo: list[S.Atom], b: dict[str, str]) -> Iterator[dict[str, str]]:
        if not todo:
            free = [v for v in variables if v not in b]
            if not free:
                yield b
                return
            yield from _enumerate_free(free, b, domain_of)
            return

        # the atom with the most bound arguments first
        def bound_count(a: S.Atom) -> int:
            return sum(1 for t in a.args if not isinstance(t, S.Var) or t.name in b)

        i = max(range(len(todo)), key=lambda k: bound_count(todo[k]))
        atom, rest = todo[i], todo[:i] + todo[i + 1 :]
        for row in lookup(atom.pred):
            ext = match(atom, row, b)
            if ext is not None:
                yield from rec(rest, ext)

    yield from rec(atoms, dict(binding))


def _enumerate_free(free, b, domain_of) -> Iterator[dict[str, str]]:
    count = 1
    for v in free:
        count *= max(len(domain_of(v)), 1)
    if count > MAX_FREE_ENUMERATION:
        raise GroundingTooLarge(
            f"grounding would enumerate {count} values of unconstrained variables "
            f"{', '.join(free)} (limit {MAX_FREE_ENUMERATION})"
        )

    def rec(i: int, cur: dict[str, str]) -> Iterator[dict[str, str]]:
        if i == len(free):
            yield cur
            return
        for o in domain_of(free[i]):
            nxt = dict(cur)
            nxt[free[i]] = o
            yield from rec(i + 1, nxt)

    yield from rec(0, dict(b))


# ---------------------------------------------------------------- the grounder


class _Grounder:
    def __init__(self, domain: S.Domain, problem: S.Problem):
        from .quantifiers import objects_by_type

        self.domain, self.problem = domain, problem
        self.fluent_preds = set()
        for a in domain.actions:
            for x in S.walk(a.effect):
                if isinstance(x, S.Atom):
                    self.fluent_preds.add(x.pred)
        init = [x for x in problem.init if isinstance(x, S.Atom)]
        self.static = _Index(
            (a.pred, tuple(t.name for t in a.args)) for a in init if a.pred not in self.fluent_preds
        )
        self.init_fluents = [
            (a.pred, tuple(t.name for t in a.args)) for a in init if a.pred in self.fluent_preds
        ]
        self.reachable = _Index(self.init_fluents)
        self.values = {
            (v.fluent.name, tuple(t.name for t in v.fluent.args)): v.value.value
            for v in problem.init
            if isinstance(v, S.InitValue)
        }
        self._objects_of = objects_by_type(domain, problem)
        self.var_types: dict[str, S.TypeRef] = {}
        self.fact_names: dict[Fact, str] = {}

    # -- helpers
    def lookup(self, pred: str) -> set[tuple[str, ...]]:
        if pred in self.fluent_preds:
            return self.reachable.rows(pred)
        return self.static.rows(pred)

    def domain_of(self, var: str) -> list[str]:
        return self._objects_of(self.var_types.get(var))

    def bindings(self, params, body, binding) -> Iterator[dict[str, str]]:
        for p in params:
            self.var_types[p.name] = p.type
        yield from _join(
            [p.name for p in params], _positive_atoms(body), binding, self.lookup, self.domain_of
        )

    def fact_atom(self, fact: Fact) -> S.Atom:
        name = self.fact_names.get(fact)
        if name is None:
            name = self.fact_names[fact] = f"{fact[0]}-{len(self.fact_names) + 1}"
        return S.Atom(name)

    # -- conditions (NNF in, ground formula or bool out)
    def cond(self, f, b: dict[str, str]):
        if isinstance(f, S.Atom):
            args = tuple(b[t.name] if isinstance(t, S.Var) else t.name for t in f.args)
            if f.pred == "=":
                return args[0] == args[1]
            fact = (f.pred, args)
            if f.pred not in self.fluent_preds:
                return fact in self.static
            if fact not in self.reachable:
                return FALSE
            return self.fact_atom(fact)
        if isinstance(f, S.Not):
            g = self.cond(f.arg, b)
            if isinstance(g, bool):
                return not g
            return S.Not(g)
        if isinstance(f, S.And):
            parts = []
            for x in f.args:
                g = self.cond(x, b)
                if g is FALSE:
                    return FALSE
                if isinstance(g, S.And):
                    parts.extend(g.args)  # flat: STRIPS readers refuse nested conjunctions
                elif g is not TRUE:
                    parts.append(g)
            return TRUE if not parts else parts[0] if len(parts) == 1 else S.And(tuple(parts))
        if isinstance(f, S.Or):
            parts = []
            for x in f.args:
                g = self.cond(x, b)
                if g is TRUE:
                    return TRUE
                if isinstance(g, S.Or):
                    parts.extend(g.args)
                elif g is not FALSE:
                    parts.append(g)
            return FALSE if not parts else parts[0] if len(parts) == 1 else S.Or(tuple(parts))
        if isinstance(f, S.Exists):
            parts = []
            for ext in self.bindings(f.params, f.body, b):
                g = self.cond(f.body, ext)
                if g is TRUE:
                    return TRUE
                if g is not FALSE:
                    parts.append(g)
            return FALSE if not parts else parts[0] if len(parts) == 1 else S.Or(tuple(parts))
        if isinstance(f, S.Forall):
            # forall x. body == not exists x. not body; the negated body's positive atoms bind x
            g = self.cond(S.Exists(f.params, nnf(f.body, True)), b)
            if isinstance(g, bool):
                return not g
            return nnf(S.Not(g))
        raise UnsupportedError(
            f"grounding does not support {type(f).__name__} in conditions (numeric comparisons)"
        )

    def relaxed(self, g) -> bool:
        """Can a ground condition hold in the delete relaxation?  (negations assumed so)"""
        if isinstance(g, bool):
            return g
        if isinstance(g, S.Atom):
            return True  # only reachable atoms survive grounding
        if isinstance(g, S.Not):
            return True
        if isinstance(g, S.And):
            return all(self.relaxed(x) for x in g.args)
        if isinstance(g, S.Or):
            return any(self.relaxed(x) for x in g.args)
        return True

    # -- effects
    def effects(self, f, b, out: list, adds: list[tuple[object, Fact]], condition=TRUE) -> bool:
        """Ground effect ``f``; collect (condition, fact) of its adds.  False: drop the action
        (an undefined cost)."""
        if f is None:
            return True
        if isinstance(f, S.And):
            return all(self.effects(x, b, out, adds, condition) for x in f.args)
        if isinstance(f, S.Atom):
            fact = (f.pred, tuple(b[t.name] if isinstance(t, S.Var) else t.name for t in f.args))
            adds.append((condition, fact))
            out.append(("add", condition, fact))
            return True
        if isinstance(f, S.Not):
            a = f.arg
            fact = (a.pred, tuple(b[t.name] if isinstance(t, S.Var) else t.name for t in a.args))
            out.append(("del", condition, fact))
            return True
        if isinstance(f, S.NumericEffect):
            value = f.value
            if isinstance(value, S.FuncTerm):
                key = (
                    value.name,
                    tuple(b[t.name] if isinstance(t, S.Var) else t.name for t in value.args),
                )
                if key not in self.values:
                    return False
                value = S.Num(self.values[key])
            out.append(("num", condition, replace(f, value=value)))
            return True
        if isinstance(f, S.When):
            c = self.cond(nnf(f.condition), b)
            if c is FALSE:
                return True
            both = c if condition is TRUE else (condition if c is TRUE else S.And((condition, c)))
            return self.effects(f.effect, b, out, adds, both)
        if isinstance(f, S.Forall):
            binder = f.body.condition if isinstance(f.body, S.When) else f.body
            binder = nnf(binder) if isinstance(binder, S.And | S.Or | S.Not | S.Imply) else binder
            for ext in self.bindings(f.params, binder, b):
                if not self.effects(f.body, ext, out, adds, condition):
                    return False
            return True
        raise UnsupportedError(f"grounding does not support {type(f).__name__} in effects")

    # -- the fixpoint and the ground task
    def instances(self, action: S.Action) -> Iterator[tuple[dict[str, str], object]]:
        pre = nnf(action.precondition) if action.precondition is not None else TRUE
        body = pre if not isinstance(pre, bool) else S.And(())
        for b in self.bindings(action.parameters, body, {}):
            g = self.cond(pre, b) if not isinstance(pre, bool) else pre
            if g is not FALSE and self.relaxed(g):
                yield b, g

    def reach(self) -> None:
        done: set[tuple[str, tuple]] = set()
        changed = True
        # An instance whose effects do not depend on what is reachable (no forall, no when)
        # adds the same facts every time: it is expanded once.
        fixed = {
            a.name
            for a in self.domain.actions
            if not any(isinstance(x, S.Forall | S.When) for x in S.walk(a.effect))
        }
        while changed:
            changed = False
            for action in self.domain.actions:
                for b, _ in list(self.instances(action)):
                    key = (action.name, tuple(b[p.name] for p in action.parameters))
                    if key in done:
                        continue
                    out: list = []
                    adds: list = []
                    if not self.effects(action.effect, b, out, adds):
                        done.add(key)
                        continue
                    for c, fact in adds:
                        if (c is TRUE or self.relaxed(c)) and self.reachable.add(fact):
                            changed = True
                    if action.name in fixed:
                        done.add(key)

    def ground(self) -> Grounded:
        self.reach()
        actions: list[S.Action] = []
        names: dict[str, tuple[str, tuple[str, ...]]] = {}
        for action in self.domain.actions:
            for b, g in self.instances(action):
                out: list = []
                if not self.effects(action.effect, b, out, []):
                    continue
                effect = []
                for kind, c, x in out:
                    if kind == "num":
                        e = x
                    elif kind == "add":
                        e = self.fact_atom(x)
                    else:
                        if x not in self.reachable:
                            continue  # deleting what never holds
                        e = S.Not(self.fact_atom(x))
                    effect.append(e if c is TRUE else S.When(c, e))
                args = tuple(b[p.name] for p in action.parameters)
                name = f"{action.name}-g{len(actions) + 1}"
                names[name] = (action.name, args)
                precondition = None if g is TRUE else g
                actions.append(S.Action(name, (), precondition, S.And(tuple(effect))))
                if len(actions) > MAX_GROUND_ACTIONS:
                    raise GroundingTooLarge(
                        f"grounding produced more than {MAX_GROUND_ACTIONS} actions"
                    )
        goal = self.cond(nnf(self.problem.goal), {}) if self.problem.goal is not None else TRUE
        impossible = S.Atom("ssr-unreachable-goal")
        if goal is FALSE:
            goal = impossible
        elif goal is TRUE:
            goal = S.And(())
        init: list = [self.fact_atom(f) for f in self.init_fluents]
        init += [
            v
            for v in self.problem.init
            if isinstance(v, S.InitValue) and v.fluent.name == "total-cost"
        ]
        predicates = [S.PredicateDecl(n) for n in self.fact_names.values()]
        if goal is impossible:
            predicates.append(S.PredicateDecl(impossible.pred))
        domain = replace(
            self.domain,
            types=(),
            constants=(),
            predicates=tuple(predicates),
            functions=tuple(f for f in self.domain.functions if f.name == "total-cost"),
            axioms=(),
            actions=tuple(actions),
        )
        problem = replace(self.problem, objects=(), init=tuple(init), goal=goal)
        facts = {v: k for k, v in self.fact_names.items()}
        return Grounded(domain, problem, names, facts)


MAX_CONDITIONS = 10


def _split_conditional(grounded: Grounded) -> Grounded:
    """Conditional effects of ground actions compiled away: one copy of an action per truth
    assignment of its distinct effect conditions (at most 2^MAX_CONDITIONS copies)."""
    actions: list[S.Action] = []
    names: dict[str, tuple[str, tuple[str, ...]]] = {}
    for a in grounded.domain.actions:
        effects = list(S.conjuncts(a.effect))
        conditions = list(dict.fromkeys(e.condition for e in effects if isinstance(e, S.When)))
        if not conditions:
            actions.append(a)
            names[a.name] = grounded.actions[a.name]
            continue
        if len(conditions) > MAX_CONDITIONS:
            raise GroundingTooLarge(
                f"action '{grounded.actions[a.name][0]}' has {len(conditions)} distinct "
                f"conditional effects once ground; compiling them away would need "
                f"2^{len(conditions)} copies (limit 2^{MAX_CONDITIONS})"
            )
        plain = [e for e in effects if not isinstance(e, S.When)]
        for k in range(2 ** len(conditions)):
            holds = [(k >> i) & 1 == 1 for i in range(len(conditions))]
            guards = [c if h else nnf(S.Not(c)) for c, h in zip(conditions, holds)]
            extra = [
                e.effect
                for e in effects
                if isinstance(e, S.When) and holds[conditions.index(e.condition)]
            ]
            parts: list = []
            for x in (a.precondition, *guards):
                if isinstance(x, S.And):
                    parts.extend(x.args)
                elif x is not None:
                    parts.append(x)
            pre = S.And(tuple(parts))
            name = f"{a.name}-c{k}"
            names[name] = grounded.actions[a.name]
            actions.append(S.Action(name, (), pre, S.And(tuple(plain + extra))))
    domain = replace(grounded.domain, actions=tuple(actions))
    return Grounded(domain, grounded.problem, names, grounded.facts)


def ground(domain: S.Domain, problem: S.Problem, *, conditional_effects: bool = True) -> Grounded:
    """Ground ``domain`` and ``problem`` over their relaxed-reachable instances; without
    ``conditional_effects``, also compile the ground conditional effects away."""
    if domain.axioms:  # inlined first (plans are unchanged by it)
        inlined = compile_away(domain, problem)
        domain, problem = inlined.domain, inlined.problem
    grounded = _Grounder(domain, problem).ground()
    return grounded if conditional_effects else _split_conditional(grounded)
