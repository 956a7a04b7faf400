"""The kitchen's test streams decide what the paper's derived predicates say: ``test-vis``
(BVis, so BOccluded) and ``test-cfree`` (collision-free placements, so Unsafe).  Each is asked
once where the answer must be yes and once where it must be no."""

from __future__ import annotations

import numpy as np
import pytest
from ssr_compile.sim.geometry import multiply, yaw_of
from ssr_compile.sim.perception import is_visible
from ssr_compile.sim.tasks import make_task
from ssr_compile.streams.kitchen_module import make_module

from ssr_compile.belief.particles import PoseBelief


@pytest.fixture(scope="module")
def cook():
    """A Cook task where a box hides the block from the camera at the start."""
    for seed in range(10):
        task = make_task("cook", seed)
        if not is_visible(task.world, "block"):
            module = make_module(task, np.random.default_rng(0))
            yield task, module
            task.world.close()
            return
        task.world.close()
    pytest.fail("no Cook seed in 0-9 with the block hidden")


def _point(task, name: str, xy=None) -> PoseBelief:
    surface = task.prior_surfaces()[name][0][0]
    pos, quat = task.world.object_pose(name)
    x, y = (pos[0], pos[1]) if xy is None else xy
    return PoseBelief.point(name, surface, (x, y, pos[2], yaw_of(quat)))


def _observation(task, module):
    block = _point(task, "block")
    (obs,) = next(iter(module.streams["sample-obs"]("block", block, "counter")))
    return obs


def _occluder(task, module, obs) -> str:
    boxes = ("cracker_box", "sugar_box")
    hiding = [b for b in boxes if not module.streams["test-vis"]("block", obs, b, _point(task, b))]
    return hiding[0] if hiding else ""


def test_vis_fails_for_the_box_that_hides_the_block_and_holds_once_it_is_moved(cook):
    task, module = cook
    obs = _observation(task, module)
    occluder = _occluder(task, module, obs)
    assert occluder, "the box hiding the block must make BVis false"
    # the same box at the far corner of the counter, off the camera's rays to the block
    surface = task.prior_surfaces()[occluder][0][0]
    corners = [
        (
            surface.center[0] + sx * 0.8 * surface.half_extents[0],
            surface.center[1] + sy * 0.8 * surface.half_extents[1],
        )
        for sx in (-1, 1)
        for sy in (-1, 1)
    ]
    answers = [
        module.streams["test-vis"]("block", obs, occluder, _point(task, occluder, xy))
        for xy in corners
    ]
    assert any(answers)  # moved away, the same box no longer hides the block


def test_cfree_refuses_a_placement_on_top_of_another_object(cook):
    task, module = cook
    sugar = _point(task, "sugar_box")
    pos = sugar.poses[0]
    on_it = _point(task, "block", (pos[0], pos[1]))
    assert module.streams["test-cfree"]("block", on_it, "sugar_box", sugar) is False
    far = _point(task, "block", (pos[0], pos[1] + 0.5))
    assert module.streams["test-cfree"]("block", far, "sugar_box", sugar) is True
    # an object never collides with itself
    assert module.streams["test-cfree"]("block", on_it, "block", on_it) is True


_REACHES: dict[int, tuple] = {}


def _block_pregrasp(task, module):
    """A base and a pre-grasp configuration for the block, from the streams (12 draws of
    bases per grasp); the same for every test of one module (the draws move its random
    numbers on, and later tests rely on the first reach's geometry)."""
    if id(module) not in _REACHES:
        _REACHES[id(module)] = _draw_pregrasp(task, module)
    return _REACHES[id(module)]


def _draw_pregrasp(task, module):
    block = _point(task, "block")
    for (g,) in module.streams["sample-grasp"]("block"):
        bases = module.streams["inv-reach"]("block", block, g)
        for _ in range(12):
            (bq,) = next(bases) or (None,)
            out = None if bq is None else module.streams["inv-kin"]("block", block, g, bq)
            if out is not None:
                return bq, out[0]
    pytest.fail("no base and pre-grasp for the block in 12 draws per grasp")


def test_afree_refuses_an_arm_configuration_inside_another_object(cook):
    """``test-afree`` (so ``armblocked``, in pick and place): the pre-grasp of the block is
    refused with the sugar box believed where the hand would be, and allowed with the box
    elsewhere, or with the arm already there and the box against the hand only (the robot is
    at that configuration: its hand is free)."""
    task, module = cook
    bq, aq = _block_pregrasp(task, module)
    hand = task.world.robot.forward_kinematics(bq, aq)[0]
    sugar_at_hand = _point(task, "sugar_box", (hand[0], hand[1]))
    test = module.streams["test-afree"]
    assert test(bq, aq, "sugar_box", sugar_at_hand) is False
    sugar = _point(task, "sugar_box", (hand[0], hand[1] + 0.6))
    assert test(bq, aq, "sugar_box", sugar) is True
    # where the hand is, the footprints of the box and of the block apart (so the block the
    # pick draws back up its approach passes the box: the next test)
    km = module.module
    apart = _radius(task, "block") + _radius(task, "sugar_box") + 0.01
    block_xy = np.asarray(task.world.object_pose("block")[0][:2])
    against_hand = []
    for a in np.linspace(0, 2 * np.pi, 16, endpoint=False):
        box = _point(task, "sugar_box", tuple(block_xy + apart * np.array([np.cos(a), np.sin(a)])))
        with km.planning():
            if not km.ks.test_cfree_traj_pose(bq, (aq,), "sugar_box", km.obj_pose(box)):
                against_hand.append(box)
    assert against_hand, "no belief of the box against the hand and apart from the block"
    assert all(test(bq, aq, "sugar_box", box) is False for box in against_hand)
    km.arm_now = tuple(aq)
    try:
        assert all(test(bq, aq, "sugar_box", box) is True for box in against_hand)
    finally:
        km.arm_now = None


def _radius(task, name: str) -> float:
    he = task.world.half_extents[name]
    return float(np.hypot(he[0], he[1]))


def _side_reach(task, module):
    """A base and pre-grasp of the sugar box with a side grasp, and the direction (unit, on
    the counter) its pick draws it back in."""
    box = _point(task, "sugar_box")
    rest = np.asarray(task.world.object_pose("sugar_box")[0][:2])
    fk = task.world.robot.forward_kinematics
    for (g,) in module.streams["sample-grasp"]("sugar_box"):
        if g.kind != "side":
            continue
        bases = module.streams["inv-reach"]("sugar_box", box, g)
        for _ in range(12):
            (bq,) = next(bases) or (None,)
            out = None if bq is None else module.streams["inv-kin"]("sugar_box", box, g, bq)
            if out is not None:
                away = np.asarray(multiply(fk(bq, out[0]), g.pose)[0][:2]) - rest
                return bq, out[0], away / np.linalg.norm(away)
    pytest.fail("no side grasp of the sugar box reached in 12 draws of bases per grasp")


def test_afree_refuses_a_reach_whose_approach_carries_the_object_into_another(cook):
    """A pick draws the object back along its approach (placing brings it in), unchecked by
    the true world; the approach was checked with the hand alone.  ``test-afree`` checks the
    object carried along it: with the arm at the pre-grasp (the hand free there), the block
    believed where the sugar box is drawn back to is refused, and beside its way it is not.
    The clutter family's cook N = 10, seed 0 drew the cracker box back through a block beside
    the hand's way, and every arm motion from there stopped at its first waypoint (nine
    cycles)."""
    task, _ = cook
    module = make_module(task, np.random.default_rng(1))  # the fixture's draws left as they are
    km = module.module
    bq, aq, away = _side_reach(task, module)
    rest = np.asarray(task.world.object_pose("sugar_box")[0][:2])
    apart = _radius(task, "sugar_box") + _radius(task, "block") + 0.005
    side = np.array([-away[1], away[0]])
    test = module.streams["test-afree"]
    km.arm_now = tuple(aq)  # the hand is free where it is: only what it carries is checked
    try:
        assert test(bq, aq, "block", _point(task, "block", tuple(rest + apart * away))) is False
        assert test(bq, aq, "block", _point(task, "block", tuple(rest + apart * side))) is True
    finally:
        km.arm_now = None


def test_an_arm_motion_from_carry_to_a_grasp_is_planned_for_after_the_held_object_is_down(
    cook, monkeypatch
):
    """The robot holds the sugar box at carry.  A motion from carry the robot may take next is
    checked with the box in hand; one whose end the arm cannot reach with the box in hand (the
    block's pre-grasp) is taken after the box is put down, and is planned without it.  Stow
    without deferral: every motion from carry to a grasp of the block, checked with the box
    in hand, failed, until no plan was left."""
    from ssr_compile.sim.robot import ARM_CARRY
    from ssr_compile.sim.world import Held

    task, module = cook
    km = module.module
    block = _point(task, "block")
    bq, aq = _block_pregrasp(task, module)
    (sugar_grasp,) = next(iter(module.streams["sample-grasp"]("sugar_box")))
    w = task.world
    km.obstacles = {"block": block}  # localized where it is
    with km.planning() as pw:  # the pre-grasp cannot be reached with the box in hand
        km._place_obstacles(pw)
        pw.set_base(bq)
        pw.set_arm(aq)
        assert not pw.robot_collision()
        pw.held = Held("sugar_box", sugar_grasp.pose)
        pw.set_arm(aq)  # the held box follows the hand
        assert pw.robot_collision()
    checked_with: list = []
    real = km.ks.plan_arm_motion

    def spy(*args, **kw):
        checked_with.append(None if w.held is None else w.held.obj)
        return real(*args, **kw)

    monkeypatch.setattr(km.ks, "plan_arm_motion", spy)
    km.holding, km.arm_now = ("sugar_box", sugar_grasp), tuple(ARM_CARRY)
    try:
        motion = module.streams["plan-arm-motion"]
        out = motion(bq, tuple(ARM_CARRY), tuple(aq))
        assert out is not None
        assert np.allclose(out[0][0], ARM_CARRY) and np.allclose(out[0][-1], aq)
        assert checked_with and set(checked_with) == {None}
        checked_with.clear()
        turned = tuple(np.add(ARM_CARRY, (0.4, 0, 0, 0, 0, 0, 0)))  # reached with the box
        motion(bq, tuple(ARM_CARRY), turned)  # may be next: checked with the box in hand
        assert checked_with and set(checked_with) == {"sugar_box"}
    finally:
        km.holding, km.arm_now, km.obstacles = None, None, {}
