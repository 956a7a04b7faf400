"""Each task's goal is reachable in the simulator from its latent state with a hand-written
plan (no planner): the world, the streams and the actions work together (paper appendix)."""

import numpy as np
import pytest
from ssr_compile.sim.scripted import Scripted
from ssr_compile.sim.tasks import TASKS, make_task
from ssr_compile.sim.world import DRAWER_TRAVEL

from ssr_compile.belief.particles import ObservationModel

EXACT = ObservationModel(p_fn=0.0)


@pytest.fixture
def task(request):
    t = make_task(request.param, 3)
    yield t
    t.close()


def _near(detection, true_pose, tol=0.05):
    return np.linalg.norm(np.subtract(detection[:3], true_pose[:3])) < tol


@pytest.mark.parametrize("task", ["inspect"], indirect=True)
def test_inspect_plan(task):
    w, s = task.world, Scripted(task.world, np.random.default_rng(0))
    s.park()
    assert "block" not in s.observe(EXACT)  # closed drawers hide the block
    assert s.move_drawer("bottom_drawer", DRAWER_TRAVEL).ok
    s.park()
    det = s.observe(EXACT)
    assert _near(det["block"], w.true_state()["objects"]["block"]["pose"])
    assert s.move_drawer("bottom_drawer", 0.0).ok
    assert task.goal_satisfied()


@pytest.mark.parametrize("task", ["stow"], indirect=True)
def test_stow_plan(task):
    s = Scripted(task.world, np.random.default_rng(0))
    out = s.move_drawer("top_drawer", 0.0)  # the sugar box blocks the drawer
    assert not out.ok and task.world.drawer_q["top_drawer"] > 0.05
    assert s.move_drawer("top_drawer", DRAWER_TRAVEL).ok
    s.pick("sugar_box")
    s.place("sugar_box", "counter")
    s.pick("block")
    s.place("block", "top_drawer")
    assert s.move_drawer("top_drawer", 0.0).ok
    assert task.goal_satisfied()


@pytest.mark.parametrize("task", ["swap"], indirect=True)
def test_swap_plan(task):
    w, s = task.world, Scripted(task.world, np.random.default_rng(0))
    s.move_drawer("bottom_drawer", DRAWER_TRAVEL)
    s.park()
    assert "block" not in s.observe(EXACT)
    s.move_drawer("bottom_drawer", 0.0)
    s.move_drawer("top_drawer", DRAWER_TRAVEL)
    s.park()
    assert "block" in s.observe(EXACT)
    s.pick("block")
    s.place("block", "counter")
    s.move_drawer("top_drawer", 0.0)
    s.move_drawer("bottom_drawer", DRAWER_TRAVEL)
    s.pick("block")
    s.place("block", "bottom_drawer")
    assert s.move_drawer("bottom_drawer", 0.0).ok
    assert task.goal_satisfied()
    assert w.true_state()["drawers"]["top_drawer"] == 0.0


@pytest.mark.parametrize("task", ["cook"], indirect=True)
def test_cook_plan(task):
    w, s = task.world, Scripted(task.world, np.random.default_rng(0))
    s.park()
    assert "block" not in s.observe(EXACT)  # one of the boxes hides it
    for box in ("cracker_box", "sugar_box"):
        if "block" in s.observe(EXACT):
            break
        s.pick(box)
        s.place(box, "counter")
        s.park()
    assert "block" in s.observe(EXACT)
    s.pick("block")
    s.place("block", "stove")
    assert not task.goal_satisfied()
    assert s.press().info["stove_on"]
    assert "block" in w.cooked and not task.goal_satisfied()  # cooked, the stove still on
    assert not s.press().info["stove_on"]
    assert task.goal_satisfied() and not w.stove_on


@pytest.mark.parametrize("name", TASKS)
def test_task_data(name):
    t = make_task(name, 7)
    try:
        assert set(t.prior) <= set(t.world.present())
        for entries in t.prior.values():
            assert abs(sum(w for _, w in entries) - 1.0) < 1e-9
            assert all(s in t.world.surfaces for s, _ in entries)
        assert (
            t.latent["objects"]["block"]["surface"]
            == {
                "inspect": "bottom_drawer",
                "swap": "top_drawer",
                "stow": "counter",
                "cook": "counter",
            }[name]
        )
        assert t.goal_satisfied() == (name == "inspect")
        for surf, _ in t.prior_surfaces()["block"]:
            lo, hi, z = t.world.surface_world_rect(surf.name)
            assert np.allclose(surf.center, (lo + hi) / 2) and abs(surf.z - z) < 1e-9
    finally:
        t.close()


def test_same_seed_same_scene():
    a, b, c = make_task("cook", 11), make_task("cook", 11), make_task("cook", 12)
    try:
        assert a.latent == b.latent
        assert a.latent["objects"] != c.latent["objects"]
    finally:
        for t in (a, b, c):
            t.close()


def test_cook_block_is_hidden_initially():
    from ssr_compile.sim.perception import is_visible

    for seed in range(4):
        t = make_task("cook", seed)
        try:
            assert not is_visible(t.world, "block")
        finally:
            t.close()


@pytest.mark.parametrize("view", ["camera", "top"])
def test_render_task_writes_png(tmp_path, view):
    from ssr_compile.sim.render import render_task

    out = render_task("swap", 0, str(tmp_path / "s.png"), view=view)
    with open(out, "rb") as f:
        assert f.read(8) == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize(("name", "obj"), [("swap", "block"), ("stow", "sugar_box")])
def test_objects_in_drawers_can_be_grasped_with_the_drawer_open(name, obj):
    # The back of a drawer stays under the counter when the drawer is open: a block placed there
    # (Swap seed 2, once) could never be picked, and the episode ended "no relaxed solution".
    from ssr_compile.sim.samplers import KitchenStreams

    for seed in (2, 5):
        t = make_task(name, seed)
        try:
            w = t.world
            ks = KitchenStreams(w, np.random.default_rng(1))
            p = ks.current_pose(obj)
            assert p.surface == "top_drawer"
            w.set_drawer("top_drawer", DRAWER_TRAVEL)
            w.set_drawer("bottom_drawer", 0.0)
            bases = [b for (g,) in ks.sample_grasps(obj) for b in ks.inv_reach(obj, p, g)]
            assert bases, (name, seed)
        finally:
            t.close()


def test_an_object_the_goal_moves_stands_where_a_grasp_reaches_it_with_the_drawers_as_given():
    # Stow seed 5's block stood once at the counter's corner beside the open top drawer, where
    # 1 of 40 batches of base draws reached it: the episode ended "no relaxed solution".  Now
    # a goal's object on the counter is placed only where some grasp reaches it (the drawers
    # as the task opens them); objects the goal does not move (Cook's boxes) are not checked,
    # and their worlds are as before.
    from ssr_compile.sim.samplers import KitchenStreams

    for name, seed in (("stow", 5), ("stow", 1), ("stow", 2)):
        t = make_task(name, seed)
        try:
            w = t.world
            ks = KitchenStreams(w, np.random.default_rng(1))
            p = ks.current_pose("block")
            assert p.surface == "counter"
            found = sum(
                next(iter(ks.inv_reach("block", p, g)), None) is not None
                for (g,) in ks.sample_grasps("block")
            )
            assert found >= 2, (name, seed, found)  # more than one grasp reaches it
        finally:
            t.close()
