"""The Franka Panda of ``pybullet_data`` on a planar mobile base (paper §VIII).

The base is three joints (prismatic x, prismatic y, revolute yaw) prepended at run time to the
panda URDF: we write a URDF into a temp dir with the mesh paths made absolute, whose root is a
massless ``world`` link, then a box-shaped base body carrying ``panda_link0`` on a pedestal.
Inverse kinematics uses pybullet's ``calculateInverseKinematics`` with null-space restarts in a
private DIRECT client holding the bare arm (so that IK never moves the base joints), and every
solution is verified by forward kinematics.
"""

from __future__ import annotations

import math
import os
import re
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pybullet as p
import pybullet_data

from .geometry import (
    Pose,
    angle_between,
    invert,
    multiply,
    norm,
    pose,
    pose2d,
    quat_inv,
    quat_mul,
)

PANDA_URDF = os.path.join(pybullet_data.getDataPath(), "franka_panda", "panda.urdf")

#: Base body: a box of these half extents; the arm is mounted on top of it, ahead of its centre.
BASE_HALF_EXTENTS = (0.25, 0.2, 0.17)
BASE_CLEARANCE = 0.01  # the box floats 1 cm above the floor (wheels)
MOUNT_OFFSET = (0.1, 0.0, BASE_CLEARANCE + 2 * BASE_HALF_EXTENTS[2])  # panda_link0 in base frame
ARM_REACH = 1.2  # metres from the arm's mount beyond which no IK is tried


def mount_position(base) -> np.ndarray:
    """World position of the arm's mount (panda_link0) with the base at ``base`` (x, y, yaw)."""
    x, y, yaw = (float(v) for v in base)
    return np.array([x + MOUNT_OFFSET[0] * math.cos(yaw), y + MOUNT_OFFSET[0] * math.sin(yaw),
                     MOUNT_OFFSET[2]])  # fmt: skip


def within_reach(base, point) -> bool:
    """Cheap kinematic filter: ``point`` is within :data:`ARM_REACH` of the mount at ``base``."""
    return float(np.linalg.norm(np.asarray(point, float) - mount_position(base))) <= ARM_REACH


BASE_LIMITS = ((-3.0, 3.0), (-3.0, 3.0), (-np.pi, np.pi))

ARM_JOINTS = tuple(f"panda_joint{i}" for i in range(1, 8))
FINGER_JOINTS = ("panda_finger_joint1", "panda_finger_joint2")
BASE_JOINTS = ("base_x", "base_y", "base_theta")
TOOL_LINK = "panda_grasptarget"
HAND_LINKS = ("panda_link8", "panda_hand", "panda_leftfinger", "panda_rightfinger", TOOL_LINK)
FINGER_OPEN = 0.04
#: IK attempts from a given seed kept per robot (see :meth:`Robot.inverse_kinematics`).
IK_ATTEMPTS_KEPT = 50_000
_DAMPING = 1e-4 * np.eye(6)  # of the damped least-squares step in Robot._refine
# An IK refinement stops after STALL steps that brought its error no lower than STALL_GAIN
# times the best it had reached, when the robot's ``stall`` is on (Robot._refine; the
# planner's streams turn it on, streams/kitchen_module.py)
STALL = 15
STALL_GAIN = 0.99

#: A comfortable arm configuration (arm folded up, hand forward and down).
ARM_REST = (0.0, -0.6, 0.0, -2.4, 0.0, 1.9, 0.785)
#: Arm tucked in above the base: used while driving and to clear the camera's view.
ARM_TUCK = (0.0, -1.2, 0.0, -2.9, 0.0, 1.8, 0.785)
#: Arm raised ahead of the base: carrying a (tall) object clear of the base and the floor.
ARM_CARRY = (0.0, -0.05, 0.0, -1.0, 0.0, 0.95, 0.785)

_BASE_XML = """
  <link name="world">
    <inertial><mass value="0"/><inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial>
  </link>
  <link name="base_x_link">
    <inertial><mass value="0.01"/><inertia ixx="1e-4" ixy="0" ixz="0" iyy="1e-4" iyz="0" izz="1e-4"/></inertial>
  </link>
  <link name="base_y_link">
    <inertial><mass value="0.01"/><inertia ixx="1e-4" ixy="0" ixz="0" iyy="1e-4" iyz="0" izz="1e-4"/></inertial>
  </link>
  <link name="base_link">
    <inertial><mass value="20"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>
    <visual><origin xyz="0 0 {bz}"/><geometry><box size="{bx} {by} {bh}"/></geometry>
      <material name="base_grey"><color rgba="0.35 0.35 0.4 1"/></material></visual>
    <collision><origin xyz="0 0 {bz}"/><geometry><box size="{bx} {by} {bh}"/></geometry></collision>
  </link>
  <joint name="base_x" type="prismatic">
    <parent link="world"/><child link="base_x_link"/><axis xyz="1 0 0"/>
    <limit lower="{xl}" upper="{xu}" effort="1000" velocity="1"/>
  </joint>
  <joint name="base_y" type="prismatic">
    <parent link="base_x_link"/><child link="base_y_link"/><axis xyz="0 1 0"/>
    <limit lower="{yl}" upper="{yu}" effort="1000" velocity="1"/>
  </joint>
  <joint name="base_theta" type="revolute">
    <parent link="base_y_link"/><child link="base_link"/><axis xyz="0 0 1"/>
    <limit lower="{tl}" upper="{tu}" effort="1000" velocity="1"/>
  </joint>
  <joint name="base_to_panda" type="fixed">
    <parent link="base_link"/><child link="panda_link0"/><origin xyz="{mx} {my} {mz}"/>
  </joint>
"""


def write_mobile_panda_urdf(directory: str) -> str:
    """Write the mobile-base panda URDF into ``directory`` and return its path."""
    with open(PANDA_URDF) as f:
        text = f.read()
    mesh_dir = os.path.join(os.path.dirname(PANDA_URDF), "meshes")
    text = text.replace("package://meshes", mesh_dir)
    body = re.search(r"<robot[^>]*>(.*)</robot>", text, re.S)
    if body is None:  # pragma: no cover - the shipped file is well formed
        raise RuntimeError(f"unexpected panda URDF format: {PANDA_URDF}")
    (xl, xu), (yl, yu), (tl, tu) = BASE_LIMITS
    hx, hy, hz = BASE_HALF_EXTENTS
    base = _BASE_XML.format(
        bx=2 * hx, by=2 * hy, bh=2 * hz, bz=BASE_CLEARANCE + hz,
        xl=xl, xu=xu, yl=yl, yu=yu, tl=tl, tu=tu,
        mx=MOUNT_OFFSET[0], my=MOUNT_OFFSET[1], mz=MOUNT_OFFSET[2],
    )  # fmt: skip
    path = os.path.join(directory, "mobile_panda.urdf")
    with open(path, "w") as f:
        f.write(
            f'<?xml version="1.0"?>\n<robot name="mobile_panda">{base}{body.group(1)}</robot>\n'
        )
    return path


def _joint_and_link_maps(body: int, client: int) -> tuple[dict[str, int], dict[str, int]]:
    joints, links = {}, {}
    for j in range(p.getNumJoints(body, physicsClientId=client)):
        info = p.getJointInfo(body, j, physicsClientId=client)
        joints[info[1].decode()] = j
        links[info[12].decode()] = j
    return joints, links


def base_to_link0(base_conf: Sequence[float]) -> Pose:
    """World pose of ``panda_link0`` for a base configuration ``(x, y, yaw)``."""
    x, y, yaw = base_conf
    return multiply(pose2d(x, y, 0.0, yaw), pose(MOUNT_OFFSET))


@dataclass
class IKResult:
    conf: tuple[float, ...]
    pos_error: float
    ori_error: float


class Robot:
    """The mobile panda loaded into ``client``, plus a private IK client with the bare arm."""

    def __init__(self, client: int, tmpdir: str | None = None) -> None:
        self.client = client
        # the stall rule of the IK refinement, (steps, gain), or None (off; see _refine)
        self.stall: tuple[int, float] | None = None
        self._tmp = None
        if tmpdir is None:
            self._tmp = tempfile.TemporaryDirectory(prefix="ssr_sim_")
            tmpdir = self._tmp.name
        urdf = write_mobile_panda_urdf(tmpdir)
        self.body = p.loadURDF(urdf, useFixedBase=True, physicsClientId=client)
        self.joints, self.links = _joint_and_link_maps(self.body, client)
        self.base_joints = [self.joints[n] for n in BASE_JOINTS]
        self.arm_joints = [self.joints[n] for n in ARM_JOINTS]
        self.finger_joints = [self.joints[n] for n in FINGER_JOINTS]
        self.tool_link = self.links[TOOL_LINK]
        self.base_link = self.links["base_link"]
        self.hand_links = frozenset(self.links[n] for n in HAND_LINKS)
        # the links rigid with the tool frame (panda_joint8 is fixed): the hand and panda_link7
        self.wrist_links = tuple(sorted(self.hand_links | {self.links["panda_link7"]}))
        lims = [p.getJointInfo(self.body, j, physicsClientId=client)[8:10] for j in self.arm_joints]
        self.arm_lower = np.array([lo for lo, _ in lims])
        self.arm_upper = np.array([hi for _, hi in lims])
        # Private kinematics client: the bare arm with panda_link0 at the origin.
        self.ik_client = p.connect(p.DIRECT)
        self.ik_body = p.loadURDF(PANDA_URDF, useFixedBase=True, physicsClientId=self.ik_client)
        ik_joints, ik_links = _joint_and_link_maps(self.ik_body, self.ik_client)
        self.ik_arm = [ik_joints[n] for n in ARM_JOINTS]
        self.ik_fingers = [ik_joints[n] for n in FINGER_JOINTS]
        self.ik_tool = ik_links[TOOL_LINK]
        # (target in the arm's frame, seed, tolerances), as bytes -> the IK attempt's answer
        self._ik_attempts: dict[bytes, IKResult | None] = {}
        self.ik_attempts_reused = 0  # for benchmarks and tests
        self.set_fingers(FINGER_OPEN)

    def close(self) -> None:
        if self.ik_client is not None and p.isConnected(self.ik_client):
            p.disconnect(self.ik_client)
        self.ik_client = None
        if self._tmp is not None:
            self._tmp.cleanup()
            self._tmp = None

    # -- state -------------------------------------------------------------------------------
    def set_base(self, conf: Sequence[float]) -> None:
        self._reset(self.body, self.base_joints, conf, self.client)

    def set_arm(self, conf: Sequence[float]) -> None:
        self._reset(self.body, self.arm_joints, conf, self.client)

    def set_fingers(self, width: float) -> None:
        self._reset(self.body, self.finger_joints, [width] * len(self.finger_joints), self.client)

    @staticmethod
    def _reset(body: int, joints: list[int], values: Sequence[float], client: int) -> None:
        """Reset ``joints`` to ``values`` in one call (the state ``resetJointState`` joint by
        joint leaves)."""
        if len(values) != len(joints):
            raise ValueError(f"{len(joints)} joint values expected, got {len(values)}")
        p.resetJointStatesMultiDof(
            body, joints, [[v] for v in map(float, values)], physicsClientId=client
        )

    def get_base(self) -> tuple[float, float, float]:
        return tuple(
            p.getJointState(self.body, j, physicsClientId=self.client)[0] for j in self.base_joints
        )  # type: ignore[return-value]

    def get_arm(self) -> tuple[float, ...]:
        return tuple(
            p.getJointState(self.body, j, physicsClientId=self.client)[0] for j in self.arm_joints
        )

    def tool_pose(self) -> Pose:
        st = p.getLinkState(
            self.body, self.tool_link, computeForwardKinematics=True, physicsClientId=self.client
        )
        return pose(st[4], st[5])

    def within_limits(self, conf: Sequence[float], tol: float = 1e-6) -> bool:
        c = np.asarray(conf)
        return bool(np.all(c >= self.arm_lower - tol) and np.all(c <= self.arm_upper + tol))

    # -- kinematics (private client) ---------------------------------------------------------
    def _ik_fk(self, conf: Sequence[float]) -> Pose:
        self._reset(self.ik_body, self.ik_arm, conf, self.ik_client)
        st = p.getLinkState(
            self.ik_body,
            self.ik_tool,
            computeForwardKinematics=True,
            physicsClientId=self.ik_client,
        )
        return pose(st[4], st[5])

    def _refine(
        self, conf: np.ndarray, target: Pose, pos_tol: float, ori_tol: float, iters: int = 60
    ) -> tuple[np.ndarray, float, float]:
        """Damped least-squares refinement with the Jacobian, clamped to the joint limits.

        With :attr:`stall` on (``(STALL, STALL_GAIN)``, what the planner's streams use), an
        attempt that stalls -- :data:`STALL` steps without bringing its error (the larger of
        the position and orientation errors, each over its tolerance) below :data:`STALL_GAIN`
        of the best so far -- stops there with the best iterate it reached.  Stalled attempts
        were four fifths of the refinement's steps (a target out of reach, or an arm held at
        a joint limit, circles for all 60), and almost all of them fail; one that converges
        gains more than that every few steps (Stow, seed 1: 5,219 attempts succeeded, 96 of
        them after more than 8 steps, each still improving).  Iterates that go round a cycle
        (the clamp at a joint limit often brings a configuration back bit for bit) stall.
        (A rule of 8 steps and 0.98 lost slow convergers that matter: the waypoints of an
        approach path have one attempt each, and of 60 bases inv-reach found on Stow seed 0,
        whose landing corners it had checked, 9 corners then failed for a fresh sampler
        against none without the rule; with 15 steps and 0.99, none.)"""
        zeros = [0.0] * 9
        fingers = [FINGER_OPEN, FINGER_OPEN]
        lower, upper = self.arm_lower, self.arm_upper
        best, best_at, best_conf = math.inf, 0, conf  # see STALL
        stall_steps, stall_gain = self.stall or (iters, 0.0)
        # without the rule: a configuration that comes back (bit for bit) starts a cycle the
        # iterates go round until the last one, which is read off the cycle
        seen: dict[bytes, int] | None = {} if self.stall is None else None
        visited: list[np.ndarray] = []
        for i in range(iters):
            reached = self._ik_fk(conf)
            e_pos = np.subtract(target[0], reached[0])
            dq = quat_mul(target[1], quat_inv(reached[1]))
            if dq[3] < 0:
                dq = tuple(-v for v in dq)
            s = norm(dq[:3])
            e_rot = np.zeros(3) if s < 1e-12 else np.asarray(dq[:3]) / s * 2 * math.atan2(s, dq[3])
            pos_err, ori_err = norm(e_pos), norm(e_rot)
            if pos_err < pos_tol * 0.5 and ori_err < ori_tol * 0.5:
                break
            err_now = max(pos_err / pos_tol, ori_err / ori_tol)
            if err_now < best:
                if err_now < best * stall_gain:
                    best_at = i
                best, best_conf = err_now, conf
            if i - best_at >= stall_steps:
                conf = best_conf
                break
            lin, ang = p.calculateJacobian(
                self.ik_body, self.ik_tool, [0.0, 0.0, 0.0], conf.tolist() + fingers,
                zeros, zeros, physicsClientId=self.ik_client,
            )  # fmt: skip
            jac = np.ascontiguousarray(np.array(lin + ang)[:, :7])
            err = np.concatenate([e_pos, e_rot])
            step = jac.T @ np.linalg.solve(jac @ jac.T + _DAMPING, err)
            if seen is not None:
                seen[conf.tobytes()] = i
                visited.append(conf)
            conf = np.minimum(np.maximum(conf + step, lower), upper)  # np.clip's values
            first = None if seen is None else seen.get(conf.tobytes())
            if first is not None:  # configuration i + 1 is configuration ``first``
                conf = visited[first + (iters - first) % (i + 1 - first)]
                break
        reached = self._ik_fk(conf)
        pos_err = norm(np.subtract(reached[0], target[0]))
        return conf, pos_err, angle_between(reached[1], target[1])

    def forward_kinematics(self, base_conf: Sequence[float], arm_conf: Sequence[float]) -> Pose:
        """World pose of the tool frame, computed without touching the world's state."""
        return multiply(base_to_link0(base_conf), self._ik_fk(arm_conf))

    def sample_arm(self, rng: np.random.Generator) -> tuple[float, ...]:
        return tuple(float(v) for v in rng.uniform(self.arm_lower, self.arm_upper))

    def inverse_kinematics(
        self,
        base_conf: Sequence[float],
        tool_world: Pose,
        rng: np.random.Generator,
        *,
        seed_conf: Sequence[float] | None = None,
        restarts: int = 12,
        pos_tol: float = 2e-3,
        ori_tol: float = 2e-2,
    ) -> IKResult | None:
        """Arm configuration putting the tool at ``tool_world`` for a fixed base, or None.

        Null-space IK (joint limits and a rest pose) from ``seed_conf`` then random restarts;
        each candidate is iterated and accepted only when forward kinematics agrees within
        ``pos_tol`` (m) and ``ori_tol`` (rad) and it is within the joint limits.

        An attempt from a given seed (``seed_conf``, else :data:`ARM_REST`) depends on the
        target and the seed only (the private client holds the bare arm): its answer is kept
        and used again for the same target and seed, bit for bit (cartesian paths are solved
        again and again from the same bases, e.g. every landing corner of a drawer base).  The
        random restarts are not kept, and draw from ``rng`` as ever.
        """
        target = multiply(invert(base_to_link0(base_conf)), tool_world)
        seeds = [tuple(seed_conf)] if seed_conf is not None else [ARM_REST]
        for k in range(restarts):
            if k < len(seeds):
                key = np.array([*target[0], *target[1], *seeds[k], pos_tol, ori_tol]).tobytes()
                if key in self._ik_attempts:
                    self.ik_attempts_reused += 1
                    res = self._ik_attempts[key]
                else:
                    res = self._ik_attempt(target, seeds[k], pos_tol, ori_tol)
                    self._keep(key, res)
            else:
                res = self._ik_attempt(target, self.sample_arm(rng), pos_tol, ori_tol)
            if res is not None:
                return res
        return None

    def _keep(self, key: bytes, res: IKResult | None) -> None:
        """Keep an attempt's answer, dropping the oldest beyond :data:`IK_ATTEMPTS_KEPT`."""
        kept = self._ik_attempts
        while kept and len(kept) >= IK_ATTEMPTS_KEPT:
            del kept[next(iter(kept))]
        if IK_ATTEMPTS_KEPT > 0:
            kept[key] = res

    def _ik_attempt(
        self, target: Pose, seed: Sequence[float], pos_tol: float, ori_tol: float
    ) -> IKResult | None:
        """One IK attempt from ``seed`` for ``target`` (in the arm's frame), or None."""
        lower = list(self.arm_lower) + [0.0, 0.0]
        upper = list(self.arm_upper) + [FINGER_OPEN, FINGER_OPEN]
        ranges = [hi - lo for lo, hi in zip(lower, upper, strict=True)]
        self._ik_fk(seed)
        sol = p.calculateInverseKinematics(
            self.ik_body,
            self.ik_tool,
            target[0],
            target[1],
            lowerLimits=lower,
            upperLimits=upper,
            jointRanges=ranges,
            restPoses=list(seed) + [FINGER_OPEN, FINGER_OPEN],
            maxNumIterations=100,
            residualThreshold=1e-5,
            physicsClientId=self.ik_client,
        )
        conf = np.clip(np.asarray(sol[:7]), self.arm_lower, self.arm_upper)
        conf, pos_err, ori_err = self._refine(conf, target, pos_tol, ori_tol)
        if pos_err < pos_tol and ori_err < ori_tol and self.within_limits(conf):
            return IKResult(tuple(float(v) for v in conf), pos_err, ori_err)
        return None
