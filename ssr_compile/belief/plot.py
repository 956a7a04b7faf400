"""Top-view pictures of pose beliefs, in the style of paper Fig. 3 (left): particles coloured
from black (low weight) to green (high weight) over the supporting surfaces."""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.colors import LinearSegmentedColormap  # noqa: E402
from matplotlib.patches import Rectangle  # noqa: E402

from .particles import PoseBelief, Surface  # noqa: E402

#: black (low weight) -> green (high weight)
WEIGHT_CMAP = LinearSegmentedColormap.from_list("black_green", ["#000000", "#00c800"])
_MARKERS = "o^sDvP*X<>"


def plot_belief(
    beliefs_or_belief: PoseBelief | Sequence[PoseBelief] | Mapping[str, PoseBelief],
    surfaces: Sequence[Surface],
    path: str | os.PathLike[str],
    title: str | None = None,
) -> str:
    """Draw a PNG top view at ``path``: surfaces as rectangles, particles as dots coloured by
    weight relative to the heaviest particle of their belief, one marker shape per object, and
    each object's point estimate labelled.  Returns the path written."""
    if isinstance(beliefs_or_belief, PoseBelief):
        beliefs = [beliefs_or_belief]
    elif isinstance(beliefs_or_belief, Mapping):
        beliefs = list(beliefs_or_belief.values())
    else:
        beliefs = list(beliefs_or_belief)
    fig, ax = plt.subplots(figsize=(7, 6), dpi=110)
    try:
        for s in surfaces:
            (cx, cy), (hx, hy) = s.center, s.half_extents
            ax.add_patch(
                Rectangle(
                    (cx - hx, cy - hy), 2 * hx, 2 * hy, facecolor="#eeeeee", edgecolor="#555555"
                )
            )
            ax.annotate(
                f"{s.name} (z={s.z:.2f})",
                (cx - hx, cy + hy),
                fontsize=7,
                color="#333333",
                va="bottom",
            )
        sc = None
        for k, pb in enumerate(beliefs):
            rel = pb.weights / pb.weights.max()
            order = np.argsort(rel, kind="stable")  # heavy particles drawn last, on top
            sc = ax.scatter(
                pb.poses[order, 0],
                pb.poses[order, 1],
                c=rel[order],
                cmap=WEIGHT_CMAP,
                vmin=0.0,
                vmax=1.0,
                s=10,
                marker=_MARKERS[k % len(_MARKERS)],
                linewidths=0,
                label=f"{pb.obj} (n={len(pb)})",
            )
            name, est = pb.point_estimate()
            ax.plot(est[0], est[1], "r+", markersize=10)
            ax.annotate(
                pb.obj,
                (est[0], est[1]),
                color="red",
                fontsize=9,
                xytext=(4, 4),
                textcoords="offset points",
            )
        if sc is not None:
            fig.colorbar(sc, ax=ax, label="weight / max weight")
            ax.legend(loc="upper right", fontsize=7)
        ax.set_aspect("equal")
        ax.autoscale_view()
        ax.margins(0.05)
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        ax.set_title(title or "pose beliefs (top view)")
        fig.tight_layout()
        fig.savefig(path)
    finally:
        plt.close(fig)
    return os.fspath(path)
