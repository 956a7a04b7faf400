"""Compile pass — an action over many pairs as two half-steps through a hub.

The kitchen's ``move-base(?q1, ?t, ?q2)`` requires ``(motion base ?q1 ?t ?q2)``, and the
optimistic instantiation certifies that fact for every pair of base configurations (one shared
trajectory object since :mod:`.leaves`).  With 190 bases, late in a cluttered kitchen's episode,
that is 36,000 ground actions, nearly all of the task, and Fast Downward's translator and
heuristics pay for each of them at every planner call.

The pairs have a product's shape: the same second halves ``(?t, ?q2)`` follow every first half
``?q1``.  This pass writes such an action ``A`` as two actions that meet at a *hub* object:

- ``A-hub-out(?hub, X...)``: ``A``'s precondition (without the pair's fact), with
  ``(A-hub-from ?hub X...)`` in its place; ``A``'s effects on the first half and its cost;
  it leaves the hub-idle state for ``(A-hub-at ?hub)``;
- ``A-hub-in(?hub, Y...)``: ``(A-hub-at ?hub)`` and ``(A-hub-to ?hub Y...)``; ``A``'s effects
  on the second half; back to hub-idle.

Every other action, ``A`` itself included, and the goal require ``(hub-idle)``, so the two
halves always follow each other and a plan maps back step for step: the task's ground actions
go from ``|X| * |Y|`` to ``|X| + |Y|`` per hub.  ``A`` keeps the pairs that fit no hub (a real
trajectory, a pair whose first half lacks some of the hub's second halves).

An action is split only when the split cannot change what it does:

- the pair's fact (the *key*) is a positive top-level conjunct of ``A``'s precondition, over a
  static predicate nothing else in the domain or the goal reads, naming every parameter;
- the second half ``Y`` is the parameters no other precondition conjunct names and whose
  effects are positive atoms over ``Y`` alone (an add of the second half cannot be undone by a
  delete of the first, as it cannot in ``A``: PDDL applies adds after deletes);
- every other effect names no parameter of ``Y`` (it is applied at the hub's way out, against
  the state ``A`` would have read).

Only actions with at least :data:`MIN_PAIRS` pair facts are split: smaller tasks are written as
they were.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

from .. import syntax as S
from ..errors import SSRError
from ..formulas import atoms, changed_atoms, free_variables
from .result import PassResult, Plan

# Split an action only when its pair facts are at least this many.  The kitchen's Table I
# problems have up to 40 bases (1,600 pairs) and are written as before; a cluttered
# kitchen's late replans have 100-200 (10,000-40,000 pairs).
MIN_PAIRS = 2500

IDLE = "hub-idle"


@dataclass
class Hubs(PassResult):
    """The pass's result: which actions were split, and how their halves map back."""

    # action A -> (A-hub-out name, A-hub-in name, A's parameters, X parameters, Y parameters)
    split: dict[str, tuple[str, str, tuple[str, ...], tuple[str, ...], tuple[str, ...]]] = field(
        default_factory=dict
    )
    # pairs written through hubs, and hubs made (for the record and the tests)
    pairs: int = 0
    hubs: int = 0

    def map_plan(self, plan: Sequence[tuple[str, Sequence[str]]]) -> Plan:
        halves = {}
        for action, (out, into, params, xs, ys) in self.split.items():
            halves[out] = (action, True, params, xs)
            halves[into] = (action, False, params, ys)
        result: Plan = []
        pending = None  # (action, hub, binding of the way out)
        for name, args in plan:
            args = tuple(args)
            half = halves.get(name)
            if half is None and pending is None:
                result.append((name, args))
                continue
            if half is None or half[1] == (pending is not None):
                raise SSRError(
                    f"internal error: the plan step ({name} {' '.join(args)}) is not where a "
                    "hub's two halves allow it"
                )
            action, way_out, params, names = half
            binding = dict(zip(names, args[1:]))
            if way_out:
                pending = (action, args[0], binding)
                continue
            if (action, args[0]) != pending[:2]:
                raise SSRError(
                    f"internal error: the plan enters hub {args[0]} of {action} from "
                    f"{pending[1]} of {pending[0]}"
                )
            binding.update(pending[2])
            result.append((action, tuple(binding[p] for p in params)))
            pending = None
        if pending is not None:
            raise SSRError(f"internal error: a plan ends inside hub {pending[1]}")
        return result


def _fresh(name: str, taken: set[str]) -> str:
    while name in taken:
        name += "_"
    taken.add(name)
    return name


def _var_names(f) -> set[str]:
    return {v.name for v in free_variables(f)}


def _split_of(action: S.Action, key: S.Atom) -> tuple[tuple[str, ...], tuple[str, ...]] | None:
    """``(X, Y)``: the action's parameters on the hub's way out and way in, or None."""
    params = S.names(action.parameters)
    if not set(params) <= {t.name for t in key.args if isinstance(t, S.Var)}:
        return None
    rest = [c for c in S.conjuncts(action.precondition) if c is not key]
    ys = set(params)
    for c in rest:
        ys -= _var_names(c)
    effects = S.conjuncts(action.effect)
    changed = True
    while changed:
        changed = False
        for e in effects:
            names = _var_names(e)
            if names & ys and (not isinstance(e, S.Atom) or not names <= ys):
                ys -= names
                changed = True
    xs = tuple(p for p in params if p not in ys)
    if not xs or not ys:
        return None
    for e in effects:
        names = _var_names(e)
        if names & ys and names & set(xs):
            return None
    return xs, tuple(p for p in params if p in ys)


def candidates(
    domain: S.Domain, problem: S.Problem
) -> dict[str, tuple[S.Atom, tuple[str, ...], tuple[str, ...]]]:
    """Action name -> ``(key atom, X, Y)`` for each action that may be split."""
    reads: Counter[str] = Counter()
    changed: set[str] = set()
    for action in domain.actions:
        reads.update(a.pred for a in atoms(action.precondition))
        changed.update(a.pred for a in changed_atoms(action.effect))
        reads.update(a.pred for a in atoms(action.effect) if a not in changed_atoms(action.effect))
    for axiom in domain.axioms:
        changed.add(axiom.name)
        reads.update(a.pred for a in atoms(axiom.body))
    reads.update(a.pred for a in atoms(problem.goal))
    out = {}
    for action in domain.actions:
        for c in S.conjuncts(action.precondition):
            if isinstance(c, S.Atom) and c.pred not in changed and reads[c.pred] == 1:
                split = _split_of(action, c)
                if split is not None:
                    out[action.name] = (c, *split)
                    break
    return out


def _bind(key: S.Atom, fact: S.Atom) -> dict[str, str] | None:
    binding: dict[str, str] = {}
    for t, v in zip(key.args, fact.args):
        if isinstance(t, S.Var):
            if binding.setdefault(t.name, v.name) != v.name:
                return None
        elif t.name != v.name:
            return None
    return binding


def _classes(rows: dict[tuple, set[tuple]]) -> list[tuple[list[tuple], frozenset[tuple]]]:
    """First halves grouped behind hubs: ``[(xs, ys)]``, each x having every y of its hub.

    The second halves more than one first half has are the hubs' material (a real trajectory
    belongs to one pair); the largest group of first halves with the same such set becomes a
    hub, and every first half that has all of that set joins it."""
    seen: Counter[tuple] = Counter(y for ys in rows.values() for y in ys)
    core = {x: frozenset(y for y in ys if seen[y] > 1) for x, ys in rows.items()}
    left = dict(core)
    out = []
    while left:
        groups: dict[frozenset, list] = {}
        for x, ys in left.items():
            groups.setdefault(ys, []).append(x)
        ys, xs = max(groups.items(), key=lambda kv: (len(kv[0]) * len(kv[1]), len(kv[0])))
        members = [x for x in left if ys <= left[x]]
        if len(members) * len(ys) <= len(members) + len(ys) + 1:
            break
        out.append((members, ys))
        for x in members:
            del left[x]
    return out


def route_through_hubs(domain: S.Domain, problem: S.Problem) -> Hubs:
    """The task with each action over many pairs split through hubs (see the module's
    docstring), or the task as it was."""
    if domain.durative_actions or problem.goal is None:
        return Hubs(domain, problem)
    keys = candidates(domain, problem)
    if not keys:
        return Hubs(domain, problem)
    facts: dict[str, list[S.Atom]] = {name: [] for name in keys}
    by_pred = {key.pred: name for name, (key, _, _) in keys.items()}
    for f in problem.init:
        if isinstance(f, S.Atom) and f.pred in by_pred:
            facts[by_pred[f.pred]].append(f)
    keys = {n: k for n, k in keys.items() if len(facts[n]) >= MIN_PAIRS}
    if not keys:
        return Hubs(domain, problem)

    taken = {o.name for o in (*problem.objects, *domain.constants)}
    taken |= {p.name for p in domain.predicates} | {a.name for a in domain.actions}
    taken |= {a.name for a in domain.axioms}
    idle = _fresh(IDLE, taken)
    split: dict = {}
    new_actions: list[S.Action] = []
    new_preds: list[S.PredicateDecl] = []
    new_objects: list[S.Typed] = []
    removed: set[S.Atom] = set()
    added: list[S.Atom] = []
    total = 0
    by_name = {a.name: a for a in domain.actions}
    for name, (key, xs, ys) in keys.items():
        action = by_name[name]
        rows: dict[tuple, set[tuple]] = {}
        tuples: dict[tuple[tuple, tuple], S.Atom] = {}
        for f in facts[name]:
            b = _bind(key, f)
            if b is None:
                continue
            x, y = tuple(b[p] for p in xs), tuple(b[p] for p in ys)
            rows.setdefault(x, set()).add(y)
            tuples[(x, y)] = f
        classes = _classes(rows)
        if not classes:
            continue
        out_name, in_name = _fresh(f"{name}-hub-out", taken), _fresh(f"{name}-hub-in", taken)
        from_p, to_p = _fresh(f"{name}-hub-from", taken), _fresh(f"{name}-hub-to", taken)
        at_p = _fresh(f"{name}-hub-at", taken)
        hub_var = _fresh("?hub", set(S.names(action.parameters)))
        h = S.Var(hub_var)
        typed = {p.name: p for p in action.parameters}
        for members, seconds in classes:
            hub = _fresh(f"hub{len(new_objects) + 1}", taken)
            new_objects.append(S.Typed(hub, None))
            c = S.const(hub)
            for x in members:
                added.append(S.Atom(from_p, (c, *map(S.const, x))))
                for y in seconds:
                    removed.add(tuples[(x, y)])
                    total += 1
            for y in seconds:
                added.append(S.Atom(to_p, (c, *map(S.const, y))))
        x_vars = tuple(S.Var(p) for p in xs)
        y_vars = tuple(S.Var(p) for p in ys)
        rest = tuple(c for c in S.conjuncts(action.precondition) if c is not key)
        effects = S.conjuncts(action.effect)
        y_set = set(ys)
        firsts = tuple(e for e in effects if not (_var_names(e) & y_set))
        seconds_eff = tuple(e for e in effects if _var_names(e) & y_set)
        idle_atom = S.Atom(idle, ())
        new_actions.append(
            S.Action(
                out_name,
                (S.Typed(hub_var, None), *(typed[p] for p in xs)),
                S.And((idle_atom, S.Atom(from_p, (h, *x_vars)), *rest)),
                S.And((S.Not(idle_atom), S.Atom(at_p, (h,)), *firsts)),
            )
        )
        new_actions.append(
            S.Action(
                in_name,
                (S.Typed(hub_var, None), *(typed[p] for p in ys)),
                S.And((S.Atom(at_p, (h,)), S.Atom(to_p, (h, *y_vars)))),
                S.And((S.Not(S.Atom(at_p, (h,))), idle_atom, *seconds_eff)),
            )
        )
        new_preds += [
            S.PredicateDecl(from_p, (S.Typed("?h", None), *(typed[p] for p in xs))),
            S.PredicateDecl(to_p, (S.Typed("?h", None), *(typed[p] for p in ys))),
            S.PredicateDecl(at_p, (S.Typed("?h", None),)),
        ]
        split[name] = (out_name, in_name, S.names(action.parameters), xs, ys)
    if not split:
        return Hubs(domain, problem)
    idle_atom = S.Atom(idle, ())
    actions = tuple(
        replace(a, precondition=S.And((idle_atom, *S.conjuncts(a.precondition))))
        for a in domain.actions
    )
    domain = replace(
        domain,
        predicates=(*domain.predicates, S.PredicateDecl(idle, ()), *new_preds),
        actions=(*actions, *new_actions),
    )
    problem = replace(
        problem,
        objects=(*problem.objects, *new_objects),
        init=(*(f for f in problem.init if f not in removed), idle_atom, *added),
        goal=S.And((idle_atom, *S.conjuncts(problem.goal))),
    )
    return Hubs(domain, problem, split, total, len(new_objects))
