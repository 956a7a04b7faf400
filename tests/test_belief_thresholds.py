"""The thresholds of the belief layer, each pinned at its boundary: the visible fraction of a
particle's box (0.5 of its test points), the camera's visibility rule (fraction >= 0.5), and
the reinvigoration rule (nearest particle farther than k standard deviations: d^2 > k^2)."""

from __future__ import annotations

import numpy as np

from ssr_compile.belief.observation import box_points, visibility_mask
from ssr_compile.belief.particles import ObservationModel, PoseBelief, Surface, update

TABLE = Surface("table", (0.0, 0.0), (1.0, 1.0), 0.0)
HALF = (0.05, 0.05, 0.05)


class HalfPlaneCamera:
    """Sees exactly the points with y > 0 (a wall along the x axis hides the rest)."""

    def visible(self, points, ignore=()):
        return np.asarray(points)[:, 1] > 0.0


def _belief_at(y: float) -> PoseBelief:
    return PoseBelief.point("o", TABLE, (0.0, y, 0.05, 0.0))


def test_box_points_are_the_centre_and_eight_corners():
    pts = box_points(np.array([[0.0, 0.0, 0.05, 0.0]]), HALF)
    assert pts.shape == (1, 9, 3)
    assert sum(p[1] > 0 for p in pts[0]) == 4  # at y = 0, only 4 of 9 points lie at y > 0


def test_a_particle_is_visible_when_at_least_half_its_test_points_are():
    camera = HalfPlaneCamera()
    # 5 of 9 points visible (0.56): visible under the 0.5 rule
    assert visibility_mask(_belief_at(0.001), camera, HALF).tolist() == [True]
    # 4 of 9 (0.44): not visible
    assert visibility_mask(_belief_at(-0.001), camera, HALF).tolist() == [False]
    # every point visible
    assert visibility_mask(_belief_at(0.2), camera, HALF).tolist() == [True]
    # the rule is a parameter: 5/9 is not enough for 0.6
    mask = visibility_mask(_belief_at(0.001), camera, HALF, min_visible_fraction=0.6)
    assert mask.tolist() == [False]


def test_the_cameras_rule_counts_exactly_half_as_visible(monkeypatch):
    from ssr_compile.sim import perception

    for fraction, expected in ((0.5, True), (0.49, False), (0.51, True), (0.0, False)):
        monkeypatch.setattr(perception, "visible_fraction", lambda world, name, f=fraction: f)
        assert perception.is_visible(None, "block") is expected, fraction


def _one_particle_update(k_sigma: float) -> PoseBelief:
    model = ObservationModel(p_fn=0.1, sigma=(0.01, 0.01, 0.01, 0.1))
    belief = PoseBelief.point("o", TABLE, (0.0, 0.0, 0.05, 0.0))
    z = np.array([k_sigma * 0.01, 0.0, 0.05, 0.0])
    return update(
        belief, z, np.array([True]), model, rng=np.random.default_rng(0), rejuvenate=False
    )


def test_no_reinvigoration_within_five_standard_deviations():
    # 4 sigma away: d^2 = 16 <= 25, the particle explains the detection; nothing is replaced
    post = _one_particle_update(4.0)
    assert len(post) == 1
    assert np.allclose(post.poses[0, :2], [0.0, 0.0])


def test_reinvigoration_beyond_five_standard_deviations():
    # 6 sigma away: d^2 = 36 > 25, the particle set has no support there: particles are drawn
    # around the detection and carry almost all the mass
    post = _one_particle_update(6.0)
    near = np.abs(post.poses[:, 0] - 0.06) < 0.04
    assert post.weights[near].sum() > 0.9
