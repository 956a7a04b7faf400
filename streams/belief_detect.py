"""Streams of the abstract belief example ``domains/pddl/belief-detect`` (paper §IV-A, §V).

A camera fixed in the world looks over a table with two tall boxes A and B and a small target
object whose pose is uncertain: the prior belief puts 45% of its mass behind box A, 45% behind
box B (as seen from the camera) and 10% on a spot the camera sees whatever the boxes do.
The planner may ``detect`` the target (cost ``ObsCost``), move a box aside (cost 2) and
``pick`` the target once its belief is *localized*.

Scene (metres, world frame, z up; a small PyBullet DIRECT scene built on first use, one
client per streams instance (:func:`make_module`), disconnected at exit):

* camera eye at ``(0, 0, 1.1)``; table top ``z = 0.7`` centred at ``(1.0, 0)``;
* boxes (half extents 0.05 x 0.07 x 0.12) in front of the target's likely spots at
  ``(0.8, -/+0.15)``; the target's spots at ``(1.0, -/+0.1875)`` lie on the camera rays
  through the boxes; the always visible spot is at ``(1.0, 0.45)``;
* each box has an aside strip near ``y = -0.6`` (A) or ``y = -0.75`` (B), off every ray to
  the target's spots.

Costs (paper §V-A, self-loop determinization ``c + c'/p - c'``): ``c = 1`` is the cost of one
detection (an image and a detector pass); ``c' = 1`` is the cost of a failed one, after which
the robot is back where it was and looks again.  ``p`` is eq. 2's lower bound
``(1 - p_FN) P(X_i) (1 - eps)^(n-1)`` with ``p_FN = 0.1``, ``eps = 0.1`` and ``n = 3`` objects,
so ``p = 0.729 P(X_i)``.  Hence

* a detection behind a (moved) box: ``P(X) = 0.45``, ``p = 0.328``, ``ObsCost = 3.05``;
* a detection on the visible spot: ``P(X) = 0.10``, ``p = 0.0729``, ``ObsCost = 13.7``;

so moving the occluder first (``2 + 3.05 = 5.05``) beats detecting where the target is unlikely
(``13.7``); with the boxes already out of the way, detecting directly costs ``3.05``.
"""

from __future__ import annotations

import math
import sys
import weakref
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
import pybullet as p

from ssr_compile.belief.observation import (
    BeliefParameters,
    Observation,
    bvis,
    obs_cost,
    sample_obs,
    update_belief,
)
from ssr_compile.belief.particles import PoseBelief, Surface
from ssr_compile.belief.visibility import PyBulletCamera
from ssr_compile.stream import StreamInfo, StreamsModule

# ----------------------------------------------------------------- parameters

SEED = 0
# eps, delta, c (one detection), c' (a failed one: look again), p_FN = 0.1 and the detector's
# noise (sigma: 1 cm, 1 cm, 1 cm, 5 deg): the library's defaults, as in the kitchen
BELIEF = BeliefParameters()
N_OBJECTS = 3  # target, box A, box B: n in eq. 2
LOCALIZED_STD = 0.013  # localized: x and y spread at most 1.3 cm (one spot alone: 1.7 cm)

EYE = (0.0, 0.0, 1.1)
TABLE = Surface("table", (1.0, 0.0), (0.4, 0.8), 0.7)


@dataclass(frozen=True)
class Body:
    """A box-shaped object of the scene."""

    name: str
    half_extents: tuple[float, float, float]
    aside: Surface | None = None  # where a box may be moved out of the camera's way

    def pose_on(self, x: float, y: float) -> tuple[float, float, float, float]:
        return (x, y, TABLE.z + self.half_extents[2], 0.0)


BODIES = {
    "target": Body("target", (0.025, 0.025, 0.03)),
    "boxa": Body("boxa", (0.05, 0.07, 0.12), Surface("aside-a", (0.6, -0.6), (0.05, 0.04), 0.7)),
    "boxb": Body("boxb", (0.05, 0.07, 0.12), Surface("aside-b", (0.6, -0.75), (0.05, 0.04), 0.7)),
}
BEHIND_A = (1.0, -0.1875)
BEHIND_B = (1.0, 0.1875)
VISIBLE_SPOT = (1.0, 0.45)
PRIOR_MASS = {BEHIND_A: 0.45, BEHIND_B: 0.45, VISIBLE_SPOT: 0.10}
SPOT_SPREAD = 0.03  # particles of a spot lie within +/- 3 cm of it
PARTICLES_PER_SPOT = 30

# ----------------------------------------------------------------- the PyBullet scene


class Scene:
    """The DIRECT client, the body ids and the camera."""

    def __init__(self) -> None:
        self.client = p.connect(p.DIRECT)
        half = (*TABLE.half_extents, TABLE.z / 2)
        self.table = self._box(half, (*TABLE.center, TABLE.z / 2))
        self.ids: dict[str, int] = {}
        parking = {"target": VISIBLE_SPOT, "boxa": (0.8, -0.15), "boxb": (0.8, 0.15)}
        for name, body in BODIES.items():
            self.ids[name] = self._box(body.half_extents, body.pose_on(*parking[name])[:3])
        self.camera = PyBulletCamera(EYE, client=self.client)

    def _box(self, half_extents, position) -> int:
        shape = p.createCollisionShape(
            p.GEOM_BOX, halfExtents=list(half_extents), physicsClientId=self.client
        )
        return p.createMultiBody(0, shape, basePosition=list(position), physicsClientId=self.client)

    def close(self) -> None:
        if self.client is not None and p.isConnected(self.client):
            p.disconnect(self.client)
        self.client = None


# ----------------------------------------------------------------- beliefs


def prior_belief() -> PoseBelief:
    """The target's prior: 30 particles around each spot, weighted by :data:`PRIOR_MASS`."""
    gen = np.random.default_rng(SEED)
    z = TABLE.z + BODIES["target"].half_extents[2]
    poses, weights = [], []
    for (x, y), mass in PRIOR_MASS.items():
        xy = np.array([x, y]) + gen.uniform(-SPOT_SPREAD, SPOT_SPREAD, (PARTICLES_PER_SPOT, 2))
        for px, py in xy:
            poses.append((px, py, z, 0.0))
            weights.append(mass / PARTICLES_PER_SPOT)
    return PoseBelief.from_particles(
        "target",
        [TABLE],
        ["table"] * len(poses),
        np.array(poses),
        np.array(weights),
        z_offset=BODIES["target"].half_extents[2],
    )


def box_belief(name: str, x: float, y: float, surface: Surface = TABLE) -> PoseBelief:
    """A known box pose: a point belief."""
    return PoseBelief.point(name, surface, BODIES[name].pose_on(x, y))


# ----------------------------------------------------------------- streams


def update_belief_fn(o: str, pb1: PoseBelief, obs: Observation) -> tuple[PoseBelief] | None:
    """``update-belief``: the posterior assuming the hypothesised detection (paper §IV-A)."""
    if not o == pb1.obj == obs.obj:
        return None
    return (update_belief(o, pb1, obs, BELIEF.model),)


def is_localized(pb: PoseBelief) -> bool:
    """Spread of the belief in x and y at most :data:`LOCALIZED_STD` (and on one surface)."""
    return len(pb.surface_probs()) == 1 and float(pb.std()[:2].max()) <= LOCALIZED_STD + 1e-12


def localized_test(o: str, pb: PoseBelief) -> bool:
    """``test-localized`` / ``(localized ?o ?pb)``: ``pb`` is precise enough to grasp ``o``."""
    return pb.obj == o and is_localized(pb)


def obscost(o: str, pb: PoseBelief, obs: Observation) -> float | None:
    """``ObsCost ?o ?pb ?obs``: ``c + c'/p - c'`` with ``p`` eq. 2's bound (paper §V-A, §V-B);
    ``None`` (not applicable) when ``p = 0``."""
    if not o == pb.obj == obs.obj:
        return None
    cost = obs_cost(obs, pb, N_OBJECTS, BELIEF.c_detect, BELIEF.c_recover, BELIEF.model)
    return cost if math.isfinite(cost) else None


STREAM_INFO = {
    "sample-obs": {"p_success": 1.0, "cost": 0.1},
    "update-belief": {"kind": "function", "cost": 0.1},
    "test-vis": {"kind": "test", "p_success": 0.5, "cost": 0.2},
    "sample-aside": {"cost": 0.1},
    "test-localized": {"kind": "test", "p_success": 0.5, "cost": 0.05},
    # Planned with before evaluation: c, the cheapest any detection can be (p = 1).
    "obscost": {"optimistic_value": BELIEF.c_detect},
}

VALUES = {
    # problem-occluded: the boxes stand in front of the target's two likely spots
    "pb-target": prior_belief(),
    "pb-boxa": box_belief("boxa", 0.8, -0.15),
    "pb-boxb": box_belief("boxb", 0.8, 0.15),
    # problem-clear: the boxes stand by the table's edge, out of the camera's way
    "pb-boxa-clear": box_belief("boxa", 0.65, -0.5),
    "pb-boxb-clear": box_belief("boxb", 0.65, -0.7),
}


class DetectStreams:
    """The streams of one solve or one episode: their seeded random generator (ties between
    observation regions, aside placements) and their PyBullet scene (visibility tests), both
    owned by this object -- no module globals.  :func:`make_module` wraps one."""

    def __init__(self, seed: int = SEED):
        self.rng = np.random.default_rng(seed)
        self._scene: Scene | None = None

    def scene(self) -> Scene:
        """The scene, created on first use and disconnected when this object is collected
        (or at exit)."""
        if self._scene is None:
            self._scene = Scene()
            weakref.finalize(self, self._scene.close)
        return self._scene

    def sample_obs(self, o: str, pb: PoseBelief) -> Iterator[tuple[Observation]]:
        """``sample-obs``: observations ``(z, X_i, eps)`` of ``o`` under ``pb`` (paper §V-B).

        The library's :func:`ssr_compile.belief.observation.sample_obs`, heaviest first (ties
        broken by the seeded generator): the planner first sees the observations most likely to
        succeed (here behind A or B, 0.45 each) and the visible spot (0.10) only afterwards.
        Ends when every particle is covered.
        """
        if o != pb.obj:
            return
        yield from sample_obs(
            o, pb, self.rng, delta=BELIEF.delta, eps=BELIEF.eps, heaviest_first=True
        )

    def vis_test(self, o: str, obs: Observation, o2: str, pb2: PoseBelief) -> bool:
        """``test-vis`` / ``BVis ?o ?obs ?o2 ?pb2``: ``o2`` under ``pb2`` leaves ``X_i`` visible
        with probability at least ``1 - eps`` (ray casts, paper §V-B)."""
        if o == o2 or obs.obj != o or pb2.obj != o2:
            return True  # an object never occludes itself (the derived predicate excludes it)
        sc = self.scene()
        return bvis(obs, sc.ids[o2], pb2, sc.camera, half_extents=BODIES[o].half_extents)

    def sample_aside(self, b: str) -> Iterator[tuple[PoseBelief]]:
        """Placements of box ``b`` on its aside strip (known poses: point beliefs), endless."""
        body = BODIES.get(b)
        if body is None or body.aside is None:
            return
        while True:
            x, y = body.aside.sample_xy(self.rng, 1)[0]
            yield (box_belief(b, float(x), float(y), body.aside),)

    def streams(self) -> dict:
        return {
            "sample-obs": self.sample_obs,
            "update-belief": update_belief_fn,
            "test-vis": self.vis_test,
            "sample-aside": self.sample_aside,
            "test-localized": localized_test,
            "obscost": obscost,
        }

    def module(self, values: dict | None = None) -> StreamsModule:
        """A :class:`StreamsModule` over these streams (``values``: the objects' Python
        values, :data:`VALUES` by default)."""
        return StreamsModule(
            "ssr_compile.streams.belief_detect",
            self.streams(),
            {k: StreamInfo.of(v, k) for k, v in STREAM_INFO.items()},
            dict(VALUES if values is None else values),
            sys.modules[__name__],
        )


def make_module(seed: int = SEED, problem: str | None = None) -> StreamsModule:
    """The streams with their own generator seeded by ``seed`` (``ssr-compile solve --seed
    N``) and their own scene.  Both problems' objects are in :data:`VALUES`, so ``problem``
    (the problem file's path) changes nothing."""
    return DetectStreams(seed).module()


# The module's own STREAMS (for from_module and `import`): a default instance with seed 0.
STREAMS = DetectStreams(SEED).streams()
