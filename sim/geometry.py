"""Small rigid-transform helpers (poses as ``(position, quaternion_xyzw)``), pure numpy.

Kept independent of a pybullet connection so that streams and tasks can do pose algebra
without a client.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]
Pose = tuple[Vec3, Quat]

IDENTITY_QUAT: Quat = (0.0, 0.0, 0.0, 1.0)


def norm(v) -> float:
    """Euclidean norm of a vector: the arithmetic of ``np.linalg.norm`` (``sqrt(v.dot(v))``,
    so the same float), without its argument handling (it is called a million times an
    episode)."""
    a = np.asarray(v, dtype=float)
    return math.sqrt(a.dot(a))


def pose(pos: Sequence[float], quat: Sequence[float] = IDENTITY_QUAT) -> Pose:
    """Normalise to a tuple-of-floats pose (hashable, comparable)."""
    if quat is IDENTITY_QUAT:  # the default: already a unit quaternion of floats
        return (tuple(map(float, pos)), IDENTITY_QUAT)  # type: ignore[return-value]
    q = np.asarray(quat, dtype=float)
    q = q / math.sqrt(q.dot(q))
    return (tuple(map(float, pos)), tuple(q.tolist()))  # type: ignore[return-value]


def quat_mul(a: Sequence[float], b: Sequence[float]) -> Quat:
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    )


def quat_inv(q: Sequence[float]) -> Quat:
    return (-q[0], -q[1], -q[2], q[3])


def quat_from_axis_angle(axis: Sequence[float], angle: float) -> Quat:
    ax = np.asarray(axis, dtype=float)
    ax = ax / np.linalg.norm(ax)
    s = math.sin(angle / 2.0)
    return (float(ax[0] * s), float(ax[1] * s), float(ax[2] * s), float(math.cos(angle / 2.0)))


def quat_from_yaw(yaw: float) -> Quat:
    return (0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0))


def quat_to_matrix(q: Sequence[float]) -> np.ndarray:
    x, y, z, w = q
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def matrix_to_quat(m: np.ndarray) -> Quat:
    tr = m[0, 0] + m[1, 1] + m[2, 2]
    if tr > 0:
        s = np.sqrt(tr + 1.0) * 2
        q = ((m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s, 0.25 * s)
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = np.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2]) * 2
        q = (0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s, (m[2, 1] - m[1, 2]) / s)
    elif m[1, 1] > m[2, 2]:
        s = np.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2]) * 2
        q = ((m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s, (m[0, 2] - m[2, 0]) / s)
    else:
        s = np.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1]) * 2
        q = ((m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s, (m[1, 0] - m[0, 1]) / s)
    n = np.linalg.norm(q)
    return tuple(float(v / n) for v in q)  # type: ignore[return-value]


def rotate(q: Sequence[float], v: Sequence[float]) -> np.ndarray:
    return quat_to_matrix(q) @ np.asarray(v, dtype=float)


def multiply(*poses: Pose) -> Pose:
    """Compose transforms left to right: ``multiply(A, B)`` is A∘B."""
    pos = np.zeros(3)
    quat: Quat = IDENTITY_QUAT
    for p_, q_ in poses:
        pos = pos + rotate(quat, p_)
        quat = quat_mul(quat, q_)
    return pose(pos, quat)


def invert(p_: Pose) -> Pose:
    qi = quat_inv(p_[1])
    return pose(-rotate(qi, p_[0]), qi)


def yaw_of(q: Sequence[float]) -> float:
    x, y, z, w = q
    return math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


def angle_between(q1: Sequence[float], q2: Sequence[float]) -> float:
    """Rotation angle (rad) between two orientations."""
    d = abs(float(np.dot(np.asarray(q1, float), np.asarray(q2, float))))
    return 2.0 * math.acos(min(1.0, d))


def wrap_angle(a: float) -> float:
    return float((a + np.pi) % (2 * np.pi) - np.pi)


def bases_near(a, b, tol: tuple[float, float]) -> bool:
    """Base configurations ``(x, y, yaw)`` within ``tol = (metres, radians)`` of each other
    along each axis (yaw wrapped)."""
    dxy, dyaw = tol
    return (
        abs(a[0] - b[0]) <= dxy
        and abs(a[1] - b[1]) <= dxy
        and abs(wrap_angle(float(a[2]) - float(b[2]))) <= dyaw
    )


def pose2d(x: float, y: float, z: float, yaw: float) -> Pose:
    return pose((x, y, z), quat_from_yaw(yaw))
