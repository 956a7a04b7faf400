"""The fixed camera's detector (paper §III, §V-B): detects each visible object, misses it with
probability ``p_fn``, and reports its pose with Gaussian noise; never a true pose.

Visibility is decided by ray casts (``ssr_compile.belief.visibility.PyBulletCamera``) from the camera's eye
to several points of the object; everything else in the scene occludes (other objects, the
cabinet and its drawers, the stove, the robot).  The noise model is
``ssr_compile.belief.particles.ObservationModel`` (``p_fn``, covariance over ``(x, y, z, yaw)``).
"""

from __future__ import annotations

import numpy as np

from ssr_compile.belief.particles import ObservationModel

from .geometry import multiply, pose, yaw_of
from .world import World

#: An object is visible when at least this fraction of its sample points is visible.
VISIBLE_FRACTION = 0.5
_SHRINK = 0.8


def object_points(world: World, name: str) -> np.ndarray:
    """World points used for visibility: 8 corners shrunk towards the centre, the centre of the
    top face and the centre (10, 3)."""
    hx, hy, hz = (_SHRINK * h for h in world.half_extents[name])
    local = [(sx * hx, sy * hy, sz * hz) for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]
    local += [(0.0, 0.0, hz), (0.0, 0.0, 0.0)]
    wp = world.object_pose(name)
    return np.array([multiply(wp, pose(pt))[0] for pt in local])


def visible_fraction(world: World, name: str) -> float:
    """Fraction of the object's sample points in the camera's line of sight."""
    pts = object_points(world, name)
    vis = world.camera.visible(pts, ignore=(world.objects[name],))
    return float(np.mean(vis))


def is_visible(world: World, name: str) -> bool:
    return visible_fraction(world, name) >= VISIBLE_FRACTION


def observe(
    world: World, rng: np.random.Generator, model: ObservationModel | None = None
) -> dict[str, tuple[float, float, float, float]]:
    """One camera frame: ``{object: noisy (x, y, z, yaw)}`` for the objects detected.

    Objects in the hand and objects not in the scene are not reported.  Randomness (false
    negatives, noise) comes from ``rng`` only, in a fixed object order.
    """
    model = ObservationModel() if model is None else model
    out = {}
    for name in sorted(world.objects):
        if world.support[name] is None:
            continue
        (x, y, z), quat = world.object_pose(name)
        true = np.array([x, y, z, yaw_of(quat)])
        det = model.sample_detection(true, is_visible(world, name), rng)
        if det is not None:
            out[name] = tuple(float(v) for v in det)
    return out
