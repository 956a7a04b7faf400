"""The kitchen in closed loop (paper §III, §VI, §VIII, appendix; issue 11).

:func:`make_episode` builds an :class:`ssr_compile.policy.Episode` for one of the paper's tasks:

* :class:`KitchenEnvironment` is the PyBullet *true* world (``sim.tasks.make_task``): it executes
  a plan step (base motions land with Gaussian noise; grasps, placements and drawer motions are
  checked in the true world -- a failed execution is an observation, never an exception) and
  then looks through the fixed camera (false negatives, Gaussian pose noise).  Its observation
  is a :class:`KitchenObservation`: what the robot senses of itself (configuration, drawer
  openings, the stove, what the gripper holds) and the camera's detections.
* :class:`KitchenAgent` keeps the robot's particle beliefs (canonical frame, see
  ``sim/problem.py``) and what it knows for certain, determinizes them into the kitchen
  PDDLStream problem (:func:`ssr_compile.sim.problem.state_problem`) with a streams module bound
  to its *own* planning world (never the true one), and folds each observation in: every
  object's belief is updated in the world frame at the drawers' current openings, with the
  visibility of each particle ray cast in that planning world (closed drawers, the robot, the
  localized objects at their estimates occlude), so a miss moves only what could have been seen.

Example::

    from ssr_compile.policy import PolicySettings, run_policy
    from ssr_compile.streams.environments.kitchen import make_episode
    result = run_policy(make_episode("inspect", 0), PolicySettings(variant="both"))
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pybullet as p
from ssr_compile.sim.actions import BaseNoise, execute
from ssr_compile.sim.geometry import pose
from ssr_compile.sim.perception import observe
from ssr_compile.sim.problem import (
    KnownState,
    canonical_surface,
    initial_state,
    is_localized,
    prior_belief,
    state_problem,
    to_canonical,
    to_world,
)
from ssr_compile.sim.robot import ARM_TUCK
from ssr_compile.sim.tasks import TASKS, Task, make_task
from ssr_compile.sim.world import DRAWERS, ExecutionError, Held, World

from ssr_compile import syntax as S
from ssr_compile.belief.lost import LostTest, mix_prior
from ssr_compile.belief.observation import visibility_mask
from ssr_compile.belief.particles import ObservationModel, PoseBelief, derived_rng, update
from ssr_compile.parse import parse_file
from ssr_compile.policy import Episode
from ssr_compile.resources import domains_dir
from ssr_compile.solver import Step
from ssr_compile.stream import StreamsModule

from ..kitchen_belief import MODEL
from ..kitchen_module import STREAM_INFO, KitchenModule, to_action

PLACED_STD = (0.01, 0.01, 0.0, math.radians(3.0))  # belief of an object just placed
PLACED_PARTICLES = 100
# A pick that missed: the object is more than the grasp's tolerance (2 cm) from the estimate.
# Its belief spreads by this much (x, y), no longer localized, so the next plan detects it
# again instead of repeating the same pick (Cook once picked at the same estimate 20 times).
MISSED_STD = 0.03


@dataclass
class KitchenObservation:
    """What the robot receives after an action (or before the first plan)."""

    ok: bool = True
    message: str = ""
    base: tuple[float, ...] = ()
    arm: tuple[float, ...] = ()
    drawers: dict[str, float] = field(default_factory=dict)
    held: str | None = None
    stove_on: bool = False
    detections: dict[str, tuple[float, float, float, float]] = field(default_factory=dict)

    def __str__(self) -> str:
        seen = ", ".join(sorted(self.detections)) or "nothing"
        return ("ok" if self.ok else f"FAILED: {self.message}") + f"; sees {seen}"


class KitchenEnvironment:
    """The true kitchen of a task (see the module doc)."""

    def __init__(
        self,
        task: Task,
        rng: np.random.Generator,
        *,
        noise: BaseNoise | None = None,
        model: ObservationModel | None = None,
    ) -> None:
        self.task = task
        self.world: World = task.world
        self.rng = rng
        self.noise = BaseNoise() if noise is None else noise
        self.model = MODEL if model is None else model
        self.log: list[tuple[str, str]] = []

    def _sense(self, ok: bool = True, message: str = "") -> KitchenObservation:
        w = self.world
        return KitchenObservation(
            ok,
            message,
            tuple(float(v) for v in w.robot.get_base()),
            tuple(float(v) for v in w.robot.get_arm()),
            dict(w.drawer_q),
            None if w.held is None else w.held.obj,
            w.stove_on,
            observe(w, self.rng, self.model),
        )

    def observe(self) -> KitchenObservation:
        return self._sense()

    def execute(self, step: Step) -> KitchenObservation:
        ok, message = True, ""
        try:
            action = to_action(step.name, step.values, self.world.robot.get_arm())
            if action is not None:
                out = execute(self.world, action, self.rng, self.noise)
                ok, message = out.ok, out.message
        except (ExecutionError, AssertionError, TypeError, ValueError, IndexError) as e:
            ok, message = False, f"{step.name}: {e}"
        obs = self._sense(ok, message)
        self.log.append((str(step), str(obs)))
        return obs

    def goal_holds(self) -> bool:
        return self.task.goal_satisfied()

    def close(self) -> None:
        self.task.close()


def _kitchen_files() -> tuple[S.Domain, S.StreamFile]:
    folder = domains_dir() / "kitchen"
    return parse_file(folder / "domain.pddl"), parse_file(folder / "stream.pddl")


# particles per surface of the prior a lost belief is scored against and drawn from (the
# region a box hides on the counter is a few percent of it)
LOST_PARTICLES = 400
# the share of the prior a belief not localized takes back when no plan was found from it
WIDEN_MASS = 0.5


class KitchenAgent:
    """The robot's side: beliefs, what it knows for certain, its own planning world."""

    def __init__(
        self,
        name: str,
        seed: int,
        prior: dict[str, list[tuple[str, float]]],
        goal,
        rng: np.random.Generator,
        *,
        model: ObservationModel | None = None,
        shapes: dict | None = None,
    ) -> None:
        self.domain, self.streams = _kitchen_files()
        world = World(objects=shapes)  # the objects' shapes are known, never their poses
        for o in list(world.objects):
            world.remove_object(o)
        self.task = Task(name, seed, world, prior, goal)
        self.world = world
        self.rng = rng
        self.model = MODEL if model is None else model
        self.known: KnownState | None = None
        self.placed: set[str] = set()  # objects the robot has put down (and not picked since)
        # misses of a belief the camera saw all of, scored against the prior (belief/lost.py)
        self.lost = LostTest()
        self.asked = False  # a problem asked for since the last update (:meth:`update`)
        self.km = KitchenModule(self.task, rng)
        self.surfaces = {s: canonical_surface(world, s) for s in world.surfaces}
        self._constants = (
            {"base", "arm", "stove", "aq-tuck", "aq-carry", "counter", *DRAWERS}
            | set(prior)
            | {f"{d}-{k}" for d in DRAWERS for k in ("open", "closed")}
        )

    # -- the contract ---------------------------------------------------------------------------
    def problem(self) -> tuple[S.Problem, StreamsModule]:
        k = self.known
        assert k is not None, "update(None, observation) first"
        self.asked = True  # (see :meth:`update`)
        problem, values = state_problem(self.task, k)
        self.km.drawers = dict(k.drawers)
        held = None if k.held is None else k.held[0]
        self.km.holding = k.held
        self.km.arm_now = tuple(k.arm)
        self.km.obstacles = {o: pb for o, pb in k.beliefs.items() if o != held and is_localized(pb)}
        self.km.settled = set(self.placed) & set(self.km.obstacles)
        module = StreamsModule(
            "ssr_compile.streams.kitchen_module",
            streams=self.km.streams(),
            info=dict(STREAM_INFO),
            values=values,
        )
        module.module = self.km
        return problem, module

    def is_constant(self, name: str) -> bool:
        return name in self._constants or name.startswith("g-")

    def summary(self) -> str:
        k = self.known
        if k is None:
            return "-"
        parts = []
        for o, pb in sorted(k.beliefs.items()):
            s = pb.most_likely_surface()
            loc = "loc" if is_localized(pb) else f"std {pb.std(s)[:2].max() * 100:.0f}cm"
            parts.append(f"{o}: {s} {pb.prob_surface(s):.2f} {loc}")
        if k.held is not None:
            parts.append(f"holding {k.held[0]}")
        opened = [d.split("_")[0] for d, q in sorted(k.drawers.items()) if q > 0.01]
        parts.append("open: " + (",".join(opened) or "-"))
        if k.stove_on:
            parts.append("stove on")
        if k.cooked:
            parts.append("cooked " + ",".join(sorted(k.cooked)))
        return "; ".join(parts)

    def update(self, step: Step | None, obs: KitchenObservation) -> None:
        # No step after a problem was asked for: the policy found no plan from this belief
        # and looks again (``max_looks``).  A belief that left no place to look or to act may
        # be wrong, not only unlucky: its objects not localized take back some of the prior.
        widen = self.known is not None and step is None and self.asked
        self.asked = False
        if self.known is None:
            self._start(obs)
        k = self.known
        assert k is not None
        arm_before = k.arm
        k.base, k.arm, k.drawers = tuple(obs.base), tuple(obs.arm), dict(obs.drawers)
        k.stove_on = obs.stove_on
        if step is not None:
            self._effects(step, obs)
            if step.name == "move-arm" and not obs.ok:
                self._collided(step, arm_before, obs)
        if k.stove_on:  # what is on the burner while it is on is cooked
            for o, pb in k.beliefs.items():
                if pb.prob_surface("stove") >= 0.95:
                    k.cooked.add(o)
        self._look(obs, widen)

    # -- belief update ------------------------------------------------------------------------
    def _start(self, obs: KitchenObservation) -> None:
        w = self.world
        w.set_base(obs.base)
        w.set_arm(obs.arm)
        for d, q in obs.drawers.items():
            w.set_drawer(d, q)
        self.known = initial_state(self.task, seed=self.task.seed)

    def _placed(self, o: str, pb: PoseBelief) -> PoseBelief:
        """The belief of ``o`` just placed at the point belief ``pb``: a small cloud."""
        s, est = pb.point_estimate()
        n = PLACED_PARTICLES
        poses = est + self.rng.normal(size=(n, 4)) * np.array(PLACED_STD)
        surf = self.surfaces[s]
        poses[:, :2] = surf.clip(poses[:, :2])
        return PoseBelief(o, (surf,), np.zeros(n, int), poses, None, pb.z_offset)

    def _missed(self, pb: PoseBelief) -> PoseBelief:
        """The belief of an object a pick at its estimate missed: spread by :data:`MISSED_STD`
        on its surfaces (the miss is evidence that the estimate is off by more than that)."""
        poses = np.array(pb.poses)
        poses[:, :2] += self.rng.normal(size=(len(poses), 2)) * MISSED_STD
        for i in np.unique(pb.labels):
            sel = pb.labels == i
            poses[sel, :2] = pb.surfaces[i].clip(poses[sel, :2])
        return PoseBelief(pb.obj, pb.surfaces, pb.labels, poses, pb.weights, pb.z_offset)

    def _effects(self, step: Step, obs: KitchenObservation) -> None:
        k = self.known
        assert k is not None
        if step.name == "pick" and obs.held == step.values[0]:
            o, g = step.values[0], step.values[2]
            k.held = (o, g)
            # The grasp keeps the plan's name: the rest of the plan places ``o`` with it, and
            # the next replan, constrained to that tail, held after no pick (Stow seed 0 fell
            # back after each one, and picked and placed the block again four times).
            k.held_name = step.args[2]
            k.beliefs.pop(o, None)
            self.placed.discard(o)
            self.lost.reset(o)
        elif step.name == "pick" and not obs.ok and step.values[0] in k.beliefs:
            o = step.values[0]
            k.beliefs[o] = self._missed(k.beliefs[o])
        elif step.name == "place" and not obs.ok and obs.held is not None:
            # still in the hand: the world refused this placement (not proposed again)
            self.km.failed_places.append((step.values[0], step.values[1]))
        elif step.name == "place" and obs.held is None and k.held is not None:
            o, pb = step.values[0], step.values[1]
            k.held, k.held_name = None, None
            k.beliefs[o] = self._placed(o, pb)
            self.placed.add(o)
            self.lost.reset(o)
            if obs.stove_on and pb.most_likely_surface() == "stove":
                k.cooked.add(o)
        if obs.held is None and k.held is not None and step.name != "place":
            # dropped (never expected): the object is lost to the belief
            k.held, k.held_name = None, None

    def _collided(self, step: Step, arm_before, obs: KitchenObservation) -> None:
        """An arm motion the true world stopped: the configuration after the one where the arm
        stopped (as the robot executed the path) collided; arm motions at this base with the
        same object in the hand (or none) avoid it from now on (:meth:`KitchenModule.blocked`)."""
        action = to_action(step.name, step.values, arm_before)
        path = np.asarray(action.path, float)
        if len(path) < 2:
            return
        stop = np.asarray(obs.arm, float)
        i = int(np.argmin(np.max(np.abs(path - stop), axis=1)))
        hit = path[min(i + 1, len(path) - 1)]
        held = None if self.known is None or self.known.held is None else self.known.held[0]
        hit = tuple(float(v) for v in hit)
        self.km.collided.append((tuple(obs.base), tuple(obs.arm), hit, held))

    def _arrange(self) -> None:
        """The planning world as the robot knows it: its configuration, the drawers, the object
        in its hand, localized objects at their estimates (the others out of the scene).  The
        object in the hand hides what is behind it from the camera as any other: left out, a
        miss behind it counted as a look -- the inspect family's N = 2, seed 0 picked up the
        box hiding the block, saw nothing past the box in its hand, and its belief left the
        counter where the block was (0.18 -> 0.002) for drawers it could not see into."""
        w, k = self.world, self.known
        assert k is not None
        w.held = None
        for d, q in k.drawers.items():
            w.set_drawer(d, q)
        w.set_base(k.base)
        w.set_arm(k.arm)
        for o in list(w.objects):
            if w.support.get(o) is not None:
                w.remove_object(o)
        if k.held is not None:
            o, g = k.held
            w.held = Held(o, pose(*g.pose))
            w.sync()
        for o, pb in k.beliefs.items():
            if is_localized(pb):
                x, y, z, yaw = to_world(pb, k.drawers).point_estimate()[1]
                body = w.objects[o]
                quat = (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))
                p.resetBasePositionAndOrientation(body, (x, y, z), quat, physicsClientId=w.client)

    def _look(self, obs: KitchenObservation, widen: bool = False) -> None:
        """The beliefs after ``obs``; with ``widen``, each belief not localized and not
        detected now is mixed with its prior (:data:`WIDEN_MASS`; the prior's particles in
        view weighted by the miss).  The inspect family's N = 4, K = 1, seed 1 opened both
        drawers and saw no block; its belief lay in the drawers where the camera does not
        see and nowhere on the counter, where the block stood behind the box: no plan, and
        each look again a miss of a belief that expected one."""
        k = self.known
        assert k is not None
        self._arrange()
        w = self.world
        try:
            for o, pb in sorted(k.beliefs.items()):
                pbw = to_world(pb, k.drawers)
                mask = self._seen(o, pbw)
                det = obs.detections.get(o)
                post = update(pbw, det, mask, self.model, rng=self.rng)
                if det is None:  # its own generator: the agent's draws stay as they were
                    rng = derived_rng("lost", self.task.seed, o, pb.digest)
                    post = self.lost.miss(
                        pbw, mask, lambda o=o, r=rng: self._prior(o, r), self.model, rng, post
                    )
                    if widen and not is_localized(to_canonical(post, k.drawers)):
                        prior, prior_mask = self._prior(o, rng)
                        post = mix_prior(post, prior, prior_mask, WIDEN_MASS, self.model, rng)
                else:
                    self.lost.reset(o)
                k.beliefs[o] = to_canonical(post, k.drawers)
        finally:
            w.held = None
            for o in list(w.objects):
                w.remove_object(o)
            w.set_arm(ARM_TUCK)

    def _prior(self, o: str, rng: np.random.Generator) -> tuple[PoseBelief, np.ndarray]:
        """``o``'s prior (the task's, drawn afresh) in the world frame and which of its
        particles the camera sees now (the planning world arranged by :meth:`_look`)."""
        k, w = self.known, self.world
        assert k is not None
        entries = self.task.prior[o]
        prior = prior_belief(w, o, entries, rng, n=LOST_PARTICLES, canonical=self.surfaces)
        prior = to_world(prior, k.drawers)
        return prior, self._seen(o, prior)

    def _seen(self, o: str, belief: PoseBelief) -> np.ndarray:
        """Which particles of ``o``'s ``belief`` (world frame) the camera sees in the planning
        world as arranged now (``o`` itself hides nothing)."""
        w = self.world
        return visibility_mask(belief, w.camera, w.half_extents[o], ignore=(w.objects[o],))

    def close(self) -> None:
        self.world.close()


class _KitchenEpisode(Episode):
    def close(self) -> None:
        self.environment.close()
        self.agent.close()  # type: ignore[attr-defined]


def make_episode(
    task: str,
    seed: int = 0,
    *,
    base_noise: float = 0.01,
    yaw_noise: float = 0.01,
    p_fn: float = 0.1,
    gui: bool = False,
    **options: Any,
) -> Episode:
    """An episode of ``task`` (one of ``inspect``, ``stow``, ``swap``, ``cook``, or a task file's
    path, ``.toml``: ``sim/task_file.py``) generated from ``seed``: the true world, and an agent that knows the prior, the goal and its own
    configuration.  ``base_noise``/``yaw_noise``: std of a base motion's landing error (m, rad);
    ``p_fn``: the camera's false-negative rate."""
    if task not in TASKS and not str(task).endswith(".toml"):
        raise ValueError(
            f"unknown task {task!r}; expected one of {', '.join(TASKS)} or a task file (.toml)"
        )
    if options:
        raise TypeError(f"unknown option(s) {', '.join(sorted(options))}")
    model = ObservationModel(p_fn=p_fn, sigma=MODEL.sigma)
    true_task = make_task(task, seed, gui=gui)
    env = KitchenEnvironment(
        true_task,
        np.random.default_rng([seed, 1]),
        noise=BaseNoise(base_noise, yaw_noise),
        model=model,
    )
    agent = KitchenAgent(
        true_task.name, seed, true_task.prior, true_task.goal, np.random.default_rng([seed, 2]),
        model=model, shapes=true_task.world.shapes(),
    )  # fmt: skip
    return _KitchenEpisode(env, agent, f"kitchen-{true_task.name}-{seed}")


__all__ = ["KitchenAgent", "KitchenEnvironment", "KitchenObservation", "make_episode"]
