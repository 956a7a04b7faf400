"""A belief that no longer holds the object: misses scored against the prior.

A miss (no detection) re-weights a particle belief by the false-negative rate wherever the
camera could see (:func:`~ssr_compile.belief.particles.update`).  When the camera sees *every*
particle, every weight is multiplied alike and the normalised belief does not move: the filter
cannot say "it is not there", only "it is there and was missed".  A belief that has collapsed
where the object is not (Cook seed 17: three centimetres of particles on the counter beside the
cracker box, the block behind the sugar box) then survives any number of looks, and a planner
that trusts it drives to the same base to look again and again.

:class:`LostTest` is a one-sided CUSUM test of "the object is not where the belief says"
against "the object is where the prior allows": each miss adds the log-likelihood ratio
``log P(miss | prior) - log P(miss | belief)`` to a per-object score (floored at zero; a
detection, or the robot moving the object, resets it).  Past ``log(1 / prior_odds)`` the
posterior of "lost" is above one half and :func:`mix_prior` hands that mass to the prior,
re-weighted by the miss just received: particles where the camera could not see come back, and
the next plan looks there (or moves what hides them).

A miss that the belief itself found likely (``P(miss | belief) > surprise``: most of the belief
was hidden) is not scored: it says little either way, and it spares the ray tests of the prior.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from .particles import ObservationModel, PoseBelief, systematic_resample


def miss_probability(
    belief: PoseBelief, visible_mask: np.ndarray, model: ObservationModel
) -> float:
    """``P(no detection | belief)``: ``1 - (1 - p_fn) * (the belief's visible mass)``."""
    mask = np.asarray(visible_mask, dtype=bool).reshape(-1)
    visible = float(belief.weights[mask].sum())
    return max(0.0, 1.0 - (1.0 - model.p_fn) * visible)


def mix_prior(
    belief: PoseBelief,
    prior: PoseBelief,
    prior_mask: np.ndarray,
    mass: float,
    model: ObservationModel,
    rng: np.random.Generator,
) -> PoseBelief:
    """``belief`` with probability ``1 - mass`` and, with ``mass``, the prior after the miss
    (its particles the camera could see weighted by ``p_fn``), in as many particles as
    ``belief`` has: ``round(mass N)`` drawn from that prior, the rest resampled from
    ``belief``.  The surfaces are the union of both (by name)."""
    n = len(belief)
    n_new = min(n, max(1, round(mass * n)))
    n_old = n - n_new
    mask = np.asarray(prior_mask, dtype=bool).reshape(-1)
    w = prior.weights * np.where(mask, model.p_fn, 1.0)
    if w.sum() <= 0:  # p_fn = 0 and the prior all in view: the miss rules the prior out too
        return belief
    new = systematic_resample(w, rng, n_new)
    old = systematic_resample(belief.weights, rng, n_old) if n_old else np.zeros(0, int)
    surfaces = list(belief.surfaces)
    index = {s.name: k for k, s in enumerate(surfaces)}
    for s in prior.surfaces:
        if s.name not in index:
            index[s.name] = len(surfaces)
            surfaces.append(s)
    relabel = np.array([index[s.name] for s in prior.surfaces])
    labels = np.concatenate([belief.labels[old], relabel[prior.labels[new]]])
    poses = np.vstack([belief.poses[old], prior.poses[new]])
    weights = np.concatenate(  # (normalised by PoseBelief when the belief kept no particle)
        [np.full(n_old, (1.0 - mass) / max(n_old, 1)), np.full(n_new, mass / n_new)]
    )
    return PoseBelief(belief.obj, surfaces, labels, poses, weights, belief.z_offset)


@dataclass
class LostTest:
    """Per-object CUSUM of misses against the prior (module doc).

    ``prior_odds``: the odds, before any evidence, that a belief has lost its object; the
    test fires when the misses have made "lost" more likely than not.  ``surprise``: misses
    the belief gave at least this probability are not scored."""

    prior_odds: float = 0.01
    surprise: float = 0.5
    scores: dict[str, float] = field(default_factory=dict)
    fired: int = 0  # how often a belief was handed back to its prior

    @property
    def threshold(self) -> float:
        return math.log(1.0 / self.prior_odds)

    def reset(self, obj: str) -> None:
        """``obj`` was seen, or moved by the robot: its belief is fresh evidence."""
        self.scores.pop(obj, None)

    def miss(
        self,
        belief: PoseBelief,
        visible_mask: np.ndarray,
        prior: Callable[[], tuple[PoseBelief, np.ndarray]],
        model: ObservationModel,
        rng: np.random.Generator,
        posterior: PoseBelief | None = None,
    ) -> PoseBelief:
        """Score a miss of ``belief`` (its particles in view: ``visible_mask``) and return the
        belief to use: ``posterior`` (``belief`` after the miss; ``belief`` itself if not
        given), or that mixed with the prior when the test fires.  ``prior()`` gives the
        prior belief and its visibility mask (called only for a surprising miss)."""
        posterior = belief if posterior is None else posterior
        p_belief = miss_probability(belief, visible_mask, model)
        if p_belief > self.surprise:
            return posterior
        prior_belief, prior_mask = prior()
        p_prior = miss_probability(prior_belief, prior_mask, model)
        if p_prior <= 0.0:
            return posterior
        obj = belief.obj
        ratio = math.log(p_prior) - math.log(max(p_belief, 1e-300))
        score = max(0.0, self.scores.get(obj, 0.0) + ratio)
        self.scores[obj] = score
        if score <= self.threshold:
            return posterior
        # posterior of "lost": prior odds times the likelihood ratio of the misses
        mass = 1.0 / (1.0 + math.exp(self.threshold - score))
        self.scores.pop(obj, None)
        self.fired += 1
        return mix_prior(posterior, prior_belief, prior_mask, mass, model, rng)


__all__ = ["LostTest", "miss_probability", "mix_prior"]
