"""The kitchen's motion streams (paper §IV): base, arm, drawer and button motions.

:class:`MotionStreams` is one part of :class:`~ssr_compile.streams.kitchen_module.KitchenModule`
(see that module for the planning state the streams are evaluated in).  Its methods use the
module's state (``world``, ``ks``, ``drawers``, ``obstacles``, ``holding``, ``arm_now``,
``collided``, ``_drawer_motions``, ``_reach_openings``) and helpers (``planning``, ``_snap``,
``_reachable``, ``_place_obstacles``).
"""

from __future__ import annotations

import numpy as np
from ssr_compile.sim.actions import DrawerMotion
from ssr_compile.sim.geometry import bases_near
from ssr_compile.sim.world import Held

# Radians (max over the joints) around an arm configuration that collided in the true world
# within which arm motions at that base are refused (:meth:`MotionStreams.blocked`).
BLOCKED = 0.3
# (m, rad): bases this close share what the true world refused there.
SAME_BASE = (0.03, 0.05)
RETRIES = 3  # random IK restarts may miss: a function stream tries this often before failing


class ArmConf(tuple):
    """An arm configuration computed by a stream, equal only to itself.

    Two streams may compute the same joint values (the pre-pose at an open drawer's handle
    ends a pull and starts a push); as plain tuples they would share one object name, and the
    next plan's structure (Algorithm 2) would then demand that two *different* streams return
    one value again -- which no optimistic plan can promise."""

    __slots__ = ()

    def __eq__(self, other: object) -> bool:
        return self is other

    def __ne__(self, other: object) -> bool:
        return self is not other

    def __hash__(self) -> int:
        return id(self)


def conf_key(q) -> tuple:
    return tuple(np.round(np.asarray(q, float), 6))


def same_conf(q1, q2, tol: float = 1e-6) -> bool:
    return len(q1) == len(q2) and float(np.max(np.abs(np.subtract(q1, q2)))) <= tol


class MotionStreams:
    """Base, arm, drawer and button motion streams of a :class:`KitchenModule`."""

    def plan_base_motion(self, q1, q2):
        with self.planning():
            return self.ks.plan_base_motion(q1, q2)

    def _note_reach(self, q, openings) -> None:
        self._reach_openings[conf_key(q)] = dict(openings)

    def _openings_at(self, q1, q2) -> dict[str, float] | None:
        """The drawer openings while the arm moves between ``q1`` and ``q2``: those the reach
        end was computed under -- a pull's approach with its drawer closed and the others
        closed, as pull requires; a pick in a drawer with that drawer open.  No drawer moves
        during an arm motion, so they hold for the whole motion, whenever the plan takes it.
        ``None`` (the openings the robot saw) for a reach the streams did not compute (the arm
        where it stopped) or one any openings allow (a pick on the counter)."""
        for q in (q2, q1):
            found = self._reach_openings.get(conf_key(q))
            if found is not None:
                return found
        return None

    def plan_arm_motion(self, bq, q1, q2):
        """An arm motion that also avoids the objects the robot has localized where it believes
        they are (:attr:`obstacles`): the arm leaving an object it just placed must not sweep
        through it, which the true world refuses (and a replan would try the same path again).
        Drawers are where they will be when the motion is taken (:meth:`_openings_at`), not
        where the robot saw them: Swap without deferral opened the bottom drawer, and every
        motion to its approach for pulling it open again later (after closing it), checked with
        the hand inside the open drawer, failed level after level until the instance cap."""
        openings = self._openings_at(q1, q2)
        with self.planning() as w:
            for d, q in (openings or {}).items():
                w.set_drawer(d, q)
            self._place_obstacles(w)
            # A motion is certified both ways (see :func:`to_action`), so one that ends where
            # the arm is now may be executed next, reversed: it is planned from here.
            now = self.arm_now
            reverse = now is not None and not same_conf(q1, now) and same_conf(q2, now)
            if self.holding is not None and now is not None and (same_conf(q1, now) or reverse):
                # The motion the robot may execute next carries what it holds: checked with
                # it (an arm motion with the cracker box in hand failed in the true world, and
                # the replan chose the same motion again, Cook seed 1; Stow seeds 5 and 9 took
                # a motion planned with the hand empty towards the pick, reversed, 90 times).
                o, g = self.holding
                w.held = Held(o, g.pose)
                # ... unless its far end cannot be reached with the object in hand: then the
                # plan takes it after putting the object down, from a named configuration
                # the arm happens to be in now (carry).  Stow without deferral held the sugar
                # box at carry, and every motion from carry to a grasp of the block, checked
                # with the box in hand, failed, until no plan was left (6 of 12 episodes).
                w.set_base(bq)
                w.set_arm(q1 if reverse else q2)
                if w.robot_collision():
                    w.held = None
            # RRT-Connect may miss a path that exists; a function fails for the whole solve,
            # and with the arm where it is, no other motion may be left (Cook seed 3 ended
            # "no relaxed solution" on one miss, with a path there on the next try).
            blocked = self.blocked(bq)
            for _ in range(RETRIES):
                if reverse:
                    out = self.ks.plan_arm_motion(bq, q2, q1, blocked)
                    path = None if out is None else (tuple(out[0][::-1]),)
                else:
                    path = self.ks.plan_arm_motion(bq, q1, q2, blocked)
                if path is not None:
                    return path
            return None

    def blocked(self, bq):
        """Configurations the true world refused at (or near) base ``bq``, as a test for arm
        motions: within :data:`BLOCKED` of a configuration that collided, on its side of the
        halfway point from where the arm stopped (the arm may still leave that point).  The
        planning world did not know what the arm hit -- an estimate a little off, or an object
        not yet localized -- and the motion stream, asked again, planned through it again
        (Cook seed 5 executed one carry motion 90 times).  Only what collided with the same
        object in the hand as now (or none): a carry motion that a held box stopped says
        nothing of the motions with the block in the hand.  Refused around the carry
        configuration with the box, every motion to carry with the block was refused too,
        and the robot moved its arm from one reach configuration to the next for 40 cycles
        (cluttered kitchen: cook, 8 objects, 6 boxes, seed 2)."""
        held = None if self.holding is None else self.holding[0]
        near = [
            (np.asarray(stop, float), np.asarray(hit, float))
            for b, stop, hit, with_held in self.collided
            if with_held == held and bases_near(b, bq, SAME_BASE)
        ]
        if not near:
            return None

        def test(q: np.ndarray) -> bool:
            for stop, hit in near:
                to_hit = float(np.max(np.abs(q - hit)))
                if to_hit <= BLOCKED and to_hit <= float(np.max(np.abs(q - stop))):
                    return True
            return False

        return test

    def sample_drawer_base(self, d: str):
        return self._each(lambda: self.ks.sample_drawer_base(d), moving=d)

    def _drawer_motion(self, d: str, a1, a2, bq, start=None):
        key = (d, a1[1], a2[1], tuple(bq), tuple(sorted(self.drawers.items())))
        if start is not None:
            # The arm is where an earlier plan put it for this very motion: that motion.
            taken = self._planned_from(self._drawer_motions, key, start, lambda m: m.arm_path)
            if taken is not None:
                m, path = taken
                return DrawerMotion(d, path, m.drawer_path)
        with self.planning(moving=d):
            self.world.set_drawer(d, a1[1])
            if not self._reachable(bq, self.world.handle_pose(d)):
                return None
            for _ in range(RETRIES):
                m = self.ks.plan_drawer(d, a1[1], a2[1], bq, seed=start)
                path = self._snap(None if m is None else m.arm_path, start)
                if path is not None:
                    self._note_reach(path[0], {**self.world.drawer_q, d: a1[1]})
                    self._note_reach(path[-1], {**self.world.drawer_q, d: a2[1]})
                    motion = DrawerMotion(d, tuple(path), m.drawer_path)
                    self._drawer_motions.append((key, motion))
                    return motion
        return None

    def _plan_drawer(self, d: str, a1, a2, bq):
        m = self._drawer_motion(d, a1, a2, bq)
        return None if m is None else (ArmConf(m.arm_path[0]), ArmConf(m.arm_path[-1]), m)

    def _plan_drawer_from(self, d: str, a1, a2, bq, aq):
        m = self._drawer_motion(d, a1, a2, bq, aq)
        return None if m is None else (ArmConf(m.arm_path[-1]), m)

    def sample_press_base(self, s: str):
        return self._each(self.ks.sample_press_base)

    def _press(self, bq, start=None):
        key = (tuple(bq), tuple(sorted(self.drawers.items())))
        with self.planning():
            if not self._reachable(bq, self.world.button_pose()[0]):
                return None
            for _ in range(RETRIES):
                res = self.ks.plan_press(bq, seed=start)
                path = self._snap(None if res is None else tuple(res[0]), start)
                if path is not None:
                    self._press_paths.append((key, path))
                    return path
        if start is not None:
            # No path from where the arm is, but the arm is where a press path planned
            # before from this base starts (it moved there for it): that path.  Otherwise
            # the plan moves the arm there again, a motion of length zero, and the next
            # replan is the same (the clutter family's N = 4, K = 1, seed 5 did so for 83
            # cycles, until its 100 ran out).
            taken = self._planned_from(self._press_paths, key, start, lambda p: p)
            if taken is not None:
                return taken[1]
        return None

    def _planned_from(self, planned: list, key, start, path_of):
        """The first of ``planned`` ((key, motion) pairs) with ``key`` whose arm path (by
        ``path_of``) starts where the arm is (``start``, within SNAP), and that path snapped
        to ``start``; ``None`` when there is none."""
        for k, m in planned:
            path = self._snap(path_of(m), start) if k == key else None
            if path is not None:
                return m, path
        return None

    def plan_press(self, bq):
        path = self._press(bq)
        return None if path is None else (ArmConf(path[0]), path)

    def plan_press_from(self, bq, aq):
        path = self._press(bq, aq)
        return None if path is None else (path,)
