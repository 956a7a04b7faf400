"""Building blocks for hand-written plans: each composes the kitchen streams into actions and
executes them, replanning the geometric details (not the plan) after noisy base motions.

Used by the tests that show each task's goal is reachable in the simulator, and by demos.
"""

from __future__ import annotations

import numpy as np

from ssr_compile.belief.particles import ObservationModel

from .actions import Action, BaseNoise, MoveArm, MoveBase, Outcome, Pick, Place, Press, execute
from .perception import observe
from .robot import ARM_CARRY, ARM_TUCK
from .samplers import Grasp, KitchenStreams, ObjPose
from .world import PARK_BASE, ExecutionError, World


class Scripted:
    """Executes high-level steps (pick, place, open/close a drawer, press) in a world."""

    def __init__(self, world: World, rng: np.random.Generator, noise: BaseNoise | None = None):
        self.world = world
        self.rng = rng
        self.noise = noise
        self.ks = KitchenStreams(world, rng)
        self.trace: list[tuple[Action, Outcome]] = []

    def run(self, action: Action) -> Outcome:
        out = execute(self.world, action, self.rng, self.noise)
        self.trace.append((action, out))
        return out

    def arm_to(self, q: tuple[float, ...]) -> None:
        w = self.world
        if np.max(np.abs(np.subtract(w.robot.get_arm(), q))) < 1e-6:
            return
        res = self.ks.plan_arm_motion(w.robot.get_base(), w.robot.get_arm(), q)
        if res is None:
            raise ExecutionError("no arm motion found")
        self.run(MoveArm(res[0]))

    def stow_arm(self) -> None:
        self.arm_to(ARM_TUCK if self.world.held is None else ARM_CARRY)

    def base_to(self, base: tuple[float, float, float]) -> None:
        self.stow_arm()
        res = self.ks.plan_base_motion(self.world.robot.get_base(), base)
        if res is None:
            raise ExecutionError("no base motion found")
        self.run(MoveBase(res[0]))

    def park(self) -> None:
        """Drive out of the camera's view (for an unobstructed observation)."""
        self.base_to(PARK_BASE)

    def observe(self, model: ObservationModel | None = None) -> dict:
        return observe(self.world, self.rng, model)

    def _reach(self, obj: str, p: ObjPose, tries: int = 6):
        """Drive to a base for (obj, p) and return (grasp, pre-conf, approach) from the base
        where the robot actually landed."""
        held = self.world.held
        for _ in range(tries):
            grasps = (
                [(Grasp(obj, "held", held.grasp),)]
                if held is not None
                else self.ks.sample_grasps(obj)
            )
            for (g,) in grasps:
                for (base,) in self.ks.inv_reach(obj, p, g):
                    self.base_to(base)
                    kin = self.ks.inv_kin(obj, p, g, self.world.robot.get_base())
                    if kin is not None:
                        return g, kin
                    break
        raise ExecutionError(f"cannot reach {obj} at {p}")

    def pick(self, obj: str) -> None:
        p = self.ks.current_pose(obj)
        g, (pre, approach) = self._reach(obj, p)
        self.arm_to(pre)
        out = self.run(Pick(obj, g.pose, approach))
        if not out.ok:
            raise ExecutionError(out.message)
        self.stow_arm()

    def place(self, obj: str, surface: str, clearance: float = 0.15, rounds: int = 5) -> None:
        held = self.world.held
        if held is None or held.obj != obj:
            raise ExecutionError(f"not holding {obj}")
        others = [
            np.asarray(self.world.object_pose(o)[0][:2]) for o in self.world.present() if o != obj
        ]
        candidates = (p for _ in range(rounds) for p in self.ks.sample_placements(obj, surface))
        for (p,) in candidates:
            xy = np.asarray(self.ks.world_pose(p)[0][:2])
            if any(np.linalg.norm(xy - o) < clearance for o in others):
                continue  # keep room for the gripper around the other objects
            try:
                _, (pre, approach) = self._reach(obj, p, tries=1)
            except ExecutionError:
                continue
            self.arm_to(pre)
            out = self.run(Place(obj, surface, approach))
            if not out.ok:
                raise ExecutionError(out.message)
            self.arm_to(ARM_TUCK)
            return
        raise ExecutionError(f"no reachable placement of {obj} on {surface}")

    def move_drawer(self, drawer: str, q: float) -> Outcome:
        """Open (pull) or close (push) ``drawer`` to opening ``q``; a blocked push returns a
        failed outcome with the opening where the drawer stopped."""
        w = self.world
        for (base,) in self.ks.sample_drawer_base(drawer):
            self.base_to(base)
            motion = self.ks.plan_drawer(drawer, w.drawer_q[drawer], q, w.robot.get_base())
            if motion is None:
                continue
            self.arm_to(motion.arm_path[0])
            out = self.run(motion)
            self.arm_to_safe()
            return out
        raise ExecutionError(f"cannot move {drawer}")

    def arm_to_safe(self) -> None:
        """Back to the tucked arm (after a blocked push the hand may still touch the handle:
        then it first backs off along the approach axis)."""
        try:
            self.arm_to(ARM_TUCK)
        except ExecutionError:
            w = self.world
            base = w.robot.get_base()
            path = self.ks.approach_path(base, w.robot.tool_pose(), 0.08, seed=w.robot.get_arm())
            if path is None:
                raise
            self.run(MoveArm((w.robot.get_arm(), *path[::-1])))
            self.arm_to(ARM_TUCK)

    def press(self) -> Outcome:
        for (base,) in self.ks.sample_press_base():
            self.base_to(base)
            res = self.ks.plan_press(self.world.robot.get_base())
            if res is None:
                continue
            self.arm_to(res[0][0])
            out = self.run(Press(res[0]))
            self.arm_to(ARM_TUCK)
            return out
        raise ExecutionError("cannot reach the stove button")
