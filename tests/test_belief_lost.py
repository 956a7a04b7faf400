"""A belief that has lost its object (Cook seed 17): misses the camera saw all of the belief for
are scored against the prior (ssr_compile/belief/lost.py), and past the threshold the prior
gets its mass back where the camera could not see."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ssr_compile.belief.lost import LostTest, miss_probability, mix_prior
from ssr_compile.belief.particles import ObservationModel, PoseBelief, Surface, update

COUNTER = Surface("counter", (0.0, 0.0), (1.0, 0.5), 0.9)
SHELF = Surface("shelf", (3.0, 0.0), (0.5, 0.5), 1.5)
MODEL = ObservationModel(p_fn=0.1)


def _cluster(n=100, at=(0.5, 0.2)):
    rng = np.random.default_rng(0)
    poses = np.column_stack(
        [at[0] + rng.normal(size=n) * 0.02, at[1] + rng.normal(size=n) * 0.02,
         np.full(n, 0.95), np.zeros(n)]
    )  # fmt: skip
    return PoseBelief("block", [COUNTER], np.zeros(n, int), poses, z_offset=0.05)


def _prior(n=400):
    return PoseBelief.uniform("block", [COUNTER, SHELF], n, np.random.default_rng(1))


def _seen(prior):
    """The camera cannot see x < -0.5 on the counter, nor the shelf."""
    return ~((prior.labels == 0) & (prior.poses[:, 0] < -0.5)) & (prior.labels == 0)


def test_miss_probability_is_one_minus_the_seen_mass():
    b = _cluster()
    everything = np.ones(len(b), bool)
    assert miss_probability(b, everything, MODEL) == pytest.approx(0.1)
    half = np.arange(len(b)) % 2 == 0
    assert miss_probability(b, half, MODEL) == pytest.approx(1 - 0.9 * b.weights[half].sum())
    assert miss_probability(b, ~everything, MODEL) == pytest.approx(1.0)


def test_a_fully_seen_belief_missed_again_and_again_goes_back_to_the_prior():
    belief, prior = _cluster(), _prior()
    seen = np.ones(len(belief), bool)
    prior_seen = _seen(prior)
    p_prior = miss_probability(prior, prior_seen, MODEL)
    assert 0.1 < p_prior < 1
    step = math.log(p_prior / 0.1)
    test = LostTest(prior_odds=0.01)
    fires_at = math.floor(math.log(100) / step) + 1  # the first miss past the threshold
    current = belief
    for k in range(1, fires_at):
        # the plain filter does not move: every particle was in view
        post = update(current, None, seen, MODEL, rng=np.random.default_rng(k))
        out = test.miss(current, seen, lambda: (prior, prior_seen), MODEL,
                        np.random.default_rng(k), post)  # fmt: skip
        assert out is post and test.fired == 0
        assert test.scores["block"] == pytest.approx(k * step)
    post = update(current, None, seen, MODEL, rng=np.random.default_rng(9))
    out = test.miss(
        current, seen, lambda: (prior, prior_seen), MODEL, np.random.default_rng(9), post
    )
    assert test.fired == 1 and "block" not in test.scores  # fired, and starts again from zero
    assert len(out) == len(belief)
    # the mass handed back is the posterior of "lost": prior odds times the misses' ratio
    mass = 1 / (1 + math.exp(math.log(100) - fires_at * step))
    drawn = {tuple(p) for p in prior.poses}
    fresh = np.flatnonzero([tuple(p) in drawn for p in out.poses])  # drawn from the prior
    assert out.weights[fresh].sum() == pytest.approx(mass, abs=0.02)
    assert mass > 0.5
    # the prior's part is mostly where the camera did not see (weighted by the miss): the
    # hidden end of the counter and the shelf, which the union of surfaces now holds
    assert [s.name for s in out.surfaces] == ["counter", "shelf"]
    new = out.poses[fresh]
    in_hidden = (out.labels[fresh] == 1) | (new[:, 0] < -0.5)
    assert prior.weights[~prior_seen].sum() < 0.5 < 0.75 < in_hidden.mean()


def test_a_miss_of_a_mostly_hidden_belief_is_not_scored_and_a_detection_resets():
    belief, prior = _cluster(), _prior()
    calls = []

    def prior_fn():
        calls.append(1)
        return prior, _seen(prior)

    test = LostTest()
    hidden = np.zeros(len(belief), bool)
    assert test.miss(belief, hidden, prior_fn, MODEL, np.random.default_rng(0)) is belief
    assert calls == [] and "block" not in test.scores  # not scored: no rays cast for the prior
    seen = np.ones(len(belief), bool)
    test.miss(belief, seen, prior_fn, MODEL, np.random.default_rng(0))
    assert test.scores["block"] > 0
    test.reset("block")
    assert "block" not in test.scores


def test_the_score_never_goes_below_zero():
    # misses the belief explains better than the prior (the prior all in view, the belief
    # half hidden) do not bank credit against later evidence
    belief, prior = _cluster(), _prior()
    half = np.arange(len(belief)) % 2 == 0
    test = LostTest(surprise=1.0)
    for _ in range(5):
        test.miss(belief, half, lambda: (prior, np.ones(len(prior), bool)), MODEL,
                  np.random.default_rng(0))  # fmt: skip
    assert test.scores["block"] == 0.0


def test_mix_prior_keeps_the_particle_count_and_the_belief_share():
    belief, prior = _cluster(), _prior()
    out = mix_prior(belief, prior, np.ones(len(prior), bool), 0.3, MODEL, np.random.default_rng(0))
    assert len(out) == len(belief)
    old = np.flatnonzero(np.isin(out.poses[:, 0], belief.poses[:, 0]))
    assert out.weights[old].sum() == pytest.approx(0.7)
    # the draws follow the prior after the miss: in view, weight p_fn (over many draws)
    seen = _seen(prior)
    hidden, total = 0, 0
    for k in range(40):
        out = mix_prior(belief, prior, seen, 0.5, MODEL, np.random.default_rng(k))
        drawn = out.poses[len(belief) // 2 :]  # the belief's half first, then the prior's
        hidden += int(np.sum((out.labels[len(belief) // 2 :] == 1) | (drawn[:, 0] < -0.5)))
        total += len(drawn)
    h = prior.weights[~seen].sum()
    assert hidden / total == pytest.approx(h / (h + 0.1 * (1 - h)), abs=0.03)
    # p_fn = 0 and a prior all in view: the miss rules the prior out too, nothing to mix
    zero = ObservationModel(p_fn=0.0)
    same = mix_prior(belief, prior, np.ones(len(prior), bool), 0.3, zero, np.random.default_rng(0))
    assert same is belief
