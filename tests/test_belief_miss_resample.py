"""The particle filter resamples after a *missed* detection when the effective sample size
falls below ``resample_frac`` of the particle count (issue 38: the threshold compared without
the particle count never resampled after a miss)."""

from __future__ import annotations

import numpy as np
import pytest

from ssr_compile.belief.particles import ObservationModel, PoseBelief, Surface, update

SHELF = Surface("shelf", (0.0, 0.0), (1.0, 1.0), 0.0)


def test_a_miss_that_leaves_few_effective_particles_resamples():
    rng = np.random.default_rng(3)
    prior = PoseBelief.uniform("o", [SHELF], 200, rng)
    visible = np.zeros(200, bool)
    visible[:180] = True  # 180 of 200 particles in view, none seen: a miss
    model = ObservationModel(p_fn=0.1)
    kept = update(prior, None, visible, model, resample_frac=0.0, rng=rng)
    # by hand: weights 0.1/38 (180 visible) and 1/38 (20 occluded)
    ess = (180 * 0.1 + 20) ** 2 / (180 * 0.1**2 + 20)
    assert kept.ess() == pytest.approx(ess)  # 66.2, below half of 200
    assert kept.mass(np.flatnonzero(visible)) == pytest.approx(18 / 38)
    out = update(prior, None, visible, model, rng=np.random.default_rng(3))
    assert out.ess() == pytest.approx(200)  # resampled (and jittered): equal weights again
    assert SHELF.contains(out.poses[:, :2]).all()
    # plain resampling keeps the posterior: about 20/38 of the copies are occluded particles
    plain = update(prior, None, visible, model, rng=np.random.default_rng(3), rejuvenate=False)
    assert plain.ess() == pytest.approx(200)
    occluded = {tuple(p) for p in prior.poses[~visible]}
    share = np.mean([tuple(p) in occluded for p in plain.poses])
    assert share == pytest.approx(20 / 38, abs=1 / 200 + 1e-9)
