"""A kitchen task generated from a seed: the world in its latent initial state, the prior and
the goal, as a task file states them (``sim/task_file.py``).  The four tasks of the paper's
appendix (Inspect, Stow, Swap, Cook) are the shipped files ``domains/pddl/kitchen/tasks/``.

A :class:`Task` gives the world in its latent initial state, the prior belief as plain data
(``object -> [(surface, weight), ...]``: uniform over each surface, with its weight), the
latent state (``world.true_state()`` at the start, for evaluation only) and the goal as
PDDL-like tuples: ``("On", obj, surface)``, ``("Closed", drawer)``, ``("Cooked", obj)``,
``("StoveOff",)``.

* Inspect: goal block in the bottom drawer and the bottom drawer closed; prior uniform over
  both drawers; the block is in the bottom drawer (drawers closed).
* Stow: goal block in the top drawer and the top drawer closed; prior block uniform over the
  counter, sugar box uniform over the top drawer; the block is on the counter, the sugar box in
  the (open) top drawer — it is too tall for the drawer to close.
* Swap: goal and prior as Inspect; the block is in the top drawer (drawers closed).
* Cook: goal block cooked *and the stove off* (the appendix's trace turns the stove on, which
  cooks the block, then off again); prior block uniform over the counter (and so are the
  boxes); the cracker box and the sugar box are on the counter, one of them hiding the block
  from the camera.

The seed's draws, in order: the robot's base about :data:`~.world.PARK_BASE`; then each object
not among the hiders, in the file's order (its surface when it has several, then its pose);
then which hider hides the target, its pose, and the other hiders' (all placements again when
no pose of that hider hides the target).
"""

from __future__ import annotations

import math
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ssr_compile.belief.particles import Surface
from ssr_compile.catalog import TASKS

from .geometry import yaw_of
from .perception import visible_fraction
from .robot import ARM_TUCK
from .task_file import TaskSpec, load_task_file, shipped_task_file
from .world import DRAWER_TRAVEL, DRAWERS, PARK_BASE, World

Goal = tuple[tuple[str, ...], ...]
CLOSED_TOL = 0.005
HIDE_ATTEMPTS = 100  # placements of all objects before a task's hide is given up


@dataclass
class Task:
    name: str
    seed: int
    world: World
    prior: dict[str, list[tuple[str, float]]]
    goal: Goal
    latent: dict = field(default_factory=dict)
    spec: TaskSpec | None = None  # the task file it was generated from

    def goal_satisfied(self, state: dict | None = None) -> bool:
        """The goal holds in ``state`` (default: the world's true state)."""
        return goal_holds(self.goal, self.world.true_state() if state is None else state)

    def prior_surfaces(self) -> dict[str, list[tuple[Surface, float]]]:
        """The prior with each surface as a ``ssr_compile.belief.particles.Surface`` in the world frame (at
        the drawers' current openings)."""
        return {
            obj: [(belief_surface(self.world, s), w) for s, w in entries]
            for obj, entries in self.prior.items()
        }

    def close(self) -> None:
        self.world.close()


def goal_holds(goal: Goal, state: dict) -> bool:
    for fact in goal:
        head, *args = fact
        if head == "On":
            obj, surface = args
            if state["objects"].get(obj, {}).get("surface") != surface:
                return False
        elif head == "Closed":
            if state["drawers"][args[0]] > CLOSED_TOL:
                return False
        elif head == "Cooked":
            if args[0] not in state["cooked"]:
                return False
        elif head == "StoveOff":
            if state["stove_on"]:
                return False
        else:
            raise ValueError(f"unknown goal fact {fact!r}")
    return True


def belief_surface(world: World, surface: str) -> Surface:
    """A world surface as the belief layer's axis-aligned rectangle."""
    lo, hi, z = world.surface_world_rect(surface)
    return Surface(surface, tuple((lo + hi) / 2), tuple((hi - lo) / 2), z)


def _place_random(
    world: World, rng: np.random.Generator, obj: str, surface: str, moved: bool = False
) -> None:
    """``obj`` at a random stable, collision-free pose on ``surface``; in a drawer, only where
    the robot can grasp it with the drawer open (and the others closed): the back of a drawer
    stays under the counter when it is open, and a block there made Swap seed 2 unsolvable
    (no base, no grasp: "no relaxed solution" after the drawer was opened).  Elsewhere, an
    object the goal moves (``moved``) only where some grasp reaches it, with the drawers as
    they are."""
    from .samplers import KitchenStreams

    ks = KitchenStreams(world, rng, max_attempts=200)
    for (p,) in ks.sample_placements(obj, surface):
        if surface in DRAWERS and not _graspable(world, rng, p):
            continue
        # Elsewhere (the counter) the check draws from a generator of its own, seeded by the
        # pose: the seed's draws stay as they were, and so does every world whose objects
        # pass.  Stow seed 5's block stood at the counter's corner by the open drawer, where
        # 1 of 40 batches of base draws reached it (one grasp of eight) at its true pose and
        # none from the robot's estimate: the episode ended "no relaxed solution" holding the
        # sugar box.
        if moved and surface not in DRAWERS:
            if not _graspable(world, _probe_rng(p), p, slack=False):
                continue
        world.place_object(obj, surface, p.rel)
        return
    raise RuntimeError(f"no placement of {obj} on {surface}")


# (m, rad): a drawer object is placed only where some grasp reaches it from some base at its
# pose and at poses this far off -- what the robot plans with is an estimate.  Reached at the
# true pose only, Swap seed 2's block was reached at no base from an estimate 1.3 cm off, and
# the episode ended "no relaxed solution" with the drawer open in front of the robot.
GRASP_SLACK = (0.015, 0.05)


PROBE_DIGITS = 9  # decimals of a pose that seed its reach probes (:func:`_probe_rng`)


def _probe_rng(p) -> np.random.Generator:
    """A generator seeded by the pose ``p`` (for a check that must not move the seed's draws),
    rounded to PROBE_DIGITS decimals first: the last bits of a pose's quaternion are those of
    numpy's ``sin``/``cos``, which differ between CPUs (its AVX-512 implementations and libm's
    disagree by an ulp or two), and seeded by the exact bytes, an ulp drew other probes and
    gave another world (inspect seeds 2 and 3)."""
    (x, y, z), q = p.rel
    values = [round(float(v), PROBE_DIGITS) + 0.0 for v in (x, y, z, *q)]  # + 0.0: no -0.0
    return np.random.default_rng(zlib.crc32(np.asarray(values, float).tobytes()))


def _graspable(
    world: World, rng: np.random.Generator, p, slack: bool = True, attempts: int = 20
) -> bool:
    """Some grasp of ``p.obj`` at ``p`` is reached from some base -- in a drawer: with that
    drawer open and the others closed, and so it is at ``p`` moved by :data:`GRASP_SLACK`
    (each shift alone, those that stay inside the drawer); elsewhere: with the drawers as
    they are, at ``p`` alone when ``slack`` is off.  ``attempts``: draws of bases and arm
    configurations per grasp."""
    from .samplers import KitchenStreams, ObjPose

    # The bases checked along each axis of the landing margin alone, not at its corners: the
    # worlds of the seeds stay those they were (this asks whether the task is fair, not where
    # a robot may safely stand).
    ks = KitchenStreams(world, rng, max_attempts=attempts, margin_corners=False)
    (x, y, z), q = p.rel
    yaw = yaw_of(q)
    dxy, dyaw = GRASP_SLACK
    poses = [p]
    for ox, oy, oyaw in ((dxy, 0, 0), (-dxy, 0, 0), (0, dxy, 0), (0, -dxy, 0), (0, 0, dyaw)):
        if not slack:
            break
        rel = world.rest_pose(p.obj, p.surface, x + ox, y + oy, yaw + oyaw)
        if world.inside_surface(p.obj, p.surface, rel):
            poses.append(ObjPose(p.obj, p.surface, rel))
    with world.saved():
        if p.surface in DRAWERS:
            for d in DRAWERS:
                world.set_drawer(d, DRAWER_TRAVEL if d == p.surface else 0.0)
        for (g,) in ks.sample_grasps(p.obj):
            if all(next(iter(ks.inv_reach(p.obj, s, g)), None) is not None for s in poses):
                return True
    return False


def _place_occluder(world: World, rng: np.random.Generator, box: str, target: str) -> bool:
    """Put ``box`` on the counter between the camera and ``target``, facing the camera."""
    from .samplers import KitchenStreams, ObjPose

    ks = KitchenStreams(world, rng)
    (bx, by, _), _ = world.object_pose(target)
    u = np.array([bx, by]) - np.asarray(world.camera_eye[:2])
    u /= math.sqrt(u[0] * u[0] + u[1] * u[1])  # not a BLAS dot, whose kernel varies by CPU
    for _ in range(50):
        d = world.half_extents[box][1] + rng.uniform(0.03, 0.06)
        lateral = rng.uniform(-0.01, 0.01)
        x, y = np.array([bx, by]) - d * u + lateral * np.array([-u[1], u[0]])
        yaw = math.atan2(u[1], u[0]) + math.pi / 2 + float(rng.uniform(-0.1, 0.1))
        p = ObjPose(box, "counter", world.rest_pose(box, "counter", x, y, yaw))
        if not ks.placement_valid(p):
            continue
        world.place_object(box, "counter", p.rel)
        if visible_fraction(world, target) <= 0.1:
            return True
        world.remove_object(box)
    return False


# draws of bases and arm configurations per grasp of a box that must be reachable (``hide.
# reachable``): 20 judged the inspect family's N = 2, K = 1, seed 1 unreachable, whose episode
# picks that box up; at 100 it is reached (the family's unreachable boxes stay so at 300)
REACH_PROBE = 100


def _clear_to_reach(world: World, box: str, target: str, moved: bool) -> bool:
    """``box`` can be grasped and, if the goal moves ``target`` (``moved``), so can ``target``
    with ``box`` out of the scene."""
    if not _reachable(world, box):
        return False
    if not moved:
        return True
    surface, rel = world.support[box]
    world.remove_object(box)
    try:
        return _reachable(world, target)
    finally:
        world.place_object(box, surface, rel)


def _reachable(world: World, obj: str) -> bool:
    """Some grasp of ``obj`` where it stands is reached from some base, with the world as it
    is (:func:`_graspable` at that pose alone, :data:`REACH_PROBE` draws, from a generator of
    the pose's own: a world that passes keeps the seed's draws as they were)."""
    from .samplers import ObjPose

    surface, rel = world.support[obj]
    p = ObjPose(obj, surface, rel)
    return _graspable(world, _probe_rng(p), p, slack=False, attempts=REACH_PROBE)


def make_task(task: str | Path | TaskSpec, seed: int, *, gui: bool = False) -> Task:
    """Generate ``task`` from ``seed``: one of :data:`TASKS` (its shipped file), a task file's
    path (``.toml``) or a :class:`~.task_file.TaskSpec`.  A task file that is bad input, or
    whose objects the seed cannot place, raises :class:`~ssr_compile.errors.SSRError`."""
    if isinstance(task, TaskSpec):
        spec = task
    elif isinstance(task, Path) or str(task).endswith(".toml"):
        spec = load_task_file(task)
    elif task in TASKS:
        spec = load_task_file(shipped_task_file(task))
    else:
        raise ValueError(f"unknown task {task!r}; expected one of {TASKS} or a task file (.toml)")
    rng = np.random.default_rng(seed)
    world = World(gui=gui, objects=spec.shapes())
    try:
        _generate(spec, world, rng, seed)
    except BaseException:
        world.close()
        raise
    out = Task(spec.name, seed, world, {o: list(e) for o, e in spec.prior.items()}, spec.goal)
    out.spec = spec
    out.latent = world.true_state()
    return out


def _generate(spec: TaskSpec, world: World, rng: np.random.Generator, seed: int) -> None:
    """The latent state of ``spec`` drawn from ``rng`` (the order: the module doc)."""
    for obj in world.objects:
        world.remove_object(obj)
    for d in DRAWERS:
        world.set_drawer(d, 0.0)
    base = np.asarray(PARK_BASE) + rng.uniform(-0.1, 0.1, size=3) * (1.0, 1.0, 0.5)
    world.set_base(tuple(float(v) for v in base))
    world.set_arm(ARM_TUCK)
    for d, q in spec.drawers.items():
        world.set_drawer(d, q)
    hiders = () if spec.hide is None else spec.hide[1]
    moved = {f[1] for f in spec.goal if f[0] in ("On", "Cooked")}  # objects the goal moves
    objects = {o.name: o for o in spec.objects}

    def place(name: str) -> None:
        on = objects[name].on
        surface = on[0] if len(on) == 1 else on[int(rng.integers(len(on)))]
        try:
            _place_random(world, rng, name, surface, moved=name in moved)
        except RuntimeError:
            raise spec.error(
                f"objects.{name}",
                f"with seed {seed}, {name} cannot be placed on {surface} without collision",
            ) from None

    for _ in range(HIDE_ATTEMPTS if spec.hide else 1):
        for o in spec.objects:
            world.remove_object(o.name)
        for o in spec.objects:
            if o.name not in hiders:
                place(o.name)
        if spec.hide is None:
            return
        target = spec.hide[0]
        first = hiders[int(rng.integers(len(hiders)))]
        if _place_occluder(world, rng, first, target):
            for other in hiders:
                if other != first:
                    place(other)
            # (``hide.reachable``) Placed where no base reaches it, or boxed in by the others
            # placed after it, the box in front hides the block for good: the family's N = 4,
            # K = 2, seed 9 (the cracker box in the way of the sugar box's grasps; without it,
            # one is reached) proved every optimistic problem unsolvable up to level 12.
            # The target, when the goal moves it, must then be reachable with that box out of
            # the way: N = 4, K = 2, seed 0 had the block between the cracker box in front
            # and the sugar box behind it, no grasp of the block reached with the cracker box
            # gone and none of the sugar box (its episode used its 600 s, "proved
            # unsolvable").
            if not spec.hide_reachable or _clear_to_reach(world, first, target, target in moved):
                return
    raise spec.error(
        "hide", f"with seed {seed}, none of {', '.join(hiders)} could hide {spec.hide[0]}"
    )
