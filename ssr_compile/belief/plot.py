"""Top-view pictures of pose beliefs, in the style of paper Fig. 3 (left).

One colour per object (:mod:`.colors`, as in every picture of the toolkit); a particle's weight (relative to its belief's heaviest) is its opacity
and size.  Surfaces stacked above one another (the two drawers of the kitchen) would overprint
in a top view, so the surfaces are split into layers of non-overlapping footprints and each
layer gets a panel of its own.  Labels (surface names, each object's point estimate) are
placed so that their boxes do not overlap, with a leader line when moved off their point.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.colors import to_rgba  # noqa: E402
from matplotlib.patches import Rectangle  # noqa: E402

from .colors import object_colors  # noqa: E402
from .particles import PoseBelief, Surface  # noqa: E402

MIN_ALPHA = 0.15


def plot_belief(
    beliefs_or_belief: PoseBelief | Sequence[PoseBelief] | Mapping[str, PoseBelief],
    surfaces: Sequence[Surface],
    path: str | os.PathLike[str],
    title: str | None = None,
) -> str:
    """Draw the PNG of :func:`belief_figure` at ``path``; returns the path written."""
    fig = belief_figure(beliefs_or_belief, surfaces, title)
    try:
        fig.savefig(path)
    finally:
        plt.close(fig)
    return os.fspath(path)


def belief_figure(
    beliefs_or_belief: PoseBelief | Sequence[PoseBelief] | Mapping[str, PoseBelief],
    surfaces: Sequence[Surface],
    title: str | None = None,
):
    """The figure (not yet saved): one panel per layer of non-overlapping surfaces; in each,
    surfaces as rectangles, each object's particles on them in the object's colour (opacity
    and size: weight / max weight), and each object's point estimate as a labelled cross."""
    beliefs = _as_list(beliefs_or_belief)
    surfaces = list(surfaces)
    for pb in beliefs:  # surfaces the beliefs know, drawn even if not given
        for s in pb.surfaces:
            if all(s.name != t.name for t in surfaces):
                surfaces.append(s)
    layers = surface_layers(surfaces)
    fig, axes = plt.subplots(
        1, len(layers), figsize=(5.2 * len(layers) + 1.0, 5.6), dpi=110, squeeze=False
    )
    axes = list(axes[0])
    colors = object_colors(pb.obj for pb in beliefs)  # as every picture of these objects
    for ax, layer in zip(axes, layers):
        names = {s.name for s in layer}
        for s in layer:
            (cx, cy), (hx, hy) = s.center, s.half_extents
            ax.add_patch(
                Rectangle(
                    (cx - hx, cy - hy), 2 * hx, 2 * hy, facecolor="#f2f2f2", edgecolor="#555555"
                )
            )
        for pb in beliefs:
            on = np.array([pb.surfaces[i].name in names for i in pb.labels], dtype=bool)
            if not on.any():
                continue
            rel = pb.weights / pb.weights.max()
            order = np.argsort(rel, kind="stable")  # heavy particles drawn last, on top
            order = order[on[order]]
            rgba = np.tile(to_rgba(colors[pb.obj]), (len(order), 1))
            rgba[:, 3] = MIN_ALPHA + (1 - MIN_ALPHA) * rel[order]
            ax.scatter(
                pb.poses[order, 0],
                pb.poses[order, 1],
                c=rgba,
                s=4 + 14 * rel[order],
                linewidths=0,
                label=f"{pb.obj} (n={len(pb)})",
                gid=f"particles:{pb.obj}",
            )
            surface, est = pb.point_estimate()
            if surface in names:
                ax.plot(est[0], est[1], "+", color=colors[pb.obj], markersize=11, mew=2)
        ax.set_aspect("equal")
        ax.autoscale_view()
        ax.margins(0.12)
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        ax.set_title(", ".join(f"{s.name} (z={s.z:.2f})" for s in layer), fontsize=8)
    handles = [
        plt.Line2D([], [], marker="o", ls="", color=colors[pb.obj], label=pb.obj) for pb in beliefs
    ]
    if handles:
        fig.legend(handles=handles, loc="upper right", fontsize=8, title="object", ncols=1)
    fig.suptitle(
        (title or "pose beliefs (top view)") + "\nopacity and size: weight / max weight",
        fontsize=10,
    )
    fig.tight_layout(rect=(0, 0, 0.9, 1))
    for ax, layer in zip(axes, layers):
        names = {s.name for s in layer}
        labels = []
        for s in layer:
            (cx, cy), (hx, hy) = s.center, s.half_extents
            labels.append((s.name, (cx - hx, cy + hy), "#333333", False))
        for pb in beliefs:
            surface, est = pb.point_estimate()
            if surface in names:
                labels.append((pb.obj, (est[0], est[1]), colors[pb.obj], True))
        place_labels(ax, labels)
    return fig


def surface_layers(surfaces: Sequence[Surface]) -> list[list[Surface]]:
    """Surfaces in layers (highest first) such that no two in a layer overlap in top view."""
    layers: list[list[Surface]] = []
    for s in sorted(surfaces, key=lambda s: -s.z):
        for layer in layers:
            if not any(_overlap(s, t) for t in layer):
                layer.append(s)
                break
        else:
            layers.append([s])
    return layers


def _overlap(a: Surface, b: Surface) -> bool:
    return all(
        abs(a.center[i] - b.center[i]) < a.half_extents[i] + b.half_extents[i] for i in (0, 1)
    )


# Offsets in points tried for a label, nearest first.
_OFFSETS = [(4, 4), (4, -12), (-4, 4), (-4, -12)] + [
    (dx, dy) for r in (18, 30, 44, 60) for dx, dy in ((r, r), (r, -r), (-r, r), (-r, -r), (0, r), (0, -r), (r, 0), (-r, 0))
]  # fmt: skip


def place_labels(ax, labels) -> list:
    """Annotate ``labels`` — ``(text, (x, y), colour, marker)`` — on ``ax`` so that no two
    label boxes overlap: each label takes the first offset whose box is clear of the labels
    already placed (a leader line when it is far from its point)."""
    fig = ax.figure
    renderer = fig.canvas.get_renderer()
    placed: list = []
    texts = []
    for text, xy, color, is_object in labels:
        best = None
        for dx, dy in _OFFSETS:
            ha = "left" if dx >= 0 else "right"
            far = abs(dx) > 6 or abs(dy) > 12
            ann = ax.annotate(
                text,
                xy,
                xytext=(dx, dy),
                textcoords="offset points",
                fontsize=9 if is_object else 7,
                color=color,
                fontweight="bold" if is_object else "normal",
                ha=ha,
                va="bottom",
                arrowprops={"arrowstyle": "-", "color": color, "lw": 0.6} if far else None,
                bbox={"boxstyle": "square,pad=0.1", "fc": "white", "ec": "none", "alpha": 0.7},
                gid=f"label:{text}",
            )
            box = ann.get_window_extent(renderer)
            if not any(box.overlaps(b) for b in placed):
                best = ann
                break
            ann.remove()
        if best is None:  # nowhere clear: the last offset, said so in its gid
            best = ax.annotate(
                text, xy, xytext=_OFFSETS[-1], textcoords="offset points", color=color,
                fontsize=7, gid=f"label:{text}",
            )  # fmt: skip
        placed.append(best.get_window_extent(renderer))
        texts.append(best)
    return texts


def _as_list(beliefs_or_belief) -> list[PoseBelief]:
    if isinstance(beliefs_or_belief, PoseBelief):
        return [beliefs_or_belief]
    if isinstance(beliefs_or_belief, Mapping):
        return list(beliefs_or_belief.values())
    return list(beliefs_or_belief)
