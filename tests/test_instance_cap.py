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
