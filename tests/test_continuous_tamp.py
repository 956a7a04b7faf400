"""pddlstream's own continuous_tamp domain and stream files (from the shared corpus, read in
place) with streams written for our API (tests/fixtures/ctamp): two blocks into the goal
region.  The Focused solver finds it with a planner that takes the ground task (pyperplan) and
with one that takes the lifted task (Fast Downward, whose translator meets the domain's
universal precondition), and through unified-planning's engines (ground); each step is checked against the 1-D geometry here.  A few seconds
(marked slow: deselect with -m "not slow")."""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import require_corpus

from ssr_compile.parse import parse_file
from ssr_compile.solver import SolveOptions, solve
from ssr_compile.stream import load_streams_module

FIXTURE = Path(__file__).parent / "fixtures" / "ctamp"


@pytest.mark.slow
@pytest.mark.parametrize("planner", ["pyperplan", "fd", "up:pyperplan", "up:fast-downward"])
def test_two_blocks_into_the_goal_region(planner):
    corpus = require_corpus("pddlstream-examples/examples/continuous_tamp")
    domain = parse_file(corpus / "domain.pddl")
    streams = parse_file(corpus / "stream.pddl")
    problem = parse_file(FIXTURE / "problem.pddl")
    module = load_streams_module(str(FIXTURE / "streams.py"))
    sol = solve(domain, streams, problem, module, SolveOptions(planner=planner, time_limit=120))
    assert sol.solved, sol.message
    lo, hi = module.module.REGIONS["goal"]
    placed = {}
    for step in sol.plan:
        if step.name == "place":
            b, p = step.args[1], step.values[2]
            placed[b] = p
    assert set(placed) == {"a", "b"}
    assert all(lo + 0.5 <= p <= hi - 0.5 for p in placed.values())
    assert abs(placed["a"] - placed["b"]) >= 1.0  # they do not overlap
