"""Geometric streams of the kitchen domain (paper §IV, docs/design.md §6), as plain callables.

Generator streams return iterables of output tuples, function streams return one tuple or
None, tests return bool.  All of them act on a :class:`ssr_compile.sim.world.World` (checking hypothetical
states inside ``world.saved()``, so the world is unchanged afterwards) and draw randomness from
one ``numpy.random.Generator``.  :func:`stream_table` names them for a streams module.

Values: a :class:`Grasp` is the object's pose in the tool frame; an :class:`ObjPose` is a pose
relative to the frame of its support (drawer contents move with the drawer); configurations are
tuples (base: x, y, yaw; arm: 7 joints); trajectories are tuples of configurations.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import numpy as np
import pybullet as pb

from .actions import DrawerMotion, MoveArm, MoveBase, Pick, Place, Press
from .clearance import leaving_test, too_near_test
from .geometry import (
    Pose,
    bases_near,
    invert,
    matrix_to_quat,
    multiply,
    pose,
    quat_from_axis_angle,
    quat_from_yaw,
    quat_mul,
    rotate,
)
from .motion import refine, rrt_connect
from .robot import ARM_TUCK, BASE_LIMITS, MOUNT_OFFSET
from .world import DRAWER_TRAVEL, World

Conf = tuple[float, ...]
MAX_FINGER_SPAN = 0.07  # widest object the gripper closes on (opening 0.08)
APPROACH = 0.10  # pre-grasp distance along the approach axis
ARM_RESOLUTION = 0.05  # rad, edge collision-checking resolution of arm motions
BASE_RESOLUTION = (0.02, 0.02, 0.03)
MAX_JOINT_JUMP = 0.25  # rad between consecutive IK waypoints of a Cartesian path
#: Tool orientation facing +x with the fingers closing vertically (handles, the button).
FACING_X = matrix_to_quat(np.array([[0, 0, 1], [1, 0, 0], [0, 1, 0]], float))


# Penetration (m) of the hand at a tool pose beyond which no IK solution's pose of it is free
# (:func:`hand_collision`)
HAND_DEPTH = 0.01


def approach_poses(tool: Pose, back: float = APPROACH, steps: int = 5) -> list[Pose]:
    """The tool poses of an approach to ``tool``: from ``back`` along its -z to ``tool``."""
    return [multiply(tool, pose((0, 0, -back * (1 - k / steps)))) for k in range(steps + 1)]


def hand_collision(w: World, tools: list[Pose], ignore_from: int = 0, ignore=()) -> bool:
    """The hand (the links rigid with the tool frame, ``panda_link7`` on) with its tool frame
    at any of ``tools`` enters the world deeper than :data:`HAND_DEPTH`, whatever the arm and
    the base: the robot's root is moved for the query, so that the tool is there, and put
    back.  ``ignore``: objects the hand may touch at ``tools[ignore_from:]``.  Deeper than any
    IK solution's error can make up for (2 mm and 0.02 rad at the tool frame), so every
    base's approach through these tool poses collides too."""
    r, c = w.robot, w.client
    root = pb.getBasePositionAndOrientation(r.body, physicsClientId=c)
    from_tool = invert(multiply(invert(pose(*root)), w.link_pose(r.body, r.tool_link)))
    try:
        for i, tool in enumerate(tools):
            pos, quat = multiply(tool, from_tool)
            pb.resetBasePositionAndOrientation(r.body, pos, quat, physicsClientId=c)
            for body in w.obstacles(ignore if i >= ignore_from else ()):
                for link in r.wrist_links:
                    pts = pb.getClosestPoints(r.body, body, 0.0, linkIndexA=link, physicsClientId=c)
                    if any(pt[8] < -HAND_DEPTH for pt in pts):
                        return True
        return False
    finally:
        pb.resetBasePositionAndOrientation(r.body, *root, physicsClientId=c)


@dataclass(frozen=True)
class Grasp:
    obj: str
    kind: str  # "top" or "side"
    pose: Pose  # object pose in the tool frame


@dataclass(frozen=True)
class ObjPose:
    obj: str
    surface: str
    rel: Pose  # in the surface's frame


def _grasp_from_tool(tool_in_obj: Pose) -> Pose:
    return invert(tool_in_obj)


# Radians (max over the joints) around the start of an arm motion within which the motion
# leaves what it starts near (or in: the planning world is an estimate) and may come no closer
# to it (see KitchenStreams.plan_arm_motion).
ESCAPE = 0.15
# Metres: an obstacle this near the arm (or what it holds) where a motion starts is left, not
# approached, within ESCAPE of the start -- by more than LEAVE_TOL (see plan_arm_motion).
NEAR = 0.03
LEAVE_TOL = 0.001
# A side grasp whose hand would move in along a bearing further than this from +x (the way the
# robot faces the counter and the drawers) is out of the arm's reach from every base: 0 of 400
# sampled bases reached one on Cook seeds 0-2 (1.86 to 2.97 rad), against 12-80% of the
# collision-free bases for bearings within 1.3 rad.
SIDE_BEARING_LIMIT = 1.8


# Radians (max over the joints) between the arm configuration the robot is in and the start of a
# path solved from it, bridged by a straight, collision-checked joint-space lead-in: an object's
# estimate moves as detections accumulate (the sugar box's yaw by 0.065 rad between two Cook
# cycles), the pre-grasp pose with it, and a constrained replan could not pick from where an
# earlier plan had put the arm.
LEAD_IN = 0.3
LEAD_STEP = 0.05  # radians between the lead-in's configurations
# (m, rad): a sampled base must be collision-free this far off along x, y and yaw (about two
# standard deviations of a base motion's landing error).
BASE_MARGIN = (0.02, 0.03)
# (m, rad): a base ``inv-reach`` returns reaches its grasp from the four corners this far off
# along x, y and yaw too (1.5 standard deviations of a landing error).  Without it, Stow seed 0
# drove to eight bases in a row: each time the robot landed, the grasp was out of the arm's
# reach from where it stood (1 in 5 of the bases sampled there fail at one corner).
LANDING = (0.015, 0.015)
# Bearing of a drawer-pulling base from the open handle (rad, from the world's +x): beside the
# drawer's axis, the hand moves the handle across the arm, not into the robot.  Bases that serve
# a pull from where they are and from their landing corners (:func:`_landings`), of 360 sampled
# per range (6 seeds, Inspect seed 0's kitchen), bottom / top drawer: 0.6 to 1.5 rad: 57 / 311;
# -1.5 to -0.6 and 0.6 to 1.5 alike: 19 / 165; the former -60 to +60 deg: 22 / 124.  Three
# draws in four take the side that serves, one the other side (a kitchen laid out otherwise).
DRAWER_BEARING = (0.6, 1.5)
# (m, rad): an IK solution found at a base this near seeds the IK at another (the pre-grasp
# the landed robot solves for is almost the one it drove there for).
HINT_NEAR = (0.05, 0.1)
HINTS_KEPT = 64  # IK solutions kept per (object, grasp)


def _landings(base: Conf) -> list[Conf]:
    """Four corners :data:`LANDING` off ``base`` (x, y and yaw perturbed together)."""
    dxy, dyaw = LANDING
    corners = ((1, 1, 1), (-1, -1, -1), (1, -1, -1), (-1, 1, 1))
    x, y, yaw = base
    return [(x + a * dxy, y + b * dxy, yaw + c * dyaw) for a, b, c in corners]


def _lead_in(start: Conf, path: list[Conf]) -> list[Conf]:
    """``path`` starting at ``start``: a straight joint-space lead-in when ``path[0]`` is within
    :data:`LEAD_IN` of it (the caller collision-checks the result), else ``path`` unchanged."""
    a, b = np.asarray(start, float), np.asarray(path[0], float)
    gap = float(np.max(np.abs(b - a)))
    if gap > LEAD_IN:
        return path
    n = max(1, int(np.ceil(gap / LEAD_STEP)))
    lead = [tuple(float(v) for v in a + (b - a) * k / n) for k in range(n)]
    return [*lead, *path]


class KitchenStreams:
    """Stream implementations bound to one world and one random generator."""

    def __init__(
        self,
        world: World,
        rng: np.random.Generator,
        *,
        ik_restarts: int = 6,
        max_attempts: int = 30,
        rrt_iterations: int = 300,
        margin_corners: bool = True,
        hand_check: bool = False,
    ) -> None:
        """``margin_corners``: :meth:`base_free` checks the corners of the landing margin too
        (off: along each axis alone, as the task generator's reach check does).
        ``hand_check``: :meth:`inv_reach` first asks :meth:`hand_blocked` (the planner's
        streams; off for the task generator, whose draws make the paper's worlds)."""
        self.world = world
        self.hand_check = hand_check
        self.margin_corners = margin_corners
        self.rng = rng
        self.ik_restarts = ik_restarts
        self.max_attempts = max_attempts
        self.rrt_iterations = rrt_iterations
        self._kin_cache: dict = {}
        self._hand_cache: dict = {}  # see :meth:`hand_blocked`
        # (object, grasp) -> [(base, goal arm conf)]: IK solutions found, hints for nearby bases
        self._solutions: dict[tuple[str, Grasp], list[tuple[Conf, Conf]]] = {}
        self._drawer_bases: dict[str, list[Conf]] = {}  # bases sample_drawer_base found

    # -- poses -----------------------------------------------------------------------------
    def world_pose(self, p: ObjPose) -> Pose:
        return multiply(self.world.surface_frame(p.surface), p.rel)

    def current_pose(self, obj: str) -> ObjPose:
        sup = self.world.support[obj]
        if sup is None:
            raise ValueError(f"{obj} is not resting on a surface")
        return ObjPose(obj, sup[0], sup[1])

    # -- grasps ----------------------------------------------------------------------------
    def grasps(self, obj: str) -> list[Grasp]:
        """Top grasps (4 yaws, fingers across a side no wider than the gripper) and side grasps
        (from each vertical face, fingers closing horizontally)."""
        hx, hy, hz = self.world.half_extents[obj]
        half = {0: hx, 1: hy}
        out = []
        depth = min(0.025, hz)
        down = quat_from_axis_angle((1, 0, 0), np.pi)  # tool z = -object z, tool y = -object y
        for k in range(4):
            yaw = k * np.pi / 2
            across = half[1] if k % 2 == 0 else half[0]  # extent along the finger axis
            if 2 * across > MAX_FINGER_SPAN:
                continue
            tool = pose((0.0, 0.0, hz - depth), quat_mul(quat_from_yaw(yaw), down))
            out.append(Grasp(obj, "top", _grasp_from_tool(tool)))
        ez = np.array([0.0, 0.0, 1.0])
        for axis in (0, 1):
            other = 1 - axis
            if 2 * half[other] > MAX_FINGER_SPAN:
                continue
            for sign in (1.0, -1.0):
                z_t = np.zeros(3)
                z_t[axis] = -sign  # approach towards the face at +sign*axis
                y_t = np.zeros(3)
                y_t[other] = 1.0
                x_t = np.cross(y_t, z_t)
                if np.dot(x_t, ez) < 0:  # keep the hand's x axis up: mirror the finger axis
                    y_t, x_t = -y_t, -x_t
                rot = np.column_stack([x_t, y_t, z_t])
                pos = -z_t * (half[axis] - 0.02)
                tool = pose(pos, matrix_to_quat(rot))
                out.append(Grasp(obj, "side", _grasp_from_tool(tool)))
        return out

    def sample_grasps(self, obj: str) -> Iterator[tuple[Grasp]]:
        """Generator stream ``sample-grasp``: the grasps of ``obj`` in random order."""
        gs = self.grasps(obj)
        for i in self.rng.permutation(len(gs)):
            yield (gs[i],)

    # -- placements ------------------------------------------------------------------------
    def placement_valid(self, p: ObjPose, ignore: tuple[str, ...] = ()) -> bool:
        """Stable (upright, resting on the surface), inside the support, collision-free with
        the world (robot excluded) in the current state."""
        w = self.world
        s = w.surfaces[p.surface]
        hz = w.half_extents[p.obj][2]
        upright = abs(p.rel[1][0]) < 1e-6 and abs(p.rel[1][1]) < 1e-6
        if not upright or abs(p.rel[0][2] - (s.z + hz) - 1e-3) > 1e-6:
            return False
        if not w.inside_surface(p.obj, p.surface, p.rel, margin=0.005):
            return False
        with w.saved():
            if w.held is not None and w.held.obj == p.obj:
                w.held = None
            w.place_object(p.obj, p.surface, p.rel)
            body = w.objects[p.obj]
            skip = set(ignore) | {p.obj}
            return not any(w._pair(body, b) for b in w.obstacles(skip))

    def sample_placements(self, obj: str, surface: str) -> Iterator[tuple[ObjPose]]:
        """Generator stream ``sample-placement``: stable, inside, collision-free poses."""
        w = self.world
        s = w.surfaces[surface]
        for _ in range(self.max_attempts):
            x = self.rng.uniform(s.lo[0], s.hi[0])
            y = self.rng.uniform(s.lo[1], s.hi[1])
            yaw = self.rng.uniform(-np.pi, np.pi)
            p = ObjPose(obj, surface, w.rest_pose(obj, surface, x, y, yaw))
            if self.placement_valid(p):
                yield (p,)

    # -- kinematics ------------------------------------------------------------------------
    def _set_hypothesis(self, obj: str, p: ObjPose) -> bool:
        """Inside ``saved()``: put ``obj`` at ``p`` unless it is held.  Returns holding?"""
        w = self.world
        if w.held is not None and w.held.obj == obj:
            return True
        w.place_object(obj, p.surface, p.rel)
        return False

    def cartesian_path(
        self, base: Conf, poses: list[Pose], seed: Conf | None = None
    ) -> list[Conf] | None:
        """IK along a list of tool poses, each seeded by the previous solution."""
        w = self.world
        path: list[Conf] = []
        for i, tp in enumerate(poses):
            sd = seed if i == 0 else path[-1]
            restarts = self.ik_restarts if i == 0 else 1
            res = w.robot.inverse_kinematics(base, tp, self.rng, seed_conf=sd, restarts=restarts)
            if res is None:
                return None
            if path and np.max(np.abs(np.subtract(res.conf, path[-1]))) > MAX_JOINT_JUMP:
                return None
            path.append(res.conf)
        return path

    def approach_path(
        self,
        base: Conf,
        tool: Pose,
        back: float = APPROACH,
        steps: int = 5,
        ignore_hand=(),
        seed: Conf | None = None,
        hint: Conf | None = None,
    ) -> list[Conf] | None:
        """Arm path from the pre-pose (``back`` along the tool's -z) to ``tool`` (in the world
        state as it is), collision-checked; the hand may touch ``ignore_hand`` at the end.
        ``seed``: the arm is there (the path starts from it); else ``hint``: a configuration
        near the goal's to start the IK from (then random restarts)."""
        w = self.world
        poses = approach_poses(tool, back, steps)
        path = None
        if seed is not None:
            # The arm is at ``seed`` (acting from where it is): walk from the pre-pose, solved
            # from the seed itself, to the goal, so the path starts where the arm is.  (Solved
            # goal-first, the redundant arm's path often starts in another posture.)
            path = self.cartesian_path(base, poses, seed)
        if path is None:
            # Solve the goal first (from ``seed`` or ``hint``, then random restarts), then walk
            # back to the pre-pose from it.
            rev = self.cartesian_path(base, poses[::-1], hint if seed is None else seed)
            if rev is None:
                return None
            path = rev[::-1]
        if seed is not None:
            path = _lead_in(seed, path)
        w.robot.set_base(base)
        for i, q in enumerate(path):
            w.set_arm(q)
            if w.robot_collision(ignore_hand=ignore_hand if i > 0 else ()):
                return None
        return path

    def _scene_key(self) -> tuple:
        """What the kinematic streams' answers depend on besides their inputs: where the
        objects rest, the drawers' openings, what the hand holds and how."""
        w = self.world
        return (
            tuple(sorted(w.support.items())),
            tuple(sorted(w.drawer_q.items())),
            None if w.held is None else (w.held.obj, w.held.grasp),
        )

    def inv_kin(
        self, obj: str, p: ObjPose, g: Grasp, base: Conf, seed: Conf | None = None
    ) -> tuple[Conf, tuple[Conf, ...]] | None:
        """Function stream ``inv-kin``: (pre-grasp arm conf, approach path) for grasping
        ``obj`` at ``p`` with ``g`` from ``base`` (or placing it there when it is held);
        ``seed``: the arm configuration to start the IK from."""
        key = (obj, p, g, tuple(base), self._scene_key(), None if seed is None else tuple(seed))
        if key in self._kin_cache:
            return self._kin_cache[key]
        w = self.world
        with w.saved():
            holding = self._set_hypothesis(obj, p)
            w.set_base(base)
            tool = multiply(self.world_pose(p), invert(g.pose))
            if holding:
                w.held.grasp = g.pose
            hint = None if seed is not None else self._hint(obj, g, base)
            path = self.approach_path(
                base, tool, ignore_hand=() if holding else (obj,), seed=seed, hint=hint
            )
        if path is not None:
            found = self._solutions.setdefault((obj, g), [])
            found.append((tuple(base), tuple(path[-1])))
            del found[:-HINTS_KEPT]
        out = None if path is None else (path[0], tuple(path))
        self._kin_cache[key] = out
        return out

    def hand_blocked(self, obj: str, p: ObjPose, g: Grasp) -> bool:
        """The hand collides on the approach to ``g`` at ``p`` (:meth:`approach_path`'s tool
        poses) from any base (:func:`hand_collision`): ``inv-reach`` need try none.  In
        Swap, the block's placements deep in a drawer or at its front wall (the hand meets the
        cabinet) cost a failed batch of 30 IK attempts each, 0.2 s."""
        w = self.world
        key = (obj, p, g, self._scene_key())
        found = self._hand_cache.get(key)
        if found is None:
            with w.saved():
                holding = self._set_hypothesis(obj, p)
                tool = multiply(self.world_pose(p), invert(g.pose))
                poses = approach_poses(tool)
                found = hand_collision(w, poses, 1, () if holding else (obj,))
            self._hand_cache[key] = found
        return found

    def _hint(self, obj: str, g: Grasp, base: Conf) -> Conf | None:
        """The goal configuration of the latest IK solution for ``obj`` and ``g`` found from a
        base within :data:`HINT_NEAR` of ``base``, if any."""
        for b, q in reversed(self._solutions.get((obj, g), ())):
            if bases_near(b, base, HINT_NEAR):
                return q
        return None

    def lands(self, obj: str, p: ObjPose, g: Grasp, base: Conf) -> bool:
        """``inv-kin`` also succeeds from the corners :data:`LANDING` off ``base``: where a
        base motion to ``base`` lands, the robot most likely reaches the grasp from there."""
        return all(self.inv_kin(obj, p, g, b) is not None for b in _landings(base))

    def _sample_base_near(
        self, target_xy, r_range=(0.3, 0.75), bearing=(-np.pi / 3, np.pi / 3)
    ) -> Conf | None:
        """A base whose arm mount is ``r_range`` from ``target_xy``, seen from it at a bearing
        in ``bearing`` (rad, from the world's +x), the base facing it give or take 0.3 rad."""
        psi = self.rng.uniform(*bearing)
        r = self.rng.uniform(*r_range)
        yaw = psi + self.rng.uniform(-0.3, 0.3)
        link0 = np.asarray(target_xy[:2]) - r * np.array([math.cos(psi), math.sin(psi)])
        base_xy = link0 - MOUNT_OFFSET[0] * np.array([math.cos(yaw), math.sin(yaw)])
        conf = (float(base_xy[0]), float(base_xy[1]), float(yaw))
        lo = [lim[0] for lim in BASE_LIMITS]
        hi = [lim[1] for lim in BASE_LIMITS]
        if not all(a <= v <= b for a, v, b in zip(lo, conf, hi, strict=True)):
            return None
        return conf

    def base_free(self, base: Conf, arm: Conf | None = None) -> bool:
        """The robot at ``base`` (arm tucked, or at ``arm``) is collision-free, and so it is
        :data:`BASE_MARGIN` away along each axis and at the corners of that box: base motions
        land with noise, and a base sampled flush against the stove left the robot, 8 mm off,
        where its tucked arm hit the stove -- no arm motion could leave the placement (Cook
        seed 3).  The corners too: Cook seed 18 landed 14 mm and 9 mm off along x and y
        together, within the margin of each axis, where the tucked arm entered the stove by
        2 mm; with the hand empty the arm could neither tuck nor the base move, for 80 cycles."""
        w = self.world
        dx, dyaw = BASE_MARGIN
        x, y, yaw = base
        around = [(0, 0, 0), (dx, 0, 0), (-dx, 0, 0), (0, dx, 0), (0, -dx, 0)]
        around += [(0, 0, dyaw), (0, 0, -dyaw)]
        if self.margin_corners:
            around += [
                (a * dx, b * dx, c * dyaw) for a in (1, -1) for b in (1, -1) for c in (1, -1)
            ]
        with w.saved():
            w.set_arm(ARM_TUCK if arm is None else arm)
            for ox, oy, oyaw in around:
                w.set_base((x + ox, y + oy, yaw + oyaw))
                if w.robot_collision():
                    return False
            return True

    def reach_ruled_out(self, obj: str, p: ObjPose, g: Grasp) -> bool:
        """No base reaches ``g`` at ``p`` in this scene, whatever is sampled: a side grasp whose
        hand would move in along a bearing beyond :data:`SIDE_BEARING_LIMIT`, or a hand that
        collides on the approach from any base (:meth:`hand_blocked`)."""
        q = multiply(self.world_pose(p), invert(g.pose))[1]
        approach = rotate(q, (0.0, 0.0, 1.0))  # the tool's z: the way the hand moves in
        if np.hypot(approach[0], approach[1]) > 0.7:  # a side grasp
            if abs(math.atan2(approach[1], approach[0])) > SIDE_BEARING_LIMIT:
                return True
        return bool(self.hand_check and self.hand_blocked(obj, p, g))

    def inv_reach(self, obj: str, p: ObjPose, g: Grasp) -> Iterator[tuple[Conf]]:
        """Generator stream ``inv-reach``: base confs from which ``inv-kin`` succeeds, and from
        near which it does too (:meth:`lands`)."""
        if self.reach_ruled_out(obj, p, g):
            return
        target = multiply(self.world_pose(p), invert(g.pose))[0]
        tried = 0  # the attempts count IK calls: a base in collision costs little
        for _ in range(4 * self.max_attempts):
            if tried >= self.max_attempts:
                return
            base = self._sample_base_near(target)
            if base is None or not self.base_free(base):
                continue
            tried += 1
            if self.inv_kin(obj, p, g, base) is not None and self.lands(obj, p, g, base):
                yield (base,)

    # -- motions ---------------------------------------------------------------------------
    def _arm_collision_fn(self, base: Conf) -> Callable[[np.ndarray], bool]:
        w = self.world

        def collision(q: np.ndarray) -> bool:
            w.set_arm(q)
            return w.robot_collision()

        w.robot.set_base(base)
        return collision

    def plan_arm_motion(
        self, base: Conf, q1: Conf, q2: Conf, blocked: Callable[[np.ndarray], bool] | None = None
    ) -> tuple[tuple[Conf, ...]] | None:
        """Function stream ``motion`` (arm): an RRT-Connect path ``q1 -> q2`` at ``base``,
        collision-free against the world, open drawers and the held object.

        Within :data:`ESCAPE` of ``q1`` the path leaves what the arm is near: it comes no
        closer to an obstacle within :data:`NEAR` of it at ``q1`` than it is there (the world is
        an estimate; the true object may be a centimetre nearer: Cook seed 3 without plan
        constraints opened the gripper after a placement 1 mm from the true sugar box, and every
        motion planned past the estimated box hit the true one at its first waypoint).  When
        ``q1`` itself collides (the arm stopped where the estimate puts an object it did not
        touch), the path may leave it, no deeper, and is not checked otherwise there -- else no
        motion ever starts there ("no relaxed solution" after an arm motion stopped short of
        the block).  Elsewhere it keeps its distance (:mod:`.clearance`; within :data:`ESCAPE`
        of either end as near as that end is).  ``blocked``: configurations to treat as
        colliding besides (what the true world refused)."""
        w = self.world
        r = w.robot
        with w.saved():
            w.set_base(base)
            check = self._arm_collision_fn(base)
            start = np.asarray(q1, float)
            stuck = check(start)
            near, leaving = leaving_test(w, start, NEAR, LEAVE_TOL)
            too_near = too_near_test(w, (start, np.asarray(q2, float)), ESCAPE, LEAVE_TOL)

            def collision(q: np.ndarray) -> bool:
                q = np.asarray(q, float)
                if blocked is not None and blocked(q):
                    return True
                if (stuck or near) and float(np.max(np.abs(q - start))) <= ESCAPE:
                    if not leaving(q):
                        return True
                    if stuck:
                        return False
                return check(q) or too_near(q)

            path = rrt_connect(
                q1, q2, lambda: np.asarray(r.sample_arm(self.rng)),
                collision, self.rng,
                resolution=ARM_RESOLUTION, max_iterations=self.rrt_iterations,
            )  # fmt: skip
        return None if path is None else (tuple(refine(path, ARM_RESOLUTION)),)

    def plan_base_motion(self, b1: Conf, b2: Conf) -> tuple[tuple[Conf, ...]] | None:
        """Function stream ``motion`` (base): an RRT-Connect path in (x, y, yaw) with the arm
        (and held object) as they are, collision-checked at 2 cm / 0.03 rad."""
        w = self.world
        lo = np.array([-1.5, -1.8, -np.pi])
        hi = np.array([0.8, 1.8, np.pi])

        def collision(q: np.ndarray) -> bool:
            w.set_base(q)
            return w.robot_collision()

        with w.saved():
            path = rrt_connect(
                b1, b2, lambda: self.rng.uniform(lo, hi), collision, self.rng,
                resolution=BASE_RESOLUTION, step=0.5, weights=(1.0, 1.0, 0.3),
                max_iterations=self.rrt_iterations,
            )  # fmt: skip
        return None if path is None else (tuple(refine(path, BASE_RESOLUTION)),)

    # -- drawers ---------------------------------------------------------------------------
    def handle_tool(self, drawer: str, q: float) -> Pose:
        x = self.world.handle_pose(drawer)[0] + self.world.drawer_q[drawer] - q
        _, y, z = self.world.handle_pose(drawer)
        return pose((x, y, z), FACING_X)

    def sample_drawer_base(self, drawer: str) -> Iterator[tuple[Conf]]:
        """Generator stream: base confs from which the handle is reachable over the whole
        travel of ``drawer`` (checked at both ends), from near which it is too (the corners
        :data:`LANDING` off, as :meth:`lands`: the scripted Swap once landed 6 mm and 9 mrad
        off a base and found no push from there)."""

        def robust(base: Conf) -> bool:
            return all(
                self.plan_drawer(drawer, 0.0, DRAWER_TRAVEL, b) is not None
                for b in (base, *_landings(base))
            )

        # Bases that served before first (the handle's path is the same whatever the opening):
        # 1 in 20 sampled bases reaches the bottom drawer's low handle, fewer from near as well.
        found = self._drawer_bases.setdefault(drawer, [])
        for base in list(found):
            if self.base_free(base) and robust(base):
                yield (base,)
        lo, hi = DRAWER_BEARING
        for k in range(2 * self.max_attempts):
            target = self.handle_tool(drawer, DRAWER_TRAVEL)[0]
            bearing = (lo, hi) if k % 4 != 3 else (-hi, -lo)
            base = self._sample_base_near(target, (0.3, 0.6), bearing)
            if base is None or base in found or not self.base_free(base):
                continue
            if robust(base):
                found.append(base)
                yield (base,)

    def plan_drawer(
        self,
        drawer: str,
        q1: float,
        q2: float,
        base: Conf,
        step: float = 0.02,
        seed: Conf | None = None,
    ) -> DrawerMotion | None:
        """Function stream ``pull``/``push``: approach the handle at opening ``q1``, move it to
        ``q2`` (tool following the handle), retreat.  Collision-checked with the drawer (and
        its contents) moving; the gripper may touch the handle's drawer only."""
        w = self.world
        n = max(1, int(np.ceil(abs(q2 - q1) / step)))
        qs = [q1 + (q2 - q1) * k / n for k in range(n + 1)]
        with w.saved():
            w.set_drawer(drawer, q1)
            w.set_base(base)
            start = self.approach_path(base, self.handle_tool(drawer, q1), back=0.08, seed=seed)
            if start is None:
                return None
            moving = self.cartesian_path(base, [self.handle_tool(drawer, q) for q in qs], start[-1])
            if moving is None:
                return None
            for q_d, q_a in zip(qs, moving, strict=True):
                w.set_drawer(drawer, q_d)
                w.set_arm(q_a)
                if w.robot_collision():
                    return None
            end = self.approach_path(base, self.handle_tool(drawer, q2), back=0.08)
            if end is None:
                return None
        arm = list(start) + list(moving[1:]) + list(end[::-1][1:])
        dq = [q1] * len(start) + qs[1:] + [q2] * (len(end) - 1)
        return DrawerMotion(drawer, tuple(arm), tuple(dq))

    # -- stove button ------------------------------------------------------------------------
    def plan_press(self, base: Conf, seed: Conf | None = None) -> tuple[tuple[Conf, ...]] | None:
        """Function stream: approach path to the stove button (pre-press -> press)."""
        w = self.world
        with w.saved():
            w.set_base(base)
            path = self.approach_path(
                base, pose(w.button_pose()[0], FACING_X), back=0.08, seed=seed
            )
        return None if path is None else (tuple(path),)

    def sample_press_base(self) -> Iterator[tuple[Conf]]:
        target = self.world.button_pose()[0]
        for _ in range(self.max_attempts):
            base = self._sample_base_near(target, (0.3, 0.6))
            if base is not None and self.base_free(base) and self.plan_press(base) is not None:
                yield (base,)

    # -- tests -----------------------------------------------------------------------------
    def test_cfree_pose_pose(self, o1: str, p1: ObjPose, o2: str, p2: ObjPose) -> bool:
        """Test stream ``cfree-pose-pose``: the two objects at these poses do not collide."""
        w = self.world
        with w.saved():
            w.held = None
            w.place_object(o1, p1.surface, p1.rel)
            w.place_object(o2, p2.surface, p2.rel)
            return not w._pair(w.objects[o1], w.objects[o2])

    def test_cfree_traj_pose(self, base: Conf, traj, o2: str, p2: ObjPose) -> bool:
        """Test stream ``cfree-traj-pose``: the arm trajectory at ``base`` avoids ``o2`` at
        ``p2``."""
        w = self.world
        with w.saved():
            w.place_object(o2, p2.surface, p2.rel)
            w.set_base(base)
            for q in traj:
                w.set_arm(q)
                if w._pair(w.robot.body, w.objects[o2]):
                    return False
        return True


def stream_table(ks: KitchenStreams) -> dict[str, Callable]:
    """Stream names (paper §IV, docs/design.md §6) -> callables, for a streams module to bind."""
    return {
        "sample-grasp": ks.sample_grasps,
        "sample-placement": ks.sample_placements,
        "inv-reach": ks.inv_reach,
        "inv-kin": ks.inv_kin,
        "plan-arm-motion": ks.plan_arm_motion,
        "plan-base-motion": ks.plan_base_motion,
        "sample-drawer-base": ks.sample_drawer_base,
        "plan-drawer": ks.plan_drawer,
        "sample-press-base": ks.sample_press_base,
        "plan-press": ks.plan_press,
        "test-cfree-pose-pose": ks.test_cfree_pose_pose,
        "test-cfree-traj-pose": ks.test_cfree_traj_pose,
    }


__all__ = [
    "Grasp",
    "KitchenStreams",
    "ObjPose",
    "stream_table",
    "MoveArm",
    "MoveBase",
    "Pick",
    "Place",
    "Press",
]
