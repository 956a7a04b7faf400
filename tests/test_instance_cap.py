"""The optimistic instantiation's cap is checked while the instances are built, not after a
whole depth's join (which took 9 s and 600 MB on tamp2d with 1000 blocks before refusing)."""

from __future__ import annotations

import pytest

from ssr_compile.compile import instantiate as inst_mod
from ssr_compile.compile.pipeline import compile_problem
from ssr_compile.errors import UnsupportedError
from ssr_compile.examples import load_example
from ssr_compile.parse import parse_problem


def _blocks(n: int):
    objs = " ".join(f"b{i} p{i}" for i in range(n))
    init = " ".join(
        f"(Block b{i}) (Pose b{i} p{i}) (AtPose b{i} p{i}) (Contained b{i} p{i} rtable)"
        for i in range(n)
    )
    return parse_problem(
        f"(define (problem t) (:domain tamp2d) (:objects {objs} q0 rtable rgoal) (:init "
        f"(Region rtable) (Region rgoal) (Conf q0) (AtConf q0) (HandEmpty) {init} "
        f"(= (total-cost) 0)) (:goal (In b0 rgoal)) (:metric minimize (total-cost)))"
    )


def test_the_cap_stops_the_join_as_soon_as_it_is_passed(monkeypatch):
    ex = load_example("tamp2d")
    problem = _blocks(60)
    monkeypatch.setattr(inst_mod, "MAX_INSTANCES", 50)
    drawn = 0
    real = inst_mod._matches

    def counting(*args, **kwargs):
        nonlocal drawn
        for m in real(*args, **kwargs):
            drawn += 1
            yield m

    monkeypatch.setattr(inst_mod, "_matches", counting)
    with pytest.raises(UnsupportedError, match="more than 50 stream instances at level 1"):
        compile_problem(ex.domain, ex.streams, problem, level=1)
    # 60 blocks x 60 poses x ... candidate bindings exist; the join stopped right after 51
    assert drawn <= 52


def test_the_focused_solver_stops_raising_the_level_at_the_cap(monkeypatch):
    # A resource limit, like the last level: "no plan up to the level before", not a crash of
    # the whole solve (a kitchen episode ended on it); at the first level it is still an error.
    from pathlib import Path

    from ssr_compile.streams import tamp2d

    from ssr_compile.parse import parse_file
    from ssr_compile.solver import SolveOptions, solve
    from ssr_compile.stream import from_module

    folder = Path(__file__).resolve().parents[1] / "domains" / "pddl" / "tamp2d"
    domain, streams = parse_file(folder / "domain.pddl"), parse_file(folder / "stream.pddl")
    problem = parse_file(folder / "problem-blocked.pddl")
    first = compile_problem(domain, streams, problem, level=1)
    cap = len(first.instantiation.results) + 1  # level 1 fits, a higher level does not
    monkeypatch.setattr(inst_mod, "MAX_INSTANCES", cap)
    sol = solve(domain, streams, problem, from_module(tamp2d), SolveOptions(time_limit=60))
    assert sol.status == "unsolvable", sol.message
    assert "would pass the cap" in sol.message and "up to level 1 " in sol.message
    monkeypatch.setattr(inst_mod, "MAX_INSTANCES", 1)
    with pytest.raises(UnsupportedError, match="more than 1 stream instances at level 1"):
        solve(domain, streams, problem, from_module(tamp2d), SolveOptions(time_limit=60))
