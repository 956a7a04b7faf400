"""Pass 5 — lowering to what a planner backend supports (one module per step: ground,
derived, quantifiers, disjunctions, negations, costs, rename; this one orders them).

A backend states its :class:`~ssr_compile.planners.base.Capabilities` (costs, axioms, negative
preconditions, disjunction, quantifiers, conditional effects); this pass rewrites the plain
domain and problem to fit, and returns a map from a plan of its output back to its input:

* axioms  -> derived predicates inlined (:mod:`.derived`);
* quantifiers -> expanded over the problem's objects (respecting types);
* disjunction / ``imply`` -> each action split into one copy per disjunct of its precondition's
  DNF (``a--1``, ``a--2``...); a disjunctive goal gets one ``ssr-goal--k`` action per disjunct;
* negative preconditions -> complement predicates ``not-p`` kept in step by the effects, and
  equality with constants substituted into the action (its parameter disappears);
* costs -> unit costs (else integer costs, scaled and rounded up, by :mod:`.costs`);
* names -> renamed where a reader would refuse them (an action named like a predicate, ``@x``),
  mapped back by :meth:`Lowered.map_plan`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from .. import syntax as S
from ..errors import UnsupportedError
from .costs import compile_costs
from .derived import compile_away, normalise_axiom_bodies
from .disjunctions import GOAL_ACTION, GOAL_REACHED, split_disjunctions  # noqa: F401
from .formulas import has, map_atoms
from .ground import Grounded, ground
from .negations import DISTINCT, remove_negations  # noqa: F401
from .quantifiers import MAX_EXPANSION, expand_quantifiers, objects_by_type  # noqa: F401
from .rename import Renaming, rename_task

Plan = list[tuple[str, tuple[str, ...]]]


@dataclass
class Lowered:
    domain: S.Domain
    problem: S.Problem
    scale: int
    # lowered action name -> (original name, argument template); a template entry is an int
    # (index into the lowered action's arguments) or a str (a constant substituted in).
    templates: dict[str, tuple[str, tuple[int | str, ...]]]
    # names changed so that every reader accepts them (see :func:`lower`)
    renaming: Renaming | None = None
    # ground action name -> (lifted action, arguments), when the task was grounded
    grounded: Grounded | None = None

    def map_plan(self, plan: Plan) -> Plan:
        out: Plan = []
        if self.renaming:
            plan = self.renaming.plan_back(list(plan))
        for name, args in plan:
            if name.startswith(GOAL_ACTION):
                continue
            original, template = self.templates.get(name, (name, None))
            if template is None:
                out.append((original, tuple(args)))
            else:
                out.append(
                    (original, tuple(args[t] if isinstance(t, int) else t for t in template))
                )
        if self.grounded is not None:
            out = self.grounded.map_plan(out)
        return out


def lower(
    domain: S.Domain,
    problem: S.Problem,
    caps,
    *,
    cost_functions: set[str] = frozenset(),
    scale: int | None = None,
    unit_cost: bool = False,
) -> Lowered:
    """Rewrite ``domain`` and ``problem`` for a backend with capabilities ``caps``."""
    if domain.durative_actions:
        a = domain.durative_actions[0]
        raise UnsupportedError(
            f"durative action '{a.name}': temporal planning is not supported by the classical backends",
            line=a.span.line if a.span else None,
            col=a.span.col if a.span else None,
        )
    domain = normalise_axiom_bodies(domain)
    grounded = None
    if getattr(caps, "ground", False):
        grounded = ground(domain, problem, conditional_effects=caps.conditional_effects)
        domain, problem = grounded.domain, grounded.problem
    if not caps.axioms:
        domain, problem = compile_away(domain, problem)
    if not caps.quantifiers:
        domain, problem = expand_quantifiers(domain, problem)
    templates: dict[str, tuple[str, tuple[int | str, ...]]] = {}
    if not caps.disjunction:
        domain, problem, templates = split_disjunctions(domain, problem)
    if not caps.negative_preconditions:
        domain, problem, templates = remove_negations(domain, problem, templates)
    if not caps.conditional_effects:
        for a in domain.actions:
            if has(a.effect, S.When):
                raise UnsupportedError(
                    f"action '{a.name}' has conditional effects, which this planner does not support",
                    line=a.span.line if a.span else None,
                    col=a.span.col if a.span else None,
                )
    domain, problem, scale = compile_costs(
        domain,
        problem,
        cost_functions=set(cost_functions),
        scale=scale,
        unit_cost=unit_cost or not caps.costs,
    )
    domain = replace(domain, requirements=requirements_of(domain, problem))
    problem = replace(problem, requirements=None)
    # unified-planning's reader keeps every kind of name in one namespace (an action and a
    # predicate may not share a name) and wants plain identifiers: rename what offends it,
    # and map plans back.
    domain, problem, renaming = rename_task(domain, problem)
    return Lowered(domain, problem, scale, templates, renaming or None, grounded)


def requirements_of(domain: S.Domain, problem: S.Problem) -> tuple[str, ...]:
    """The requirement flags the (lowered) domain and problem really use."""
    used = [":strips"]
    conds = (
        [a.precondition for a in domain.actions]
        + [ax.body for ax in domain.axioms]
        + [problem.goal]
    )
    conds = [c for c in conds if c is not None]
    effects = [a.effect for a in domain.actions if a.effect is not None]
    found: list[S.Atom] = []
    for c in conds:
        map_atoms(c, lambda a: found.append(a) or a)
    if domain.types or any(o.type for o in problem.objects):
        used.append(":typing")
    if any(has(c, S.Not) for c in conds):
        used.append(":negative-preconditions")
    if any(has(c, S.Or, S.Imply) for c in conds):
        used.append(":disjunctive-preconditions")
    if any(a.pred == "=" for a in found):
        used.append(":equality")
    if any(has(c, S.Exists) for c in conds):
        used.append(":existential-preconditions")
    if any(has(c, S.Forall) for c in conds):
        used.append(":universal-preconditions")
    if any(has(e, S.When, S.Forall) for e in effects):
        used.append(":conditional-effects")
    if domain.axioms:
        used.append(":derived-predicates")
    if problem.metric is not None:
        used.append(":action-costs")
    return tuple(used)
