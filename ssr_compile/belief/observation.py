"""Observation streams on pose beliefs (paper §IV-A, §V-A, §V-B, §V-C).

* :class:`BeliefParameters`: a domain's ``eps``, ``delta``, costs ``c`` and ``c'``, and
  observation model (``p_FN``, noise), in one place.
* ``sample-obs``: :func:`sample_obs` yields hypothesised observations ``?obs = (z, X_i, eps)``.
* ``test-vis`` / ``BVis``: :func:`visibility_lower_bound` estimates ``L_j(X_i)`` by ray casting
  and :func:`bvis` tests ``L_j(X_i) >= 1 - eps``; :func:`blocking_bodies` evaluates the derived
  predicate ``BOccluded`` by listing every body for which BVis fails.
* ``ObsCost``: :func:`obs_cost`, eq. 2's lower bound inside self-loop determinization (§V-A).
* ``update-belief``: :func:`update_belief`, the posterior assuming the hypothesised detection.
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Collection, Iterator, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from .determinize import self_loop_cost
from .particles import ObservationModel, PoseBelief, derived_rng, update, wrap_angle
from .visibility import Visibility, bodies_at


@dataclass(frozen=True)
class BeliefParameters:
    """The parameters of a domain's belief streams (paper §V); the paper gives no numbers, and
    the shipped domains use these defaults.

    ``eps``: occlusion tolerance of an observation (§V-B); ``delta``: radius of an observation's
    region ``X_i`` in metres (about twice the size of the kitchen's objects); ``c_detect``: the
    cost ``c`` of one detection and ``c_recover`` the cost ``c'`` of a failed one, after which
    the robot looks again (self-loop determinization, §V-A); ``model``: the detector's
    false-negative probability ``p_FN`` and pose noise (:class:`ObservationModel`).
    """

    eps: float = 0.1
    delta: float = 0.1
    c_detect: float = 1.0
    c_recover: float = 1.0
    model: ObservationModel = field(default_factory=ObservationModel)


DEFAULTS = BeliefParameters()


def _readonly(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=float, copy=True)
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class ObsRegion:
    """``X_i``: the poses where the object is expected (paper §V-B).

    From :func:`sample_obs` it is ``{x' in B_delta(x_i) : P(x') > 0}``: the particles of the
    source belief (digest ``source``) on the surface of ``x_i`` within planar distance ``delta`` of
    it, with their ``indices``.  A hand-made region (``from_poses``) has no source.
    """

    surface: str
    poses: np.ndarray
    center: np.ndarray
    delta: float
    indices: tuple[int, ...] = ()
    source: str | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "poses", _readonly(np.asarray(self.poses).reshape(-1, 4)))
        object.__setattr__(self, "center", _readonly(np.asarray(self.center).reshape(4)))
        object.__setattr__(self, "indices", tuple(int(i) for i in self.indices))

    @classmethod
    def from_poses(cls, surface: str, poses: np.ndarray) -> ObsRegion:
        """A region made of explicit poses (e.g. the x1, x2, x3 of paper Fig. 2)."""
        poses = np.asarray(poses, dtype=float).reshape(-1, 4)
        center = poses.mean(axis=0)
        delta = float(np.max(np.linalg.norm(poses[:, :2] - center[:2], axis=1)))
        return cls(surface, poses, center, delta)

    def key(self) -> str:
        h = hashlib.sha1(repr((self.surface, self.delta, self.indices, self.source)).encode())
        h.update(self.poses.tobytes())
        h.update(self.center.tobytes())
        return h.hexdigest()

    def mass(self, pb: PoseBelief) -> float:
        """``P(X_i)`` under ``pb``: the indexed particles if ``pb`` is the source belief, else the
        particles of ``pb`` on the same surface within ``delta`` of the centre."""
        if self.source == pb.digest:
            return pb.mass(self.indices)
        near = np.linalg.norm(pb.poses[:, :2] - self.center[:2], axis=1) <= self.delta + 1e-12
        return float(pb.weights[near & (pb.surface_names == self.surface)].sum())


@dataclass(frozen=True, eq=False)
class Observation:
    """``?obs = (z, X_i, eps)`` for object ``obj`` (paper §V-B): a hypothesised detection at
    ``z`` (x, y, z, yaw), the region ``X_i`` and the occlusion tolerance ``eps``."""

    obj: str
    z: np.ndarray
    region: ObsRegion
    eps: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "z", _readonly(np.asarray(self.z).reshape(4)))
        if not 0.0 <= self.eps < 1.0:
            raise ValueError(f"eps must lie in [0, 1), got {self.eps}")

    @property
    def digest(self) -> str:
        h = hashlib.sha1(repr((self.obj, self.eps, self.region.key())).encode())
        h.update(self.z.tobytes())
        return h.hexdigest()

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Observation) and self.digest == other.digest

    def __hash__(self) -> int:
        return int(self.digest[:15], 16)

    def __repr__(self) -> str:
        x, y, z, yaw = self.z
        return (
            f"Obs({self.obj} z=({x:.3f}, {y:.3f}, {z:.3f}, {math.degrees(yaw):.0f}deg) "
            f"X={self.region.surface}[{len(self.region.poses)}] eps={self.eps:g})"
        )


def sample_obs(
    obj: str,
    pb: PoseBelief,
    rng: np.random.Generator,
    *,
    delta: float = DEFAULTS.delta,
    eps: float = DEFAULTS.eps,
    heaviest_first: bool = False,
    among: np.ndarray | None = None,
) -> Iterator[tuple[Observation]]:
    """The ``sample-obs`` stream (paper §IV-A, §V-B): lazy ``(obs,)`` tuples.

    Each observation takes a particle ``x_i``, ``z = x_i`` (the determinized outcome: the
    object is seen where it is hypothesised) and ``X_i`` = the positive-weight particles on the
    same surface within planar distance ``delta`` of ``x_i``.  ``among`` (bool, one per
    particle) restricts both ``x_i`` and ``X_i`` to some particles (for instance those on one
    surface that the camera can see at all).

    By default the draws are endless and ``x_i`` is drawn by weight.  With ``heaviest_first``,
    the observations are a finite enumeration of distinct regions, heaviest first: ``x_i`` is a
    particle whose neighbourhood holds the most probability not yet covered by an earlier
    region (ties broken by ``rng``), and the stream ends when every particle is covered.  The
    Focused solver evaluates one output per level, so the planner first sees the observations
    most likely to succeed -- the order the shipped domains use.
    """
    if obj != pb.obj:
        raise ValueError(f"belief is over {pb.obj!r}, not {obj!r}")
    on = pb.weights > 0
    if among is not None:
        on &= np.asarray(among, dtype=bool)
    if not on.any():
        return
    if heaviest_first:
        yield from _heaviest_first(obj, pb, rng, on, delta, eps)
        return
    p = pb.weights if among is None else np.where(on, pb.weights, 0.0) / pb.weights[on].sum()
    while True:
        i = int(rng.choice(len(pb), size=1, p=p)[0])
        near = np.linalg.norm(pb.poses[:, :2] - pb.poses[i, :2], axis=1) <= delta
        members = np.flatnonzero(near & (pb.labels == pb.labels[i]) & on)
        yield (_observation(obj, pb, i, members, delta, eps),)


def _heaviest_first(obj, pb: PoseBelief, rng, on: np.ndarray, delta: float, eps: float):
    dist = np.linalg.norm(pb.poses[:, None, :2] - pb.poses[None, :, :2], axis=2)
    same = pb.labels[:, None] == pb.labels[None, :]
    near = (dist <= delta) & same & on[None, :]
    covered = ~on
    while not covered.all():
        gain = near @ np.where(covered, 0.0, pb.weights)
        gain[covered] = -1.0
        best = np.flatnonzero(gain >= gain.max() - 1e-9)
        i = int(rng.choice(best))
        members = np.flatnonzero(near[i])
        covered[members] = True
        yield (_observation(obj, pb, i, members, delta, eps),)


def _observation(obj, pb: PoseBelief, i: int, members, delta: float, eps: float) -> Observation:
    """``(z, X_i, eps)`` for the particle ``i`` and the region of the particles ``members``."""
    region = ObsRegion(
        str(pb.surface_names[i]), pb.poses[members], pb.poses[i], delta, members, pb.digest
    )
    return Observation(obj, pb.poses[i], region, eps)


def box_points(poses: np.ndarray, half_extents: Sequence[float], inset: float = 0.8) -> np.ndarray:
    """Test points of an axis-aligned box (in its own frame) at each pose: the centre and the
    8 corners pulled towards the centre by ``inset``.  Returns (N, 9, 3) world points."""
    poses = np.asarray(poses, dtype=float).reshape(-1, 4)
    h = np.asarray(half_extents, dtype=float) * inset
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    local = np.vstack([np.zeros(3), signs * h])  # (9, 3)
    c, s = np.cos(poses[:, 3]), np.sin(poses[:, 3])
    wx = c[:, None] * local[None, :, 0] - s[:, None] * local[None, :, 1]
    wy = s[:, None] * local[None, :, 0] + c[:, None] * local[None, :, 1]
    return np.stack([wx, wy, np.broadcast_to(local[:, 2], wx.shape)], axis=-1) + poses[:, None, :3]


def _pose_visibility(
    poses: np.ndarray,
    visibility: Visibility,
    half_extents: Sequence[float],
    ignore: Collection[int],
    min_visible_fraction: float,
) -> np.ndarray:
    pts = box_points(poses, half_extents)
    vis = visibility.visible(pts.reshape(-1, 3), ignore=ignore).reshape(pts.shape[:2])
    return vis.mean(axis=1) >= min_visible_fraction - 1e-12


def visibility_mask(
    pb: PoseBelief,
    visibility: Visibility,
    half_extents: Sequence[float],
    *,
    ignore: Collection[int] = (),
    min_visible_fraction: float = 0.5,
) -> np.ndarray:
    """Which particles of ``pb`` would be visible (bool (N,)), for :func:`ssr_compile.belief.particles.update`.

    Rule: a pose is visible when at least ``min_visible_fraction`` of its 9 box test points
    (:func:`box_points`) are visible -- a detector needs a good part of the object in view.
    ``ignore`` should contain the object's own body (else it hides its own centre).  All rays
    go in one batched call.
    """
    return _pose_visibility(pb.poses, visibility, half_extents, ignore, min_visible_fraction)


def visibility_lower_bound(
    obs: Observation,
    body_j: int,
    pb_j: PoseBelief | None,
    visibility: Visibility,
    *,
    half_extents: Sequence[float],
    k: int = 16,
    rng: np.random.Generator | None = None,
    ignore: Collection[int] | None = None,
    min_visible_fraction: float = 0.5,
) -> float:
    """``L_j(X_i) = inf_{x_i in X_i} E_{x_j ~ pb_j}[1 - B_j^i(x_i, x_j)]`` (paper §V-B).

    Body ``j`` is put at poses ``x_j`` from ``pb_j`` (all particles with their weights when there
    are at most ``k``, so a point belief is exact; otherwise ``k`` weighted draws, each ``1/k``);
    ``pb_j = None`` keeps body ``j`` where it is (the robot, a drawer).  ``B_j^i`` counts only
    body ``j``: every other body is ignored (by default all bodies the camera knows of except
    ``j``; pass ``ignore`` for a visibility without a ``bodies()`` method).  ``x_i`` is visible
    under the rule of :func:`visibility_mask` (box ``half_extents`` of object ``i``).  One batched
    ray cast per sampled ``x_j`` covers every ``x_i`` in ``X_i``.
    """
    poses_i = obs.region.poses
    if len(poses_i) == 0:
        return 1.0
    if ignore is None:
        bodies = getattr(visibility, "bodies", None)
        if bodies is None:
            raise TypeError("pass `ignore`: this visibility cannot list its bodies")
        ignore = [b for b in bodies() if b != body_j]
    if pb_j is None:
        samples, weights = [None], np.ones(1)
    elif len(pb_j) <= k:
        samples, weights = list(pb_j.poses), pb_j.weights
    else:
        rng = rng or derived_rng(obs.digest, pb_j.digest, body_j)
        samples, weights = list(pb_j.poses[pb_j.sample_indices(rng, k)]), np.full(k, 1.0 / k)
    client = getattr(visibility, "client", 0)
    expected = np.zeros(len(poses_i))
    for pose_j, w in zip(samples, weights, strict=True):
        placement = {} if pose_j is None else {body_j: tuple(pose_j)}
        with bodies_at(client, placement):
            vis = _pose_visibility(poses_i, visibility, half_extents, ignore, min_visible_fraction)
        expected += w * vis
    return float(expected.min())


def bvis(
    obs: Observation,
    body_j: int,
    pb_j: PoseBelief | None,
    visibility: Visibility,
    **kwargs: object,
) -> bool:
    """The ``test-vis`` stream / ``BVis ?o ?obs ?o2 ?pb2`` (paper §IV-A): body ``j`` under
    ``pb_j`` leaves ``X_i`` visible with probability at least ``1 - eps``, i.e.
    ``L_j(X_i) >= 1 - eps``.  Keyword arguments go to :func:`visibility_lower_bound`."""
    return visibility_lower_bound(obs, body_j, pb_j, visibility, **kwargs) >= 1.0 - obs.eps - 1e-12  # type: ignore[arg-type]


def blocking_bodies(
    obs: Observation,
    beliefs: Mapping[int, PoseBelief | None],
    visibility: Visibility,
    **kwargs: object,
) -> list[int]:
    """Bodies for which BVis fails; ``BOccluded`` (paper §IV-A) holds iff this is non-empty."""
    return [b for b, pb in beliefs.items() if not bvis(obs, b, pb, visibility, **kwargs)]


def detection_probability_bound(
    obs: Observation, pb: PoseBelief, n_objects: int, p_fn: float
) -> float:
    """Eq. 2 of paper §V-B: ``p >= (1 - p_fn) P(X_i) (1 - eps)^(n - 1)``.

    The paper prints ``p_FN`` as the first factor, but the detection probability given
    visibility is ``P(Z^d = 1 | Z^v = 1) = 1 - p_FN`` (stated just above eq. 1), so ``1 - p_fn``
    is meant.  ``P(X_i)`` is the belief's mass of the region (:meth:`ObsRegion.mass`).
    """
    if n_objects < 1:
        raise ValueError("n_objects counts the object itself, so it is at least 1")
    return (1.0 - p_fn) * obs.region.mass(pb) * (1.0 - obs.eps) ** (n_objects - 1)


def obs_cost(
    obs: Observation,
    pb: PoseBelief,
    n_objects: int,
    c: float = DEFAULTS.c_detect,
    c_fail: float = DEFAULTS.c_recover,
    model: ObservationModel | None = None,
) -> float:
    """``ObsCost ?o ?pb ?obs`` (paper §V-A, §V-B): self-loop determinized cost
    ``c + c_fail / p - c_fail`` with ``p`` the eq. 2 bound; ``inf`` when ``p = 0``."""
    p = detection_probability_bound(obs, pb, n_objects, (model or DEFAULTS.model).p_fn)
    return self_loop_cost(c, c_fail, min(max(p, 0.0), 1.0))


def update_belief(
    obj: str,
    pb1: PoseBelief,
    obs: Observation,
    model: ObservationModel | None = None,
    *,
    visible_mask: np.ndarray | None = None,
    **kwargs: object,
) -> PoseBelief:
    """The ``update-belief`` stream (paper §IV-A): the posterior of ``pb1`` assuming the
    hypothesised detection ``obs.z`` (the planner's determinized outcome).  Every particle is
    taken as visible unless ``visible_mask`` says otherwise (detect is only applicable when
    ``X_i`` is not BOccluded).  Deterministic: same inputs, same posterior."""
    if not obj == pb1.obj == obs.obj:
        raise ValueError(f"object mismatch: {obj!r}, belief {pb1.obj!r}, obs {obs.obj!r}")
    mask = np.ones(len(pb1), dtype=bool) if visible_mask is None else visible_mask
    z = obs.z.copy()
    z[3] = float(wrap_angle(z[3]))
    return update(pb1, z, mask, model, **kwargs)  # type: ignore[arg-type]
