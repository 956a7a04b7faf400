"""Compile pass — plan constraints (paper §VI-A, Algorithm 2 ``ConstrainPlan``).

Given the unexecuted tail of the last plan and which of its argument values are *constants*
(objects, grasps: values still meaningful after new observations), build a domain whose only
actions are one copy per plan step, so the next plan keeps the old plan's structure:

* step ``i`` requires ``(applied-(i-1))``, deletes it and adds ``(applied-i)`` (a chain: each
  step is applied exactly once, in order; ``(applied-0)`` holds initially).  The paper only
  needs the order; deleting the previous marker also forbids repeating a step, which a
  planner's search would otherwise explore: on a kitchen replan with six free base motions
  the search ran past 60 s where the chain takes 23 expansions;
* a constant argument ``v`` at parameter ``?p`` is substituted for ``?p``, which the step no
  longer takes (the paper's ``(= ?p v)``; a translator explores an equality over every object:
  on a Swap replan's tail of 25 steps, substituting cut Fast Downward's translation by a
  seventh with the same plans); the map back puts ``v`` in again;
* any other value ``v`` becomes a free-variable object ``@v`` (here ``free-k``).  The steps
  are totally ordered, so the first step that uses ``v`` is known when compiling: it binds
  ``v`` (adds ``(assigned v ?p)``; a second parameter ``?q`` of the same step with value ``v``
  becomes ``?p``), and every later use requires ``(assigned v ?p)``.  Every use of one free
  variable therefore takes the same new value.  The paper's guard ``(imply (bound v)
  (assigned v ?p))`` is equivalent under the total order, but a planner's translator splits
  each such disjunction into two copies of the action, and a step with three of them grounds
  eight times over (the kitchen's constrained replans: 35,632 operators where 676 do);
  a positive precondition also lets the translator ground the step from the bound value only;
* the goal gains ``(applied-|a|)``;
* a free variable that can take one value only (below) is that value: substituted like a
  constant, with no ``assigned`` or ``ssr-may`` fact (on a Swap replan, 30 of 41 free
  variables; the translator's time on the constrained tasks fell by a further sixth);
* a free variable's binding step also requires ``(ssr-may v ?p)``, a static fact the initial
  state states for each value ``v`` can still take (:func:`free_domains`), when that is fewer
  than all objects.  A planner's translator grounds every step over every value its relaxed
  reachability allows, and the chain's order is lost there: each base motion of a kitchen
  tail was grounded over all 22 x 22 base configurations (six of them, 2,904 of 3,860
  operators, 2 s of translation) where the plan tail admits a handful.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

from .. import syntax as S
from ..errors import UnsupportedError
from ..formulas import changed_atoms
from .formulas import conj, substitute
from .result import PassResult

Plan = list[tuple[str, tuple[str, ...]]]

ASSIGNED = "ssr-assigned"
MAY = "ssr-may"


def applied(i: int) -> S.Atom:
    return S.Atom(f"ssr-applied-{i}")


def is_chained(domain: S.Domain) -> bool:
    """Is ``domain`` (or what a later pass made of it, the grounding pass's ``NAME-N`` atoms
    included) constrained to a plan's steps?"""
    first = applied(0).pred
    prefix = first + "-"
    return any(
        p.name == first or (p.name.startswith(prefix) and p.name[len(prefix) :].isdigit())
        for p in domain.predicates
    )


@dataclass
class Constrained(PassResult):
    """The constraints pass's result (:func:`constrain_plan`): its map back names each step
    copy by its action."""

    # new action name -> (original action name, step index)
    steps: dict[str, tuple[str, int]] = field(default_factory=dict)
    # free-variable object -> the value it stood for in the old plan
    free: dict[str, str] = field(default_factory=dict)
    # the tail's values that no value of this problem fits (each in the old plan's name):
    # their free variables' domains (:func:`free_domains`) are empty, so no plan follows the
    # tail here and a planner need not be asked
    unfit: tuple[str, ...] = ()
    # new action name -> per original parameter, the index of the step's parameter that
    # carries it (an int) or the constant substituted for it (a str)
    arguments: dict[str, tuple[int | str, ...]] = field(default_factory=dict)

    def map_plan(self, plan: Plan) -> Plan:
        """A plan of the constrained problem in the original action names and arguments."""
        out = []
        for name, args in plan:
            template = self.arguments.get(name)
            if template is not None:
                args = tuple(args[t] if isinstance(t, int) else t for t in template)
            out.append((self.steps.get(name, (name, 0))[0], tuple(args)))
        return out


def constrain_plan(
    domain: S.Domain,
    problem: S.Problem,
    tail: Sequence[tuple[str, Sequence[str]]],
    is_constant: Callable[[str], bool],
) -> Constrained:
    """Algorithm 2: the constrained domain and problem for the plan ``tail``."""
    if not tail:
        raise ValueError("constrain_plan needs a non-empty plan tail")
    schemas = {a.name: a for a in domain.actions}
    free: dict[str, str] = {}  # old value -> free-variable object
    # per step: the schema, each parameter's term (a constant or a free-variable object), the
    # free variables the step binds (-> the parameter binding it) and the parameters that
    # repeat a free variable the step binds (-> that parameter)
    terms: list[tuple[S.Action, dict[str, str], dict[str, str], dict[str, str]]] = []
    for i, (name, args) in enumerate(tail, start=1):
        schema = schemas.get(name)
        if schema is None:
            raise UnsupportedError(
                f"plan step {i} uses action '{name}', which the domain does not define"
            )
        if len(args) != len(schema.parameters):
            raise UnsupportedError(
                f"plan step {i}: '{name}' takes {len(schema.parameters)} arguments, got {len(args)}"
            )
        term: dict[str, str] = {}
        binds: dict[str, str] = {}
        repeats: dict[str, str] = {}
        for value, param in zip(args, schema.parameters):
            if is_constant(value):
                term[param.name] = value
                continue
            if value not in free:
                free[value] = f"free-{len(free) + 1}"
                binds[free[value]] = param.name
            elif free[value] in binds:
                repeats[param.name] = binds[free[value]]
            term[param.name] = free[value]
        terms.append((schema, term, binds, repeats))
    free_vars = set(free.values())
    domains = free_domains(domain, problem, [(s, t) for s, t, _, _ in terms], free_vars)
    # A free variable that can take one value only is that value: substituted like a constant.
    single = {v: next(iter(d)) for v, d in domains.items() if d is not None and len(d) == 1}
    actions: list[S.Action] = []
    steps: dict[str, tuple[str, int]] = {}
    arguments: dict[str, tuple[int | str, ...]] = {}
    may: list[S.Atom] = []
    for i, (schema, term, binds, repeats) in enumerate(terms, start=1):
        pre: list[S.Formula] = [applied(i - 1)]
        eff: list[S.Formula] = [applied(i), S.Not(applied(i - 1))]
        sub: dict[str, S.Term] = {}  # parameters the step no longer takes -> what replaces them
        for param in schema.parameters:
            p, t = param.name, term[param.name]
            if t not in free_vars:
                sub[p] = S.Const(t)
            elif t in single:
                sub[p] = S.Const(single[t])
            elif p in repeats:
                sub[p] = S.Var(repeats[p])
            elif binds.get(t) == p:
                eff.append(S.Atom(ASSIGNED, (S.Const(t), S.Var(p))))
                if domains.get(t) is not None:
                    pre.append(S.Atom(MAY, (S.Const(t), S.Var(p))))
                    may += [S.Atom(MAY, (S.Const(t), S.Const(x))) for x in sorted(domains[t])]
            else:
                pre.append(S.Atom(ASSIGNED, (S.Const(t), S.Var(p))))
        new_name = f"{schema.name}-step{i}"
        steps[new_name] = (schema.name, i)
        kept = [p for p in schema.parameters if p.name not in sub]
        position = {p.name: k for k, p in enumerate(kept)}
        arguments[new_name] = tuple(
            sub[p.name].name
            if isinstance(sub.get(p.name), S.Const)
            else position[sub[p.name].name if p.name in sub else p.name]
            for p in schema.parameters
        )
        actions.append(
            replace(
                schema,
                name=new_name,
                parameters=tuple(kept),
                precondition=substitute(conj(schema.precondition, *pre), sub),
                effect=substitute(conj(schema.effect, *eff), sub),
            )
        )
    n = len(tail)
    predicates = list(domain.predicates) + [
        S.PredicateDecl(ASSIGNED, (S.Typed("?v"), S.Typed("?x"))),
        S.PredicateDecl(MAY, (S.Typed("?v"), S.Typed("?x"))),
    ]
    predicates += [S.PredicateDecl(applied(i).pred) for i in range(0, n + 1)]
    new_domain = replace(domain, actions=tuple(actions), predicates=tuple(predicates))
    # The values substituted into the steps must be domain constants: a domain may only
    # mention objects it declares (Fast Downward's translator refuses others).
    used = {value for name, args in tail for value in args if is_constant(value)}
    used |= set(single.values())
    known = {c.name for c in domain.constants}
    moved = tuple(o for o in problem.objects if o.name in used and o.name not in known)
    missing = used - known - {o.name for o in moved}
    # The free-variable objects the steps still name.
    free_objects = tuple(S.Typed(v) for v in free.values() if v not in single)
    constants = domain.constants + moved + tuple(S.Typed(v) for v in sorted(missing)) + free_objects
    new_domain = replace(new_domain, constants=constants)
    kept = tuple(o for o in problem.objects if o.name not in used)
    new_problem = replace(
        problem,
        objects=kept,
        init=problem.init + tuple(may) + (applied(0),),
        goal=conj(problem.goal, applied(n)),
    )
    unfit = tuple(old for old, v in free.items() if domains.get(v) is not None and not domains[v])
    return Constrained(
        new_domain,
        new_problem,
        steps=steps,
        free={v: k for k, v in free.items()},
        arguments=arguments,
        unfit=unfit,
    )


def _adds(effect, bound: frozenset[str] = frozenset()):
    """The atoms an effect may add, each with the variables a ``forall`` quantifies in it."""
    if isinstance(effect, S.Atom):
        yield effect, bound
    elif isinstance(effect, S.And):
        for e in effect.args:
            yield from _adds(e, bound)
    elif isinstance(effect, S.When):
        yield from _adds(effect.effect, bound)
    elif isinstance(effect, S.Forall):
        yield from _adds(effect.body, bound | {p.name for p in effect.params})


# An argument of a step's atom: ("c", constant), ("v", free-variable object) or ("*", "") for
# anything (a quantified variable of an effect).
Arg = tuple[str, str]


def free_domains(
    domain: S.Domain,
    problem: S.Problem,
    steps: Sequence[tuple[S.Action, dict[str, str]]],
    free_vars: set[str],
) -> dict[str, set[str] | None]:
    """The values each free variable of a plan tail can take in a plan that follows the tail
    (``None``: not narrowed), as a fixpoint over the steps' preconditions:

    * a static atom (no action changes it, no axiom derives it) holds in the initial state;
    * a fluent atom holds in the initial state or is added by an earlier step (the steps are
      totally ordered; deletions are ignored, which only keeps more values).

    Each free variable in such an atom keeps the values of the facts that match the atom's
    other arguments.  ``steps`` gives each step's schema and each parameter's term: a constant
    or one of the free-variable objects ``free_vars``."""
    derived = {ax.name for ax in domain.axioms}
    fluent = {a.pred for action in domain.actions for a in changed_atoms(action.effect)}
    facts: dict[str, list[tuple[str, ...]]] = {}
    for f in problem.init:
        if isinstance(f, S.Atom):
            facts.setdefault(f.pred, []).append(tuple(a.name for a in f.args))

    def arg_of(t, term: dict[str, str], bound=frozenset()) -> Arg:
        if isinstance(t, S.Var):
            if t.name in bound or t.name not in term:
                return ("*", "")
            value = term[t.name]
            return ("v", value) if value in free_vars else ("c", value)
        return ("c", t.name)

    # (step index, predicate, arguments) for every precondition atom; the adds likewise
    needs: list[tuple[int, str, tuple[Arg, ...]]] = []
    adds: list[tuple[int, str, tuple[Arg, ...]]] = []
    for i, (schema, term) in enumerate(steps):
        for a in S.conjuncts(schema.precondition):
            if isinstance(a, S.Atom) and a.pred != "=" and a.pred not in derived:
                needs.append((i, a.pred, tuple(arg_of(t, term) for t in a.args)))
        for a, bound in _adds(schema.effect):
            adds.append((i, a.pred, tuple(arg_of(t, term, bound) for t in a.args)))
    dom: dict[str, set[str] | None] = dict.fromkeys(free_vars)

    def fits(arg: Arg, value: str) -> bool:
        kind, x = arg
        if kind == "c":
            return value == x
        if kind == "v":
            d = dom[x]
            return d is None or value in d
        return True

    def values(arg: Arg) -> set[str] | None:
        kind, x = arg
        if kind == "c":
            return {x}
        return dom[x] if kind == "v" else None

    # Only atoms with a free variable narrow anything; the candidate facts of each, with the
    # constants already matched.
    work = []
    for i, pred, args in needs:
        if not any(k == "v" for k, _ in args):
            continue
        rows = [r for r in facts.get(pred, ()) if len(r) == len(args)]
        rows = [r for r in rows if all(k != "c" or r[j] == x for j, (k, x) in enumerate(args))]
        earlier = [a for j, p, a in adds if p == pred and j < i and len(a) == len(args)]
        if pred not in fluent:
            earlier = []
        work.append((args, rows, earlier))
    changed = True
    while changed:
        changed = False
        for args, rows, earlier in work:
            live = [r for r in rows if all(fits(a, x) for a, x in zip(args, r))]
            for j, (kind, v) in enumerate(args):
                if kind != "v":
                    continue
                keep: set[str] | None = {r[j] for r in live}
                for other in earlier:
                    if not all(
                        values(o) is None or values(a) is None or values(o) & values(a)
                        for q, (a, o) in enumerate(zip(args, other))
                        if q != j
                    ):
                        continue
                    more = values(other[j])
                    if more is None:
                        keep = None
                        break
                    keep |= more
                if keep is None:
                    continue
                old = dom[v]
                new = keep if old is None else old & keep
                if old is None or new != old:
                    dom[v] = new
                    changed = True
    return dom
