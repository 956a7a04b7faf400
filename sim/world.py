"""The PyBullet kitchen of paper §VIII, built from primitives (docs/design.md §6).

Layout (metres, world frame; the robot works in ``x < 0.8`` and faces +x):

* floor; a counter ``x in [0.8, 1.3], y in [0.4, 1.2]``, top at 0.70;
* a cabinet ``x in [0.8, 1.3], y in [-0.35, 0.35]`` (height 0.70) holding a top and a bottom
  drawer on prismatic joints (axis -x, so the joint value is how far the drawer is open, in
  ``[0, DRAWER_TRAVEL]``).  Drawers are open-top boxes; the top drawer's floor is 0.15 below
  the cabinet's top panel, so the tall sugar box (0.18) standing in it hits the cabinet when
  the drawer is pushed in (the Stow task), while the block (0.04) fits;
* a stove ``x in [0.8, 1.3], y in [-1.0, -0.4]`` with a burner plate on top and a button on
  its front face;
* a camera fixed in the world frame, above and in front of the furniture.

Object poses are kept as (support, pose relative to the support's frame), as in paper §III
("the discrete frame each object is attached to, and the pose relative to it"): objects in a
drawer move with it.  The world is kinematic: no dynamics are stepped, every state change is
a reset, collisions are ``getClosestPoints`` queries with an explicit client id.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Iterable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np
import pybullet as p

from .geometry import (
    IDENTITY_QUAT,
    Pose,
    invert,
    multiply,
    pose,
    quat_from_yaw,
    quat_mul,
    quat_to_matrix,
    rotate,
    yaw_of,
)
from .robot import ARM_TUCK, BASE_CLEARANCE, BASE_HALF_EXTENTS, FINGER_OPEN, Robot

COUNTER_TOP = 0.70
CABINET_FRONT = 0.8
CABINET_BACK = 1.3
CABINET_HALF_WIDTH = 0.35
DRAWER_TRAVEL = 0.38
DRAWER_LENGTH = 0.44
DRAWER_HALF_WIDTH = 0.32
DRAWER_WALL = 0.08
#: Per drawer: (floor top z, opening bottom z, opening top z).
DRAWER_LEVELS = {"top_drawer": (0.53, 0.42, 0.68), "bottom_drawer": (0.20, 0.05, 0.40)}
DRAWERS = ("top_drawer", "bottom_drawer")
HANDLE_OFFSET = 0.05  # handle bar centre in front of the drawer front
STOVE_Y = (-1.0, -0.4)
BURNER = ((0.9, 1.2), (-0.85, -0.55))  # x range, y range
BURNER_TOP = COUNTER_TOP + 0.01
BUTTON_CENTER = (CABINET_FRONT - 0.01, -0.7, 0.55)
SURFACE_MARGIN = 0.005
PLACE_GAP = 1e-3  # objects rest this far above their support (no spurious contacts)
# An object released at most this tilted (rad) settles upright (:meth:`World.stable_on`): the
# in-hand pose carries the arm's IK error from the pick, and Cook seed 20 released the cracker
# box 0.3 degrees off upright, 1.3 mm above the counter, refused 40 times in a row.
SETTLE_TILT = 0.05
COLLISION_TOL = 1e-4
COLLISIONS_KEPT = 50_000  # robot_collision's answers kept per world (about 40 MB at most)

#: The kinds of objects the world can build: half extents (x, y, z) and colour.  The sugar box
#: is taller than the top drawer's clearance (0.15) and both boxes are tall enough to hide the
#: block from the camera.  A task names its objects and gives each a kind (``sim/task_file.py``);
#: a world built without a list has one object of each kind, named after it.
OBJECTS = {
    "block": ((0.02, 0.02, 0.02), (0.1, 0.8, 0.1, 1.0)),
    "sugar_box": ((0.045, 0.025, 0.09), (0.95, 0.85, 0.2, 1.0)),
    "cracker_box": ((0.08, 0.03, 0.105), (0.85, 0.15, 0.1, 1.0)),
}

#: An object taller than this (the top drawer's clearance) is tall: plans put it on the counter
#: only (``sim/problem.py``).
TALL_HEIGHT = 0.15

CAMERA_EYE = (0.15, -0.25, 2.2)
CAMERA_TARGET = (0.95, 0.1, 0.45)
#: A base pose from which the robot (arm tucked) does not block the camera's view.
PARK_BASE = (-0.6, -1.3, 0.0)


@dataclass(frozen=True)
class SurfaceRegion:
    """A placement rectangle ``[lo, hi]`` (x, y) at height ``z`` in the frame of (body, link)."""

    name: str
    body: int
    link: int
    lo: tuple[float, float]
    hi: tuple[float, float]
    z: float


@dataclass
class Held:
    obj: str
    grasp: Pose  # object pose in the tool frame


class ExecutionError(RuntimeError):
    """An action could not be executed in the simulator (precondition violated)."""


def _boxes(
    client: int, boxes: Sequence[tuple[Sequence[float], Sequence[float]]]
) -> tuple[int, int]:
    """Compound collision + visual shape of boxes given as (center, half_extents)."""
    centers = [list(c) for c, _ in boxes]
    halves = [list(h) for _, h in boxes]
    n = len(boxes)
    col = p.createCollisionShapeArray(
        [p.GEOM_BOX] * n,
        halfExtents=halves,
        collisionFramePositions=centers,
        physicsClientId=client,
    )
    vis = p.createVisualShapeArray(
        [p.GEOM_BOX] * n, halfExtents=halves, visualFramePositions=centers, physicsClientId=client
    )
    return col, vis


def surface_rects() -> dict[str, tuple[tuple[float, float], tuple[float, float], float]]:
    """Each surface's placement rectangle ``(lo, hi, z)`` in its own frame (the counter, the
    burner, and the part of each drawer that is out of the cabinet when it is fully open)."""
    m = 0.03
    out = {
        "counter": ((CABINET_FRONT + m, 0.4 + m), (CABINET_BACK - m, 1.2 - m), COUNTER_TOP),
        "stove": ((BURNER[0][0], BURNER[1][0]), (BURNER[0][1], BURNER[1][1]), BURNER_TOP),
    }
    inner = DRAWER_HALF_WIDTH - 0.01
    for name in DRAWERS:
        out[name] = ((0.01, -inner), (DRAWER_TRAVEL - 0.02, inner), 0.0)
    return out


def _span(lo: float, hi: float) -> tuple[float, float]:
    """(center, half extent) of an interval."""
    return (lo + hi) / 2.0, (hi - lo) / 2.0


def _box(x: Sequence[float], y: Sequence[float], z: Sequence[float]):
    (cx, hx), (cy, hy), (cz, hz) = _span(*x), _span(*y), _span(*z)
    return (cx, cy, cz), (hx, hy, hz)


class World:
    """One kitchen in its own pybullet client (``p.DIRECT`` unless ``gui``).

    ``objects``: name -> (half extents, colour) of the movable objects to build (default
    :data:`OBJECTS`: one of each kind)."""

    def __init__(
        self,
        *,
        gui: bool = False,
        objects: dict[str, tuple[tuple[float, float, float], tuple[float, ...]]] | None = None,
    ) -> None:
        self.client = p.connect(p.GUI if gui else p.DIRECT)
        c = self.client
        if gui:
            p.configureDebugVisualizer(p.COV_ENABLE_GUI, 0, physicsClientId=c)
        # Floor
        col, vis = _boxes(c, [((0, 0, -0.01), (4.0, 4.0, 0.01))])
        self.floor = p.createMultiBody(0, col, vis, physicsClientId=c)
        self._color(self.floor, -1, (0.75, 0.75, 0.72, 1))
        # Counter
        col, vis = _boxes(c, [_box((CABINET_FRONT, CABINET_BACK), (0.4, 1.2), (0, COUNTER_TOP))])
        self.counter = p.createMultiBody(0, col, vis, physicsClientId=c)
        self._color(self.counter, -1, (0.55, 0.45, 0.35, 1))
        # Stove with burner and button (fixed links so that they can be coloured)
        self.stove = self._build_stove()
        # Cabinet with two drawers
        self.cabinet = self._build_cabinet()
        self.drawer_link = {name: i for i, name in enumerate(DRAWERS)}
        # Objects
        self.objects: dict[str, int] = {}
        self.half_extents: dict[str, tuple[float, float, float]] = {}
        self.colors: dict[str, tuple[float, ...]] = {}
        for name, (half, rgba) in (OBJECTS if objects is None else objects).items():
            col, vis = _boxes(c, [((0, 0, 0), half)])
            body = p.createMultiBody(0, col, vis, basePosition=(0, 0, -5), physicsClientId=c)
            self._color(body, -1, rgba)
            self.objects[name] = body
            self.half_extents[name] = tuple(half)
            self.colors[name] = tuple(rgba)
        self.body_names = {b: n for n, b in self.objects.items()}
        self.robot = Robot(c)
        self._arm_links: list[int] | None = None  # the links _arm_over_base checks
        self._bodies: list[int] | None = None  # the client's bodies (see state_key)
        self._jointed: list[tuple[int, list[int]]] = []  # (body, its joints that move)
        self._collisions: dict[tuple, bool] = {}  # robot_collision's answers by state_key
        self.collisions_reused = 0  # for benchmarks and tests
        self.surfaces = self._surfaces()
        # State
        self.support: dict[str, tuple[str, Pose] | None] = {n: None for n in self.objects}
        self.held: Held | None = None
        self.drawer_q = {d: 0.0 for d in DRAWERS}
        self.stove_on = False
        self.cooked: set[str] = set()
        self.camera_eye = CAMERA_EYE
        self.camera_target = CAMERA_TARGET
        self._camera = None
        self.set_base(PARK_BASE)
        self.set_arm(ARM_TUCK)
        for d in DRAWERS:
            self.set_drawer(d, 0.0)

    # -- construction ---------------------------------------------------------------------------
    def _color(self, body: int, link: int, rgba) -> None:
        p.changeVisualShape(body, link, rgbaColor=list(rgba), physicsClientId=self.client)

    def _build_stove(self) -> int:
        c = self.client
        col, vis = _boxes(c, [_box((CABINET_FRONT, CABINET_BACK), STOVE_Y, (0, COUNTER_TOP))])
        b_col, b_vis = _boxes(c, [_box(BURNER[0], BURNER[1], (COUNTER_TOP, BURNER_TOP))])
        bx, by, bz = BUTTON_CENTER
        k_col, k_vis = _boxes(c, [((bx, by, bz), (0.01, 0.025, 0.025))])
        body = p.createMultiBody(
            0, col, vis,
            linkMasses=[0, 0], linkCollisionShapeIndices=[b_col, k_col],
            linkVisualShapeIndices=[b_vis, k_vis],
            linkPositions=[(0, 0, 0)] * 2, linkOrientations=[(0, 0, 0, 1)] * 2,
            linkInertialFramePositions=[(0, 0, 0)] * 2,
            linkInertialFrameOrientations=[(0, 0, 0, 1)] * 2,
            linkParentIndices=[0, 0], linkJointTypes=[p.JOINT_FIXED] * 2,
            linkJointAxis=[(0, 0, 1)] * 2, physicsClientId=c,
        )  # fmt: skip
        self._color(body, -1, (0.9, 0.9, 0.9, 1))
        self._color(body, 0, (0.15, 0.15, 0.15, 1))
        self._color(body, 1, (0.8, 0.1, 0.1, 1))
        self.burner_link, self.button_link = 0, 1
        return body

    def _build_cabinet(self) -> int:
        c = self.client
        f, b, w = CABINET_FRONT, CABINET_BACK, CABINET_HALF_WIDTH
        carcass = [
            _box((b - 0.02, b), (-w, w), (0, COUNTER_TOP)),  # back
            _box((f, b), (-w, -w + 0.02), (0, COUNTER_TOP)),  # sides
            _box((f, b), (w - 0.02, w), (0, COUNTER_TOP)),
            _box((f, b), (-w, w), (COUNTER_TOP - 0.02, COUNTER_TOP)),  # top panel
            _box((f, b), (-w, w), (0.40, 0.42)),  # shelf between the drawers
            _box((f, b), (-w, w), (0.0, 0.05)),  # bottom
        ]
        col, vis = _boxes(c, carcass)
        link_cols, link_vis, link_pos = [], [], []
        hw, wall, length = DRAWER_HALF_WIDTH, DRAWER_WALL, DRAWER_LENGTH
        for name in DRAWERS:
            floor_z, open_lo, open_hi = DRAWER_LEVELS[name]
            front_z = (open_lo - floor_z - 0.01, open_hi - floor_z + 0.01)  # covers the opening
            handle_z = (front_z[0] + front_z[1]) / 2.0
            parts = [
                _box((0.0, length), (-hw + 0.01, hw - 0.01), (-0.01, 0.0)),  # floor
                _box((-0.02, 0.0), (-w, w), front_z),  # front panel
                _box((length - 0.01, length), (-hw + 0.01, hw - 0.01), (-0.01, wall)),  # back
                _box((0.0, length), (-hw, -hw + 0.01), (-0.01, wall)),  # sides
                _box((0.0, length), (hw - 0.01, hw), (-0.01, wall)),
                _box((-HANDLE_OFFSET - 0.01, -HANDLE_OFFSET + 0.01), (-0.07, 0.07),
                     (handle_z - 0.01, handle_z + 0.01)),  # handle bar
                _box((-HANDLE_OFFSET + 0.01, -0.02), (-0.07, -0.05), (handle_z - 0.01, handle_z + 0.01)),
                _box((-HANDLE_OFFSET + 0.01, -0.02), (0.05, 0.07), (handle_z - 0.01, handle_z + 0.01)),
            ]  # fmt: skip
            lc, lv = _boxes(c, parts)
            link_cols.append(lc)
            link_vis.append(lv)
            link_pos.append((f, 0.0, floor_z))
        self.handle_z = {
            name: (DRAWER_LEVELS[name][1] + DRAWER_LEVELS[name][2]) / 2.0 for name in DRAWERS
        }
        body = p.createMultiBody(
            0, col, vis,
            linkMasses=[0, 0], linkCollisionShapeIndices=link_cols, linkVisualShapeIndices=link_vis,
            linkPositions=link_pos, linkOrientations=[(0, 0, 0, 1)] * 2,
            linkInertialFramePositions=[(0, 0, 0)] * 2,
            linkInertialFrameOrientations=[(0, 0, 0, 1)] * 2,
            linkParentIndices=[0, 0], linkJointTypes=[p.JOINT_PRISMATIC] * 2,
            linkJointAxis=[(-1, 0, 0)] * 2, physicsClientId=c,
        )  # fmt: skip
        self._color(body, -1, (0.85, 0.8, 0.7, 1))
        self._color(body, 0, (0.6, 0.7, 0.85, 1))
        self._color(body, 1, (0.6, 0.85, 0.7, 1))
        return body

    def _surfaces(self) -> dict[str, SurfaceRegion]:
        frames = {"counter": (self.counter, -1), "stove": (self.stove, -1)}
        frames.update({name: (self.cabinet, i) for i, name in enumerate(DRAWERS)})
        return {
            name: SurfaceRegion(name, *frames[name], lo, hi, z)
            for name, (lo, hi, z) in surface_rects().items()
        }

    def shapes(self) -> dict[str, tuple[tuple[float, float, float], tuple[float, ...]]]:
        """name -> (half extents, colour) of the movable objects (``World(objects=...)``)."""
        return {n: (self.half_extents[n], self.colors[n]) for n in self.objects}

    def is_tall(self, name: str) -> bool:
        """Taller than :data:`TALL_HEIGHT` (the boxes): counter only for plans."""
        return 2 * self.half_extents[name][2] > TALL_HEIGHT

    def close(self) -> None:
        self.robot.close()
        if p.isConnected(self.client):
            p.disconnect(self.client)

    def __enter__(self) -> World:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # -- frames -----------------------------------------------------------------------------
    def link_pose(self, body: int, link: int) -> Pose:
        if link < 0:
            pos, quat = p.getBasePositionAndOrientation(body, physicsClientId=self.client)
            return pose(pos, quat)
        st = p.getLinkState(body, link, computeForwardKinematics=True, physicsClientId=self.client)
        return pose(st[4], st[5])

    def surface_frame(self, surface: str) -> Pose:
        s = self.surfaces[surface]
        return self.link_pose(s.body, s.link)

    def object_pose(self, name: str) -> Pose:
        """Current world pose of an object (held objects follow the tool)."""
        if self.held is not None and self.held.obj == name:
            return multiply(self.robot.tool_pose(), self.held.grasp)
        sup = self.support[name]
        if sup is None:
            raise KeyError(f"{name} is nowhere")
        return multiply(self.surface_frame(sup[0]), sup[1])

    def surface_world_rect(self, surface: str) -> tuple[np.ndarray, np.ndarray, float]:
        """World-frame (lo_xy, hi_xy, z) of a surface's placement rectangle (axis aligned)."""
        s = self.surfaces[surface]
        frame = self.surface_frame(surface)
        a = np.asarray(multiply(frame, pose((s.lo[0], s.lo[1], s.z)))[0])
        b = np.asarray(multiply(frame, pose((s.hi[0], s.hi[1], s.z)))[0])
        return np.minimum(a, b)[:2], np.maximum(a, b)[:2], float(a[2])

    def footprint(self, name: str, world_pose: Pose) -> np.ndarray:
        """World xy of the four bottom corners of an object at ``world_pose`` (4, 2)."""
        hx, hy, hz = self.half_extents[name]
        corners = [(sx * hx, sy * hy, -hz) for sx in (-1, 1) for sy in (-1, 1)]
        return np.array([multiply(world_pose, pose(c))[0][:2] for c in corners])

    def rest_pose(self, name: str, surface: str, x: float, y: float, yaw: float) -> Pose:
        """Relative pose in the surface frame of ``name`` standing upright at (x, y, yaw)."""
        s = self.surfaces[surface]
        return pose((x, y, s.z + self.half_extents[name][2] + PLACE_GAP), quat_from_yaw(yaw))

    def inside_surface(self, name: str, surface: str, rel: Pose, margin: float = 0.0) -> bool:
        """Footprint of ``name`` at ``rel`` (surface frame) lies inside the surface rectangle."""
        s = self.surfaces[surface]
        hx, hy, _ = self.half_extents[name]
        yaw = yaw_of(rel[1])
        c, si = abs(math.cos(yaw)), abs(math.sin(yaw))
        ex, ey = c * hx + si * hy, si * hx + c * hy
        x, y = rel[0][0], rel[0][1]
        return bool(
            x - ex >= s.lo[0] + margin
            and x + ex <= s.hi[0] - margin
            and y - ey >= s.lo[1] + margin
            and y + ey <= s.hi[1] - margin
        )

    def stable_on(
        self, name: str, surface: str, world_pose: Pose, z_tol: float = 0.01
    ) -> Pose | None:
        """Relative pose if ``name`` released at ``world_pose`` rests inside ``surface`` (at
        most :data:`SETTLE_TILT` off upright, within ``z_tol`` above it): its upright rest pose
        there; else None."""
        rel = multiply(invert(self.surface_frame(surface)), world_pose)
        s = self.surfaces[surface]
        # the tilt of the object's z axis: 2 asin(|(qx, qy)|)
        upright = 2.0 * math.asin(min(1.0, math.hypot(rel[1][0], rel[1][1]))) <= SETTLE_TILT
        dz = rel[0][2] - (s.z + self.half_extents[name][2])
        if upright and -1e-3 <= dz <= z_tol and self.inside_surface(name, surface, rel):
            return self.rest_pose(name, surface, rel[0][0], rel[0][1], yaw_of(rel[1]))
        return None

    # -- state setters ----------------------------------------------------------------------------
    def sync(self) -> None:
        """Reset every object body to the pose implied by the state."""
        for name, body in self.objects.items():
            if self.held is None and self.support[name] is None:
                continue
            if self.support[name] is None and (self.held is None or self.held.obj != name):
                continue
            pos, quat = self.object_pose(name)
            p.resetBasePositionAndOrientation(body, pos, quat, physicsClientId=self.client)

    def place_object(self, name: str, surface: str, rel: Pose) -> None:
        self.support[name] = (surface, pose(*rel))
        if self.held is not None and self.held.obj == name:
            self.held = None
        self.sync()
        self._cook()

    def remove_object(self, name: str) -> None:
        """Take ``name`` out of the scene (tasks that do not use it)."""
        self.support[name] = None
        p.resetBasePositionAndOrientation(
            self.objects[name], (0, 0, -5), (0, 0, 0, 1), physicsClientId=self.client
        )

    def present(self) -> list[str]:
        """Objects in the scene (resting somewhere or held)."""
        held = None if self.held is None else self.held.obj
        return [n for n in self.objects if self.support[n] is not None or n == held]

    def set_object(self, name: str, surface: str, x: float, y: float, yaw: float) -> None:
        self.place_object(name, surface, self.rest_pose(name, surface, x, y, yaw))

    def set_drawer(self, drawer: str, q: float) -> None:
        q = float(np.clip(q, 0.0, DRAWER_TRAVEL))
        self.drawer_q[drawer] = q
        p.resetJointState(self.cabinet, self.drawer_link[drawer], q, physicsClientId=self.client)
        self.sync()

    def set_base(self, conf: Sequence[float]) -> None:
        self.robot.set_base(conf)
        self.sync()

    def set_arm(self, conf: Sequence[float]) -> None:
        self.robot.set_arm(conf)
        if self.held is not None:
            self.sync()

    def grab(self, name: str, grasp: Pose) -> None:
        self.support[name] = None
        self.held = Held(name, pose(*grasp))
        hy = self.half_extents[name]
        self.robot.set_fingers(min(0.04, min(hy[:2]) + 0.002))
        self.sync()

    def _cook(self) -> None:
        if self.stove_on:
            for name, sup in self.support.items():
                if sup is not None and sup[0] == "stove":
                    self.cooked.add(name)

    def toggle_stove(self) -> None:
        self.stove_on = not self.stove_on
        self._color(
            self.stove,
            self.burner_link,
            (0.9, 0.3, 0.0, 1) if self.stove_on else (0.15, 0.15, 0.15, 1),
        )
        self._cook()

    # -- snapshots -----------------------------------------------------------------------------
    def snapshot(self) -> dict:
        return {
            "base": self.robot.get_base(),
            "arm": self.robot.get_arm(),
            "held": None if self.held is None else (self.held.obj, self.held.grasp),
            "support": dict(self.support),
            "drawers": dict(self.drawer_q),
            "stove_on": self.stove_on,
            "cooked": set(self.cooked),
        }

    def restore(self, snap: dict) -> None:
        self.support = dict(snap["support"])
        self.held = None if snap["held"] is None else Held(*snap["held"])
        self.stove_on = snap["stove_on"]
        self.cooked = set(snap["cooked"])
        self.robot.set_base(snap["base"])
        self.robot.set_arm(snap["arm"])
        if self.held is None:
            self.robot.set_fingers(FINGER_OPEN)
        for d, q in snap["drawers"].items():
            p.resetJointState(self.cabinet, self.drawer_link[d], q, physicsClientId=self.client)
            self.drawer_q[d] = q
        for name, body in self.objects.items():
            if self.support[name] is None and (self.held is None or self.held.obj != name):
                p.resetBasePositionAndOrientation(
                    body, (0, 0, -5), (0, 0, 0, 1), physicsClientId=self.client
                )
        self.sync()

    @contextmanager
    def saved(self) -> Iterator[None]:
        """Restore the full state on exit (streams use this to check hypothetical states)."""
        snap = self.snapshot()
        try:
            yield
        finally:
            self.restore(snap)

    def true_state(self) -> dict:
        """The latent state, for evaluation only (never an input of the policy)."""
        objects = {}
        for name in self.present():
            sup = self.support[name]
            where = "hand" if sup is None else sup[0]
            pos, quat = self.object_pose(name)
            objects[name] = {"surface": where, "pose": (*pos, yaw_of(quat))}
        return {
            "base": self.robot.get_base(),
            "arm": self.robot.get_arm(),
            "holding": None if self.held is None else self.held.obj,
            "drawers": dict(self.drawer_q),
            "objects": objects,
            "stove_on": self.stove_on,
            "cooked": sorted(self.cooked),
        }

    # -- collisions ----------------------------------------------------------------------------
    def _pair(self, a: int, b: int, link_a: int | None = None, link_b: int | None = None) -> bool:
        kw = {}
        if link_a is not None:
            kw["linkIndexA"] = link_a
        if link_b is not None:
            kw["linkIndexB"] = link_b
        pts = p.getClosestPoints(a, b, 0.0, physicsClientId=self.client, **kw)
        return any(pt[8] < -COLLISION_TOL for pt in pts)

    def obstacles(self, ignore: Iterable[str] = ()) -> list[int]:
        skip = set(ignore)
        if self.held is not None:
            skip.add(self.held.obj)
        out = [self.floor, self.counter, self.stove, self.cabinet]
        out += [b for n, b in self.objects.items() if n not in skip and self.support[n] is not None]
        return out

    def robot_collision(self, ignore: Iterable[str] = (), ignore_hand: Iterable[str] = ()) -> bool:
        """Robot (and what it holds) in collision with the world at the current state.

        ``ignore``: objects not checked at all; ``ignore_hand``: objects the gripper links may
        touch (the object being grasped at the grasp configuration).

        Answers are kept by :meth:`state_key` (streams check the same configurations in the
        same scene again and again: a cartesian path solved again from the same base)."""
        key = (self.state_key(), tuple(sorted(set(ignore))), tuple(sorted(set(ignore_hand))))
        found = self._collisions.get(key)
        if found is not None:
            self.collisions_reused += 1
            return found
        out = self._robot_collision(ignore, ignore_hand)
        kept = self._collisions
        while kept and len(kept) >= COLLISIONS_KEPT:
            del kept[next(iter(kept))]
        if COLLISIONS_KEPT > 0:
            kept[key] = out
        return out

    def state_key(self) -> tuple:
        """What a collision query of this client reads, as pybullet has it (whoever set it):
        every body's base pose and the positions of its joints that move; and which objects
        are present and held."""
        c = self.client
        if self._bodies is None or len(self._bodies) != p.getNumBodies(physicsClientId=c):
            self._bodies = [p.getBodyUniqueId(i, physicsClientId=c)
                            for i in range(p.getNumBodies(physicsClientId=c))]  # fmt: skip
            self._jointed = []
            for body in self._bodies:
                moving = [j for j in range(p.getNumJoints(body, physicsClientId=c))
                          if p.getJointInfo(body, j, physicsClientId=c)[2] != p.JOINT_FIXED]  # fmt: skip
                if moving:
                    self._jointed.append((body, moving))
        values: list[float] = []
        for body in self._bodies:
            pos, quat = p.getBasePositionAndOrientation(body, physicsClientId=c)
            values += pos
            values += quat
        for body, joints in self._jointed:
            values += [s[0] for s in p.getJointStates(body, joints, physicsClientId=c)]
        held = None if self.held is None else self.held.obj
        present = tuple([n for n in self.objects if self.support[n] is not None])
        return struct.pack(f"{len(values)}d", *values), held, present  # packed: 600 bytes

    def _robot_collision(self, ignore: Iterable[str], ignore_hand: Iterable[str]) -> bool:
        r = self.robot
        hand_ok = {self.objects[n] for n in ignore_hand}
        for body in self.obstacles(ignore):
            if body in hand_ok:
                for link in range(p.getNumJoints(r.body, physicsClientId=self.client)):
                    if link not in r.hand_links and self._pair(r.body, body, link):
                        return True
            elif self._pair(r.body, body):
                return True
        # Arm against its own base.  pybullet answers no closest-point query between links of
        # one body, so: no hand or forearm link origin may enter the base box (inflated).
        if self._arm_over_base():
            return True
        if self.held is not None:
            hb = self.objects[self.held.obj]
            for body in self.obstacles(ignore):
                if self._pair(hb, body):
                    return True
            if self._pair(hb, r.body, link_b=r.base_link):
                return True
        return False

    def robot_clearances(self, reach: float, ignore: Iterable[str] = ()) -> dict[int, float]:
        """The smallest signed distance (negative: penetration) from the robot, or what it
        holds, to each obstacle closer than ``reach``, by body (robot against its own base
        excluded; see :meth:`robot_collision`)."""
        out: dict[int, float] = {}
        movers = [self.robot.body]
        if self.held is not None:
            movers.append(self.objects[self.held.obj])
        for body in self.obstacles(ignore):
            for m in movers:
                for pt in p.getClosestPoints(m, body, reach, physicsClientId=self.client):
                    if pt[8] < out.get(body, reach):
                        out[body] = pt[8]
        return out

    def robot_contacts(self) -> list[str]:
        """What the robot (or what it holds) touches now, by name (for messages)."""
        names = {self.floor: "floor", self.counter: "counter", self.stove: "stove"}
        names[self.cabinet] = "cabinet"
        names.update({b: n for n, b in self.objects.items()})
        out = []
        for body in self.obstacles():
            if self._pair(self.robot.body, body) or (
                self.held is not None and self._pair(self.objects[self.held.obj], body)
            ):
                out.append(names.get(body, f"body {body}"))
        if self._arm_over_base():
            out.append("its own base")
        return out

    def _arm_over_base(self, inflate: float = 0.08) -> bool:
        r = self.robot
        base = self.link_pose(r.body, r.base_link)
        inv_pos, inv_quat = invert(base)
        hx, hy, hz = BASE_HALF_EXTENTS
        top = BASE_CLEARANCE + 2 * hz
        # Each link's origin in the base's frame: ``multiply(inv, pose(origin))``, with the
        # parts that do not depend on the link computed once (the same arithmetic, the same
        # floats) and the link states read in one call.
        origin = np.zeros(3) + rotate(IDENTITY_QUAT, inv_pos)
        rot = quat_to_matrix(quat_mul(IDENTITY_QUAT, inv_quat))
        links = self._arm_links
        if links is None:
            links = self._arm_links = list(r.arm_joints[3:]) + sorted(r.hand_links)
        for st in p.getLinkStates(r.body, links, physicsClientId=self.client):
            x, y, z = origin + rot @ np.array(st[4], dtype=float)
            if abs(x) < hx + inflate and abs(y) < hy + inflate and z < top + inflate:
                return True
        return False

    def object_collision(self, name: str, ignore: Iterable[str] = ()) -> bool:
        """Object ``name`` (at its current pose) against the world, the robot included."""
        body = self.objects[name]
        skip = set(ignore) | {name}
        for other in self.obstacles(skip):
            if self._pair(body, other):
                return True
        return self._pair(body, self.robot.body)

    # -- camera -----------------------------------------------------------------------------------
    @property
    def camera(self):
        """A ``ssr_compile.belief.visibility.PyBulletCamera`` at the fixed camera's eye."""
        if self._camera is None:
            from ssr_compile.belief.visibility import PyBulletCamera

            self._camera = PyBulletCamera(self.camera_eye, client=self.client)
        return self._camera

    def button_pose(self) -> Pose:
        """World pose of the stove button's front face centre (facing -x)."""
        x, y, z = BUTTON_CENTER
        return pose((x - 0.01, y, z))

    def handle_pose(self, drawer: str) -> tuple[float, float, float]:
        """World position of the drawer's handle bar centre."""
        q = self.drawer_q[drawer]
        return (CABINET_FRONT - q - HANDLE_OFFSET, 0.0, self.handle_z[drawer])
