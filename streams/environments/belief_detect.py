"""The closed loop of the abstract belief example ``domains/pddl/belief-detect`` (paper §III,
Algorithm 1): the true scene (:class:`DetectWorld`) and the robot's belief (:class:`DetectAgent`);
the scene and the streams are those of :mod:`ssr_compile.streams.belief_detect`.
"""

from __future__ import annotations

import math

import numpy as np

from ssr_compile.belief.observation import visibility_mask
from ssr_compile.belief.particles import PoseBelief, update
from ssr_compile.belief.visibility import bodies_at

from ..belief_detect import (
    BEHIND_A,
    BEHIND_B,
    BELIEF,
    BODIES,
    TABLE,
    VISIBLE_SPOT,
    DetectStreams,
    Scene,
    box_belief,
    prior_belief,
)

GRASP_TOLERANCE = 0.02  # a pick succeeds when the belief's estimate is this close to the truth


def _box_poses(sc: Scene, beliefs: dict[str, PoseBelief]) -> dict[int, tuple]:
    return {sc.ids[b]: tuple(beliefs[b].poses[0]) for b in ("boxa", "boxb")}


class DetectWorld:
    """The true scene: where the target really is (drawn from the prior with the episode's
    seed), where the boxes stand, and the camera that detects with false negatives and
    Gaussian noise (``BELIEF.model``).  The robot observes by executing ``detect``."""

    def __init__(self, seed: int, boxes: dict[str, tuple[float, float]]):
        self.rng = np.random.default_rng([seed, 11])
        prior = prior_belief()
        i = int(self.rng.choice(len(prior), p=prior.weights))
        self.target = tuple(float(v) for v in prior.poses[i])
        self.boxes = {b: BODIES[b].pose_on(*xy) for b, xy in boxes.items()}
        self.holding = False
        self.scene = Scene()  # its own client: the planner's scene never sees the truth

    def visible(self) -> bool:
        """Is the target at its true pose visible from the camera, boxes at their true poses?"""
        sc = self.scene
        placements = {sc.ids[b]: pose for b, pose in self.boxes.items()}
        placements[sc.ids["target"]] = self.target
        with bodies_at(sc.client, placements):
            point = PoseBelief.point("target", TABLE, self.target)
            mask = visibility_mask(
                point, sc.camera, BODIES["target"].half_extents, ignore=[sc.ids["target"]]
            )
        return bool(mask[0])

    def observe(self) -> None:
        return None  # the camera reports only when the robot runs its detector (detect)

    def execute(self, step) -> dict:
        if step.name == "detect":
            z = BELIEF.model.sample_detection(self.target, self.visible(), self.rng)
            return {"action": "detect", "detection": None if z is None else tuple(z)}
        if step.name == "move-aside":
            b, pb2 = step.args[0], step.values[2]
            self.boxes[b] = tuple(float(v) for v in pb2.poses[0])
            return {"action": "move-aside", "ok": True}
        if step.name == "pick":
            _, estimate = step.values[1].point_estimate()
            ok = not self.holding and math.dist(estimate[:2], self.target[:2]) <= GRASP_TOLERANCE
            self.holding = self.holding or ok
            return {"action": "pick", "ok": ok}
        return {"action": step.name, "ok": False}

    def goal_holds(self) -> bool:
        return self.holding

    def close(self) -> None:
        self.scene.close()


class DetectAgent:
    """The robot's belief: the target's particles, the boxes' known poses, its hand."""

    def __init__(self, domain, streams, seed: int, boxes: dict[str, tuple[float, float]]):
        self.domain, self.streams = domain, streams
        self.rng = np.random.default_rng([seed, 13])
        self.detect = DetectStreams(seed)  # the planner's streams, one generator per episode
        self.beliefs = {"target": prior_belief()}
        self.beliefs.update({b: box_belief(b, *xy) for b, xy in boxes.items()})
        self.names = {o: f"pb-{o}" for o in self.beliefs}
        self.changes = 0
        self.holding = False
        self.last = "prior"

    def _set(self, obj: str, belief: PoseBelief) -> None:
        if belief != self.beliefs[obj]:
            self.changes += 1
            self.beliefs[obj] = belief
            self.names[obj] = f"pb-{obj}-{self.changes}"

    def update(self, step, observation) -> None:
        if step is None or observation is None:
            return
        if observation["action"] == "detect":
            pb = self.beliefs["target"]
            sc = self.detect.scene()
            with bodies_at(sc.client, _box_poses(sc, self.beliefs)):
                mask = visibility_mask(
                    pb, sc.camera, BODIES["target"].half_extents, ignore=[sc.ids["target"]]
                )
            z = observation["detection"]
            self._set(
                "target",
                update(pb, None if z is None else np.array(z), mask, BELIEF.model, rng=self.rng),
            )
            self.last = "detected" if z is not None else "missed"
        elif observation["action"] == "move-aside":
            self._set(step.args[0], step.values[2])
            self.last = f"moved {step.args[0]}"
        elif observation["action"] == "pick":
            self.holding = self.holding or observation["ok"]
            self.last = "picked" if observation["ok"] else "pick failed"
            if not observation["ok"]:
                # The fingers closed on nothing: the target is not where the estimate says,
                # within about the grasp tolerance.  Spread the particles by that much so the
                # belief is no longer localized and the next plan looks again.
                pb = self.beliefs["target"]
                poses = pb.poses.copy()
                poses[:, :2] += self.rng.normal(0.0, GRASP_TOLERANCE, (len(pb), 2))
                self._set(
                    "target",
                    PoseBelief(pb.obj, pb.surfaces, pb.labels, poses, pb.weights, pb.z_offset),
                )

    def problem(self):
        from ssr_compile import syntax as S

        def atom(pred, *args):
            return S.Atom(pred, tuple(S.Const(a) for a in args))

        objects = ["target", "boxa", "boxb", *self.names.values()]
        init = [atom("graspable", "target"), atom("uncertain", "target")]
        init += [atom("box", "boxa"), atom("box", "boxb")]
        for o, name in self.names.items():
            init.append(atom("poseb", o, name))
            if not (o == "target" and self.holding):
                init.append(atom("atposeb", o, name))
        init.append(atom("holding", "target") if self.holding else atom("handempty"))
        init.append(S.InitValue(S.FuncTerm("total-cost"), S.Num(0)))
        problem = S.Problem(
            "belief-detect-now",
            "belief-detect",
            None,
            tuple(S.Typed(n) for n in objects),
            tuple(init),
            atom("holding", "target"),
            S.Metric("minimize", S.FuncTerm("total-cost")),
        )
        return problem, self.detect.module({self.names[o]: b for o, b in self.beliefs.items()})

    def is_constant(self, name: str) -> bool:
        return name in ("target", "boxa", "boxb")

    def summary(self) -> str:
        pb = self.beliefs["target"]
        probs = {"behind A": 0.0, "behind B": 0.0, "visible spot": 0.0}
        for spot, label in (
            (BEHIND_A, "behind A"),
            (BEHIND_B, "behind B"),
            (VISIBLE_SPOT, "visible spot"),
        ):
            near = np.linalg.norm(pb.poses[:, :2] - np.array(spot), axis=1) <= 0.08
            probs[label] = float(pb.weights[near].sum())
        spread = float(pb.std()[:2].max())
        hand = "holding" if self.holding else "hand empty"
        parts = ", ".join(f"{k} {v:.2f}" for k, v in probs.items())
        return f"target: {parts}; spread {100 * spread:.1f} cm; {self.last}; {hand}"


PROBLEM_BOXES = {
    "occluded": {"boxa": (0.8, -0.15), "boxb": (0.8, 0.15)},
    "clear": {"boxa": (0.65, -0.5), "boxb": (0.65, -0.7)},
}


def make_episode(problem: str | None = None, seed: int = 0):
    """An episode of belief-detect in closed loop: ``problem`` is ``occluded`` (default) or
    ``clear`` (where the boxes stand); the target's true pose is drawn from the prior."""
    from ssr_compile.examples import load_example
    from ssr_compile.policy import Episode

    key = (problem or "occluded").removeprefix("problem-").removesuffix(".pddl")
    if key not in PROBLEM_BOXES:
        raise ValueError(f"no problem '{problem}'; expected one of {', '.join(PROBLEM_BOXES)}")
    ex = load_example("belief-detect")
    boxes = PROBLEM_BOXES[key]
    return Episode(
        DetectWorld(seed, dict(boxes)),
        DetectAgent(ex.domain, ex.streams, seed, dict(boxes)),
        f"belief-detect/{key}",
    )
