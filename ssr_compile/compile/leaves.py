"""Compile pass — one optimistic object for all the *leaf* outputs of a stream.

Some stream outputs are leaves: no stream takes them as input, and each instance's certified
facts name its inputs beside them.  A motion planner's trajectory is the typical one:
``plan-base-motion(?q1, ?q2)`` certifies ``(motion base ?q1 ?t ?q2)``, and the fact already
tells the pair apart without ``?t``.  The optimistic instantiation still makes one fresh ``?t``
per pair of base configurations, quadratic in the configurations; on the kitchen's Cook replans
they were 3,844 of 4,225 objects, and Fast Downward's translator spent two thirds of its time
on them (1.31 s against 0.47 s for the same task with one shared trajectory object, the same
4,400 ground actions).

This pass gives every optimistic leaf output of a stream one shared object (``opt-<stream>-<var>``)
in the planner's task; the plan maps back to the per-instance objects through the *key fact*:
the certified fact that names all the stream's inputs and the leaf, which the action using the
leaf requires as a plain positive conjunct of its precondition.  So everything the solver
reads (the instantiation, the stream plan, the preimage) stays as it was.

A stream output is a leaf when

- no stream, rule or function domain of the stream file names a predicate it certifies with
  the output in it (nothing can consume it), and neither do the domain's axioms, the goal,
  action effects or a function value of the initial state;
- at least one of those facts names every input of the stream (the key), and actions use the
  key predicates only as positive top-level conjuncts of their preconditions; the output's
  other facts (``(traj base ?t)``) are read by no action at all.

One thing is looser than before: a plan tail that used one optimistic trajectory in two steps
(an arm motion out and back) constrains the next plan to use *a* shared trajectory in both,
not necessarily the same instance's; each step still has its own certified motion.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace

from .. import syntax as S
from ..errors import SSRError
from ..formulas import atoms
from .instantiate import Instantiation
from .result import PassResult, Plan

SHARED_PREFIX = "opt-"


@dataclass
class SharedLeaves(PassResult):
    """The pass's result: which objects were merged, and how to tell them apart again."""

    # shared object -> its originals (for the record and the tests)
    merged: dict[str, list[str]] = field(default_factory=dict)
    # (predicate, arguments with shared objects) -> the same fact's original arguments
    keys: dict[tuple[str, tuple[str, ...]], tuple[str, ...]] = field(default_factory=dict)
    # action name -> its parameters, and per parameter index the key atoms naming it
    params: dict[str, tuple[str, ...]] = field(default_factory=dict)
    uses: dict[str, list[tuple[int, list[S.Atom]]]] = field(default_factory=dict)

    def map_plan(self, plan: Sequence[tuple[str, Sequence[str]]]) -> Plan:
        out: Plan = []
        for name, args in plan:
            args = tuple(args)
            if not any(a in self.merged for a in args):
                out.append((name, args))
                continue
            binding = dict(zip(self.params.get(name, ()), args))
            fixed = list(args)
            for i, key_atoms in self.uses.get(name, ()):
                if args[i] not in self.merged:
                    continue
                param = self.params[name][i]
                for atom in key_atoms:
                    ground = tuple(
                        binding.get(t.name, t.name) if isinstance(t, S.Var) else t.name
                        for t in atom.args
                    )
                    original = self.keys.get((atom.pred, ground))
                    if original is not None:
                        j = next(k for k, t in enumerate(atom.args) if t.name == param)
                        fixed[i] = original[j]
                        break
            if any(a in self.merged for a in fixed):
                raise SSRError(
                    f"internal error: the plan step ({name} {' '.join(args)}) uses a shared "
                    "optimistic object that no certified fact of the step identifies"
                )
            out.append((name, tuple(fixed)))
        return out


def _used_predicates(streams: S.StreamFile) -> set[str]:
    """Predicates a stream, rule or function of the stream file reads."""
    used: set[str] = set()
    for block in (*streams.streams, *streams.functions, *streams.predicates, *streams.rules):
        used.update(a.pred for a in atoms(block.domain))
    return used


def _action_use(domain: S.Domain) -> tuple[dict[str, list[tuple[str, S.Atom]]], set[str]]:
    """Per predicate, the (action, atom) pairs where it is a positive top-level precondition
    conjunct; and the predicates used anywhere else in the domain (effects, axioms, nested or
    negated conditions)."""
    top: dict[str, list[tuple[str, S.Atom]]] = {}
    elsewhere: set[str] = set()
    for action in domain.actions:
        for c in S.conjuncts(action.precondition):
            if isinstance(c, S.Atom):
                top.setdefault(c.pred, []).append((action.name, c))
            else:
                elsewhere.update(a.pred for a in atoms(c))
        elsewhere.update(a.pred for a in atoms(action.effect))
    for axiom in domain.axioms:
        elsewhere.add(axiom.name)
        elsewhere.update(a.pred for a in atoms(axiom.body))
    return top, elsewhere


def leaf_outputs(
    domain: S.Domain, problem: S.Problem, streams: S.StreamFile
) -> dict[tuple[str, str], list[S.Atom]]:
    """``(stream, output variable) -> its key atoms`` (over the stream's variables) for every
    leaf output (see the module's docstring)."""
    consumed = _used_predicates(streams)
    top, elsewhere = _action_use(domain)
    elsewhere |= {a.pred for a in atoms(problem.goal)}
    out: dict[tuple[str, str], list[S.Atom]] = {}
    for stream in streams.streams:
        inputs = {i.name for i in stream.inputs}
        certified = [a for a in S.conjuncts(stream.certified) if isinstance(a, S.Atom)]
        for o in stream.outputs:
            mine = [a for a in certified if any(t.name == o.name for t in a.args)]
            keys, ok = [], bool(mine)
            for a in mine:
                if a.pred in consumed or a.pred in elsewhere:
                    ok = False
                elif inputs <= {t.name for t in a.args}:
                    keys.append(a)
                elif a.pred in top:
                    ok = False  # an action reads it without the inputs to tell instances apart
            if ok and keys:
                out[(stream.name, o.name)] = keys
    return out


def share_leaves(
    domain: S.Domain, problem: S.Problem, streams: S.StreamFile, inst: Instantiation
) -> SharedLeaves:
    """The task with one object per leaf output of a stream (optimistic instances only)."""
    leaves = leaf_outputs(domain, problem, streams)
    if not leaves:
        return SharedLeaves(domain, problem)
    by_stream = {s.name: s for s in streams.streams}
    valued = {t.name for v in problem.init if isinstance(v, S.InitValue) for t in v.fluent.args}
    types = {o.name: o.type for o in problem.objects}
    taken = set(types) | {c.name for c in domain.constants}
    shared_of: dict[tuple[str, str], str] = {}
    alias: dict[str, str] = {}
    merged: dict[str, list[str]] = {}
    keys: dict[tuple[str, tuple[str, ...]], tuple[str, ...]] = {}
    key_preds: set[str] = set()
    for res in inst.results:
        stream = by_stream.get(res.instance.stream)
        if not res.optimistic or stream is None:
            continue
        mine = {}
        for var, name in zip(stream.outputs, res.outputs):
            if (stream.name, var.name) in leaves and name not in valued and name in types:
                shared = shared_of.get((stream.name, var.name))
                if shared is None:
                    shared = f"{SHARED_PREFIX}{stream.name}-{var.name.lstrip('?')}"
                    while shared in taken:
                        shared += "_"
                    taken.add(shared)
                    shared_of[(stream.name, var.name)] = shared
                mine[var.name] = (name, shared)
        if not mine:
            continue
        original = dict(zip((i.name for i in stream.inputs), res.instance.inputs))
        original.update(zip((x.name for x in stream.outputs), res.outputs))
        entries = []
        for var in mine:
            for a in leaves[(stream.name, var)]:
                before = tuple(original.get(t.name, t.name) for t in a.args)
                after = tuple(
                    mine[t.name][1] if t.name in mine else original.get(t.name, t.name)
                    for t in a.args
                )
                entries.append(((a.pred, after), before))
        if any(keys.get(k, v) != v for k, v in entries):
            continue  # two instances would certify the same shared fact: keep this one apart
        for var, (name, shared) in mine.items():
            alias[name] = shared
            merged.setdefault(shared, []).append(name)
            key_preds.update(a.pred for a in leaves[(stream.name, var)])
        keys.update(entries)
    if not alias:
        return SharedLeaves(domain, problem)

    def rename(fact):
        if isinstance(fact, S.Atom) and any(t.name in alias for t in fact.args):
            return S.Atom(fact.pred, tuple(S.const(alias.get(t.name, t.name)) for t in fact.args))
        return fact

    init = tuple(dict.fromkeys(rename(f) for f in problem.init))
    objects = [o for o in problem.objects if o.name not in alias]
    objects += [S.Typed(shared, types[names[0]]) for shared, names in merged.items()]
    top, _ = _action_use(domain)
    params: dict[str, tuple[str, ...]] = {}
    uses: dict[str, list[tuple[int, list[S.Atom]]]] = {}
    for action in domain.actions:
        names = tuple(p.name for p in action.parameters)
        params[action.name] = names
        key_atoms = [
            c for pred in sorted(key_preds) for a, c in top.get(pred, ()) if a == action.name
        ]
        for i, p in enumerate(names):
            naming = [c for c in key_atoms if any(t.name == p for t in c.args)]
            if naming:
                uses.setdefault(action.name, []).append((i, naming))
    return SharedLeaves(
        domain,
        replace(problem, objects=tuple(objects), init=init),
        merged,
        keys,
        params,
        uses,
    )
