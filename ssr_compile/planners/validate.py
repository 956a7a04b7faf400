"""Checking a plan with unified-planning's sequential plan validator (tests reuse this).

The validator says *why* a plan fails, which is what a failing test should print.  The task
goes through the same renaming as the ``up`` backend, so inputs with an action and a predicate
of the same name validate too.
"""

from __future__ import annotations

import os
import tempfile
import warnings
from pathlib import Path

from ..compile.rename import rename_task
from ..errors import UnsupportedError
from ..printer import to_text
from ..syntax import Domain, Problem
from .base import GroundAction


def validate_plan(
    domain: Domain, problem: Problem, actions: list[GroundAction]
) -> tuple[bool, str]:
    """``(True, "")`` when ``actions`` is a valid plan for the task, else ``(False, reason)``.

    Raises :class:`UnsupportedError` for derived predicates, which unified-planning's PDDL
    reader does not read.
    """
    if domain.axioms:
        raise UnsupportedError("the plan validator cannot read derived predicates (:derived)")
    import unified_planning.shortcuts as up
    from unified_planning.io import PDDLReader
    from unified_planning.plans import ActionInstance, SequentialPlan

    up.get_environment().credits_stream = None
    renamed = rename_task(domain, problem)
    dom, prob, renaming = renamed.domain, renamed.problem, renamed.renaming
    act = renaming.actions
    obj = renaming.objects
    with tempfile.TemporaryDirectory(prefix="ssr-validate-") as tmp:
        d_path, p_path = os.path.join(tmp, "domain.pddl"), os.path.join(tmp, "problem.pddl")
        Path(d_path).write_text(to_text(dom))
        Path(p_path).write_text(to_text(prob))
        task = PDDLReader().parse_problem(d_path, p_path)
    steps = []
    for name, args in actions:
        try:
            action = task.action(act.get(name, name))
            objects = [task.object(obj.get(a, a)) for a in args]
        except Exception as e:  # noqa: BLE001 - an unknown name is an invalid plan
            return False, f"({' '.join([name, *args])}): {e}"
        steps.append(ActionInstance(action, objects))
    with warnings.catch_warnings():
        # It warns that it cannot tell whether it supports costs from static functions; it does.
        warnings.simplefilter("ignore", UserWarning)
        with up.PlanValidator(name="sequential_plan_validator") as validator:
            res = validator.validate(task, SequentialPlan(steps))
    if res.status.name == "VALID":
        return True, ""
    return False, res.reason.name + (
        f": {res.inapplicable_action}" if getattr(res, "inapplicable_action", None) else ""
    )
