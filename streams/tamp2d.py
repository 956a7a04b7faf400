"""Streams of the 2-D pick-and-place domains ``domains/pddl/tamp2d`` and ``tamp2d-routes``.

The world is a table line (y = 0) with rectangular blocks standing on it and a gripper moving
in the plane above (paper §IV: continuous values come from streams).  Values are plain,
hashable tuples — named tuples, so that a pose and a grasp with the same number never share
a name in the solver's value table (it names equal values alike, keyed by type name):

* :class:`Block` ``(name, width, height)``: a block; at a pose it occupies the interval
  ``[x - width/2, x + width/2]`` of the table, up to ``height``;
* :class:`Region` ``(lo, hi)``: an interval of the table;
* :class:`Pose` ``(x,)``: the x centre of a block on the table;
* :class:`Grasp` ``(dy,)``: a top grasp, the gripper ``dy`` above the block's top;
* :class:`Conf` ``(x, y)``: the gripper's position;
* :class:`Traj` ``(path,)``: waypoints (confs) up to :data:`SAFE_HEIGHT`, across and down.

The configuration of a grasp is the gripper :data:`CLEARANCE` above where it holds the block:
``pick`` and ``place`` include the vertical stroke down and back, so a held block's bottom is
at least :data:`CLEARANCE` above the table whenever the gripper moves, higher than every
block (CLEARANCE > 2 max height + max grasp - min height - min grasp).  Motions thus never
hit a block, whatever they carry; ``place``'s ``(not (Unsafe ...))`` guards the stroke down.

Streams (``STREAMS``; kinds and costs in ``STREAM_INFO``):

* ``sample-placement`` — generator, endless and lazy, seeded from its inputs: uniform poses of
  a block inside a region.  It knows nothing of the other blocks, so it sometimes yields a
  pose overlapping one; ``test-cfree`` then fails and the solver must sample again or move the
  other block (``problem-blocked.pddl`` exercises both: b0 fits in the goal region only where
  b1 already stands, and b1's placements on the table may hit b0).
* ``sample-grasp`` — generator, finite, **fails at first**: its first draw yields nothing
  (``None``), the next ones the grasps of :data:`GRASPS`; a solver must come back to it.
* ``ik`` — function: the one gripper configuration for a block, pose and grasp; ``None`` when
  it is out of the gripper's reach :data:`REACH`.
* ``motion`` — function, **deferrable** (expensive, almost always succeeds: paper §VII).
* ``test-cfree`` — test: two blocks at two poses do not overlap.
* ``distance`` — cost function: the length of the motion between two configurations.

``VALUES`` names the values of the problems' objects: blocks (``b0``, ``b1``), their initial
poses (``p0``, ``p1``), regions (``rtable``, ``rgoal``, ``rnear``, ``rfar``) and the initial
gripper configuration (``q0``).  Poses and configurations are named in the problem files by
such objects; one dict covers every problem of both folders (names a problem does not use are
ignored).  :func:`check_plan` validates a plan on the geometric state, independently of PDDL.
"""

from __future__ import annotations

import functools
import math
import sys
import zlib
from collections.abc import Callable, Iterator, Mapping, Sequence
from typing import Any, NamedTuple

import numpy as np
import numpy.random  # noqa: F401 - numpy loads it lazily, at the first sample otherwise

from ssr_compile import syntax as S
from ssr_compile.stream import StreamInfo, StreamsModule


class Block(NamedTuple):
    name: str
    width: float
    height: float


class Region(NamedTuple):
    lo: float
    hi: float


class Pose(NamedTuple):
    x: float


class Grasp(NamedTuple):
    dy: float


class Conf(NamedTuple):
    x: float
    y: float


class Traj(NamedTuple):
    path: tuple[Conf, ...]


SAFE_HEIGHT = 4.0  # the gripper travels across at this height, above every block
REACH = (-6.0, 14.0)  # the gripper's reachable x interval
GRASPS = (0.2, 0.4)  # vertical offsets above a block's top
CLEARANCE = 1.6  # the stroke of pick and place (see the module docstring)
TOL = 1e-6

VALUES: dict[str, Any] = {
    "b0": Block("b0", 1.0, 1.0),
    "b1": Block("b1", 1.0, 0.8),
    "p0": Pose(0.0),  # b0 on the table
    "p1": Pose(4.7),  # b1 in the middle of rgoal (problem-blocked.pddl)
    "q0": Conf(-2.0, 3.0),
    "rtable": Region(-5.0, 2.5),
    "rgoal": Region(4.0, 5.4),  # room for one block of width 1 only
    "rnear": Region(2.8, 4.3),  # tamp2d-routes: the cheap goal region
    "rfar": Region(11.0, 12.5),  # tamp2d-routes: the dear one
}


# ---------------------------------------------------------------- streams


def _rng(seed: int, *inputs: Any) -> np.random.Generator:
    """A generator seeded from ``seed`` and the inputs' text (stable across runs)."""
    return np.random.default_rng([int(seed), zlib.crc32(repr(inputs).encode())])


def sample_placement(block: Block, region: Region, *, seed: int = 0) -> Iterator[tuple[Pose]]:
    """Endless uniform poses of ``block`` inside ``region`` (nothing if it does not fit);
    ``seed`` is the base seed of the sampler (:func:`make_module` binds it)."""
    lo, hi = region.lo + block.width / 2, region.hi - block.width / 2
    if lo > hi + TOL:
        return
    rng = _rng(seed, block, region)
    while True:
        x = round(float(rng.uniform(lo, hi)), 3)
        yield (Pose(min(max(x, lo), hi)),)


def sample_grasp(block: Block) -> Iterator[tuple[Grasp] | None]:
    """The top grasps of a block; the first draw fails (a stream that succeeds only later)."""
    yield None
    for dy in GRASPS:
        yield (Grasp(dy),)


def kinematics(block: Block, pose: Pose, grasp: Grasp) -> Conf:
    """Where the gripper waits above ``block`` at ``pose`` before (after) the stroke down."""
    return Conf(pose.x, round(block.height + grasp.dy + CLEARANCE, 6))


def ik(block: Block, pose: Pose, grasp: Grasp) -> tuple[Conf] | None:
    """The gripper configuration holding ``block`` at ``pose``; None when out of reach."""
    q = kinematics(block, pose, grasp)
    if not REACH[0] <= q.x <= REACH[1]:
        return None
    return (q,)


def motion(q1: Conf, q2: Conf) -> tuple[Traj] | None:
    """Up to the safe height, across, and down: collision-free above any block."""
    if not all(REACH[0] <= q.x <= REACH[1] for q in (q1, q2)):
        return None
    path = (q1, Conf(q1.x, SAFE_HEIGHT), Conf(q2.x, SAFE_HEIGHT), q2)
    return (Traj(path),)


def test_cfree(block: Block, pose: Pose, block2: Block, pose2: Pose) -> bool:
    """The two blocks' intervals do not overlap (touching is fine; a block never hits itself)."""
    if block.name == block2.name:
        return True
    return abs(pose.x - pose2.x) >= (block.width + block2.width) / 2 - TOL


def distance(q1: Conf, q2: Conf) -> float:
    """The length of :func:`motion`'s path (at least 2 (SAFE_HEIGHT - y) > 1 for every conf)."""
    return round((SAFE_HEIGHT - q1.y) + abs(q2.x - q1.x) + (SAFE_HEIGHT - q2.y), 6)


STREAMS: dict[str, Callable] = {
    "sample-placement": sample_placement,
    "sample-grasp": sample_grasp,
    "ik": ik,
    "motion": motion,
    "test-cfree": test_cfree,
    "distance": distance,
}

STREAM_INFO: dict[str, StreamInfo] = {
    "sample-placement": StreamInfo(p_success=0.8, cost=1),
    "sample-grasp": StreamInfo(p_success=0.5, cost=1),
    "ik": StreamInfo(kind="function", p_success=0.95, cost=1, redraw_inputs=True),
    "motion": StreamInfo(deferrable=True, kind="function", p_success=0.99, cost=10),
    "test-cfree": StreamInfo(kind="test", p_success=0.7, cost=0.1),
    # A lower bound of every real distance (the gripper climbs to SAFE_HEIGHT and back).
    "distance": StreamInfo(optimistic_value=1.0, cost=0.1),
}


def make_module(seed: int = 0, problem: str | None = None) -> StreamsModule:
    """The streams with their samplers seeded by ``seed`` (``ssr-compile solve --seed N``).
    Every problem of the example uses the objects of :data:`VALUES`, so ``problem`` (the
    problem file's path) changes nothing."""
    streams = dict(STREAMS)
    streams["sample-placement"] = functools.partial(sample_placement, seed=seed)
    return StreamsModule(__name__, streams, dict(STREAM_INFO), dict(VALUES), sys.modules[__name__])


# ---------------------------------------------------------------- plan checking


class PlanError(AssertionError):
    """A plan is not valid in the geometric world (the message says which step and why)."""


def _close(a: float, b: float) -> bool:
    return abs(a - b) <= 1e-6


def _same_conf(q1: Conf, q2: Conf) -> bool:
    return _close(q1.x, q2.x) and _close(q1.y, q2.y)


def _overlap(a: tuple[float, float, float, float], b: tuple[float, float, float, float]) -> bool:
    """Do two rectangles (x0, x1, y0, y1) overlap with positive area?"""
    return min(a[1], b[1]) - max(a[0], b[0]) > TOL and min(a[3], b[3]) - max(a[2], b[2]) > TOL


def _rect(block: Block, x: float, bottom: float = 0.0) -> tuple[float, float, float, float]:
    return (x - block.width / 2, x + block.width / 2, bottom, bottom + block.height)


def check_plan(
    domain: S.Domain,
    problem: S.Problem,
    values: Mapping[str, Any] | Callable[[str], Any] | None,
    plan: Sequence[tuple[str, Sequence[Any]]],
    *,
    allow_deferred: bool = True,
) -> float:
    """Simulate ``plan`` on the geometric state and return its cost; raise :class:`PlanError`.

    ``plan`` is a sequence of ``(action, args)``; an argument is an object name (looked up in
    ``values`` — a mapping or a ``name -> value`` callable such as a solver's value table —
    then in :data:`VALUES`) or a value itself.  Independent of the PDDL semantics: it tracks
    the blocks' positions and the gripper, checks that the gripper is where each action needs
    it, that kinematics hold, that placements lie on the table without overlap, that motions
    start and end right and hit no block (a trajectory still optimistic — deferred — is
    replaced by :func:`motion` when ``allow_deferred``), and that the goal holds at the end.
    The cost is the sum of :func:`distance` over moves plus 1 per pick and place.
    """
    lookup = values if callable(values) else (values or {}).get

    def val(x: Any, kind: type | None = None, where: str = "") -> Any:
        v = x
        if isinstance(x, str):
            v = lookup(x)
            if v is None or v == x:
                v = VALUES.get(x, x)
        if kind is not None and not isinstance(v, kind):
            raise PlanError(f"{where}: {x!r} is not a {kind.__name__} (its value is {v!r})")
        return v

    placed: dict[str, tuple[Block, float]] = {}
    gripper: Conf | None = None
    held: tuple[Block, Grasp] | None = None
    for fact in problem.init:
        if not isinstance(fact, S.Atom):
            continue
        args = [a.name for a in fact.args]
        if fact.pred == "atpose":
            block = val(args[0], Block, "init")
            placed[block.name] = (block, val(args[1], Pose, "init").x)
        elif fact.pred == "atconf":
            gripper = val(args[0], Conf, "init")
        elif fact.pred == "atgrasp":
            held = (val(args[0], Block, "init"), val(args[1], Grasp, "init"))
    if gripper is None:
        raise PlanError("the problem gives no initial gripper configuration (AtConf)")

    schemas = {a.name: a for a in domain.actions}
    cost = 0.0
    for i, (name, args) in enumerate(plan, start=1):
        where = f"step {i} ({name} {' '.join(str(a) for a in args)})"
        if name not in schemas or len(schemas[name].parameters) != len(args):
            raise PlanError(f"{where}: not an action of domain {domain.name}")
        if name == "move":
            q1, q2 = val(args[0], Conf, where), val(args[2], Conf, where)
            if not _same_conf(gripper, q1):
                raise PlanError(f"{where}: the gripper is at {gripper}, not at {q1}")
            traj = val(args[1], None, where)
            if not isinstance(traj, Traj):
                if not allow_deferred:
                    raise PlanError(f"{where}: trajectory {args[1]!r} has no value")
                made = motion(q1, q2)
                if made is None:
                    raise PlanError(f"{where}: no motion from {q1} to {q2}")
                traj = made[0]
            _check_path(traj, q1, q2, placed, held, where)
            gripper = q2
            cost += distance(q1, q2)
        elif name in ("pick", "place"):
            block = val(args[0], Block, where)
            pose = val(args[1], Pose, where)
            grasp = val(args[2], Grasp, where)
            q = val(args[3], Conf, where)
            if not _same_conf(gripper, q):
                raise PlanError(f"{where}: the gripper is at {gripper}, not at {q}")
            if not _same_conf(q, kinematics(block, pose, grasp)):
                raise PlanError(f"{where}: {q} does not hold {block.name} at {pose} with {grasp}")
            if name == "pick":
                if held is not None:
                    raise PlanError(f"{where}: the gripper already holds {held[0].name}")
                if block.name not in placed or not _close(placed[block.name][1], pose.x):
                    raise PlanError(f"{where}: {block.name} is not at {pose}")
                del placed[block.name]
                held = (block, grasp)
            else:
                if held is None or held[0].name != block.name or not _close(held[1].dy, grasp.dy):
                    raise PlanError(f"{where}: the gripper does not hold {block.name} with {grasp}")
                for other, x in placed.values():
                    if not test_cfree(block, pose, other, Pose(x)):
                        raise PlanError(f"{where}: {block.name} at {pose} overlaps {other.name}")
                placed[block.name] = (block, pose.x)
                held = None
            cost += 1
        else:
            raise PlanError(f"{where}: unknown action")

    def holds(f) -> bool:
        if isinstance(f, S.And):
            return all(holds(x) for x in f.args)
        if isinstance(f, S.Or):
            return any(holds(x) for x in f.args)
        if isinstance(f, S.Not):
            return not holds(f.arg)
        if isinstance(f, S.Atom):
            args = [a.name for a in f.args]
            if f.pred == "in":
                block, region = val(args[0], Block, "goal"), val(args[1], Region, "goal")
                if block.name not in placed:
                    return False
                x = placed[block.name][1]
                return (
                    x - block.width / 2 >= region.lo - TOL
                    and x + block.width / 2 <= region.hi + TOL
                )
            if f.pred == "atpose":
                block = val(args[0], Block, "goal")
                return block.name in placed and _close(placed[block.name][1], val(args[1]).x)
            if f.pred == "handempty":
                return held is None
            if f.pred == "atconf":
                return _same_conf(gripper, val(args[0], Conf, "goal"))
        raise PlanError(f"the goal's {f} cannot be checked geometrically")

    if problem.goal is not None and not holds(problem.goal):
        raise PlanError("the goal does not hold at the end of the plan")
    return cost


def _check_path(
    traj: Traj,
    q1: Conf,
    q2: Conf,
    placed: Mapping[str, tuple[Block, float]],
    held: tuple[Block, Grasp] | None,
    where: str,
) -> None:
    path = traj.path
    if not path or not _same_conf(path[0], q1) or not _same_conf(path[-1], q2):
        raise PlanError(f"{where}: the trajectory does not lead from {q1} to {q2}")
    obstacles = [_rect(b, x) for b, x in placed.values()]
    for a, b in zip(path, path[1:]):
        steps = max(2, math.ceil(math.dist(a, b) / 0.05) + 1)
        for t in np.linspace(0.0, 1.0, steps):
            x, y = a.x + t * (b.x - a.x), a.y + t * (b.y - a.y)
            if not REACH[0] - TOL <= x <= REACH[1] + TOL:
                raise PlanError(f"{where}: the path leaves the reach at x={x:.3f}")
            point = (x, x, y, y)
            shapes = [(x - 0.01, x + 0.01, y - 0.01, y + 0.01)]  # the gripper itself
            if held is not None:
                block, grasp = held
                bottom = y - grasp.dy - block.height
                if bottom < -TOL:
                    raise PlanError(f"{where}: {block.name} goes through the table")
                shapes.append(_rect(block, x, bottom))
            if point[2] < -TOL:
                raise PlanError(f"{where}: the gripper goes through the table")
            for shape in shapes:
                for obstacle in obstacles:
                    if _overlap(shape, obstacle):
                        raise PlanError(f"{where}: the path hits a block at ({x:.3f}, {y:.3f})")
