"""pddlstream's continuous_tamp example (its domain and stream files from the shared corpus, read
in place) with problems and streams of ours (tests/fixtures/pddlstream/continuous_tamp.py): the
solver, untuned, solves ``tight(2)`` and ``tight(4)`` (two goal blocks into a region with one
unit of slack) with its defaults, and each plan is replayed against the 1-D geometry --
placements inside their regions, no overlap, the gripper where each action needs it, the goal
at the end.  Plans are checked, not times (``bench/pddlstream_examples.py`` measures those)."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest
from conftest import require_corpus

from ssr_compile.parse import parse_file, parse_problem
from ssr_compile.solver import SolveOptions, solve

sys.path.insert(0, str(Path(__file__).parent / "fixtures" / "pddlstream"))
import continuous_tamp as ctamp  # noqa: E402


def solve_ctamp(name: str, seed: int):
    corpus = require_corpus("pddlstream-examples/examples/continuous_tamp")
    domain = parse_file(corpus / "domain.pddl")
    streams = parse_file(corpus / "stream.pddl")
    text, module = ctamp.make(name, seed)
    return solve(domain, streams, parse_problem(text), module, SolveOptions(time_limit=60))


@pytest.mark.parametrize("seed", [0, 1])
def test_two_blocks_into_a_tight_region(seed):
    sol = solve_ctamp("tight(2)", seed)
    assert sol.solved, sol.message
    ctamp.check_plan("tight(2)", sol.plan)
    placed = [s for s in sol.plan if s.name == "place"]
    assert {s.args[1] for s in placed} >= {"a", "b"}


@pytest.mark.slow
@pytest.mark.parametrize("seed", [2, 3])
def test_two_of_four_blocks_into_a_tight_region(seed):
    sol = solve_ctamp("tight(4)", seed)
    assert sol.solved, sol.message
    ctamp.check_plan("tight(4)", sol.plan)


def test_the_geometry_check_rejects_a_broken_plan():
    """The checker itself: the second block placed at the first one's pose is refused."""
    sol = solve_ctamp("tight(2)", 0)
    assert sol.solved, sol.message
    places = [i for i, s in enumerate(sol.plan) if s.name == "place"]
    first, second = sol.plan[places[0]], sol.plan[places[1]]
    bad = list(sol.plan)
    values = list(second.values)
    values[2] = first.values[2]
    bad[places[1]] = type(second)(second.name, second.args, tuple(values))
    with pytest.raises(AssertionError):
        ctamp.check_plan("tight(2)", bad)
