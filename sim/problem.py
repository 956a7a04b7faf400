"""The initial PDDLStream problem of a kitchen task (``domains/pddl/kitchen``).

:func:`task_problem` builds the problem's syntax tree and the Python values of its objects
from what the robot knows: the world's fixed geometry, its own configuration, the drawers'
openings, the prior beliefs (uniform over the prior surfaces, with the prior's weights) and
the goal — never from the latent poses of the objects.

Conventions shared with ``streams/kitchen_module.py``:

* beliefs are in the *canonical frame*: the world frame with every drawer fully open.  A
  belief over a drawer is therefore fixed relative to the drawer and moves with it; pull and
  push leave ``AtPoseB`` unchanged;
* a drawer has two angles, ``<drawer>-closed`` (0) and ``<drawer>-open`` (``DRAWER_TRAVEL``),
  valued ``(drawer, q)``;
* the arm's stowed configurations are ``aq-tuck`` (hand empty) and ``aq-carry`` (holding).
"""

from __future__ import annotations

import numpy as np

from ssr_compile import syntax as S
from ssr_compile.belief.particles import PoseBelief, Surface

from .robot import ARM_CARRY, ARM_TUCK
from .tasks import Task
from .world import DRAWER_TRAVEL, DRAWERS, PLACE_GAP, World

DOMAIN = "kitchen"
PARTICLES_PER_SURFACE = 100
FIXED = ("counter", "stove")
TALL = ("sugar_box", "cracker_box")  # taller than a drawer's clearance: counter only
ABOVE = (("top_drawer", "bottom_drawer"),)  # an open top drawer hides the bottom one


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
    world: World, obj: str, entries: list[tuple[str, float]], rng: np.random.Generator
) -> PoseBelief:
    """Uniform over each prior surface (canonical frame), each surface with its prior weight."""
    hz = world.half_extents[obj][2] + PLACE_GAP
    surfaces, labels, poses, weights = [], [], [], []
    for k, (name, w) in enumerate(entries):
        s = canonical_surface(world, name)
        surfaces.append(s)
        n = PARTICLES_PER_SURFACE
        xy = s.sample_xy(rng, n)
        for x, y in xy:
            poses.append((x, y, s.z + hz, rng.uniform(-np.pi, np.pi)))
            labels.append(k)
            weights.append(w / n)
    return PoseBelief(obj, surfaces, labels, np.array(poses), np.array(weights), hz)


def _atom(pred: str, *args: str) -> S.Atom:
    return S.Atom(pred, tuple(S.Const(a) for a in args))


def task_problem(task: Task, *, seed: int | None = None) -> tuple[S.Problem, dict]:
    """The initial problem of ``task`` and the values of its objects (see the module doc)."""
    w = task.world
    rng = np.random.default_rng(task.seed if seed is None else seed)
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
    for d in DRAWERS:
        closed = obj(angle_name(d, False), (d, 0.0))
        opened = obj(angle_name(d, True), (d, DRAWER_TRAVEL))
        init += [_atom("angle", d, closed), _atom("angle", d, opened)]
        init += [_atom("closed", d, closed), _atom("open", d, opened)]
        now = opened if w.drawer_q[d] > DRAWER_TRAVEL / 2 else closed
        init.append(_atom("atangle", d, now))
    for d1, d2 in ABOVE:
        init.append(_atom("above", d1, d2))

    # the robot
    tuck = obj("aq-tuck", tuple(ARM_TUCK))
    carry = obj("aq-carry", tuple(ARM_CARRY))
    init += [_atom("conf", "arm", tuck), _atom("stow", tuck), _atom("stowempty", tuck)]
    init += [_atom("conf", "arm", carry), _atom("stow", carry), _atom("stowheld", carry)]
    base = obj("bq0", tuple(float(v) for v in w.robot.get_base()))
    init += [_atom("conf", "base", base), _atom("atconf", "base", base)]
    arm = tuple(float(v) for v in w.robot.get_arm())
    if np.max(np.abs(np.subtract(arm, ARM_TUCK))) < 1e-6:
        init.append(_atom("atconf", "arm", tuck))
    else:
        q0 = obj("aq0", arm)
        init += [_atom("conf", "arm", q0), _atom("atconf", "arm", q0)]
    init.append(_atom("handempty"))

    # the objects and their prior beliefs
    for o, entries in sorted(task.prior.items()):
        obj(o)
        init.append(_atom("graspable", o))
        if o in TALL:
            init.append(_atom("tall", o))
        for s in surfaces:
            if o not in TALL or s == "counter":
                init.append(_atom("placeable", o, s))
        pb = obj(belief_name(o), prior_belief(w, o, entries, rng))
        init += [_atom("poseb", o, pb), _atom("atposeb", o, pb)]
        init += [_atom("possible", o, pb, s) for s, _ in entries]
        if len(entries) == 1:  # certainly on that surface, though not localized on it
            init.append(_atom("beliefon", o, pb, entries[0][0]))
    init.append(S.InitValue(S.FuncTerm("total-cost"), S.Num(0)))

    goal = []
    for head, *args in task.goal:
        if head == "On":
            goal.append(_atom("on", *args))
        elif head == "Closed":
            goal.append(_atom("atangle", args[0], angle_name(args[0], False)))
        elif head == "Cooked":
            goal.append(_atom("cooked", args[0]))
        else:
            raise ValueError(f"unknown goal fact {head!r}")
    problem = S.Problem(
        f"kitchen-{task.name}-{task.seed}",
        DOMAIN,
        objects=tuple(S.Typed(o) for o in objects),
        init=tuple(init),
        goal=goal[0] if len(goal) == 1 else S.And(tuple(goal)),
        metric=S.Metric("minimize", S.FuncTerm("total-cost")),
    )
    return problem, values
