"""``sample-obs`` is written once, in the belief library (:func:`sample_obs`), and the belief
parameters (eps, delta, c, c', p_FN, noise) live in one dataclass: both shipped domains, the
kitchen and belief-detect, go through them."""

from __future__ import annotations

import copy
import inspect

import numpy as np
import pytest

from ssr_compile.belief.observation import DEFAULTS, BeliefParameters, obs_cost, sample_obs
from ssr_compile.belief.particles import ObservationModel, PoseBelief, Surface

pytest.importorskip("pybullet")

from ssr_compile.sim.problem import task_problem  # noqa: E402
from ssr_compile.sim.tasks import make_task  # noqa: E402
from ssr_compile.streams import belief_detect as bd  # noqa: E402
from ssr_compile.streams import kitchen_belief as kb  # noqa: E402
from ssr_compile.streams import kitchen_module as km  # noqa: E402


def _library(o, pb, rng, **kw):
    """The library's observations, heaviest first, with the shipped domains' parameters."""
    out = sample_obs(o, pb, rng, delta=DEFAULTS.delta, eps=DEFAULTS.eps, heaviest_first=True, **kw)
    return [obs for (obs,) in out]


def test_belief_detect_sample_obs_is_the_librarys():
    prior = bd.VALUES["pb-target"]
    streams = bd.DetectStreams(3)
    rng = copy.deepcopy(streams.rng)
    got = [obs for (obs,) in streams.sample_obs("target", prior)]
    assert len(got) == 3 and got == _library("target", prior, rng)


def test_kitchen_sample_obs_is_the_librarys():
    for name in ("inspect", "cook"):
        task = make_task(name, 0)
        try:
            problem, values = task_problem(task)
            module = km.make_module(task, np.random.default_rng(5), values)
            kitchen = module.module
            possible = [f for f in problem.init if getattr(f, "pred", None) == "possible"]
            assert possible
            for fact in possible:
                o, pb_name, s = (a.name for a in fact.args)
                pb = values[pb_name]
                seen = (pb.surface_names == s) & (pb.weights > 0) & kitchen._seeable(o, pb, s)
                rng = copy.deepcopy(kitchen.rng)
                got = [obs for (obs,) in module.streams["sample-obs"](o, pb, s)]
                # the library's regions, less those whose detection is no option
                lib = _library(o, pb, rng, among=seen)
                assert got == [x for x in lib if kitchen.obscost(o, pb, x) is not None], (o, s)
                assert all(obs.region.surface == s for obs in got)
        finally:
            task.world.close()


def test_both_domains_give_the_same_observations_of_the_same_belief(monkeypatch):
    """belief-detect's prior (all on the table), asked of the kitchen's stream with every
    particle in the camera's view, gives belief-detect's observations."""
    prior = bd.VALUES["pb-target"]
    task = make_task("inspect", 0)
    try:
        kitchen = km.make_module(task, np.random.default_rng(0)).module
        monkeypatch.setattr(kitchen, "_seeable", lambda o, pb, s: np.ones(len(pb), bool))
        kitchen.rng = np.random.default_rng(7)
        in_kitchen = [obs for (obs,) in kitchen.sample_obs("target", prior, "table")]
    finally:
        task.world.close()
    in_detect = [obs for (obs,) in bd.DetectStreams(7).sample_obs("target", prior)]
    assert len(in_detect) == 3 and in_kitchen == in_detect


def test_belief_parameters_live_in_one_dataclass():
    assert bd.BELIEF == kb.BELIEF == DEFAULTS == BeliefParameters()
    assert DEFAULTS.model == ObservationModel(p_fn=0.1)
    assert (kb.MODEL, kb.EPS, kb.DELTA) == (kb.BELIEF.model, kb.BELIEF.eps, kb.BELIEF.delta)
    assert (kb.C_DETECT, kb.C_RECOVER) == (kb.BELIEF.c_detect, kb.BELIEF.c_recover)
    for module in (bd, kb, km):
        text = inspect.getsource(module)
        assert "ObservationModel(p_fn" not in text
        assert not any(f"{name} = 0.1" in text for name in ("EPS", "DELTA")), module.__name__
        assert not any(f"{name} = 1.0" in text for name in ("C_DETECT", "C_RECOVER"))
    # the library's defaults are the dataclass's
    pb = PoseBelief.point("o", Surface("t", (0, 0), (1, 1), 0.0), (0, 0, 0, 0))
    (obs,) = next(sample_obs("o", pb, np.random.default_rng(0)))
    assert (obs.eps, obs.region.delta) == (DEFAULTS.eps, DEFAULTS.delta)
    assert obs_cost(obs, pb, 1) == obs_cost(obs, pb, 1, 1.0, 1.0, ObservationModel(p_fn=0.1))


def test_sample_obs_among_restricts_centres_and_regions():
    surface = Surface("t", (0, 0), (1, 1), 0.0)
    pb = PoseBelief.uniform("o", [surface], 60, np.random.default_rng(1))
    among = pb.poses[:, 0] > 0
    for heaviest_first in (False, True):
        out = sample_obs(
            "o", pb, np.random.default_rng(2), among=among, heaviest_first=heaviest_first
        )
        for _, (obs,) in zip(range(30), out):
            assert among[list(obs.region.indices)].all() and obs.z[0] > 0
    nothing = np.zeros(len(pb), bool)
    assert list(sample_obs("o", pb, np.random.default_rng(2), among=nothing)) == []


def test_no_region_is_proposed_where_a_detection_has_no_chance():
    """Swap, after the bottom drawer was seen empty: the block's belief keeps a few percent
    there; every region of it costs more than a detection may (obscost fails), so sample-obs
    proposes none and is exhausted, instead of one failed region per level."""
    task = make_task("swap", 0)
    try:
        problem, values = task_problem(task)
        kitchen = km.make_module(task, np.random.default_rng(0), values).module
        pb = values["pb-block"]
        drawer = np.asarray(pb.surface_names) == "bottom_drawer"
        assert 0 < pb.weights[drawer].sum() < 1
        seeable = {s: kitchen._seeable("block", pb, s) for s in ("top_drawer", "bottom_drawer")}
        kitchen._seeable = lambda o, b, s: seeable[s]
        assert list(kitchen.sample_obs("block", pb, "bottom_drawer"))  # the prior: 50 %
        w = np.where(drawer, 0.01 * pb.weights, pb.weights)
        faint = PoseBelief(pb.obj, pb.surfaces, pb.labels, pb.poses, w / w.sum(), pb.z_offset)
        assert 0 < faint.weights[drawer].sum() < 0.02
        rng = copy.deepcopy(kitchen.rng)
        lib = _library("block", faint, rng, among=drawer & seeable["bottom_drawer"])
        assert lib and all(kitchen.obscost("block", faint, x) is None for x in lib)
        assert list(kitchen.sample_obs("block", faint, "bottom_drawer")) == []
    finally:
        task.world.close()


def test_regions_in_view_now_take_turns_with_hidden_ones():
    """Cook seed 0: the boxes, localized where they stand, hide most of the block's regions,
    the heaviest two among them.  Heaviest first, a plan that detects the block without moving
    a box (a replan keeping the last plan's structure) failed ``test-vis`` on one draw per
    level; now the heaviest region in view comes first, then the heaviest hidden one, and so
    on -- every region still comes once."""
    task = make_task("cook", 0)
    try:
        problem, values = task_problem(task)
        kitchen = km.make_module(task, np.random.default_rng(5), values).module
        kitchen.obstacles = {o: values[f"pb-{o}"] for o in ("cracker_box", "sugar_box")}
        pb = values["pb-block"]
        seen = (pb.surface_names == "counter") & (pb.weights > 0)
        seen &= kitchen._seeable("block", pb, "counter")
        rng = copy.deepcopy(kitchen.rng)
        lib = _library("block", pb, rng, among=seen)
        lib = [x for x in lib if kitchen.obscost("block", pb, x) is not None]
        clear = [kitchen._clear_now("block", x) for x in lib]
        assert clear[:2] == [False, False] and clear.count(True) >= 3  # the case at hand
        got = [obs for (obs,) in kitchen.sample_obs("block", pb, "counter")]
        assert len(got) == len(lib) and all(x in got for x in lib)  # the same regions, once each
        in_view = [x for x, c in zip(lib, clear, strict=True) if c]
        hidden = [x for x, c in zip(lib, clear, strict=True) if not c]
        assert got[:6] == [in_view[0], hidden[0], in_view[1], hidden[1], in_view[2], hidden[2]]
        kitchen.obstacles = {}
        rng2 = copy.deepcopy(kitchen.rng)
        plain = [obs for (obs,) in kitchen.sample_obs("block", pb, "counter")]
        assert plain == [x for x in _library("block", pb, rng2, among=seen)
                         if kitchen.obscost("block", pb, x) is not None]  # fmt: skip
    finally:
        task.world.close()
