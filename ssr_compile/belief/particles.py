"""Particle pose beliefs and their Bayesian update (paper §III, §IV-A, §V-B).

The paper maintains a factored belief: one particle filter per object over its pose (§III,
Fig. 3).  A :class:`PoseBelief` is an immutable set of weighted particles over
(supporting surface, pose) with poses ``(x, y, z, yaw)`` in the world frame: the pose of the
object's body frame, which for the box objects used here is the box centre, so a particle on a
surface has ``z = surface.z + z_offset`` (``z_offset`` = half the object's height).

The detection model (§V-B): no false positives, a false negative with probability ``p_fn`` when
the object is visible, and a Gaussian pose measurement ``z ~ N(x, Sigma)`` when detected.
:func:`update` is the deterministic Bayesian filter step given what was (or was not) observed;
the planner-facing streams (sample-obs, test-vis/BVis, ObsCost, update-belief) are in
:mod:`ssr_compile.belief.observation`.
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

Region = Callable[[np.ndarray, np.ndarray], np.ndarray] | tuple[Sequence[float], Sequence[float]]


def wrap_angle(a: np.ndarray | float) -> np.ndarray:
    """Wrap angles to ``[-pi, pi)``."""
    return (np.asarray(a, dtype=float) + np.pi) % (2.0 * np.pi) - np.pi


def logsumexp(a: np.ndarray) -> float:
    """``log(sum(exp(a)))`` without overflow; ``-inf`` when every entry is ``-inf``."""
    a = np.asarray(a, dtype=float)
    if a.size == 0:
        return -math.inf
    m = float(np.max(a))
    if not math.isfinite(m):
        return m
    return m + math.log(float(np.sum(np.exp(a - m))))


def _readonly(a: np.ndarray) -> np.ndarray:
    a = np.array(a, copy=True)
    a.setflags(write=False)
    return a


@dataclass(frozen=True)
class Surface:
    """A named axis-aligned supporting rectangle at height ``z`` (counter top, drawer floor...)."""

    name: str
    center: tuple[float, float]
    half_extents: tuple[float, float]
    z: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "center", tuple(float(v) for v in self.center))
        object.__setattr__(self, "half_extents", tuple(float(v) for v in self.half_extents))
        object.__setattr__(self, "z", float(self.z))
        if len(self.center) != 2 or len(self.half_extents) != 2:
            raise ValueError(f"surface {self.name!r}: center and half_extents are 2-D")
        if min(self.half_extents) < 0:
            raise ValueError(f"surface {self.name!r}: negative half extents")

    @property
    def area(self) -> float:
        return 4.0 * self.half_extents[0] * self.half_extents[1]

    def contains(self, xy: np.ndarray, margin: float = 1e-9) -> np.ndarray:
        """Bool per row of ``xy`` (N, 2): inside the rectangle (``margin`` tolerance)."""
        d = np.abs(np.atleast_2d(xy)[:, :2] - np.asarray(self.center))
        return np.all(d <= np.asarray(self.half_extents) + margin, axis=1)

    def clip(self, xy: np.ndarray) -> np.ndarray:
        """Project points (N, 2) onto the rectangle."""
        c, h = np.asarray(self.center), np.asarray(self.half_extents)
        return np.clip(np.atleast_2d(xy)[:, :2], c - h, c + h)

    def distance(self, xy: np.ndarray) -> np.ndarray:
        """Planar distance (N,) from points to the rectangle (0 inside)."""
        pts = np.atleast_2d(xy)[:, :2]
        return np.linalg.norm(pts - self.clip(pts), axis=1)

    def sample_xy(self, rng: np.random.Generator, n: int) -> np.ndarray:
        c, h = np.asarray(self.center), np.asarray(self.half_extents)
        return c + rng.uniform(-1.0, 1.0, size=(n, 2)) * h


def systematic_resample(
    weights: np.ndarray, rng: np.random.Generator, n: int | None = None
) -> np.ndarray:
    """Low-variance (systematic) resampling: indices of ``n`` particles, one uniform draw.

    Particle ``i`` is copied ``floor(n w_i)`` or ``ceil(n w_i)`` times (Thrun et al., Prob.
    Robotics, Table 4.4), so resampling an already uniform set returns every particle once.
    """
    w = np.asarray(weights, dtype=float)
    n = len(w) if n is None else int(n)
    cum = np.cumsum(w / w.sum())
    cum[-1] = 1.0
    positions = (rng.random() + np.arange(n)) / n
    return np.minimum(np.searchsorted(cum, positions, side="right"), len(w) - 1)


class PoseBelief:
    """Immutable weighted particles over (surface, pose) for one object (paper §III, Fig. 3).

    ``labels[i]`` indexes ``surfaces`` for particle ``i``; ``poses`` is (N, 4) ``(x, y, z, yaw)``;
    ``weights`` (N,) sum to 1.  Arrays are read-only copies.  Equality and hashing use a content
    digest, so two beliefs with identical particles are the same planner value.
    """

    __slots__ = ("obj", "surfaces", "labels", "poses", "weights", "z_offset", "_digest")

    def __init__(
        self,
        obj: str,
        surfaces: Sequence[Surface],
        labels: Sequence[int] | np.ndarray,
        poses: np.ndarray,
        weights: np.ndarray | None = None,
        z_offset: float = 0.0,
    ) -> None:
        poses = np.asarray(poses, dtype=float).reshape(-1, 4)
        labels = np.asarray(labels, dtype=np.int64).reshape(-1)
        n = len(poses)
        if n == 0 or len(labels) != n:
            raise ValueError(f"need >= 1 particle and one label per pose, got {n}, {len(labels)}")
        surfaces = tuple(surfaces)
        if labels.min() < 0 or labels.max() >= len(surfaces):
            raise ValueError("particle label out of range of the surfaces")
        if not np.all(np.isfinite(poses)):
            raise ValueError("particle poses must be finite")
        w = np.full(n, 1.0 / n) if weights is None else np.asarray(weights, dtype=float).reshape(-1)
        if len(w) != n or not np.all(np.isfinite(w)) or np.any(w < 0) or w.sum() <= 0:
            raise ValueError("weights must be finite, non-negative, not all zero, one per particle")
        poses = poses.copy()
        poses[:, 3] = wrap_angle(poses[:, 3])
        s = object.__setattr__
        s(self, "obj", str(obj))
        s(self, "surfaces", surfaces)
        s(self, "labels", _readonly(labels))
        s(self, "poses", _readonly(poses))
        s(self, "weights", _readonly(w / w.sum()))
        s(self, "z_offset", float(z_offset))
        s(self, "_digest", None)

    def __setattr__(self, name: str, value: object) -> None:
        raise AttributeError(f"PoseBelief is immutable (cannot set {name!r})")

    # ----------------------------------------------------------------- constructors
    @classmethod
    def uniform(
        cls,
        obj: str,
        surfaces: Sequence[Surface],
        n: int,
        rng: np.random.Generator,
        *,
        z_offset: float = 0.0,
        by_area: bool = True,
    ) -> PoseBelief:
        """``n`` equally weighted particles spread uniformly over ``surfaces`` (surface chosen
        proportionally to its area, or uniformly if ``by_area`` is False), yaw uniform."""
        surfaces = tuple(surfaces)
        probs = np.array([s.area if by_area else 1.0 for s in surfaces], dtype=float)
        if probs.sum() <= 0:
            probs = np.ones(len(surfaces))
        labels = np.sort(rng.choice(len(surfaces), size=n, p=probs / probs.sum()))
        poses = np.empty((n, 4))
        for k, surf in enumerate(surfaces):
            idx = np.flatnonzero(labels == k)
            poses[idx, :2] = surf.sample_xy(rng, len(idx))
            poses[idx, 2] = surf.z + z_offset
        poses[:, 3] = rng.uniform(-np.pi, np.pi, size=n)
        return cls(obj, surfaces, labels, poses, None, z_offset)

    @classmethod
    def point(
        cls, obj: str, surface: Surface, pose: Sequence[float], *, z_offset: float | None = None
    ) -> PoseBelief:
        """A known pose: one particle of weight 1 on ``surface``."""
        pose = np.asarray(pose, dtype=float).reshape(4)
        off = pose[2] - surface.z if z_offset is None else z_offset
        return cls(obj, (surface,), [0], pose[None, :], None, off)

    @classmethod
    def from_particles(
        cls,
        obj: str,
        surfaces: Sequence[Surface],
        labels: Sequence[str | int],
        poses: np.ndarray,
        weights: np.ndarray | None = None,
        *,
        z_offset: float = 0.0,
    ) -> PoseBelief:
        """Arbitrary particles; ``labels`` are surface names or indices into ``surfaces``."""
        surfaces = tuple(surfaces)
        index = {s.name: k for k, s in enumerate(surfaces)}
        ints = [index[lab] if isinstance(lab, str) else int(lab) for lab in labels]
        return cls(obj, surfaces, ints, poses, weights, z_offset)

    def with_log_weights(
        self, log_w: np.ndarray, labels: np.ndarray | None = None, poses: np.ndarray | None = None
    ) -> PoseBelief:
        """Same object and surfaces, new (log-space, unnormalised) weights and maybe particles."""
        log_w = np.asarray(log_w, dtype=float)
        total = logsumexp(log_w)
        if not math.isfinite(total):
            raise ValueError("all log-weights are -inf (or invalid): nothing to normalise")
        w = np.exp(log_w - total)
        labels = self.labels if labels is None else labels
        poses = self.poses if poses is None else poses
        return PoseBelief(self.obj, self.surfaces, labels, poses, w, self.z_offset)

    # ----------------------------------------------------------------- value semantics
    @property
    def digest(self) -> str:
        """SHA-1 of the content (object, surfaces, particles, weights)."""
        if self._digest is None:
            h = hashlib.sha1()
            h.update(repr((self.obj, self.surfaces, self.z_offset)).encode())
            for a in (self.labels, self.poses, self.weights):
                h.update(np.ascontiguousarray(a).tobytes())
            object.__setattr__(self, "_digest", h.hexdigest())
        return self._digest  # type: ignore[return-value]

    def __eq__(self, other: object) -> bool:
        return isinstance(other, PoseBelief) and self.digest == other.digest

    def __hash__(self) -> int:
        return int(self.digest[:15], 16)

    def __len__(self) -> int:
        return len(self.weights)

    def __repr__(self) -> str:
        name, est = self.point_estimate()
        x, y, z, yaw = est
        return (
            f"PoseBelief({self.obj}: n={len(self)} ess={self.ess():.1f} "
            f"{name}:{self.prob_surface(name):.2f} est=({x:.3f}, {y:.3f}, {z:.3f}, "
            f"{math.degrees(yaw):.0f}deg) #{self.digest[:6]})"
        )

    # ----------------------------------------------------------------- queries
    @property
    def surface_names(self) -> np.ndarray:
        """Surface name of each particle, (N,) object array."""
        return np.array([s.name for s in self.surfaces], dtype=object)[self.labels]

    def surface(self, name: str) -> Surface:
        for s in self.surfaces:
            if s.name == name:
                return s
        raise KeyError(name)

    def surface_probs(self) -> dict[str, float]:
        out: dict[str, float] = {}
        for k, s in enumerate(self.surfaces):
            out[s.name] = out.get(s.name, 0.0) + float(self.weights[self.labels == k].sum())
        return out

    def prob_surface(self, name: str) -> float:
        return self.surface_probs().get(name, 0.0)

    def mass(self, indices: Sequence[int] | np.ndarray) -> float:
        """Probability mass of the particles with these (distinct) indices."""
        return float(self.weights[np.unique(np.asarray(indices, dtype=np.int64))].sum())

    def region_mask(self, region: Region) -> np.ndarray:
        """Bool (N,): particles inside ``region``, either a predicate ``f(poses, names) -> bool``
        or an axis-aligned box ``(lo, hi)`` over the first 2 or 3 pose coordinates."""
        if callable(region):
            return np.asarray(region(self.poses, self.surface_names), dtype=bool).reshape(-1)
        lo, hi = (np.asarray(v, dtype=float) for v in region)
        d = len(lo)
        return np.all((self.poses[:, :d] >= lo) & (self.poses[:, :d] <= hi), axis=1)

    def prob_region(self, region: Region) -> float:
        return float(self.weights[self.region_mask(region)].sum())

    def most_likely_surface(self) -> str:
        probs = self.surface_probs()
        return max(probs, key=lambda k: (probs[k], k))

    def point_estimate(self) -> tuple[str, np.ndarray]:
        """Weighted mean pose over the particles of the most likely surface (circular mean for
        yaw), with that surface's name."""
        name = self.most_likely_surface()
        sel = self.surface_names == name
        w = self.weights[sel] / self.weights[sel].sum()
        pose = np.empty(4)
        pose[:3] = w @ self.poses[sel, :3]
        pose[3] = math.atan2(w @ np.sin(self.poses[sel, 3]), w @ np.cos(self.poses[sel, 3]))
        return name, pose

    def covariance(self, surface: str | None = None) -> np.ndarray:
        """Weighted 4x4 covariance of ``(x, y, z, yaw)`` (yaw deviations wrapped around the
        circular mean), over all particles or those of one surface."""
        sel = np.ones(len(self), bool) if surface is None else self.surface_names == surface
        if not sel.any():
            raise KeyError(f"no particle on surface {surface!r}")
        w = self.weights[sel] / self.weights[sel].sum()
        x = self.poses[sel]
        mean = w @ x
        mean[3] = math.atan2(w @ np.sin(x[:, 3]), w @ np.cos(x[:, 3]))
        dev = x - mean
        dev[:, 3] = wrap_angle(dev[:, 3])
        return (dev * w[:, None]).T @ dev

    def std(self, surface: str | None = None) -> np.ndarray:
        """Weighted standard deviation per axis ``(x, y, z, yaw)``."""
        return np.sqrt(np.maximum(np.diag(self.covariance(surface)), 0.0))

    def ess(self) -> float:
        """Effective sample size ``1 / sum w_i^2`` (N for uniform weights, 1 for one particle)."""
        return float(1.0 / np.sum(self.weights**2))

    def sample_indices(self, rng: np.random.Generator, k: int) -> np.ndarray:
        return rng.choice(len(self), size=k, p=self.weights)

    def sample(self, rng: np.random.Generator, k: int) -> list[tuple[str, np.ndarray]]:
        """``k`` draws (with replacement, by weight) of ``(surface name, pose)``."""
        names = self.surface_names
        return [(str(names[i]), self.poses[i].copy()) for i in self.sample_indices(rng, k)]

    def resample(self, rng: np.random.Generator) -> PoseBelief:
        """Systematic resampling to N equally weighted particles (ESS becomes N)."""
        idx = systematic_resample(self.weights, rng)
        return PoseBelief(
            self.obj, self.surfaces, self.labels[idx], self.poses[idx], None, self.z_offset
        )


def derived_rng(*parts: object) -> np.random.Generator:
    """A generator seeded from a digest of the inputs, so that functions of values stay
    deterministic (the same belief and observation always give the same posterior)."""
    h = hashlib.sha1()
    for part in parts:
        h.update(part.tobytes() if isinstance(part, np.ndarray) else repr(part).encode())
    return np.random.default_rng(int(h.hexdigest()[:16], 16))


@dataclass(frozen=True)
class ObservationModel:
    """Detector model of paper §V-B: no false positives, false-negative probability ``p_fn``,
    Gaussian pose noise ``N(x, Sigma)`` over ``(x, y, z, yaw)``.

    The paper gives no numbers.  Defaults: ``p_fn = 0.1`` (a detector that misses one visible
    object in ten), ``sigma = (1 cm, 1 cm, 1 cm, 5 deg)``, typical of RGB-D pose estimation of
    tabletop objects at 1-2 m.  ``cov`` (a 4x4 nested tuple) overrides ``sigma`` when given.
    """

    p_fn: float = 0.1
    sigma: tuple[float, float, float, float] = (0.01, 0.01, 0.01, math.radians(5.0))
    cov: tuple[tuple[float, ...], ...] | None = None
    _inv: np.ndarray = field(init=False, repr=False, compare=False)
    _logdet: float = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if not 0.0 <= self.p_fn <= 1.0:
            raise ValueError(f"p_fn must lie in [0, 1], got {self.p_fn}")
        cov = self.covariance
        if cov.shape != (4, 4) or not np.allclose(cov, cov.T):
            raise ValueError("cov must be a symmetric 4x4 matrix over (x, y, z, yaw)")
        sign, logdet = np.linalg.slogdet(cov)
        if sign <= 0:
            raise ValueError("cov must be positive definite")
        object.__setattr__(self, "_inv", np.linalg.inv(cov))
        object.__setattr__(self, "_logdet", float(logdet))

    @property
    def covariance(self) -> np.ndarray:
        if self.cov is not None:
            return np.asarray(self.cov, dtype=float)
        return np.diag(np.asarray(self.sigma, dtype=float) ** 2)

    def mahalanobis2(self, z: np.ndarray, poses: np.ndarray) -> np.ndarray:
        """Squared Mahalanobis distances (N,) between a detection and particles (yaw wrapped)."""
        with np.errstate(over="ignore", invalid="ignore"):
            d = np.asarray(poses, dtype=float).reshape(-1, 4) - np.asarray(z, dtype=float)
            d[:, 3] = wrap_angle(d[:, 3])
            m = np.einsum("ni,ij,nj->n", d, self._inv, d)
        return np.where(np.isnan(m), np.inf, m)

    def log_likelihood(self, z: np.ndarray, poses: np.ndarray) -> np.ndarray:
        """``log N(z; x_i, Sigma)`` for each particle ``x_i`` (N,)."""
        return -0.5 * (self.mahalanobis2(z, poses) + self._logdet + 4.0 * math.log(2.0 * math.pi))

    def sample_detection(
        self, true_pose: Sequence[float], visible: bool, rng: np.random.Generator
    ) -> np.ndarray | None:
        """Simulate the detector: ``None`` if occluded or missed (probability ``p_fn``),
        otherwise the true pose plus Gaussian noise (yaw wrapped)."""
        if not visible or rng.random() < self.p_fn:
            return None
        z = np.asarray(true_pose, dtype=float) + rng.multivariate_normal(
            np.zeros(4), self.covariance
        )
        z[3] = float(wrap_angle(z[3]))
        return z


def _reinvigorate(
    belief: PoseBelief,
    z: np.ndarray,
    model: ObservationModel,
    rng: np.random.Generator,
    frac: float,
    keep_mass: float,
) -> PoseBelief:
    """Replace ``round(frac N)`` particles by draws from ``N(z, Sigma)`` on the surface that
    contains the detection; the others are resampled from the *prior* (the deprived posterior
    has collapsed onto the least-bad particles, useless as a hedge) and together keep
    probability ``keep_mass``."""
    n = len(belief)
    n_new = min(n, max(1, round(frac * n)))
    xy = z[None, :2]
    height = np.array([abs(s.z + belief.z_offset - z[2]) for s in belief.surfaces])
    inside = np.array([bool(s.contains(xy)[0]) for s in belief.surfaces])
    planar = np.array([float(s.distance(xy)[0]) for s in belief.surfaces])
    k = (
        int(np.argmin(np.where(inside, height, np.inf)))
        if inside.any()
        else int(np.argmin(planar + height))
    )
    surf = belief.surfaces[k]
    center = surf.clip(xy)[0]
    std = np.sqrt(np.diag(model.covariance))
    new_xy = np.empty((n_new, 2))
    todo = np.arange(n_new)
    for _ in range(20):  # rejection sampling of the truncated Gaussian, then clip what is left
        cand = center + rng.normal(size=(len(todo), 2)) * std[:2]
        ok = surf.contains(cand)
        new_xy[todo[ok]] = cand[ok]
        todo = todo[~ok]
        if len(todo) == 0:
            break
    if len(todo):
        new_xy[todo] = surf.clip(center + rng.normal(size=(len(todo), 2)) * std[:2])
    new_poses = np.column_stack(
        [new_xy, np.full(n_new, surf.z + belief.z_offset), z[3] + rng.normal(size=n_new) * std[3]]
    )
    n_old = n - n_new
    old = systematic_resample(belief.weights, rng, n_old) if n_old else np.zeros(0, int)
    keep = keep_mass if n_old else 0.0
    weights = np.concatenate(
        [np.full(n_old, keep / max(n_old, 1)), np.full(n_new, (1 - keep) / n_new)]
    )
    labels = np.concatenate([belief.labels[old], np.full(n_new, k)])
    poses = np.vstack([belief.poses[old], new_poses])
    return PoseBelief(belief.obj, belief.surfaces, labels, poses, weights, belief.z_offset)


def kernel_bandwidth(belief: PoseBelief, scale: float | None = None) -> np.ndarray:
    """Per-particle diagonal kernel covariance (N, 4) of the regularised filter: Silverman's
    rule over the weighted spread of the particles *of the same surface* (so surfaces at
    different heights never mix), ``h = (4 / (N (d + 2)))^(1 / (d + 4))`` with ``d = 4``.
    A surface whose particles all coincide (a point belief) gets a zero kernel."""
    n = len(belief)
    h = (4.0 / (n * 6.0)) ** (1.0 / 8.0) if scale is None else float(scale)
    out = np.zeros((n, 4))
    for k in np.unique(belief.labels):
        sel = belief.labels == k
        w = belief.weights[sel]
        if w.sum() <= 0:
            continue
        w = w / w.sum()
        x = belief.poses[sel]
        mean = w @ x
        mean[3] = math.atan2(w @ np.sin(x[:, 3]), w @ np.cos(x[:, 3]))
        dev = x - mean
        dev[:, 3] = wrap_angle(dev[:, 3])
        var = w @ dev**2
        out[sel] = (h**2) * var
    return out


def _regularised_posterior(
    belief: PoseBelief,
    z: np.ndarray,
    mask: np.ndarray,
    model: ObservationModel,
    rng: np.random.Generator,
) -> PoseBelief | None:
    """Posterior of a detection ``z`` for the prior seen as a kernel density
    ``sum_i w_i N(x; x_i, H_i)`` (the regularised particle filter): a Gaussian mixture with
    components ``N(m_i, S_i)``, ``S_i = H_i - H_i (H_i + Sigma)^-1 H_i``,
    ``m_i = x_i + H_i (H_i + Sigma)^-1 (z - x_i)`` and weights ``w_i N(z; x_i, H_i + Sigma)``
    (visible particles only).  ``N`` equally weighted particles are drawn from it, so the
    reported spread is the posterior's (about the sensor noise after one detection from a
    broad prior), never the zero spread of copies of one prior particle.  Diagonal ``Sigma``
    only (else ``None``: the caller resamples plainly).  ``None`` too when no visible particle
    has positive weight."""
    cov = model.covariance
    if not np.allclose(cov, np.diag(np.diag(cov))):
        return None
    sig = np.diag(cov)
    H = kernel_bandwidth(belief)
    tot = H + sig  # (N, 4)
    d = z[None, :] - belief.poses
    d[:, 3] = wrap_angle(d[:, 3])
    with np.errstate(divide="ignore"):
        log_w = np.log(belief.weights) - 0.5 * np.sum(d**2 / tot + np.log(2 * np.pi * tot), axis=1)
    log_w = np.where(mask, log_w, -np.inf)
    total = logsumexp(log_w)
    if not math.isfinite(total):
        return None
    w = np.exp(log_w - total)
    n = len(belief)
    idx = systematic_resample(w, rng, n)
    gain = H[idx] / tot[idx]
    mean = belief.poses[idx] + gain * d[idx]
    var = H[idx] - gain * H[idx]
    poses = mean + rng.normal(size=(n, 4)) * np.sqrt(np.maximum(var, 0.0))
    labels = belief.labels[idx]
    for k in np.unique(labels):  # stay on the surface: clip x, y into it, z at its height
        sel = labels == k
        surf = belief.surfaces[k]
        poses[sel, :2] = surf.clip(poses[sel, :2])
    poses[:, 3] = wrap_angle(poses[:, 3])
    return PoseBelief(belief.obj, belief.surfaces, labels, poses, None, belief.z_offset)


def _jitter(belief: PoseBelief, rng: np.random.Generator) -> PoseBelief:
    """Rejuvenation after plain resampling: each copy moves by a draw of the regularised
    filter's kernel (:func:`kernel_bandwidth`), staying on its surface."""
    H = kernel_bandwidth(belief)
    if not np.any(H > 0):
        return belief
    poses = belief.poses + rng.normal(size=belief.poses.shape) * np.sqrt(H)
    for k in np.unique(belief.labels):
        sel = belief.labels == k
        poses[sel, :2] = belief.surfaces[k].clip(poses[sel, :2])
    return PoseBelief(
        belief.obj, belief.surfaces, belief.labels, poses, belief.weights, belief.z_offset
    )


def update(
    belief: PoseBelief,
    detection: np.ndarray | Sequence[float] | None,
    visible_mask: np.ndarray,
    model: ObservationModel | None = None,
    *,
    rng: np.random.Generator | None = None,
    resample_frac: float = 0.5,
    reinvig_mahalanobis: float = 5.0,
    reinvig_frac: float = 0.5,
    reinvig_keep_mass: float = 0.01,
    rejuvenate: bool = True,
) -> PoseBelief:
    """Bayesian filter step for one object (paper §V-B detection model), in log space.

    ``detection`` is a detected pose ``(x, y, z, yaw)``, an ``Observation`` (its ``z`` is used)
    or ``None`` for a miss; ``visible_mask`` (N,) says which particles the camera could see
    (see :func:`ssr_compile.belief.observation.visibility_mask`).

    * Detection ``z``: ``w_i <- w_i (1 - p_fn) N(z; x_i, Sigma)`` for visible particles and
      ``w_i <- 0`` for occluded ones (no false positives: an occluded object is never detected).
    * Miss (``detection is None``): ``w_i <- w_i p_fn`` for visible particles, unchanged for
      occluded ones.  If that zeroes everything (``p_fn = 0`` and every particle visible, a miss
      the model calls impossible) the prior is returned unchanged: the model has no answer.
    * Weights are normalised with log-sum-exp, so tiny likelihoods never underflow to NaN.
    * Particle deprivation -> reinvigoration.  If a detection is explained by no particle --
      the normaliser is ``-inf``, or the nearest visible particle of positive weight lies more
      than ``reinvig_mahalanobis`` standard deviations (Mahalanobis) from ``z`` -- the particle
      set simply has no support where the object is (too few particles for a 1 cm posterior,
      or the object is somewhere the prior missed).  Re-weighting would then collapse onto the
      least-bad particle, far from ``z``.  Since there are no false positives, the object is
      near ``z``: a fraction ``reinvig_frac`` of the particles is replaced by draws from
      ``N(z, Sigma)`` restricted to the surface containing ``z`` (the nearest surface if none
      does), carrying mass ``1 - reinvig_keep_mass``; the rest keep the old hypotheses with the
      small mass ``reinvig_keep_mass`` (resampled from the prior), so that a wrong detection
      can still be recovered from.
    * Resampling (systematic) when ESS < ``resample_frac * N``, then *rejuvenation* (unless
      ``rejuvenate`` is False): after a detection the particles are drawn from the
      regularised posterior (:func:`_regularised_posterior`: the prior as a kernel density,
      so the posterior keeps the spread the evidence supports instead of collapsing onto
      copies of the one prior particle nearest ``z``); after a miss each copy is jittered by
      the kernel (:func:`_jitter`).

    ``rng`` drives reinvigoration and resampling; when ``None`` it is seeded from the belief's
    digest and the detection, so the update is a deterministic function of its inputs (as the
    update-belief stream requires, §IV-A).
    """
    model = model or ObservationModel()
    mask = np.asarray(visible_mask, dtype=bool).reshape(-1)
    if len(mask) != len(belief):
        raise ValueError(f"visible_mask has {len(mask)} entries for {len(belief)} particles")
    if detection is not None and hasattr(detection, "z"):  # an Observation: its detection z
        detection = detection.z
    z = None if detection is None else np.asarray(detection, dtype=float).reshape(4)
    if z is not None and np.any(np.isnan(z)):
        raise ValueError("detection contains NaN")
    if rng is None:
        rng = derived_rng(belief.digest, z, mask, model)
    with np.errstate(divide="ignore"):
        log_w = np.log(belief.weights)
        if z is None:
            post = log_w + np.where(mask, math.log(model.p_fn) if model.p_fn > 0 else -np.inf, 0.0)
            if not math.isfinite(logsumexp(post)):
                return belief
            out = belief.with_log_weights(post)
        else:
            z = np.clip(z, -1e6, 1e6)
            z[3] = float(wrap_angle(z[3]))
            log_det = math.log(1.0 - model.p_fn) if model.p_fn < 1 else -np.inf
            post = np.where(mask, log_w + log_det + model.log_likelihood(z, belief.poses), -np.inf)
            support = mask & (belief.weights > 0)
            d2 = model.mahalanobis2(z, belief.poses[support])
            deprived = not math.isfinite(logsumexp(post)) or (
                d2.size == 0 or float(d2.min()) > reinvig_mahalanobis**2
            )
            regularised = rejuvenate and np.allclose(
                model.covariance, np.diag(np.diag(model.covariance))
            )
            if deprived and regularised and d2.size:
                # a particle's kernel may still explain z: then no particle is missing
                tot = kernel_bandwidth(belief)[support] + np.diag(model.covariance)
                dk = z[None, :] - belief.poses[support]
                dk[:, 3] = wrap_angle(dk[:, 3])
                deprived = float(np.min(np.sum(dk**2 / tot, axis=1))) > reinvig_mahalanobis**2
                if not deprived:
                    reg = _regularised_posterior(belief, z, mask, model, rng)
                    if reg is not None:
                        return reg
                    deprived = True
            if deprived:
                return _reinvigorate(belief, z, model, rng, reinvig_frac, reinvig_keep_mass)
            out = belief.with_log_weights(post)
            if regularised and out.ess() < resample_frac * len(out):
                reg = _regularised_posterior(belief, z, mask, model, rng)
                if reg is not None:
                    return reg
    if out.ess() < resample_frac * len(out):
        out = out.resample(rng)
        if rejuvenate:
            out = _jitter(out, rng)
    return out
