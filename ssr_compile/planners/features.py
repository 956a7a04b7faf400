"""Which PDDL features a domain and problem use, checked against a backend's capabilities."""

from __future__ import annotations

from .. import syntax as S
from ..formulas import planner_features
from .base import Capabilities

_LABELS = {
    # the names planner_features (ssr_compile.formulas) reports
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


def unsupported(
    capabilities: Capabilities, domain: S.Domain, problem: S.Problem, *, equality: bool = True
) -> list[str]:
    """Human descriptions of the features the task uses that the backend does not support.

    Numeric fluents (other than ``total-cost``) and durative actions are supported by no
    backend.  ``equality`` says whether the backend accepts ``(= ?x ?y)``.
    """
    caps = capabilities.as_dict()
    missing = []
    for feature in sorted(planner_features(domain, problem)):
        ok = caps.get(feature, feature == "equality" and equality)
        if not ok:
            missing.append(_LABELS[feature])
    return missing
