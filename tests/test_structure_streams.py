"""Issue 9 item 6: a streams module gets its seed and problem through a factory
``make_module(seed, problem)``, not through module globals set by a ``seed()`` hook."""

from __future__ import annotations

import itertools

import pytest

from ssr_compile.resources import domains_dir
from ssr_compile.stream import StreamsModule, module_for_problem

pytest.importorskip("numpy")


def _placements(module: StreamsModule, n: int = 5):
    from ssr_compile.streams import tamp2d as T

    gen = module.streams["sample-placement"](T.VALUES["b0"], T.VALUES["rtable"])
    return [p for (p,) in itertools.islice(gen, n)]


def test_tamp2d_seed_through_the_factory():
    from ssr_compile.streams import tamp2d as T

    problem = domains_dir() / "tamp2d" / "problem.pddl"
    three = module_for_problem("ssr_compile.streams.tamp2d", problem, seed=3)
    zero = module_for_problem("ssr_compile.streams.tamp2d", problem, seed=0)
    assert not hasattr(T, "SEED") and not hasattr(T, "seed")
    assert _placements(three) == _placements(T.make_module(3)) != _placements(zero)
    assert _placements(zero) == _placements(T.make_module())  # the module's own STREAMS: seed 0


def test_belief_detect_modules_do_not_share_a_generator():
    pytest.importorskip("pybullet")
    from ssr_compile.streams import belief_detect as bd

    assert not hasattr(bd, "reset_rng") and not hasattr(bd, "_rng") and not hasattr(bd, "_scene")
    prior = bd.VALUES["pb-target"]
    a, b = bd.make_module(0), bd.make_module(0)
    first = [o for (o,) in a.streams["sample-obs"]("target", prior)]
    next(iter(a.streams["sample-aside"]("boxa")))  # draws from a's generator only
    assert [o for (o,) in b.streams["sample-obs"]("target", prior)] == first


def test_older_protocols_still_work(tmp_path):
    mod = tmp_path / "legacy_streams.py"
    mod.write_text(
        "SEEN = []\ndef seed(n):\n    SEEN.append(n)\nSTREAMS = {'s': lambda: iter(())}\n"
    )
    module = module_for_problem(str(mod), tmp_path / "p.pddl", seed=7)
    assert module.module.SEEN == [7]
