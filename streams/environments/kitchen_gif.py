"""Pictures of kitchen episodes: the fixed camera's view of the true world with the agent's
particle beliefs drawn over it and the executed action written in the frame
(``ssr-compile run TASK --gif FILE``).

``make_episode`` is the kitchen's episode factory (:func:`.kitchen.make_episode`) with a
renderer attached; the example's ``example.toml`` names it.
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from ssr_compile.sim.problem import to_world  # noqa: E402
from ssr_compile.sim.render import HEIGHT, WIDTH, project, render_image  # noqa: E402

from ssr_compile.belief.colors import object_colors  # noqa: E402

from .kitchen import make_episode as _kitchen_episode  # noqa: E402


def frame(environment, agent, caption: str) -> np.ndarray:
    """RGB (H, W, 3): the camera image, each belief's particles (size by weight, one colour
    per object) and ``caption``."""
    world = environment.world
    image = render_image(world, "camera")
    fig = plt.figure(figsize=(WIDTH / 100, HEIGHT / 100), dpi=100)
    ax = fig.add_axes((0, 0, 1, 1))
    ax.imshow(image)
    ax.set_xlim(0, WIDTH)
    ax.set_ylim(HEIGHT, 0)
    ax.axis("off")
    known = getattr(agent, "known", None)
    if known is not None:
        for obj, pb in sorted(known.beliefs.items()):
            pw = to_world(pb, known.drawers)
            px = project(world, pw.poses[:, :3], "camera")
            w = pw.weights / max(float(pw.weights.max()), 1e-12)
            ax.scatter(
                px[:, 0], px[:, 1], s=3 + 40 * w, c=object_colors(known.beliefs)[obj],
                alpha=0.55, edgecolors="none", label=obj,
            )  # fmt: skip
        ax.legend(loc="lower right", fontsize=7, framealpha=0.6, markerscale=1.5)
    ax.text(
        8, 8, caption, color="white", fontsize=8, va="top", family="monospace",
        bbox={"facecolor": "black", "alpha": 0.7, "pad": 3},
    )  # fmt: skip
    fig.canvas.draw()
    pixels = np.asarray(fig.canvas.buffer_rgba())[:, :, :3].copy()
    plt.close(fig)
    return pixels


def make_episode(task: str, seed: int = 0, **options):
    """The kitchen episode of ``task`` and ``seed`` with a renderer for ``--gif``."""
    episode = _kitchen_episode(task, seed, **options)
    episode.render = lambda caption: frame(episode.environment, episode.agent, caption)
    return episode
