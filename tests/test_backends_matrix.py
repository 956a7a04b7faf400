"""Every backend plans every shipped example problem (issue: every backend on every domain).

Each cell compiles the optimistic problem for the backend (ground for pyperplan and the
unified-planning engines, lifted for Fast Downward), solves it, maps the plan back and checks
it against the optimistic problem with the project's own simulator (preimage), which reads
derived predicates and the stream-certified facts.  Every cell takes at most a few seconds.
"""

from __future__ import annotations

import pytest

from ssr_compile.compile.pipeline import compile_problem
from ssr_compile.examples import SHIPPED_PROBLEMS, load_example
from ssr_compile.parse import parse_file
from ssr_compile.planners import get_planner
from ssr_compile.solver.preimage import plan_preimage

PROBLEMS = SHIPPED_PROBLEMS
PLANNERS = ["fd", "pyperplan", "up:fast-downward", "up:pyperplan"]


def _cells():
    for example, pfile, level in PROBLEMS:
        for planner in PLANNERS:
            yield pytest.param(
                example, pfile, level, planner, id=f"{example}/{pfile[:-5]}-{planner}"
            )


@pytest.mark.parametrize("example,pfile,level,planner", list(_cells()))
def test_backend_plans_shipped_problem(example, pfile, level, planner):
    ex = load_example(example)
    problem = parse_file(ex.folder / pfile)
    backend = get_planner(planner)
    compiled = compile_problem(
        ex.domain, ex.streams, problem, caps=backend.capabilities, level=level
    )
    if backend.capabilities.ground:
        assert compiled.lowered.grounded is not None
        assert all(not a.parameters for a in compiled.domain.actions)
        assert not compiled.domain.axioms
    result = backend.solve(compiled.domain, compiled.problem, time_limit=60)
    assert result.status == "solved", result.message
    plan = compiled.map_plan(result.actions or [])
    assert plan and all(name in {a.name for a in ex.domain.actions} for name, _ in plan)
    # raises PlanInvalid when a step is not applicable or the goal does not hold
    plan_preimage(compiled.source_domain, compiled.source_problem, plan)


def test_ground_task_keeps_only_reachable_instances():
    """Grounding evaluates static facts: a pick of a block at a pose it cannot be at (no
    certified facts) never appears, and negated derived predicates over static facts become
    plain conjunctions over the objects that really collide."""
    ex = load_example("tamp2d")
    problem = parse_file(ex.folder / "problem-blocked.pddl")
    caps = get_planner("pyperplan").capabilities
    compiled = compile_problem(ex.domain, ex.streams, problem, caps=caps, level=3)
    grounded = compiled.lowered.grounded
    lifted = {a.name for a in ex.domain.actions}
    assert {v[0] for v in grounded.actions.values()} <= lifted
    # every ground precondition mentions only 0-ary atoms of reachable facts
    for a in grounded.domain.actions:
        for x in __import__("ssr_compile.syntax", fromlist=["walk"]).walk(a.precondition):
            if hasattr(x, "pred"):
                assert not x.args


def test_the_ground_task_does_not_depend_on_string_hashing(tmp_path):
    """Two processes with different hash seeds ground the same problem into the same text:
    the planner's tie-breaking, so the plan, must not change from run to run."""
    import os
    import subprocess
    import sys

    script = (
        "from ssr_compile.compile.pipeline import compile_problem\n"
        "from ssr_compile.examples import load_example\n"
        "from ssr_compile.parse import parse_file\n"
        "from ssr_compile.planners import get_planner\n"
        "from ssr_compile.printer import to_text\n"
        "ex = load_example('tamp2d')\n"
        "p = parse_file(ex.folder / 'problem-blocked.pddl')\n"
        "caps = get_planner('pyperplan').capabilities\n"
        "c = compile_problem(ex.domain, ex.streams, p, caps=caps, level=3)\n"
        "print(to_text(c.domain) + to_text(c.problem))\n"
    )
    texts = []
    for seed in ("1", "2"):
        env = dict(os.environ, PYTHONHASHSEED=seed)
        out = subprocess.run(
            [sys.executable, "-c", script], env=env, capture_output=True, text=True, check=True
        )
        texts.append(out.stdout)
    assert texts[0] == texts[1] and "(:action" in texts[0]
