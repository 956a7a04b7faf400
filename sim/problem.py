"""The PDDLStream problem of a kitchen task (``domains/pddl/kitchen``) in any reached state.

:func:`state_problem` builds the problem's syntax tree and the Python values of its objects
from what the robot knows (a :class:`KnownState`): the world's fixed geometry, its own
configuration (an arm that is not stowed included), the drawers' openings, what it holds and
with which grasp, the stove, what is cooked, and its current pose beliefs (``localized``,
``beliefon`` and ``possible`` read off each belief) -- never from the latent poses of the
objects.  :func:`task_problem` is the initial problem: the prior beliefs (uniform over the
prior surfaces, with the prior's weights).  Facts kept from the last plan (Algorithm 1's
``ConstantFacts``) are added by the caller (``extra``).

Conventions shared with ``streams/kitchen_module.py``:

* beliefs are in the *canonical frame*: the world frame with every drawer fully open.  A
  belief over a drawer is therefore fixed relative to the drawer and moves with it; pull and
  push leave ``AtPoseB`` unchanged;
* a drawer has two angles, ``<drawer>-closed`` (0) and ``<drawer>-open`` (``DRAWER_TRAVEL``),
  valued ``(drawer, q)``;
* the arm's stowed configurations are ``aq-tuck`` (hand empty) and ``aq-carry`` (holding);
  any other arm configuration is ``aq0`` with ``(reach bq0 aq0)``, so the arm motion stream can
  bring it back to a stowed one;
* :func:`to_world` / :func:`to_canonical` move a belief between the canonical frame and the
  world frame at the drawers' current openings (visibility and real observations need the
  world frame).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ssr_compile import syntax as S
from ssr_compile.belief.particles import PoseBelief, Surface

from .robot import ARM_CARRY, ARM_TUCK, mount_position, within_reach
from .tasks import Task
from .world import DRAWER_TRAVEL, DRAWERS, PLACE_GAP, World

DOMAIN = "kitchen"
PARTICLES_PER_SURFACE = 100
FIXED = ("counter", "stove")
ABOVE = (("top_drawer", "bottom_drawer"),)  # an open top drawer hides the bottom one
LOCALIZED_STD = 0.02  # a belief is localized: x, y spread at most 2 cm ...
ON_PROB = 0.95  # ... with at least this mass on one surface
POSSIBLE_PROB = 1e-3  # a surface with at least this mass may hold the object (sample-obs)


def angle_name(drawer: str, is_open: bool) -> str:
    return f"{drawer}-{'open' if is_open else 'closed'}"


def belief_name(obj: str) -> str:
    return f"pb-{obj}"


def canonical_surface(world: World, surface: str) -> Surface:
    """A world surface as a belief-layer rectangle, drawers fully open."""
    with world.saved():
        for d in DRAWERS:
            world.set_drawer(d, DRAWER_TRAVEL)
        lo, hi, z = world.surface_world_rect(surface)
    return Surface(surface, tuple((lo + hi) / 2), tuple((hi - lo) / 2), z)


def prior_belief(
    world: World,
    obj: str,
    entries: list[tuple[str, float]],
    rng: np.random.Generator,
    *,
    n: int = PARTICLES_PER_SURFACE,
    canonical: dict[str, Surface] | None = None,
) -> PoseBelief:
    """Uniform over each prior surface (canonical frame), each surface with its prior weight;
    ``n`` particles per surface.  ``canonical``: the surfaces already made canonical (else
    :func:`canonical_surface` makes them, which restores the world's saved state: objects
    placed outside its bookkeeping leave the scene)."""
    hz = world.half_extents[obj][2] + PLACE_GAP
    surfaces, labels, poses, weights = [], [], [], []
    for k, (name, w) in enumerate(entries):
        s = canonical_surface(world, name) if canonical is None else canonical[name]
        surfaces.append(s)
        xy = s.sample_xy(rng, n)
        for x, y in xy:
            poses.append((x, y, s.z + hz, rng.uniform(-np.pi, np.pi)))
            labels.append(k)
            weights.append(w / n)
    return PoseBelief(obj, surfaces, labels, np.array(poses), np.array(weights), hz)


def is_localized(pb: PoseBelief, surface: str | None = None) -> bool:
    """``pb`` puts at least :data:`ON_PROB` on one surface (``surface`` if given) with an x, y
    spread of at most :data:`LOCALIZED_STD` there: precise enough to grasp from."""
    probs = pb.surface_probs()
    s = pb.most_likely_surface() if surface is None else surface
    if probs.get(s, 0.0) < ON_PROB:
        return False
    return float(pb.std(s)[:2].max()) <= LOCALIZED_STD + 1e-12


def drawer_shift(surface: str, drawers: dict[str, float]) -> float:
    """World x minus canonical x of a point on ``surface`` (drawers slide along -x)."""
    if surface not in DRAWERS:
        return 0.0
    return DRAWER_TRAVEL - float(drawers[surface])


def _shifted(pb: PoseBelief, drawers: dict[str, float], sign: float) -> PoseBelief:
    shifts = np.array([sign * drawer_shift(s.name, drawers) for s in pb.surfaces])
    if not np.any(shifts):
        return pb
    surfaces = [
        Surface(s.name, (s.center[0] + dx, s.center[1]), s.half_extents, s.z)
        for s, dx in zip(pb.surfaces, shifts, strict=True)
    ]
    poses = np.array(pb.poses)
    poses[:, 0] += shifts[pb.labels]
    return PoseBelief(pb.obj, surfaces, pb.labels, poses, pb.weights, pb.z_offset)


def to_world(pb: PoseBelief, drawers: dict[str, float]) -> PoseBelief:
    """A canonical-frame belief in the world frame at the drawers' openings ``drawers``:
    particles in a drawer move with it."""
    return _shifted(pb, drawers, 1.0)


def to_canonical(pb: PoseBelief, drawers: dict[str, float]) -> PoseBelief:
    """Inverse of :func:`to_world`."""
    return _shifted(pb, drawers, -1.0)


@dataclass
class KnownState:
    """What the robot knows for certain, and its beliefs (the input of :func:`state_problem`).

    ``held``: ``(object, grasp value)`` or ``None`` (``held_name``: the name the plan that
    picked it gave the grasp, kept so that a replan constrained to the plan's tail still
    matches it; else ``g-<object>``); ``beliefs``: canonical-frame pose beliefs
    of the objects that are not held; ``cooked``: objects known to be cooked."""

    base: tuple[float, ...]
    arm: tuple[float, ...]
    drawers: dict[str, float]
    beliefs: dict[str, PoseBelief]
    held: tuple[str, Any] | None = None
    held_name: str | None = None
    stove_on: bool = False
    cooked: set[str] = field(default_factory=set)
    beliefon: dict[str, str] = field(default_factory=dict)  # prior: certainly on that surface


def _atom(pred: str, *args: str) -> S.Atom:
    return S.Atom(pred, tuple(S.Const(a) for a in args))


def _same(a, b, tol: float = 1e-6) -> bool:
    return len(a) == len(b) and float(np.max(np.abs(np.subtract(a, b)))) < tol


def goal_formula(goal) -> S.Formula:
    """A task's goal (``sim.tasks``) as a PDDL formula of the kitchen domain."""
    out: list = []
    for head, *args in goal:
        if head == "On":
            out.append(_atom("on", *args))
        elif head == "Closed":
            out.append(_atom("atangle", args[0], angle_name(args[0], False)))
        elif head == "Cooked":
            out.append(_atom("cooked", args[0]))
        elif head == "StoveOff":
            out.append(S.Not(_atom("stoveon")))
        else:
            raise ValueError(f"unknown goal fact {head!r}")
    return out[0] if len(out) == 1 else S.And(tuple(out))


def near_targets(world: World, base) -> list[str]:
    """The surfaces, drawers and the stove the arm may act on with the base at ``base`` (the
    ``near`` facts of the reached base configuration): some point of a surface's rectangle
    (drawers open), a drawer's handle (open or closed) or the stove's button within the arm's
    reach.  A cheap superset: the streams acting from where the robot is (``*-here``,
    ``*-from``) are only instantiated for these, not for every belief of every object."""
    mount = mount_position(base)
    out = []
    with world.saved():
        for d in DRAWERS:
            world.set_drawer(d, DRAWER_TRAVEL)
        for s in (*FIXED, *DRAWERS):
            lo, hi, z = world.surface_world_rect(s)
            closest = (*np.clip(mount[:2], lo, hi), z)
            if within_reach(base, closest):
                out.append(s)
        for d in DRAWERS:
            handles = []
            for q in (0.0, DRAWER_TRAVEL):
                world.set_drawer(d, q)
                handles.append(world.handle_pose(d))
            if d not in out and any(within_reach(base, h) for h in handles):
                out.append(d)
    if "stove" not in out and within_reach(base, world.button_pose()[0]):
        out.append("stove")
    return sorted(out)


def state_problem(
    task: Task, known: KnownState, *, name: str | None = None, extra: tuple = ()
) -> tuple[S.Problem, dict]:
    """The problem of ``task`` from the reached state ``known`` and the values of its objects
    (see the module doc); ``extra``: facts kept from the last plan."""
    values: dict = {}
    init: list = []
    objects: list[str] = []

    def obj(name: str, value=None) -> str:
        if name not in objects and name not in ("base", "arm", "stove"):
            objects.append(name)
        if value is not None:
            values[name] = value
        return name

    surfaces = ["counter", "stove", *DRAWERS]
    for s in surfaces:
        obj(s)
        init.append(_atom("surface", s))
        init.append(_atom("fixed", s) if s in FIXED else _atom("drawer", s))
    init.append(_atom("hasbutton", "stove"))
    for d in DRAWERS:
        closed = obj(angle_name(d, False), (d, 0.0))
        opened = obj(angle_name(d, True), (d, DRAWER_TRAVEL))
        init += [_atom("angle", d, closed), _atom("angle", d, opened)]
        init += [_atom("closed", d, closed), _atom("open", d, opened)]
        now = opened if known.drawers[d] > DRAWER_TRAVEL / 2 else closed
        init.append(_atom("atangle", d, now))
    for d1, d2 in ABOVE:
        init.append(_atom("above", d1, d2))

    # the robot
    tuck = obj("aq-tuck", tuple(ARM_TUCK))
    carry = obj("aq-carry", tuple(ARM_CARRY))
    init += [_atom("conf", "arm", tuck), _atom("stow", tuck), _atom("stowempty", tuck)]
    init += [_atom("conf", "arm", carry), _atom("stow", carry), _atom("stowheld", carry)]
    base = obj("bq0", tuple(float(v) for v in known.base))
    init += [_atom("conf", "base", base), _atom("atconf", "base", base), _atom("reached", base)]
    init += [_atom("near", base, x) for x in near_targets(task.world, known.base)]
    arm = tuple(float(v) for v in known.arm)
    if _same(arm, ARM_TUCK):
        init.append(_atom("atconf", "arm", tuck))
    elif _same(arm, ARM_CARRY):
        init.append(_atom("atconf", "arm", carry))
    else:
        q0 = obj("aq0", arm)
        init += [_atom("conf", "arm", q0), _atom("atconf", "arm", q0), _atom("reach", base, q0)]
        init.append(_atom("reached", q0))
    if known.held is None:
        init.append(_atom("handempty"))
    if known.stove_on:
        init.append(_atom("stoveon"))

    # the objects and their beliefs
    for o in sorted(set(task.prior) | set(known.beliefs)):
        obj(o)
        init.append(_atom("graspable", o))
        tall = task.world.is_tall(o)  # taller than a drawer's clearance: counter only
        if tall:
            init.append(_atom("tall", o))
        for s in surfaces:
            if not tall or s == "counter":
                init.append(_atom("placeable", o, s))
        if o in known.cooked:
            init.append(_atom("cooked", o))
        if known.held is not None and known.held[0] == o:
            g = obj(known.held_name or f"g-{o}", known.held[1])
            init += [_atom("grasp", o, g), _atom("atgrasp", o, g)]
            continue
        belief = known.beliefs[o]
        pb = obj(belief_name(o), belief)
        init += [_atom("poseb", o, pb), _atom("atposeb", o, pb), _atom("current", o, pb)]
        probs = belief.surface_probs()
        if is_localized(belief):  # (no detecting it again: observing a localized object
            # again gains nothing a plan needs, and its observations, posteriors and
            # visibility tests would multiply the optimistic problem of every replan)
            s = belief.most_likely_surface()
            init += [
                _atom("localized", o, pb),
                _atom("anybase", o, pb),
                _atom("beliefon", o, pb, s),
            ]
            continue
        init += [
            _atom("possible", o, pb, s)
            for s in (x.name for x in belief.surfaces)
            if probs.get(s, 0.0) >= POSSIBLE_PROB
        ]
        sure = known.beliefon.get(o)
        if sure is None:
            sure = next((s for s, p in probs.items() if p >= ON_PROB), None)
        if sure is not None:  # certainly on that surface, though not localized on it
            init.append(_atom("beliefon", o, pb, sure))
    init.extend(f for f in extra if f not in init)
    init.append(S.InitValue(S.FuncTerm("total-cost"), S.Num(0)))

    problem = S.Problem(
        name or f"kitchen-{task.name}-{task.seed}",
        DOMAIN,
        objects=tuple(S.Typed(o) for o in objects),
        init=tuple(init),
        goal=goal_formula(task.goal),
        metric=S.Metric("minimize", S.FuncTerm("total-cost")),
    )
    return problem, values


def initial_state(task: Task, *, seed: int | None = None, world: World | None = None) -> KnownState:
    """What the robot knows before acting: its configuration, the drawers and the prior."""
    w = task.world if world is None else world
    rng = np.random.default_rng(task.seed if seed is None else seed)
    beliefs = {o: prior_belief(w, o, entries, rng) for o, entries in sorted(task.prior.items())}
    return KnownState(
        base=tuple(float(v) for v in w.robot.get_base()),
        arm=tuple(float(v) for v in w.robot.get_arm()),
        drawers=dict(w.drawer_q),
        beliefs=beliefs,
        beliefon={o: e[0][0] for o, e in task.prior.items() if len(e) == 1},
    )


def task_problem(task: Task, *, seed: int | None = None) -> tuple[S.Problem, dict]:
    """The initial problem of ``task`` and the values of its objects (see the module doc)."""
    return state_problem(task, initial_state(task, seed=seed))
