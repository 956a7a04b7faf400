"""How near an arm motion may pass the objects of the planning world (see
:meth:`~ssr_compile.sim.samplers.KitchenStreams.plan_arm_motion`).

The planning world puts the objects the robot has localized at their estimates, which may be a
centimetre off, and the object in the hand where the plan grasped it (a pick succeeds up to
2 cm off).  Paths planned at zero clearance hit the true objects: the cluttered kitchen (cook,
8 objects, 6 boxes, seed 2) executed three carry motions in a row that collided with boxes the
robot had localized, each replanned around the last hit.  Away from its ends a motion keeps
:data:`ROBOT_CLEARANCE` between the arm and the localized objects and :data:`HELD_CLEARANCE`
between what it holds and everything; near either end it may be as near as that end is.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import pybullet as p

from .world import World

ROBOT_CLEARANCE = 0.01  # metres, arm to localized objects
HELD_CLEARANCE = 0.02  # metres, held object to anything


def mover_clearances(world: World, reach: float) -> dict[tuple[bool, int], float]:
    """The smallest signed distance below ``reach`` from the robot (key ``(False, body)``) to
    each movable object present, and from what it holds (``(True, body)``) to every obstacle,
    the robot's base included."""
    c = world.client
    movable = {b for n, b in world.objects.items() if world.support[n] is not None}
    out: dict[tuple[bool, int], float] = {}
    pairs = [(world.robot.body, b, False, None) for b in world.obstacles() if b in movable]
    if world.held is not None:
        hb = world.objects[world.held.obj]
        pairs += [(hb, b, True, None) for b in world.obstacles()]
        pairs.append((hb, world.robot.body, True, world.robot.base_link))
    for a, b, held, link in pairs:
        kw = {} if link is None else {"linkIndexB": link}
        for pt in p.getClosestPoints(a, b, reach, physicsClientId=c, **kw):
            key = (held, b)
            if pt[8] < out.get(key, reach):
                out[key] = pt[8]
    return out


def leaving_test(
    world: World, start: np.ndarray, near: float, tol: float
) -> tuple[dict[int, float], Callable[[np.ndarray], bool]]:
    """The obstacles within ``near`` of the arm (or what it holds) at ``start``, by body, and a
    test of arm configurations: True when none of them is nearer than at ``start``, less
    ``tol`` (a motion leaves what it starts near)."""
    world.set_arm(start)
    there = world.robot_clearances(near)

    def leaving(q: np.ndarray) -> bool:
        world.set_arm(q)
        now = world.robot_clearances(near)
        return all(now.get(b, near) >= d0 - tol for b, d0 in there.items())

    return there, leaving


def too_near_test(
    world: World, ends: Sequence[np.ndarray], near_end: float, tol: float
) -> Callable[[np.ndarray], bool]:
    """A test of arm configurations (the base set): True when the arm, or what it holds, is
    nearer an object than its clearance -- or, within ``near_end`` (radians, max over the
    joints) of one of ``ends``, nearer than that end is, less ``tol``, when that is nearer."""
    reach = max(ROBOT_CLEARANCE, HELD_CLEARANCE)
    at_ends = []
    for end in ends:
        world.set_arm(end)
        at_ends.append((np.asarray(end, float), mover_clearances(world, reach)))

    def too_near(q: np.ndarray) -> bool:
        world.set_arm(q)
        for key, d in mover_clearances(world, reach).items():
            want = HELD_CLEARANCE if key[0] else ROBOT_CLEARANCE
            for end, there in at_ends:
                if float(np.max(np.abs(q - end))) <= near_end:
                    want = min(want, there.get(key, reach) - tol)
            if d < want:
                return True
        return False

    return too_near
