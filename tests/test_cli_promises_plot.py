"""Issue 17 row 12: plots a reader can read -- tests on the figures' artists."""

from __future__ import annotations

import itertools

import matplotlib.pyplot as plt
import numpy as np
import pytest

from ssr_compile.belief.particles import PoseBelief, Surface
from ssr_compile.belief.plot import belief_figure, plot_belief

COUNTER = Surface("counter", (1.0, 0.8), (0.2, 0.35), 0.7)
TOP = Surface("top_drawer", (1.0, 0.0), (0.17, 0.3), 0.53)
BOTTOM = Surface("bottom_drawer", (1.0, 0.0), (0.17, 0.3), 0.2)


def _particles(fig) -> dict[str, list]:
    out: dict[str, list] = {}
    for ax in fig.axes:
        for c in ax.collections:
            gid = c.get_gid() or ""
            if gid.startswith("particles:"):
                out.setdefault(gid.split(":", 1)[1], []).append((ax, c))
    return out


def _label_boxes(ax):
    renderer = ax.figure.canvas.get_renderer()
    return [
        (t.get_text(), t.get_window_extent(renderer))
        for t in ax.texts
        if (t.get_gid() or "").startswith("label:")
    ]


def _uniform(names, surfaces, n=200, seed=0):
    rng = np.random.default_rng(seed)
    return {o: PoseBelief.uniform(o, surfaces, n, rng) for o in names}


def test_one_colour_per_object_even_with_a_uniform_prior():
    beliefs = _uniform(["block", "sugar_box", "cracker_box"], [COUNTER])
    fig = belief_figure(beliefs, [COUNTER])
    try:
        parts = _particles(fig)
        assert set(parts) == set(beliefs)
        colours = {}
        for obj, items in parts.items():
            rgb = {tuple(np.round(fc[:3], 3)) for _, c in items for fc in c.get_facecolors()}
            assert len(rgb) == 1, f"{obj}: one colour for all its particles"
            colours[obj] = rgb.pop()
        assert len(set(colours.values())) == 3
    finally:
        plt.close(fig)


def test_weight_is_opacity_and_size():
    rng = np.random.default_rng(1)
    base = PoseBelief.uniform("block", [COUNTER], 50, rng)
    weights = np.linspace(0.01, 1.0, 50)
    pb = PoseBelief("block", base.surfaces, base.labels, base.poses, weights)
    fig = belief_figure(pb, [COUNTER])
    try:
        ((_, c),) = _particles(fig)["block"]
        alpha = c.get_facecolors()[:, 3]
        assert alpha.max() == pytest.approx(1.0) and alpha.min() < 0.3
        assert np.all(np.diff(alpha) >= -1e-12)  # heaviest drawn last
        sizes = c.get_sizes()
        assert sizes.max() > 2 * sizes.min()
    finally:
        plt.close(fig)


def test_stacked_drawers_are_in_panels_of_their_own():
    beliefs = _uniform(["block"], [TOP, BOTTOM])
    fig = belief_figure(beliefs, [TOP, BOTTOM, COUNTER])
    try:
        panels = [ax for ax in fig.axes if ax.patches]
        assert len(panels) == 2
        titles = [ax.get_title() for ax in panels]
        assert sum("top_drawer" in t for t in titles) == 1
        assert sum("bottom_drawer" in t for t in titles) == 1
        assert not any("top_drawer" in t and "bottom_drawer" in t for t in titles)
        # no panel draws two rectangles that overlap
        for ax in panels:
            boxes = [p.get_bbox() for p in ax.patches]
            for a, b in itertools.combinations(boxes, 2):
                assert not (a.overlaps(b) and a.width and b.width)
    finally:
        plt.close(fig)


def test_labels_never_overlap():
    # Cook: three objects with the same uniform prior -- their estimates nearly coincide
    beliefs = _uniform(["block", "sugar_box", "cracker_box"], [COUNTER], seed=3)
    fig = belief_figure(beliefs, [COUNTER])
    try:
        fig.canvas.draw()
        for ax in fig.axes:
            boxes = _label_boxes(ax)
            assert {"block", "sugar_box", "cracker_box", "counter"} <= {t for t, _ in boxes}
            for (ta, a), (tb, b) in itertools.combinations(boxes, 2):
                assert not a.overlaps(b), f"labels {ta!r} and {tb!r} overlap"
    finally:
        plt.close(fig)


def test_belief_plot_of_cook_writes_a_png(tmp_path):
    from ssr_compile.cli import main

    out = tmp_path / "b.png"
    assert main(["belief-plot", "cook", "--seed", "3", "-o", str(out)]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert plot_belief(_uniform(["x"], [COUNTER]), [COUNTER], tmp_path / "x.png").endswith("x.png")


def test_render_caption_writes_the_goal_in_pddl(tmp_path, monkeypatch):
    import matplotlib.figure
    from ssr_compile.sim.render import render_task

    texts: list[str] = []
    save = matplotlib.figure.Figure.savefig

    def spy(self, *a, **k):
        texts.extend(t.get_text() for ax in self.axes for t in ax.texts)
        return save(self, *a, **k)

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", spy)
    render_task("cook", 3, str(tmp_path / "s.png"))
    (caption,) = [t for t in texts if "goal" in t]
    assert "goal: (and (cooked block) (not (stoveon)))" in caption
    assert "('" not in caption
