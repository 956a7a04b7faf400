"""Which PDDL features a domain and problem use, checked against a backend's capabilities."""

from __future__ import annotations

from .. import syntax as S
from .base import Capabilities

_LABELS = {
    "costs": "action costs",
    "axioms": "derived predicates (axioms)",
    "negative_preconditions": "negative conditions",
    "disjunction": "disjunctive conditions",
    "quantifiers": "quantified conditions or effects",
    "conditional_effects": "conditional effects",
    "equality": "equality conditions",
    "numeric": "numeric fluents other than total-cost",
    "durative": "durative actions",
}


def _condition(f, found: set[str], negated: bool = False) -> None:
    if f is None:
        return
    if isinstance(f, S.Atom):
        if f.pred == "=":
            found.add("equality")
        if negated:
            found.add("negative_preconditions")
    elif isinstance(f, S.Not):
        _condition(f.arg, found, not negated)
    elif isinstance(f, S.And):
        for a in f.args:
            _condition(a, found, negated)
    elif isinstance(f, (S.Or, S.Imply)):
        found.add("disjunction")
        if isinstance(f, S.Imply):
            _condition(f.left, found, not negated)
            _condition(f.right, found, negated)
        else:
            for a in f.args:
                _condition(a, found, negated)
    elif isinstance(f, (S.Exists, S.Forall)):
        found.add("quantifiers")
        _condition(f.body, found, negated)
    elif isinstance(f, S.Compare):
        found.add("numeric")
    else:
        found.add("numeric" if isinstance(f, S.NumericEffect) else "durative")


def _is_total_cost(e: S.NumericEffect) -> bool:
    return e.op == "increase" and e.fluent.name == "total-cost" and not e.fluent.args


def _effect(f, found: set[str]) -> None:
    if f is None:
        return
    if isinstance(f, S.And):
        for a in f.args:
            _effect(a, found)
    elif isinstance(f, S.Forall):
        found.add("quantifiers")
        _effect(f.body, found)
    elif isinstance(f, S.When):
        found.add("conditional_effects")
        _condition(f.condition, found)
        _effect(f.effect, found)
    elif isinstance(f, S.NumericEffect):
        found.add("costs" if _is_total_cost(f) else "numeric")
    elif isinstance(f, (S.Atom, S.Not)):
        pass
    else:
        found.add("durative")


def used_features(domain: S.Domain, problem: S.Problem) -> set[str]:
    """The names of the features (keys of :data:`_LABELS`) that the task uses."""
    found: set[str] = set()
    for a in domain.actions:
        _condition(a.precondition, found)
        _effect(a.effect, found)
    for ax in domain.axioms:
        found.add("axioms")
        _condition(ax.body, found)
    if domain.durative_actions:
        found.add("durative")
    _condition(problem.goal, found)
    if problem.metric is not None:
        found.add("costs")
    return found


def unsupported(
    capabilities: Capabilities, domain: S.Domain, problem: S.Problem, *, equality: bool = True
) -> list[str]:
    """Human descriptions of the features the task uses that the backend does not support.

    Numeric fluents (other than ``total-cost``) and durative actions are supported by no
    backend.  ``equality`` says whether the backend accepts ``(= ?x ?y)``.
    """
    caps = capabilities.as_dict()
    missing = []
    for feature in sorted(used_features(domain, problem)):
        ok = caps.get(feature, feature == "equality" and equality)
        if not ok:
            missing.append(_LABELS[feature])
    return missing
