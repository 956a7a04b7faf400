"""Line-of-sight visibility from a camera fixed in the world frame (paper §III, §V-B).

The paper's camera is an RGB-D sensor fixed to the world frame; an object pose is observable when
nothing blocks the line of sight.  Everything that is a body in the PyBullet scene occludes:
objects, the links of articulated bodies (drawers, doors) and the robot.

Ray-hit convention
------------------
``p.rayTestBatch`` reports only the *first* hit of each ray.  Two things could make that first
hit wrong for a visibility query, and this module handles both:

* **The target's own surface.**  Query points usually lie on the surface of the object being
  looked at, so the ray would hit that surface exactly at the point.  Every ray is therefore
  shortened by ``surface_tol`` (1 mm by default) before the point: a surface reached within
  ``surface_tol`` of the point does not count as occlusion.
* **Ignored bodies.**  A body listed in ``ignore`` (typically the target object itself, whose
  front face would otherwise hide its own centre) must not occlude, but if it were hit first it
  would mask a real occluder behind it.  The ignored bodies are therefore *moved away* for the
  duration of the cast (``bodies_at`` puts them far below the scene, at distinct places, and
  restores their exact poses afterwards, also on error).  Rays then report the first hit among
  the remaining bodies, in one batched call.  Links of an articulated body move with its base.
"""

from __future__ import annotations

from collections.abc import Collection, Iterator, Mapping, Sequence
from contextlib import contextmanager
from typing import Protocol

import numpy as np
import pybullet as p

#: Rays per ``p.rayTestBatch`` call.  pybullet refuses more than MAX_RAY_INTERSECTION_BATCH_SIZE
#: (16384) and, with exactly that many, silently drops the last result (pybullet 3.2.x), so one less.
MAX_RAY_BATCH = int(getattr(p, "MAX_RAY_INTERSECTION_BATCH_SIZE", 16384)) - 1

#: Where ignored bodies are parked during a cast (far below and away from any scene).
_PARKING = np.array([1.0e4, 1.0e4, -1.0e4])

# A pose is either ``(position, quaternion_xyzw)`` or ``(x, y, z, yaw)``.
Pose = tuple[Sequence[float], Sequence[float]] | Sequence[float]


class Visibility(Protocol):
    """Anything that answers line-of-sight queries for world-frame points."""

    def visible(self, points: np.ndarray, ignore: Collection[int] = ()) -> np.ndarray:
        """``points`` (N, 3) in the world frame -> bool (N,): True when the segment from the
        camera to the point hits no body except those whose unique id is in ``ignore``."""
        ...


def as_pos_quat(pose: Pose) -> tuple[tuple[float, float, float], tuple[float, float, float, float]]:
    """Normalise a pose to ``((x, y, z), (qx, qy, qz, qw))``.

    Accepts ``(position, quaternion)`` (pybullet's convention) or a flat ``(x, y, z, yaw)``.
    """
    if len(pose) == 2:
        pos, quat = pose  # type: ignore[misc]
        pos_t = tuple(float(v) for v in pos)
        quat_t = tuple(float(v) for v in quat)
        if len(pos_t) != 3 or len(quat_t) != 4:
            raise ValueError(f"expected (position[3], quaternion[4]), got {pose!r}")
        return pos_t, quat_t  # type: ignore[return-value]
    if len(pose) == 4:
        x, y, z, yaw = (float(v) for v in pose)  # type: ignore[union-attr]
        return (x, y, z), (0.0, 0.0, float(np.sin(yaw / 2.0)), float(np.cos(yaw / 2.0)))
    raise ValueError(f"a pose is (position, quaternion) or (x, y, z, yaw), got {pose!r}")


@contextmanager
def bodies_at(client: int, placements: Mapping[int, Pose]) -> Iterator[None]:
    """Temporarily reset the base poses of some bodies, restoring them on exit (also on error).

    ``placements`` maps a body unique id to a pose, ``(position, quaternion)`` or
    ``(x, y, z, yaw)``.  Joint states are untouched; links of articulated bodies follow the base.
    No simulation step is taken, so nothing else in the scene changes.
    """
    saved: dict[int, tuple] = {}
    try:
        for body, pose in placements.items():
            if body not in saved:
                saved[body] = p.getBasePositionAndOrientation(body, physicsClientId=client)
            pos, quat = as_pos_quat(pose)
            p.resetBasePositionAndOrientation(body, pos, quat, physicsClientId=client)
        yield
    finally:
        for body, (pos, quat) in saved.items():
            p.resetBasePositionAndOrientation(body, pos, quat, physicsClientId=client)


class PyBulletCamera:
    """A camera fixed at ``eye`` in the world frame, answering visibility with ray casts.

    ``visible`` issues one ``p.rayTestBatch`` call per chunk of at most ``MAX_RAY_BATCH`` rays.
    ``max_range`` (metres), when given, makes points farther than that from the eye invisible.
    ``surface_tol`` is how far before the point each ray stops (see the module docstring).
    ``num_threads`` is passed to pybullet (0 lets it use all cores; results do not depend on it).
    ``rays_cast`` counts the rays cast so far (for benchmarks).
    """

    def __init__(
        self,
        eye: Sequence[float],
        *,
        client: int = 0,
        max_range: float | None = None,
        surface_tol: float = 1e-3,
        num_threads: int = 1,
    ) -> None:
        self.eye = np.asarray(eye, dtype=float).reshape(3)
        self.client = int(client)
        self.max_range = None if max_range is None else float(max_range)
        self.surface_tol = float(surface_tol)
        self.num_threads = int(num_threads)
        self.rays_cast = 0

    def __repr__(self) -> str:
        eye = ", ".join(f"{v:.3g}" for v in self.eye)
        return f"PyBulletCamera(eye=({eye}), client={self.client}, max_range={self.max_range})"

    def bodies(self) -> list[int]:
        """Unique ids of every body in this camera's physics client."""
        return [
            p.getBodyUniqueId(i, physicsClientId=self.client)
            for i in range(p.getNumBodies(physicsClientId=self.client))
        ]

    def visible(self, points: np.ndarray, ignore: Collection[int] = ()) -> np.ndarray:
        """See :class:`Visibility`.  Ignored bodies are parked away during the cast."""
        pts = np.asarray(points, dtype=float)
        if pts.ndim == 1:
            pts = pts.reshape(1, 3)
        if pts.ndim != 2 or pts.shape[1] != 3:
            raise ValueError(f"points must have shape (N, 3), got {pts.shape}")
        result = np.zeros(len(pts), dtype=bool)
        if len(pts) == 0:
            return result
        offsets = pts - self.eye
        dist = np.linalg.norm(offsets, axis=1)
        in_range = np.isfinite(dist)
        if self.max_range is not None:
            in_range &= dist <= self.max_range
        # Points within surface_tol of the eye are trivially visible (nothing fits in between).
        near = in_range & (dist <= self.surface_tol)
        result[near] = True
        cast = np.flatnonzero(in_range & ~near)
        if len(cast) == 0:
            return result
        scale = (dist[cast] - self.surface_tol) / dist[cast]
        targets = self.eye + offsets[cast] * scale[:, None]
        parking = {
            int(body): (tuple(_PARKING + np.array([10.0 * k, 0.0, 0.0])), (0.0, 0.0, 0.0, 1.0))
            for k, body in enumerate(sorted({int(b) for b in ignore}))
        }
        hits = np.empty(len(cast), dtype=bool)
        with bodies_at(self.client, parking):
            for start in range(0, len(cast), MAX_RAY_BATCH):
                chunk = targets[start : start + MAX_RAY_BATCH]
                froms = np.ascontiguousarray(np.broadcast_to(self.eye, chunk.shape))
                out = p.rayTestBatch(  # numpy arrays go in directly: no list conversion
                    froms,
                    np.ascontiguousarray(chunk),
                    numThreads=self.num_threads,
                    physicsClientId=self.client,
                )
                if len(out) != len(chunk):
                    raise RuntimeError(f"rayTestBatch returned {len(out)} results for {len(chunk)}")
                hits[start : start + len(chunk)] = [r[0] >= 0 for r in out]
                self.rays_cast += len(chunk)
        result[cast] = ~hits
        return result
