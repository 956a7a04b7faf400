"""Belief layer (streams/belief.py, streams/belief_obs.py): formulas against hand-computed values
and the paper's Fig. 2 / §V-C example with real PyBullet ray casts."""

from __future__ import annotations

import math

import numpy as np
import pybullet as p
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ssr_compile.belief.observation import (
    Observation,
    ObsRegion,
    blocking_bodies,
    box_points,
    bvis,
    detection_probability_bound,
    obs_cost,
    sample_obs,
    update_belief,
    visibility_lower_bound,
    visibility_mask,
)
from ssr_compile.belief.particles import (
    ObservationModel,
    PoseBelief,
    Surface,
    logsumexp,
    systematic_resample,
    update,
    wrap_angle,
)
from ssr_compile.belief.plot import plot_belief
from ssr_compile.belief.visibility import PyBulletCamera

A_SURF = Surface("a", (0.0, 0.0), (1.0, 1.0), 0.0)
B_SURF = Surface("b", (10.0, 10.0), (1.0, 1.0), 1.0)
SHELF = Surface("shelf", (5.0, 0.0), (0.2, 0.3), 0.5)
MODEL = ObservationModel(p_fn=0.1, sigma=(0.01, 0.01, 0.01, 0.1))


def line_belief(weights, xs=(0.0, 0.01, 0.02)):
    poses = np.array([[x, 0.0, 0.0, 0.0] for x in xs])
    return PoseBelief.from_particles("o", [A_SURF], ["a"] * len(xs), poses, np.array(weights))


def four_particles():
    poses = np.array([[0, 0, 0, 0], [0.5, 0, 0, 0], [10, 10, 1, 0], [10.5, 10, 1, 0]], float)
    return PoseBelief.from_particles(
        "o", [A_SURF, B_SURF], ["a", "a", "b", "b"], poses, np.array([0.1, 0.2, 0.3, 0.4])
    )


# ------------------------------------------------------------------ surfaces and beliefs
def test_surface_geometry():
    s = Surface("s", (1.0, 2.0), (0.5, 0.25), 0.7)
    assert s.area == pytest.approx(0.5)
    assert s.contains(np.array([[1.5, 2.25], [1.6, 2.0]])).tolist() == [True, False]
    assert s.clip(np.array([[3.0, 0.0]])).tolist() == [[1.5, 1.75]]
    assert s.distance(np.array([[1.5 + 3, 2.25 + 4], [1, 2]])).tolist() == [5.0, 0.0]


def test_uniform_belief_by_area():
    big = Surface("big", (0, 0), (1.0, 0.75), 0.9)  # area 3
    small = Surface("small", (5, 5), (0.5, 0.5), 0.4)  # area 1
    pb = PoseBelief.uniform("o", [big, small], 4000, np.random.default_rng(0), z_offset=0.05)
    assert len(pb) == 4000 and pb.ess() == pytest.approx(4000)
    assert pb.prob_surface("big") == pytest.approx(0.75, abs=0.03)
    on_big = pb.surface_names == "big"
    assert big.contains(pb.poses[on_big]).all() and small.contains(pb.poses[~on_big]).all()
    assert np.allclose(pb.poses[on_big, 2], 0.95) and np.allclose(pb.poses[~on_big, 2], 0.45)
    assert np.all((pb.poses[:, 3] >= -math.pi) & (pb.poses[:, 3] < math.pi))


def test_point_belief():
    pb = PoseBelief.point("cup", SHELF, (5.0, 0.1, 0.55, 0.3))
    assert len(pb) == 1 and pb.ess() == 1.0 and pb.prob_surface("shelf") == 1.0
    assert pb.z_offset == pytest.approx(0.05)
    name, est = pb.point_estimate()
    assert name == "shelf" and est == pytest.approx([5.0, 0.1, 0.55, 0.3])


def test_point_estimate_and_covariance_by_hand():
    poses = np.array(
        [[0, 0, 0, math.radians(170)], [2, 0, 0, math.radians(-170)], [10, 10, 1, 0]], float
    )
    pb = PoseBelief.from_particles(
        "o", [A_SURF, B_SURF], ["a", "a", "b"], poses, np.array([0.3, 0.3, 0.4])
    )
    assert pb.most_likely_surface() == "a"  # 0.6 against 0.4
    name, est = pb.point_estimate()
    assert name == "a" and est[:3] == pytest.approx([1.0, 0.0, 0.0])
    assert abs(wrap_angle(est[3] - math.pi)) < 1e-9  # circular mean of +-170 deg is 180 deg
    cov_a = pb.covariance("a")
    assert cov_a[0, 0] == pytest.approx(1.0)  # x = 0, 2 with equal weights
    assert cov_a[3, 3] == pytest.approx(math.radians(10) ** 2)
    # all particles: mean x = 0.3*0 + 0.3*2 + 0.4*10 = 4.6; var = .3*4.6^2+.3*2.6^2+.4*5.4^2
    assert pb.covariance()[0, 0] == pytest.approx(20.04)
    assert pb.std("a")[0] == pytest.approx(1.0)


def test_ess_region_and_sample():
    pb = line_belief([0.5, 0.25, 0.25])
    assert pb.ess() == pytest.approx(1 / 0.375)
    assert pb.prob_region(((0.005, -1), (1, 1))) == pytest.approx(0.5)
    assert pb.prob_region(lambda poses, names: poses[:, 0] < 0.015) == pytest.approx(0.75)
    assert pb.mass([0, 2, 2]) == pytest.approx(0.75)
    draws = pb.sample(np.random.default_rng(1), 2000)
    assert all(name == "a" for name, _ in draws)
    assert np.mean([pose[0] == 0.0 for _, pose in draws]) == pytest.approx(0.5, abs=0.04)


def test_immutability_and_value_semantics():
    pb = four_particles()
    with pytest.raises(AttributeError):
        pb.obj = "x"
    for arr in (pb.poses, pb.weights, pb.labels):
        with pytest.raises(ValueError):
            arr[0] = 0
    same = four_particles()
    assert same == pb and hash(same) == hash(pb) and len({pb, same}) == 1
    assert line_belief([1, 1, 1]) != line_belief([1, 1, 2])
    text = repr(pb)
    assert text.startswith("PoseBelief(o: n=4") and len(text) < 110
    with pytest.raises(ValueError):
        line_belief([0, 0, 0])
    with pytest.raises(ValueError):
        line_belief([1, float("nan"), 1])


# ------------------------------------------------------------------ resampling
def test_systematic_resample_counts_are_floor_or_ceil():
    for seed in range(5):
        rng = np.random.default_rng(seed)
        counts = np.bincount(systematic_resample(np.array([0.1, 0.2, 0.3, 0.4]), rng, 10), None, 4)
        assert counts.tolist() == [1, 2, 3, 4]  # n w_i is an integer: exactly that many copies
        counts = np.bincount(systematic_resample(np.array([0.5, 0.25, 0.25]), rng, 4), None, 3)
        assert counts.tolist() == [2, 1, 1]


def test_resample_keeps_distribution_and_restores_ess():
    rng = np.random.default_rng(7)
    prior = PoseBelief.uniform("o", [A_SURF, B_SURF], 200, rng)
    w = rng.random(200) ** 4
    pb = PoseBelief(prior.obj, prior.surfaces, prior.labels, prior.poses, w)
    assert pb.ess() < 100
    out = pb.resample(rng)
    assert out.ess() == pytest.approx(200)
    assert abs(out.prob_surface("a") - pb.prob_surface("a")) <= 1 / 200 + 1e-12


def test_update_resamples_when_ess_is_low():
    pb = line_belief([1 / 3, 1 / 3, 1 / 3])
    z = (0.0, 0, 0, 0)
    kept = update(pb, z, np.ones(3, bool), MODEL, resample_frac=0.0)
    w = np.array([1.0, math.exp(-0.5), math.exp(-2.0)])  # d^2 = 0, 1, 4
    assert kept.ess() == pytest.approx(w.sum() ** 2 / (w**2).sum())  # = 2.1888 < 0.9 * 3
    res = update(pb, z, np.ones(3, bool), MODEL, resample_frac=0.9)
    assert res.ess() == pytest.approx(3) and res.weights == pytest.approx([1 / 3] * 3)


# ------------------------------------------------------------------ Bayesian update
def test_gaussian_reweighting_by_hand():
    pb = line_belief([0.5, 0.25, 0.25])  # x = 0, 1 cm, 2 cm; sigma_x = 1 cm -> d^2 = 0, 1, 4
    post = update(pb, (0.0, 0.0, 0.0, 0.0), np.ones(3, bool), MODEL, resample_frac=0.0)
    unnorm = np.array([0.5, 0.25 * math.exp(-0.5), 0.25 * math.exp(-2.0)])
    assert post.weights == pytest.approx(unnorm / unnorm.sum())
    assert post.weights == pytest.approx([0.729430, 0.221210, 0.049359], abs=1e-6)
    # an occluded particle cannot have produced the detection
    post = update(pb, (0.0, 0, 0, 0), np.array([True, True, False]), MODEL, resample_frac=0.0)
    assert post.weights == pytest.approx([0.5, 0.25 * math.exp(-0.5), 0.0] / (unnorm[:2].sum()))
    assert post.poses.tolist() == pb.poses.tolist()  # same particles, only weights change


def test_miss_update_exact():
    pb = four_particles()  # region {0, 1} has P = 0.3 and is fully visible, the rest occluded
    post = update(pb, None, np.array([True, True, False, False]), MODEL)
    # P' = p_fn P / (p_fn P + (1 - P)) = 0.03 / 0.73
    assert post.mass([0, 1]) == pytest.approx(0.03 / 0.73)
    assert post.weights == pytest.approx(np.array([0.01, 0.02, 0.3, 0.4]) / 0.73)
    assert post.weights.sum() == pytest.approx(1.0)
    # everything visible: every weight scaled by p_fn, the distribution is unchanged
    assert update(pb, None, np.ones(4, bool), MODEL).weights == pytest.approx(pb.weights)
    # p_fn = 0 and everything visible: an impossible miss leaves the prior
    assert update(pb, None, np.ones(4, bool), ObservationModel(p_fn=0.0)) is pb


def test_extreme_inputs_never_nan():
    tiny = line_belief([1e-300, 1e-300, 1.0])
    cases = [
        (tiny, (0.0, 0, 0, 0), np.ones(3, bool), MODEL),
        (tiny, (1e300, -1e300, 1e300, 1e300), np.ones(3, bool), MODEL),
        (tiny, (0.02, 0, 0, 0), np.zeros(3, bool), MODEL),  # detection though all occluded
        (tiny, (0.02, 0, 0, 0), np.ones(3, bool), ObservationModel(p_fn=1.0)),
        (tiny, None, np.ones(3, bool), ObservationModel(p_fn=1e-300)),
        (tiny, (0.0, 0, 0, 0), np.ones(3, bool), ObservationModel(sigma=(1e-9, 1e-9, 1e-9, 1e-9))),
    ]
    for pb, z, mask, model in cases:
        post = update(pb, z, mask, model)
        assert np.all(np.isfinite(post.weights)) and np.all(np.isfinite(post.poses))
        assert post.weights.sum() == pytest.approx(1.0)
    with pytest.raises(ValueError):
        update(tiny, (float("nan"), 0, 0, 0), np.ones(3, bool), MODEL)
    with pytest.raises(ValueError):
        update(tiny, None, np.ones(2, bool), MODEL)


@settings(max_examples=60, deadline=None)
@given(
    weights=st.lists(st.floats(0.0, 1e300), min_size=3, max_size=3).filter(lambda w: sum(w) > 0),
    mask=st.lists(st.booleans(), min_size=3, max_size=3),
    z=st.one_of(st.none(), st.tuples(*[st.floats(-1e300, 1e300)] * 4)),
    p_fn=st.floats(0.0, 1.0),
)
def test_update_always_normalised(weights, mask, z, p_fn):
    pb = line_belief(weights)
    post = update(pb, z, np.array(mask), ObservationModel(p_fn=p_fn))
    assert np.all(np.isfinite(post.weights)) and np.all(post.weights >= 0)
    assert post.weights.sum() == pytest.approx(1.0)
    if z is None and (p_fn > 0 or not all(mask)):
        # miss: w_i p_fn^{visible_i}, normalised (no resampling: ESS stays >= N/2 or is exact)
        unnorm = pb.weights * np.where(mask, p_fn, 1.0)
        if unnorm.sum() == 0:
            # A miss that cannot happen (all the mass visible, no false negatives): the
            # update keeps the prior rather than dividing by zero.
            assert post.weights == pytest.approx(pb.weights, abs=1e-9)
        elif post.poses.tolist() == pb.poses.tolist():
            assert post.weights == pytest.approx(unnorm / unnorm.sum(), abs=1e-9)


def test_reinvigoration_after_impossible_detection():
    poses = np.array([[0.1 * i, 0, 0.05, 0] for i in range(10)])
    pb = PoseBelief.from_particles(
        "o", [A_SURF, SHELF], ["a"] * 10, poses, np.linspace(1, 2, 10), z_offset=0.05
    )
    z = np.array([5.1, 0.05, 0.55, 0.2])  # on the shelf, where the belief has no particle
    post = update(pb, z, np.ones(10, bool), MODEL, reinvig_frac=0.5, reinvig_keep_mass=0.01)
    new = post.surface_names == "shelf"
    assert new.sum() == 5  # round(0.5 * 10) particles replaced
    assert post.weights[new] == pytest.approx([0.99 / 5] * 5)
    assert post.weights[~new] == pytest.approx([0.01 / 5] * 5)
    assert post.prob_surface("shelf") == pytest.approx(0.99)
    assert SHELF.contains(post.poses[new]).all() and np.allclose(post.poses[new, 2], 0.55)
    assert np.all(np.abs(post.poses[new, :2] - z[:2]) < 6 * 0.01)  # drawn around z
    assert set(map(tuple, post.poses[~new])) <= set(map(tuple, pb.poses))  # old hypotheses
    # a detection outside every surface lands on the nearest surface, clipped into it
    far = update(pb, (5.0, 3.0, 0.55, 0.0), np.ones(10, bool), MODEL)
    assert SHELF.contains(far.poses[far.surface_names == "shelf"]).all()


def test_no_reinvigoration_when_a_particle_explains_the_detection():
    pb = line_belief([0.2, 0.3, 0.5])
    post = update(pb, (0.01, 0.0, 0.0, 0.0), np.ones(3, bool), MODEL, resample_frac=0.0)
    assert post.poses.tolist() == pb.poses.tolist()


def test_no_posterior_collapse_after_one_detection():
    # Issue 11, fault 4: 100 particles per surface and a 1 cm sensor.  Plain resampling of the
    # reweighted particles collapses onto one prior particle (std 0, centimetres off); the
    # regularised posterior keeps the spread of the evidence (about the sensor's 1 cm) and is
    # centred on the truth.
    d1 = Surface("d1", (0.6, 0.0), (0.18, 0.3), 0.2)
    d2 = Surface("d2", (0.6, 0.0), (0.18, 0.3), 0.53)
    model = ObservationModel(p_fn=0.1, sigma=(0.01, 0.01, 0.01, math.radians(5)))
    rng = np.random.default_rng(3)
    errors, spreads, collapsed = [], [], 0
    for _ in range(60):
        pb = PoseBelief.uniform("o", [d1, d2], 200, rng, z_offset=0.02, by_area=False)
        true = np.array(
            [rng.uniform(0.45, 0.75), rng.uniform(-0.25, 0.25), 0.22, rng.uniform(-3, 3)]
        )
        z = true + rng.normal(size=4) * np.array(model.sigma)
        plain = update(
            pb, z, np.ones(200, bool), model, rng=np.random.default_rng(0), rejuvenate=False
        )
        collapsed += float(plain.std("d1")[:2].max()) < 1e-6
        post = update(pb, z, np.ones(200, bool), model, rng=np.random.default_rng(0))
        assert post.prob_surface("d1") > 0.95
        _, est = post.point_estimate()
        errors.append(float(np.linalg.norm(est[:2] - true[:2])))
        spreads.append(float(post.std("d1")[:2].max()))
        assert len(np.unique(post.poses[post.labels == 0], axis=0)) > 50  # no copies of one
    assert collapsed > 0  # the fault is real without rejuvenation
    assert min(spreads) > 0.004 and max(spreads) < 0.025  # honest: about the sensor noise
    assert np.mean(errors) < 0.02 and max(errors) < 0.05


def test_update_is_deterministic_without_rng():
    pb = PoseBelief.uniform("o", [A_SURF, SHELF], 300, np.random.default_rng(2), z_offset=0.05)
    z = (5.0, 0.0, 0.55, 0.0)
    first = update(pb, z, np.ones(300, bool), MODEL)
    assert update(pb, z, np.ones(300, bool), MODEL) == first
    seeded = [update(pb, z, np.ones(300, bool), MODEL, rng=np.random.default_rng(9)) for _ in "ab"]
    assert seeded[0] == seeded[1]


# ------------------------------------------------------------------ observation model
def test_observation_model():
    model = ObservationModel(p_fn=0.1, sigma=(0.01, 0.02, 0.03, 0.1))
    logdet = 2 * math.log(0.01 * 0.02 * 0.03 * 0.1)
    peak = -0.5 * (logdet + 4 * math.log(2 * math.pi))
    poses = np.array([[0, 0, 0, 0], [0.01, 0, 0, 0], [0, 0, 0, 2 * math.pi - 0.1]])
    assert model.log_likelihood(np.zeros(4), poses) == pytest.approx([peak, peak - 0.5, peak - 0.5])
    assert model.mahalanobis2(np.zeros(4), poses) == pytest.approx([0, 1, 1])  # yaw wraps
    rng = np.random.default_rng(0)
    assert model.sample_detection((1, 2, 3, 0), False, rng) is None
    assert ObservationModel(p_fn=1.0).sample_detection((1, 2, 3, 0), True, rng) is None
    zs = [ObservationModel(p_fn=0.0).sample_detection((1, 2, 3, 0), True, rng) for _ in range(500)]
    assert np.mean(zs, axis=0)[:3] == pytest.approx([1, 2, 3], abs=0.003)
    misses = sum(model.sample_detection((0, 0, 0, 0), True, rng) is None for _ in range(2000))
    assert misses / 2000 == pytest.approx(0.1, abs=0.025)
    full = ObservationModel(cov=tuple(tuple(r) for r in np.diag([4.0, 1, 1, 1])))
    assert full.mahalanobis2(np.zeros(4), np.array([[2.0, 0, 0, 0]])) == pytest.approx([1.0])
    with pytest.raises(ValueError):
        ObservationModel(p_fn=1.5)
    assert logsumexp(np.array([-np.inf, -np.inf])) == -math.inf


# ------------------------------------------------------------------ planner streams
def test_sample_obs_region_is_delta_neighbourhood():
    poses = np.array(
        [[0, 0, 0, 0], [0.05, 0, 0, 0], [0.2, 0, 0, 0], [0.02, 0, 0, 0], [0.01, 0, 0, 0]], float
    )
    pb = PoseBelief.from_particles(
        "o", [A_SURF, SHELF], ["a", "a", "a", "shelf", "a"], poses, np.array([1, 1, 1, 1, 0.0])
    )
    gen = sample_obs("o", pb, np.random.default_rng(4), delta=0.1, eps=0.2)
    seen = set()
    for _ in range(40):
        (obs,) = next(gen)
        i = int(np.flatnonzero((pb.poses == obs.z).all(axis=1))[0])
        seen.add(i)
        expected = {
            j
            for j in range(5)
            if pb.labels[j] == pb.labels[i]
            and pb.weights[j] > 0
            and np.linalg.norm(pb.poses[j, :2] - pb.poses[i, :2]) <= 0.1
        }
        assert set(obs.region.indices) == expected and obs.eps == 0.2
        assert obs.region.mass(pb) == pytest.approx(len(expected) / 4)
    assert seen == {0, 1, 2, 3}  # every positive-weight particle, never the zero-weight one
    a = [next(sample_obs("o", pb, np.random.default_rng(5)))[0] for _ in range(2)]
    assert a[0] == a[1] and hash(a[0]) == hash(a[1])


def test_eq2_bound_and_obs_cost_by_hand():
    pb = four_particles()
    region = ObsRegion("b", pb.poses[[2, 3]], pb.poses[2], 1.0, (2, 3), pb.digest)
    obs = Observation("o", pb.poses[2], region, eps=0.2)
    # (1 - p_fn) P(X_i) (1 - eps)^(n - 1) = 0.9 * 0.7 * 0.8^2
    assert detection_probability_bound(obs, pb, 3, 0.1) == pytest.approx(0.4032)
    assert detection_probability_bound(obs, pb, 1, 0.1) == pytest.approx(0.63)
    # self-loop: c + c'/p - c' = 2 + 3/0.4032 - 3
    assert obs_cost(obs, pb, 3, c=2.0, c_fail=3.0, model=MODEL) == pytest.approx(6.4404762, 1e-7)
    assert obs_cost(obs, pb, 1, model=MODEL) == pytest.approx(1 / 0.63)
    # a region of another belief: particles on the same surface within delta of the centre
    other = ObsRegion.from_poses("a", pb.poses[[0, 1]])
    assert other.delta == pytest.approx(0.25)
    assert other.mass(pb) == pytest.approx(0.3)
    nothing = ObsRegion("a", np.zeros((0, 4)), pb.poses[0], 0.0, (), pb.digest)
    empty = Observation("o", pb.poses[0], nothing, 0.1)
    assert obs_cost(empty, pb, 2) == math.inf


def test_update_belief_assumes_the_hypothesised_detection():
    pb = PoseBelief.uniform("o", [A_SURF], 500, np.random.default_rng(3))
    (obs,) = next(sample_obs("o", pb, np.random.default_rng(3), delta=0.1))
    post = update_belief("o", pb, obs, MODEL)
    assert obs.region.mass(post) > 0.95 > obs.region.mass(pb)
    assert post.point_estimate()[1][:2] == pytest.approx(obs.z[:2], abs=0.01)
    assert update_belief("o", pb, obs, MODEL) == post  # a deterministic function
    assert update(pb, obs, np.ones(len(pb), bool), MODEL) == post  # same as passing obs.z
    with pytest.raises(ValueError):
        update_belief("other", pb, obs, MODEL)


def test_box_points_by_hand():
    pts = box_points(np.array([[1.0, 2.0, 3.0, math.pi / 2]]), (0.1, 0.2, 0.3), inset=1.0)
    assert pts.shape == (1, 9, 3)
    assert pts[0, 0] == pytest.approx([1, 2, 3])
    # local (+0.1, +0.2, +0.3) rotated by 90 deg about z is (-0.2, +0.1, +0.3)
    assert pts[0, 8] == pytest.approx([0.8, 2.1, 3.3])


def test_plot_belief_writes_png(tmp_path):
    pb = PoseBelief.uniform("o", [A_SURF, SHELF], 100, np.random.default_rng(0))
    out = plot_belief({"o": pb, "p": four_particles()}, [A_SURF, B_SURF, SHELF], tmp_path / "b.png")
    data = open(out, "rb").read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10_000


# ------------------------------------------------------------------ paper Fig. 2 / §V-C
HALF_D = (0.05, 0.05, 0.05)
SPOTS = [np.array([2.0, y, 0.05, 0.0]) for y in (-0.5, 0.0, 0.5)]  # x1, x2, x3
SPOT_SURFACE = Surface("table", (2.0, 0.0), (0.2, 1.2), 0.0)


@pytest.fixture(scope="module")
def fig2():
    """Camera at (0, 0, 0.5); spots x1..x3 on a table at x = 2; cubes A, B, C halfway along the
    lines of sight to x1, x2, x3 (each blocks its own spot only); D is a body (parked far away)
    so that `ignore` matters; E is a free spot x4 that nothing blocks."""
    cid = p.connect(p.DIRECT)

    def box(pos, half):
        col = p.createCollisionShape(p.GEOM_BOX, halfExtents=half, physicsClientId=cid)
        return p.createMultiBody(0, col, basePosition=pos, physicsClientId=cid)

    occ = {}
    for name, spot in zip("ABC", SPOTS, strict=True):
        pos = (1.0, spot[1] / 2, 0.275)  # midpoint of camera -> spot
        body = box(pos, [0.08] * 3)
        surf = Surface(f"stand_{name}", pos[:2], (0.1, 0.1), 0.195)
        occ[name] = (body, PoseBelief.point(name, surf, (*pos, 0.0)))
    d_body = box([2.0, -1.0, 0.05], list(HALF_D))  # D's real body, at the free spot x4
    cam = PyBulletCamera([0.0, 0.0, 0.5], client=cid)
    yield {"cid": cid, "occ": occ, "D": d_body, "cam": cam}
    p.disconnect(cid)


def _obs(poses, eps=0.1):
    return Observation("D", poses[0], ObsRegion.from_poses("table", np.array(poses)), eps)


def test_fig2_bvis_sparsity(fig2):
    cam, occ = fig2["cam"], fig2["occ"]
    beliefs = {body: pb for body, pb in occ.values()}
    name = {body: n for n, (body, _) in occ.items()}
    x1, x2, x3 = SPOTS
    for region, must_move in (
        ([x1, x2, x3], "ABC"),
        ([x1, x3], "AC"),
        ([x1], "A"),
    ):
        obs = _obs(region)
        moved = blocking_bodies(obs, beliefs, cam, half_extents=HALF_D)
        assert "".join(sorted(name[b] for b in moved)) == must_move
        for n, (body, pb) in occ.items():
            lb = visibility_lower_bound(obs, body, pb, cam, half_extents=HALF_D)
            assert lb == (0.0 if n in must_move else 1.0)
            assert bvis(obs, body, pb, cam, half_extents=HALF_D) == (n not in must_move)
    # D's belief: 0.5 at x1, 0.5 at x3, nothing at x2 (as in §V-C)
    pb_d = PoseBelief.from_particles("D", [SPOT_SURFACE], ["table"] * 2, np.array([x1, x3]))
    assert pb_d.prob_region(((1.9, -0.1), (2.1, 0.1))) == 0.0  # P(x2) = 0


def test_bvis_with_an_uncertain_occluder(fig2):
    cam, (body_b, pb_b) = fig2["cam"], fig2["occ"]["B"]
    obs_x2 = _obs([SPOTS[1]], eps=0.1)
    blocking = pb_b.poses[0]
    away = blocking + np.array([0.0, 3.0, 0.0, 0.0])
    stand = pb_b.surfaces[0]
    # 1 of 4 particles blocks x2: L_B = 0.75 exactly (4 <= k: every particle, with its weight)
    pb = PoseBelief.from_particles(
        "B", [stand], [0] * 4, np.array([blocking, away, away, away]), np.ones(4)
    )
    assert visibility_lower_bound(obs_x2, body_b, pb, cam, half_extents=HALF_D) == 0.75
    assert not bvis(obs_x2, body_b, pb, cam, half_extents=HALF_D)
    assert bvis(_obs([SPOTS[1]], eps=0.25), body_b, pb, cam, half_extents=HALF_D)
    # many particles: k weighted draws, deterministic without an rng, a multiple of 1/k
    many = PoseBelief.from_particles(
        "B", [stand], [0] * 40, np.array([blocking] * 10 + [away] * 30), np.ones(40)
    )
    lb = [
        visibility_lower_bound(obs_x2, body_b, many, cam, half_extents=HALF_D, k=16) for _ in "ab"
    ]
    assert lb[0] == lb[1] and (lb[0] * 16) == round(lb[0] * 16) and 0.4 < lb[0] < 1.0
    exact = visibility_lower_bound(obs_x2, body_b, many, cam, half_extents=HALF_D, k=40)
    assert exact == pytest.approx(0.75)
    # occluder restored to its pose after the casts
    pos, _ = p.getBasePositionAndOrientation(body_b, physicsClientId=fig2["cid"])
    assert pos == pytest.approx(tuple(blocking[:3]))


def test_fig2_visibility_mask_and_miss_update(fig2):
    cam, d_body = fig2["cam"], fig2["D"]
    x4 = np.array([2.0, -1.0, 0.05, 0.0])  # where D really is: nothing in between
    pb = PoseBelief.from_particles("D", [SPOT_SURFACE], ["table"] * 4, np.array([*SPOTS, x4]))
    assert visibility_mask(pb, cam, HALF_D, ignore=[d_body]).tolist() == [False] * 3 + [True]
    # without ignoring D's own body, its surface hides its own inner test points at x4
    assert visibility_mask(pb, cam, HALF_D).tolist() == [False] * 4
    mask = visibility_mask(pb, cam, HALF_D, ignore=[d_body])
    post = update(pb, None, mask, MODEL)  # a miss: only x4 could have been seen
    assert post.weights == pytest.approx(np.array([0.25, 0.25, 0.25, 0.025]) / 0.775)
