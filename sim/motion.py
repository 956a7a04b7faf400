"""RRT-Connect (Kuffner & LaValle 2000) in joint space, plus path utilities (paper §IV).

Written for this project (``pybullet-planning`` installs, but it is not a declared dependency
of the distribution and keeps a global pybullet client).  Everything random goes through the
``numpy.random.Generator`` passed in, so a seed fixes the path.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence

import numpy as np

Conf = tuple[float, ...]
CollisionFn = Callable[[np.ndarray], bool]


def interpolate(q1: Sequence[float], q2: Sequence[float], resolution: Sequence[float] | float):
    """Configurations from ``q1`` (excluded) to ``q2`` (included), steps <= ``resolution``
    per joint."""
    a, b = np.asarray(q1, float), np.asarray(q2, float)
    n = int(np.ceil(np.max(np.abs(b - a) / np.asarray(resolution, float)))) if len(a) else 0
    n = max(n, 1)
    return [a + (b - a) * (i / n) for i in range(1, n + 1)]


def segment_free(q1, q2, collision: CollisionFn, resolution) -> bool:
    return not any(collision(q) for q in interpolate(q1, q2, resolution))


def refine(path: Sequence[Sequence[float]], resolution) -> list[Conf]:
    """A path densified so that consecutive waypoints differ by <= ``resolution``."""
    if not path:
        return []
    out = [tuple(float(v) for v in path[0])]
    for a, b in zip(path[:-1], path[1:], strict=True):
        out.extend(tuple(float(v) for v in q) for q in interpolate(a, b, resolution))
    return out


class _Tree:
    def __init__(self, root: np.ndarray) -> None:
        self.nodes = [root]
        self.parents = [-1]

    def nearest(self, q: np.ndarray, weights: np.ndarray) -> int:
        d = np.sum(((np.asarray(self.nodes) - q) * weights) ** 2, axis=1)
        return int(np.argmin(d))

    def add(self, q: np.ndarray, parent: int) -> int:
        self.nodes.append(q)
        self.parents.append(parent)
        return len(self.nodes) - 1

    def path_to(self, i: int) -> list[np.ndarray]:
        out = []
        while i >= 0:
            out.append(self.nodes[i])
            i = self.parents[i]
        return out[::-1]


def _extend(tree: _Tree, target: np.ndarray, step: float, collision, resolution, weights):
    """Grow ``tree`` from its nearest node towards ``target`` until reached or blocked.
    Returns (index of last node, reached)."""
    i = tree.nearest(target, weights)
    q = tree.nodes[i]
    while True:
        delta = target - q
        dist = float(np.linalg.norm(delta * weights))
        if dist < 1e-9:
            return i, True
        nxt = target if dist <= step else q + delta * (step / dist)
        if not segment_free(q, nxt, collision, resolution):
            return i, False
        i = tree.add(nxt, i)
        q = nxt
        if nxt is target:
            return i, True


def shortcut(path, collision, resolution, rng: np.random.Generator, iterations: int = 40):
    """Random shortcutting: replace a sub-path by a straight segment when it is free."""
    path = [np.asarray(q, float) for q in path]
    for _ in range(iterations):
        if len(path) <= 2:
            break
        i, j = sorted(rng.choice(len(path), size=2, replace=False))
        if j - i < 2:
            continue
        if segment_free(path[i], path[j], collision, resolution):
            path = path[: i + 1] + path[j:]
    return path


def rrt_connect(
    start: Sequence[float],
    goal: Sequence[float],
    sample: Callable[[], np.ndarray],
    collision: CollisionFn,
    rng: np.random.Generator,
    *,
    resolution: Sequence[float] | float = 0.05,
    step: float = 0.4,
    weights: Sequence[float] | None = None,
    max_iterations: int = 400,
    max_time: float = 5.0,
    smooth: int = 40,
) -> list[Conf] | None:
    """A collision-free path ``start -> goal`` (waypoints; use :func:`refine` to densify), or
    None.  ``collision(q)`` is True when ``q`` collides; edges are checked at ``resolution``."""
    q0, q1 = np.asarray(start, float), np.asarray(goal, float)
    if collision(q0) or collision(q1):
        return None
    if segment_free(q0, q1, collision, resolution):
        return [tuple(map(float, q0)), tuple(map(float, q1))]
    w = np.ones(len(q0)) if weights is None else np.asarray(weights, float)
    ta, tb = _Tree(q0), _Tree(q1)
    deadline = time.monotonic() + max_time
    for _ in range(max_iterations):
        if time.monotonic() > deadline:
            break
        target = np.asarray(sample(), float)
        ia, _ = _extend(ta, target, step, collision, resolution, w)
        ib, reached = _extend(tb, ta.nodes[ia], step, collision, resolution, w)
        if reached:
            pa, pb = ta.path_to(ia), tb.path_to(ib)
            path = pa + pb[::-1][1:]
            if ta.nodes[0] is not q0:
                path = path[::-1]
            path = shortcut(path, collision, resolution, rng, smooth)
            return [tuple(float(v) for v in q) for q in path]
        ta, tb = tb, ta  # alternate which tree explores
    return None
