"""Joins of conjunctive stream domains over a growing set of facts: the one matcher of
optimistic instantiation, of ``:rule`` blocks, of cost-function terms and of the solver's
eager evaluation.

:class:`FactIndex` keeps the facts by predicate in the order they came, and, for the argument
positions a join has asked about, by the object at that position.  A join binds an atom whose
arguments are partly known by walking only the facts with those objects there: the same
facts, in the same order, as walking them all and discarding those that do not match, so the
bindings come in the same order whichever index is given.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Iterable

from .. import syntax as S
from ..errors import UnsupportedError
from ..formulas import unify

# A predicate with fewer facts is walked whole (looking up a narrower list costs more)
BUCKET_MIN = 8


class FactIndex(defaultdict):
    """``predicate -> facts`` in the order they were added (:meth:`add`), and on demand the
    facts of a predicate with a given object at a given argument position (:meth:`having`).
    Add facts through :meth:`add` only: a list appended to directly leaves the positions
    behind."""

    def __init__(self) -> None:
        super().__init__(list)
        # (predicate, position) -> object -> facts, for the positions asked about
        self.positions: dict[tuple[str, int], dict[str, list[S.Atom]]] = {}

    def add(self, atom: S.Atom) -> None:
        self[atom.pred].append(atom)
        for i, t in enumerate(atom.args):
            by_object = self.positions.get((atom.pred, i))
            if by_object is not None:
                by_object.setdefault(t.name, []).append(atom)

    def having(self, pred: str, position: int, name: str) -> list[S.Atom]:
        """The facts of ``pred`` with ``name`` at argument ``position``, in their order."""
        by_object = self.positions.get((pred, position))
        if by_object is None:
            by_object = self.positions[(pred, position)] = {}
            for fact in self.get(pred, ()):
                if position < len(fact.args):
                    by_object.setdefault(fact.args[position].name, []).append(fact)
        return by_object.get(name, [])


def _matches(params, domain, index, levels, fresh=None):
    """All bindings of ``params`` under which every atom of the conjunctive ``domain`` holds.

    Yields ``(binding, facts)``.  Equality atoms compare the bound names.  Parameters that
    no atom mentions cannot be bound and give no match (as in PDDLStream).  With ``fresh``
    (a list of facts, or such lists by predicate), only the bindings that use at least one of
    them (a binding may come more than once: the callers skip instances already seen).  With
    a :class:`FactIndex`, an atom with arguments already bound walks only the facts that
    have those objects there.
    """
    atoms = [a for a in S.conjuncts(domain)]
    for a in atoms:
        if not isinstance(a, S.Atom):
            raise UnsupportedError(
                f"stream domains must be conjunctions of atoms; found {type(a).__name__.lower()}",
                line=getattr(a.span, "line", None),
                col=getattr(a.span, "col", None),
            )
    positive = [a for a in atoms if a.pred != "="]
    equalities = [a for a in atoms if a.pred == "="]
    names = [p.name for p in params]
    indexed = isinstance(index, FactIndex)

    def candidates(pattern: S.Atom, binding) -> list[S.Atom]:
        facts = index.get(pattern.pred, ())
        if not indexed or len(facts) < BUCKET_MIN:
            return facts
        for j, t in enumerate(pattern.args):
            name = binding.get(t.name) if isinstance(t, S.Var) else t.name
            if name is not None:
                narrower = index.having(pattern.pred, j, name)
                if len(narrower) < len(facts):
                    facts = narrower
        return facts

    def extend(order, i: int, binding: dict[str, str], used: list[S.Atom]):
        if i == len(order):
            if all(n in binding for n in names) and all(_eq_holds(e, binding) for e in equalities):
                yield dict(binding), list(used)
            return
        pattern = order[i]
        for fact in list(candidates(pattern, binding)):
            new = unify(pattern, fact, binding)
            if new is not None:
                used.append(fact)
                yield from extend(order, i + 1, new, used)
                used.pop()

    # Most selective atoms first; facts are yielded in this order.
    order = sorted(positive, key=lambda a: len(index.get(a.pred, ())))
    if fresh is None:
        yield from extend(order, 0, {}, [])
        return
    by_pred = fresh if isinstance(fresh, dict) else facts_by_predicate(fresh)
    for k, pivot in enumerate(order):
        rest = order[:k] + order[k + 1 :]
        for fact in by_pred.get(pivot.pred, ()):
            start = unify(pivot, fact, {})
            if start is None:
                continue
            for binding, used in extend(rest, 0, start, []):
                used.insert(k, fact)
                yield binding, used


def facts_by_predicate(facts: Iterable[S.Atom]) -> dict[str, list[S.Atom]]:
    """``facts`` by predicate, in their order (the ``fresh`` of :func:`_matches`, sorted once
    for all the joins of a depth: sorted per join, it was a third of instantiation's time on
    a cluttered kitchen)."""
    by_pred: dict[str, list[S.Atom]] = defaultdict(list)
    for f in facts:
        by_pred[f.pred].append(f)
    return by_pred


def _eq_holds(atom: S.Atom, binding: dict[str, str]) -> bool:
    left, right = (
        binding.get(t.name, t.name) if isinstance(t, S.Var) else t.name for t in atom.args
    )
    return left == right
