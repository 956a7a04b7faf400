"""Which instances of a leaf test the domain can read (issue 40).

A pairwise test such as the kitchen's ``test-cfree ?o ?pb ?o2 ?pb2`` is instantiated over every
pair of beliefs, the pairs of an object with itself included; but the domain reads its fact
only next to ``(not (= ?o ?o2))``:

    (exists (?o2 ?pb2) (and (poseb ?o ?pb) (atposeb ?o2 ?pb2) (not (= ?o ?o2))
                            (not (cfree ?o ?pb ?o2 ?pb2))))

so a fact with ``?o`` equal to ``?o2`` changes no conjunction it appears in.  :func:`distinct_inputs`
finds, for each test, the pairs of inputs that must differ for any of its facts to be read: those
that every occurrence of every certified predicate (in an action, an effect's condition, an axiom
or the goal) has in an inequality conjunct of the same conjunction.  Optimistic instantiation
skips the other instances (on the kitchen of 8 objects at level 4, 1,239 of 9,292 test-cfree and
264 of 1,900 test-vis instances).
"""

from __future__ import annotations

from collections.abc import Iterable

from .. import syntax as S

Pairs = frozenset[tuple[int, int]]


def distinct_inputs(
    domain: S.Domain, problem: S.Problem, tests: Iterable[S.Stream]
) -> dict[str, tuple[tuple[str, str], ...]]:
    """Test name -> the pairs of its input variables whose values must differ for a fact it
    certifies to be read (tests with none are absent)."""
    tests = list(tests)
    wanted = {a.pred for t in tests for a in S.conjuncts(t.certified) if isinstance(a, S.Atom)}
    found: dict[str, Pairs] = {}
    roots: list[S.Formula | None] = [problem.goal]
    for a in domain.actions:
        roots += [a.precondition, a.effect]
    for da in domain.durative_actions:
        roots += [da.condition, da.effect]
    roots += [ax.body for ax in domain.axioms]
    for root in roots:
        _visit(root, (), wanted, found)
    out: dict[str, tuple[tuple[str, str], ...]] = {}
    for t in tests:
        certified = [a for a in S.conjuncts(t.certified) if isinstance(a, S.Atom)]
        if not certified or len(certified) != len(S.conjuncts(t.certified)):
            continue
        common: set[tuple[str, str]] | None = None
        for atom in certified:
            pairs = set()
            for i, j in found.get(atom.pred, frozenset()):
                x, y = atom.args[i], atom.args[j]
                if isinstance(x, S.Var) and isinstance(y, S.Var) and x.name != y.name:
                    pairs.add((x.name, y.name))
            common = pairs if common is None else common & pairs
        if common:
            out[t.name] = tuple(sorted(common))
    return out


def _visit(f, siblings: tuple, wanted: set[str], found: dict[str, Pairs]) -> None:
    """Record, for each occurrence of a ``wanted`` predicate under ``f``, the pairs of its
    argument positions that an inequality among its conjunction's ``siblings`` separates (an
    occurrence anywhere else: no pair)."""
    if f is None:
        return
    if isinstance(f, S.And):
        parts = S.conjuncts(f)
        for part in parts:
            _visit(part, parts, wanted, found)
        return
    atom = f.arg if isinstance(f, S.Not) and isinstance(f.arg, S.Atom) else f
    if isinstance(atom, S.Atom):
        if atom.pred in wanted:
            pairs = _separated(atom, siblings)
            found[atom.pred] = found[atom.pred] & pairs if atom.pred in found else pairs
        return
    for child in S.children(f):  # a new context: no siblings
        _visit(child, (), wanted, found)


def _separated(atom: S.Atom, siblings: tuple) -> Pairs:
    """The argument positions (i, j) of ``atom`` holding two variables that a sibling
    ``(not (= x y))`` keeps apart."""
    apart = set()
    for s in siblings:
        if isinstance(s, S.Not) and isinstance(s.arg, S.Atom) and s.arg.pred == "=":
            x, y = s.arg.args
            if isinstance(x, S.Var) and isinstance(y, S.Var):
                apart.add(frozenset((x.name, y.name)))
    args = atom.args
    return frozenset(
        (i, j)
        for i in range(len(args))
        for j in range(i + 1, len(args))
        if isinstance(args[i], S.Var)
        and isinstance(args[j], S.Var)
        and frozenset((args[i].name, args[j].name)) in apart
    )
