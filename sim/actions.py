"""Actions of the kitchen domain and their execution in the simulator (paper §IV, §VIII).

Each action carries the trajectories computed by the streams (``ssr_compile.sim.samplers``);
:func:`execute` plays it in the world: base motions land with Gaussian noise, arm trajectories
are followed (stopping before a collision), pick attaches the object to the hand, place
releases it onto the support underneath, pull/push move a drawer together with its contents
(a push stops where the drawer or its contents would collide), press toggles the stove, and an
object on a stove that is on becomes cooked.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .geometry import Pose, invert, multiply, wrap_angle
from .world import DRAWER_TRAVEL, ExecutionError, World

Conf = tuple[float, ...]


@dataclass(frozen=True)
class BaseNoise:
    """Gaussian landing error of a base motion (std of x, y in m and of yaw in rad)."""

    xy: float = 0.01
    yaw: float = 0.01


@dataclass(frozen=True)
class MoveBase:
    path: tuple[Conf, ...]


@dataclass(frozen=True)
class MoveArm:
    path: tuple[Conf, ...]


@dataclass(frozen=True)
class Pick:
    obj: str
    grasp: Pose  # object in tool frame
    approach: tuple[Conf, ...]  # pre-grasp -> grasp; retreat is the reverse


@dataclass(frozen=True)
class Place:
    obj: str
    surface: str
    approach: tuple[Conf, ...]  # pre-place -> place; retreat is the reverse


@dataclass(frozen=True)
class DrawerMotion:
    """Pull (opening) or push (closing): approach the handle, move with the drawer, retreat.
    ``arm_path[i]`` is reached after the drawer is set to ``drawer_path[i]``."""

    drawer: str
    arm_path: tuple[Conf, ...]
    drawer_path: tuple[float, ...]

    @property
    def kind(self) -> str:
        return "pull" if self.drawer_path[-1] > self.drawer_path[0] else "push"


@dataclass(frozen=True)
class Press:
    approach: tuple[Conf, ...]  # pre-press -> press; retreat is the reverse


Action = MoveBase | MoveArm | Pick | Place | DrawerMotion | Press


@dataclass
class Outcome:
    ok: bool = True
    message: str = ""
    info: dict = field(default_factory=dict)


def _follow_arm(world: World, path, check: bool = True) -> None:
    for i, q in enumerate(path):
        prev = world.robot.get_arm()
        world.set_arm(q)
        if check and i > 0 and world.robot_collision():
            hit = ", ".join(world.robot_contacts()) or "the world"
            world.set_arm(prev)
            raise ExecutionError(f"arm motion collides with {hit} at waypoint {i}")


def _at(conf_a, conf_b, tol: float = 0.05) -> bool:
    return bool(np.max(np.abs(np.subtract(conf_a, conf_b))) <= tol)


def execute(
    world: World, action: Action, rng: np.random.Generator, noise: BaseNoise | None = None
) -> Outcome:
    """Execute ``action`` in ``world``.  Raises :class:`ExecutionError` when a precondition is
    violated (the state is then left where the robot stopped)."""
    noise = BaseNoise() if noise is None else noise
    r = world.robot
    if isinstance(action, MoveBase):
        if not _at(r.get_base(), action.path[0], 0.1):
            raise ExecutionError("base motion does not start at the current base configuration")
        for i, q in enumerate(action.path):
            prev = r.get_base()
            world.set_base(q)
            if i > 0 and world.robot_collision():
                world.set_base(prev)
                raise ExecutionError(f"base motion collides at waypoint {i}")
        goal = np.asarray(action.path[-1], float)
        if all(_at(q, action.path[0], 1e-6) for q in action.path):
            # Told to stay where it is (a plan tail's base motion whose end is the base the
            # robot reached): it does not move, so it does not land elsewhere either.
            return Outcome(info={"base": tuple(float(v) for v in r.get_base())})
        landed = goal + rng.normal(size=3) * np.array([noise.xy, noise.xy, noise.yaw])
        landed[2] = wrap_angle(landed[2])
        world.set_base(landed)
        if world.robot_collision():  # a bump: the robot stays where it was planned to be
            world.set_base(goal)
        return Outcome(info={"base": tuple(float(v) for v in r.get_base())})
    if isinstance(action, MoveArm):
        if not _at(r.get_arm(), action.path[0]):
            raise ExecutionError("arm motion does not start at the current arm configuration")
        _follow_arm(world, action.path)
        return Outcome()
    if isinstance(action, Pick):
        if world.held is not None:
            raise ExecutionError("pick: the hand is not empty")
        if world.support[action.obj] is None:
            raise ExecutionError(f"pick: {action.obj} is not in the scene")
        if not _at(r.get_arm(), action.approach[0]):
            raise ExecutionError("pick: the arm is not at the pre-grasp configuration")
        _follow_arm(world, action.approach, check=False)
        rel = multiply(invert(r.tool_pose()), world.object_pose(action.obj))
        err = np.linalg.norm(np.subtract(rel[0], action.grasp[0]))
        if err > 0.02:
            _follow_arm(world, action.approach[::-1], check=False)
            return Outcome(False, f"pick: {action.obj} is {err:.3f} m from the grasp, missed")
        world.grab(action.obj, rel)
        _follow_arm(world, action.approach[::-1], check=False)
        return Outcome()
    if isinstance(action, Place):
        if world.held is None or world.held.obj != action.obj:
            raise ExecutionError(f"place: not holding {action.obj}")
        if not _at(r.get_arm(), action.approach[0]):
            raise ExecutionError("place: the arm is not at the pre-place configuration")
        _follow_arm(world, action.approach, check=False)
        rel = world.stable_on(action.obj, action.surface, world.object_pose(action.obj), 0.02)
        if rel is None:
            _follow_arm(world, action.approach[::-1], check=False)
            return Outcome(False, f"place: {action.obj} would not rest on {action.surface}")
        world.place_object(action.obj, action.surface, rel)
        r.set_fingers(0.04)
        _follow_arm(world, action.approach[::-1], check=False)
        return Outcome()
    if isinstance(action, DrawerMotion):
        return _drawer_motion(world, action)
    if isinstance(action, Press):
        if not _at(r.get_arm(), action.approach[0]):
            raise ExecutionError("press: the arm is not at the pre-press configuration")
        _follow_arm(world, action.approach, check=False)
        tip = np.asarray(r.tool_pose()[0])
        button = np.asarray(world.button_pose()[0])
        if np.linalg.norm(tip - button) > 0.02:
            _follow_arm(world, action.approach[::-1], check=False)
            return Outcome(False, "press: the button was not reached")
        world.toggle_stove()
        _follow_arm(world, action.approach[::-1], check=False)
        return Outcome(info={"stove_on": world.stove_on})
    raise TypeError(f"unknown action {action!r}")


def _drawer_motion(world: World, action: DrawerMotion) -> Outcome:
    """Follow the handle; the drawer (and its contents) moves only while the hand holds it."""
    r = world.robot
    d = action.drawer
    if world.held is not None:
        raise ExecutionError(f"{action.kind}: the hand is not empty")
    if not _at(r.get_arm(), action.arm_path[0]):
        raise ExecutionError(f"{action.kind}: the arm is not at the approach configuration")
    if abs(world.drawer_q[d] - action.drawer_path[0]) > 0.01:
        raise ExecutionError(f"{action.kind}: {d} is not at the expected opening")
    contents = [n for n, s in world.support.items() if s is not None and s[0] == d]
    for q_arm, q_d in zip(action.arm_path, action.drawer_path, strict=True):
        if abs(q_d - world.drawer_q[d]) > 1e-9:
            handle = np.asarray(world.handle_pose(d))
            if np.linalg.norm(np.asarray(r.tool_pose()[0]) - handle) > 0.02:
                raise ExecutionError(f"{action.kind}: the hand does not hold the handle of {d}")
            prev = world.drawer_q[d]
            world.set_drawer(d, float(np.clip(q_d, 0.0, DRAWER_TRAVEL)))
            if any(world.object_collision(n, ignore=contents) for n in contents):
                world.set_drawer(d, prev)  # blocked: the drawer stops before the collision
                return Outcome(False, f"{action.kind}: {d} blocked at {prev:.3f}", {"q": prev})
        world.set_arm(q_arm)
    return Outcome(info={"q": world.drawer_q[d]})
