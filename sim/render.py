"""Pictures of a task's scene (docs/design.md §7): the fixed camera's view, or a top view with the
prior belief's particles (a uniform sample over each object's prior surfaces) drawn on it.

Rendered with pybullet's TinyRenderer in DIRECT mode; saved as PNG with matplotlib.
"""

from __future__ import annotations

import numpy as np
import pybullet as p

from ssr_compile.belief.colors import object_colors

from .tasks import make_task
from .world import World

WIDTH, HEIGHT = 640, 480
TOP_EYE = (0.45, 0.0, 4.0)
TOP_TARGET = (0.45, 0.0, 0.0)


def _matrices(world: World, view: str):
    if view == "camera":
        eye, target, up, fov = world.camera_eye, world.camera_target, (0, 0, 1), 60.0
    elif view == "top":
        eye, target, up, fov = TOP_EYE, TOP_TARGET, (1, 0, 0), 50.0
    else:
        raise ValueError(f"view must be 'camera' or 'top', got {view!r}")
    vm = p.computeViewMatrix(eye, target, up, physicsClientId=world.client)
    pm = p.computeProjectionMatrixFOV(fov, WIDTH / HEIGHT, 0.05, 10.0, physicsClientId=world.client)
    return vm, pm


def render_image(world: World, view: str = "camera") -> np.ndarray:
    """RGB image (H, W, 3) uint8 of the world."""
    vm, pm = _matrices(world, view)
    img = p.getCameraImage(
        WIDTH, HEIGHT, vm, pm, renderer=p.ER_TINY_RENDERER, physicsClientId=world.client
    )
    return np.reshape(np.asarray(img[2], dtype=np.uint8), (HEIGHT, WIDTH, 4))[:, :, :3]


def project(world: World, points: np.ndarray, view: str) -> np.ndarray:
    """Pixel coordinates (N, 2) of world points (N, 3) in the rendered image."""
    vm, pm = _matrices(world, view)
    v = np.asarray(vm).reshape(4, 4).T  # pybullet matrices are column-major
    pr = np.asarray(pm).reshape(4, 4).T
    hom = np.column_stack([points, np.ones(len(points))])
    clip = (pr @ v @ hom.T).T
    ndc = clip[:, :3] / clip[:, 3:4]
    return np.column_stack([(ndc[:, 0] + 1) / 2 * WIDTH, (1 - ndc[:, 1]) / 2 * HEIGHT])


def prior_particles(task, rng: np.random.Generator, n: int = 150) -> dict[str, np.ndarray]:
    """A uniform sample of ``n`` points (world xyz) over each object's prior surfaces."""
    out = {}
    for obj, entries in task.prior_surfaces().items():
        weights = np.array([w for _, w in entries], float)
        idx = rng.choice(len(entries), size=n, p=weights / weights.sum())
        pts = []
        for i in idx:
            surf = entries[i][0]
            xy = surf.sample_xy(rng, 1)[0]
            pts.append((xy[0], xy[1], surf.z + task.world.half_extents[obj][2]))
        out[obj] = np.array(pts)
    return out


def render_task(task_name: str, seed: int, path: str, view: str = "camera") -> str:
    """Write a PNG of task ``task_name`` generated from ``seed`` to ``path``; returns ``path``.

    ``view="camera"``: what the fixed camera sees.  ``view="top"``: a top view with the prior
    belief's particles."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    task = make_task(task_name, seed)
    try:
        img = render_image(task.world, view)
        fig = plt.figure(figsize=(WIDTH / 100, HEIGHT / 100), dpi=100)
        ax = fig.add_axes((0, 0, 1, 1))
        ax.imshow(img)
        ax.set_axis_off()
        if view == "top":
            particles = prior_particles(task, np.random.default_rng(seed))
            colors = object_colors(particles)  # as belief-plot and run --gif colour them
            for obj, pts in particles.items():
                uv = project(task.world, pts, view)
                ax.scatter(uv[:, 0], uv[:, 1], s=6, c=colors[obj], label=obj)
            ax.legend(loc="lower left", fontsize=7)
        from ssr_compile.printer import to_text

        from .problem import task_problem

        goal = to_text(task_problem(task)[0].goal)  # the goal as the planner reads it (PDDL)
        ax.text(5, 15, f"{task_name} seed={seed} goal: {goal}", fontsize=7, color="black")
        fig.savefig(path)
        plt.close(fig)
    finally:
        task.close()
    return path
