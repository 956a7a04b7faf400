"""Ray-cast visibility (streams/visibility.py) on a small DIRECT PyBullet scene."""

from __future__ import annotations

import math

import numpy as np
import pybullet as p
import pytest

import ssr_compile.belief.visibility as visibility_mod
from ssr_compile.belief.visibility import PyBulletCamera, as_pos_quat, bodies_at


@pytest.fixture(scope="module")
def scene():
    """Camera at the origin looking along +x; an occluder box at x=1, a target box at x=2,
    and a drawer-like articulated body (a base plus one prismatic link) at y=1."""
    cid = p.connect(p.DIRECT)
    box = p.createCollisionShape(p.GEOM_BOX, halfExtents=[0.1, 0.1, 0.1], physicsClientId=cid)
    occluder = p.createMultiBody(0, box, basePosition=[1, 0, 0], physicsClientId=cid)
    target = p.createMultiBody(0, box, basePosition=[2, 0, 0], physicsClientId=cid)
    small = p.createCollisionShape(p.GEOM_BOX, halfExtents=[0.02, 0.02, 0.02], physicsClientId=cid)
    panel = p.createCollisionShape(p.GEOM_BOX, halfExtents=[0.05, 0.2, 0.2], physicsClientId=cid)
    # base far behind the camera's line of sight; the link (the drawer front) at x=1, y=1
    drawer = p.createMultiBody(
        0,
        small,
        basePosition=[1, 1, -1],
        linkMasses=[0.1],
        linkCollisionShapeIndices=[panel],
        linkVisualShapeIndices=[-1],
        linkPositions=[[0, 0, 1]],
        linkOrientations=[[0, 0, 0, 1]],
        linkInertialFramePositions=[[0, 0, 0]],
        linkInertialFrameOrientations=[[0, 0, 0, 1]],
        linkParentIndices=[0],
        linkJointTypes=[p.JOINT_PRISMATIC],
        linkJointAxis=[[0, 0, 1]],
        physicsClientId=cid,
    )
    cam = PyBulletCamera([0, 0, 0], client=cid)
    yield {"cid": cid, "occluder": occluder, "target": target, "drawer": drawer, "cam": cam}
    p.disconnect(cid)


def test_visible_and_occluded_points(scene):
    cam = scene["cam"]
    pts = np.array(
        [
            [2.0, -2.0, 0.0],  # off to the side: free line of sight
            [2.0, 0.0, 0.0],  # target centre, behind the occluder
            [0.9, 0.0, 0.0],  # the occluder's front face itself (surface tolerance)
            [0.5, 0.0, 0.0],  # in front of the occluder
        ]
    )
    assert cam.visible(pts).tolist() == [True, False, True, True]


def test_ignore_removes_occluders_and_target(scene):
    cam, occ, tgt = scene["cam"], scene["occluder"], scene["target"]
    centre = np.array([[2.0, 0.0, 0.0]])
    assert not cam.visible(centre, ignore=[tgt])[0]  # still behind the occluder
    assert not cam.visible(centre, ignore=[occ])[0]  # hidden by the target's own front face
    assert cam.visible(centre, ignore=[occ, tgt])[0]
    # the target's front face is visible once the occluder is ignored, without ignoring target
    assert cam.visible(np.array([[1.9, 0.0, 0.0]]), ignore=[occ])[0]
    # ignored bodies are back where they were, to the bit
    assert p.getBasePositionAndOrientation(occ, physicsClientId=scene["cid"])[0] == (1.0, 0.0, 0.0)
    assert p.getBasePositionAndOrientation(tgt, physicsClientId=scene["cid"])[0] == (2.0, 0.0, 0.0)


def test_max_range():
    cid = p.connect(p.DIRECT)
    try:
        cam = PyBulletCamera([0, 0, 0], client=cid, max_range=1.5)
        assert cam.visible(np.array([[1.0, 0, 0], [0, 1.6, 0], [0, 0, 0]])).tolist() == [
            True,
            False,
            True,
        ]
        assert cam.visible(np.zeros((0, 3))).shape == (0,)
    finally:
        p.disconnect(cid)


def test_articulated_link_occludes_and_moves_with_joint(scene):
    cam, drawer, cid = scene["cam"], scene["drawer"], scene["cid"]
    behind = np.array([[2.0, 2.0, 0.0]])  # the ray passes x=1 at y=1, z=0: through the panel
    assert not cam.visible(behind)[0]
    p.resetJointState(drawer, 0, 1.0, physicsClientId=cid)  # slide the panel up by 1 m
    try:
        assert cam.visible(behind)[0]
    finally:
        p.resetJointState(drawer, 0, 0.0, physicsClientId=cid)
    assert not cam.visible(behind)[0]
    assert cam.visible(behind, ignore=[drawer])[0]


def test_chunking_matches_single_batch(scene, monkeypatch):
    cam = scene["cam"]
    rng = np.random.default_rng(3)
    pts = rng.uniform([0.5, -0.5, -0.5], [2.5, 0.5, 0.5], size=(50, 3))
    whole = cam.visible(pts)
    before = cam.rays_cast
    monkeypatch.setattr(visibility_mod, "MAX_RAY_BATCH", 7)
    assert np.array_equal(cam.visible(pts), whole)
    assert cam.rays_cast - before == 50
    assert 0 < whole.sum() < 50  # the scene occludes some of them and not others


def test_more_rays_than_one_pybullet_batch(scene):
    cam = scene["cam"]
    n = visibility_mod.MAX_RAY_BATCH + 5
    pts = np.tile([[2.0, 0.0, 0.0], [2.0, -2.0, 0.0]], (n // 2 + 1, 1))[:n]
    vis = cam.visible(pts)
    assert vis.shape == (n,)
    assert vis[0::2].sum() == 0 and vis[1::2].all()


def test_bodies_at_restores_even_on_error(scene):
    cid, occ = scene["cid"], scene["occluder"]
    with bodies_at(cid, {occ: (5.0, 0.0, 0.0, math.pi / 2)}):
        pos, quat = p.getBasePositionAndOrientation(occ, physicsClientId=cid)
        assert pos == pytest.approx((5.0, 0.0, 0.0))
        assert quat == pytest.approx((0, 0, math.sin(math.pi / 4), math.cos(math.pi / 4)))
        assert scene["cam"].visible(np.array([[1.9, 0.0, 0.0]]))[0]  # occluder gone
    with pytest.raises(RuntimeError):
        with bodies_at(cid, {occ: ((0.0, 3.0, 0.0), (0, 0, 0, 1))}):
            raise RuntimeError("boom")
    assert p.getBasePositionAndOrientation(occ, physicsClientId=cid)[0] == (1.0, 0.0, 0.0)


def test_as_pos_quat_and_bodies(scene):
    pos, quat = as_pos_quat((1, 2, 3, math.pi))
    assert pos == (1.0, 2.0, 3.0) and quat == pytest.approx((0, 0, 1, 0), abs=1e-12)
    assert as_pos_quat(((1, 2, 3), (0, 0, 0, 1))) == ((1.0, 2.0, 3.0), (0.0, 0.0, 0.0, 1.0))
    with pytest.raises(ValueError):
        as_pos_quat((1, 2, 3))
    assert sorted(scene["cam"].bodies()) == sorted(
        [scene["occluder"], scene["target"], scene["drawer"]]
    )
