"""The kitchen in closed loop (issue 11): streams/environments/kitchen.py's environment and agent under
the online policy (Algorithm 1), and the faults the issue lists."""

from __future__ import annotations

import itertools
from contextlib import contextmanager

import numpy as np
import pytest
from ssr_compile.sim.world import DRAWER_TRAVEL
from ssr_compile.streams.environments.kitchen import KitchenObservation, make_episode

from ssr_compile.policy import Agent, Environment, PolicySettings, run_policy

FAST = PolicySettings(variant="both", budget=120, constrained_time=10, unconstrained_time=60,
                      max_cycles=30)  # fmt: skip


@contextmanager
def _episode(task: str, seed: int):
    ep = make_episode(task, seed)
    try:
        yield ep
    finally:
        ep.close()


def _run(task: str, seed: int, settings: PolicySettings):
    """One closed-loop episode: its result and its agent."""
    with _episode(task, seed) as ep:
        return run_policy(ep, settings), ep.agent


def test_episode_satisfies_the_contract():
    ep = make_episode("inspect", 0)
    try:
        assert isinstance(ep.environment, Environment) and isinstance(ep.agent, Agent)
        assert ep.agent.is_constant("block") and ep.agent.is_constant("bottom_drawer-open")
        assert not ep.agent.is_constant("pb-block") and not ep.agent.is_constant("bq0")
        with pytest.raises(ValueError):
            make_episode("fly", 0)
    finally:
        ep.close()


def _look(agent, drawers, detections=None):
    base = agent.known.base if agent.known else (-0.6, -1.3, 0.0)
    arm = agent.known.arm if agent.known else agent.world.robot.get_arm()
    obs = KitchenObservation(True, "", base, arm, drawers, None, False, detections or {})
    agent.update(None, obs)
    return agent.known.beliefs["block"]


def test_a_miss_with_the_drawers_closed_does_not_move_the_belief():
    # Fault 3: particles in a closed drawer are inside the cabinet (world frame): unseen, so a
    # miss leaves the belief alone; with the bottom drawer open, a miss moves mass away from it.
    ep = make_episode("inspect", 0)
    try:
        agent = ep.agent
        closed = {"top_drawer": 0.0, "bottom_drawer": 0.0}
        before = _look(agent, closed)  # the first look (a miss: everything is hidden)
        assert before.prob_surface("bottom_drawer") == pytest.approx(0.5)
        after = _look(agent, closed)
        assert after.prob_surface("bottom_drawer") == pytest.approx(0.5)
        assert np.allclose(after.poses, before.poses)
        opened = _look(agent, {"top_drawer": 0.0, "bottom_drawer": DRAWER_TRAVEL})
        assert opened.prob_surface("bottom_drawer") < 0.2  # most of the drawer was in view
    finally:
        ep.close()


def test_inspect_in_closed_loop():
    # The paper's Inspect (seed 0) executed in the true world: base motions land with noise,
    # the camera sees after every action.  Faults 1 and 2: after one noisy base motion the robot
    # acts from where it landed (no second base motion), the arm motion's end is where the pull
    # starts (a problem from a mid-episode state with the arm not stowed), and the constrained
    # replans (Algorithm 2) hold.
    ep = make_episode("inspect", 0)
    try:
        res = run_policy(ep, FAST)
        assert res.success, (res.reason, res.actions)
        names = [a.split()[0].lstrip("(") for a in res.actions]
        assert names.count("move-base") == 1 and names[0] == "move-base"
        assert "pull" in names and names[-1] == "push"
        pull = next(a for a in res.actions if a.startswith("(pull"))
        assert " bq0 aq0 " in pull  # the reached base and the arm configuration it was in
        assert res.constrained_held >= 2  # (all of them unless a machine under load times out)
    finally:
        ep.close()


def test_cook_sees_before_the_first_plan():
    # Fault 5: the camera looks before the first plan, so the boxes standing in plain view are
    # localized by real observations (not a uniform prior the planner could "detect" into a
    # harmless pose), while the block they hide is not.
    ep = make_episode("cook", 0)
    try:
        ep.agent.update(None, ep.environment.observe())
        problem, _ = ep.agent.problem()
        facts = {(a.pred, *(x.name for x in a.args)) for a in problem.init if hasattr(a, "pred")}
        for box in ("cracker_box", "sugar_box"):
            assert ("localized", box, f"pb-{box}") in facts
            true = ep.environment.world.true_state()["objects"][box]["pose"]
            est = ep.agent.known.beliefs[box].point_estimate()[1]
            assert np.linalg.norm(np.subtract(est[:2], true[:2])) < 0.03
        assert ("localized", "block", "pb-block") not in facts
    finally:
        ep.close()


@pytest.fixture
def minutes(request):
    """Episodes of minutes: run only when asked for with ``-m slow`` (the ``slow`` marker of
    pyproject.toml is otherwise run by default)."""
    expr = request.config.getoption("-m") or ""
    if "slow" not in expr or "not slow" in expr:
        pytest.skip("closed-loop episodes of minutes: run with -m slow")


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_inspect_other_seeds(seed, minutes):
    res, _ = _run("inspect", seed, FAST)
    assert res.success, (res.reason, res.actions)


@pytest.mark.slow
def test_stow_in_closed_loop(minutes):
    # Stow (seed 0): the sugar box in the top drawer must go out before the block goes in; the
    # robot picks and places from where its noisy base motions land, and pushes the drawer
    # closed from the arm configuration it moved to.
    res, _ = _run("stow", 0, PolicySettings(variant="both", budget=600, max_cycles=60))
    assert res.success, (res.reason, res.actions)
    names = [a.split()[0].lstrip("(") for a in res.actions]
    assert names.count("pick") == 2 and names.count("place") == 2 and names[-1] == "push"


@pytest.mark.slow
@pytest.mark.xfail(reason="issue 11: Swap and Cook replans still outgrow the planning limits",
                   strict=False)  # fmt: skip
@pytest.mark.parametrize("task", ["swap", "cook"])
def test_long_tasks_in_closed_loop(task, minutes):
    ep = make_episode(task, 0)
    try:
        res = run_policy(ep, PolicySettings(variant="both", budget=600, max_cycles=60))
        assert res.success, (res.reason, res.actions)
        if task == "cook":  # the appendix's trace: a box is moved before the block is detected
            names = res.actions
            first_box_pick = next(
                i for i, a in enumerate(names) if a.startswith("(pick") and "box" in a
            )
            first_detect = next(i for i, a in enumerate(names) if a.startswith("(detect block"))
            assert first_box_pick < first_detect
    finally:
        ep.close()


def test_a_drawer_below_an_open_one_is_planned_with_the_upper_one_closed():
    # Swap: with both drawers open, the bottom one can only move once the top one is closed
    # (the domain's `covered`), so its base and its push are planned in that state -- planned in
    # the state as seen, no base was ever found and the replan had no relaxed solution.
    ep = make_episode("swap", 0)
    try:
        km = ep.agent.km
        km.drawers = {"top_drawer": DRAWER_TRAVEL, "bottom_drawer": DRAWER_TRAVEL}
        bases = [b for b in itertools.islice(km.sample_drawer_base("bottom_drawer"), 4) if b]
        assert bases
        a1, a2 = ("bottom_drawer", DRAWER_TRAVEL), ("bottom_drawer", 0.0)
        assert any(km._plan_drawer("bottom_drawer", a1, a2, bq) is not None for (bq,) in bases)
        assert km.drawers["top_drawer"] == DRAWER_TRAVEL  # the robot's knowledge is untouched
    finally:
        ep.close()


def test_reaching_into_a_drawer_is_planned_with_the_other_drawers_closed():
    # The domain's `covered`: the arm reaches into a drawer, or moves it, only with every other
    # drawer closed, and the streams plan in that state.  With the bottom drawer open below the
    # top one, Swap seed 2 found no base for the block in the top drawer, and no plan closed the
    # bottom drawer first: "no relaxed solution".
    ep = make_episode("swap", 2)
    try:
        km = ep.agent.km
        km.drawers = {"top_drawer": DRAWER_TRAVEL, "bottom_drawer": DRAWER_TRAVEL}
        for use in ({"open_drawer": "top_drawer"}, {"moving": "top_drawer"}):
            with km.planning(**use) as w:
                assert w.drawer_q["bottom_drawer"] == 0.0, use
        with km.planning(open_drawer="bottom_drawer") as w:
            assert w.drawer_q["top_drawer"] == 0.0
            assert w.drawer_q["bottom_drawer"] == DRAWER_TRAVEL
        with km.planning() as w:  # nothing reached into: the drawers as the robot saw them
            assert w.drawer_q["top_drawer"] == w.drawer_q["bottom_drawer"] == DRAWER_TRAVEL
        assert km.drawers["bottom_drawer"] == DRAWER_TRAVEL  # the robot's knowledge is untouched
    finally:
        ep.close()


def test_arm_motions_avoid_the_objects_the_robot_has_localized():
    # Stow: after placing the sugar box, the planned way back to tuck swept through it (arm
    # motions were planned in a world without movable objects); the true world refused it and
    # every replan tried the same path again.  The agent's localized objects are obstacles.
    ep = make_episode("stow", 0)
    try:
        agent = ep.agent
        agent.update(None, ep.environment.observe())
        agent.problem()
        km = agent.km
        assert set(km.obstacles) == {"block", "sugar_box"}
        seen = {}

        def record(bq, q1, q2, blocked=None):
            w = km.world
            seen["present"] = sorted(w.present())
            seen["at"] = {o: w.object_pose(o)[0] for o in w.present()}
            return None

        km.ks.plan_arm_motion = record
        km.plan_arm_motion((0.0, 0.0, 0.0), (0.0,) * 7, (0.0,) * 7)
        assert seen["present"] == ["block", "sugar_box"]
        for o in ("block", "sugar_box"):
            est = agent.known.beliefs[o].point_estimate()[1]
            if o == "block":  # on the counter: where the belief puts it
                assert np.allclose(seen["at"][o][:2], est[:2], atol=1e-6)
        assert km.world.present() == []  # only while planning
    finally:
        ep.close()


def test_a_drawer_motion_starts_from_the_arm_configuration_planned_for_it():
    # Stow: after moving the arm to the push's approach, the replan solved the push anew from
    # there and found no path starting there (a redundant arm), so the robot went back to tuck
    # and forth for 80 cycles.  The motion planned for that approach is taken again.
    ep = make_episode("stow", 0)
    try:
        km = ep.agent.km
        km.drawers = {"top_drawer": DRAWER_TRAVEL, "bottom_drawer": 0.0}
        a1, a2 = ("top_drawer", DRAWER_TRAVEL), ("top_drawer", 0.0)
        for (bq,) in filter(None, itertools.islice(km.sample_drawer_base("top_drawer"), 3)):
            here = km._plan_drawer("top_drawer", a1, a2, bq)
            if here is None:
                continue
            aq1, aq2, motion = here
            after = km._plan_drawer_from("top_drawer", a1, a2, bq, tuple(aq1))
            assert after is not None
            assert after[1].arm_path == motion.arm_path and tuple(after[0]) == tuple(aq2)
            # from anywhere else, no motion is made up
            far = tuple(v + 0.5 for v in aq1)
            again = km._plan_drawer_from("top_drawer", a1, a2, bq, far)
            assert again is None or np.allclose(again[1].arm_path[0], far)
            break
        else:
            pytest.fail("no push planned from three drawer bases")
    finally:
        ep.close()


def test_a_press_starts_from_the_arm_configuration_planned_for_it(monkeypatch):
    # The clutter family's N = 4, K = 1, seed 5: after moving the arm to the press's approach,
    # the press solved anew from there found no path starting there, so every replan moved
    # the arm to where it already was (a motion of length zero) for 83 cycles.  The press
    # path planned for that approach is taken again when no other starts there.
    ep = make_episode("cook", 0)
    try:
        km = ep.agent.km
        for (bq,) in filter(None, itertools.islice(km.sample_press_base("stove"), 3)):
            here = km.plan_press(bq)
            if here is None:
                continue
            aq, path = here
            # no path from where the arm is (as the redundant arm's IK found there)
            real = km.ks.plan_press

            def not_from_a_seed(b, seed=None, real=real):
                return None if seed is not None else real(b)

            monkeypatch.setattr(km.ks, "plan_press", not_from_a_seed)
            after = km.plan_press_from(bq, tuple(aq))
            assert after is not None and tuple(after[0]) == tuple(path)
            # from anywhere else, no path is made up
            assert km.plan_press_from(bq, tuple(v + 0.5 for v in aq)) is None
            # nor from the same arm configuration at another base
            other = (bq[0] + 0.3, bq[1], bq[2])
            assert km.plan_press_from(other, tuple(aq)) is None
            break
        else:
            pytest.fail("no press planned from three press bases")
    finally:
        ep.close()


def test_a_sampler_out_of_attempts_is_not_exhausted():
    # A kitchen sampler that used up its attempts without a sample says "nothing this time"
    # (None) and starts a fresh batch on the next draw: the solver may ask again at the next
    # level instead of giving the instance up for the whole solve.
    ep = make_episode("swap", 0)
    try:
        km = ep.agent.km
        batches = iter([[], [("b1",), ("b2",)], []])
        draws = km._each(lambda: iter(next(batches)))
        assert [next(draws) for _ in range(5)] == [None, ("b1",), ("b2",), None, None]
        # The solver's view: a None draw is a failure now, not the end of the generator.
        from ssr_compile.stream import Generator

        gen = Generator(lambda: km._each(lambda: iter(next(batches2))), (), "generator", "s")
        batches2 = iter([[], [("b3",)]])
        assert gen.next() is None and not gen.exhausted
        assert gen.next() == ("b3",)
    finally:
        ep.close()


def test_a_missed_pick_spreads_the_belief_so_the_robot_looks_again():
    # A pick that missed in the true world is evidence that the estimate is off by more than the
    # grasp's tolerance: the belief spreads (no longer localized) and the next plan detects the
    # object again, instead of repeating the same pick (Cook seed 0 once did, 20 times).
    from ssr_compile.sim.problem import is_localized

    from ssr_compile.belief.particles import PoseBelief
    from ssr_compile.solver import Step

    ep = make_episode("cook", 0)
    try:
        agent = ep.agent
        closed = {"top_drawer": 0.0, "bottom_drawer": 0.0}
        _look(agent, closed)
        k = agent.known
        counter = k.beliefs["block"].surface("counter")
        rng = np.random.default_rng(0)
        poses = np.column_stack(
            [rng.normal(0.0, 0.004, (100, 2)) + counter.sample_xy(rng, 1), np.zeros((100, 2))]
        )
        k.beliefs["block"] = PoseBelief.from_particles("block", (counter,), [0] * 100, poses)
        assert is_localized(k.beliefs["block"], "counter")
        step = Step("pick", ("block", "pb-block", "g-1", "bq0", "aq0", "t-1"),
                    ("block", k.beliefs["block"], None, None, None, None))  # fmt: skip
        missed = KitchenObservation(False, "pick: block is 0.031 m from the grasp, missed",
                                    k.base, k.arm, closed, None, False, {})  # fmt: skip
        agent.update(step, missed)
        after = agent.known.beliefs["block"]
        assert not is_localized(after, "counter")
        assert after.prob_surface("counter") == pytest.approx(1.0)
        assert 0.02 < float(after.std("counter")[:2].max()) < 0.05
    finally:
        ep.close()


def test_an_arm_motion_is_tried_again_when_the_planner_misses(monkeypatch):
    # RRT-Connect may miss a path that exists; the function fails for the whole solve, and with
    # the arm where it is no other motion may be left (Cook seed 3: "no relaxed solution").
    ep = make_episode("cook", 3)
    try:
        km = ep.agent.km
        answers = iter([None, None, ("the path",)])
        monkeypatch.setattr(km.ks, "plan_arm_motion", lambda *args: next(answers))
        assert km.plan_arm_motion((0.0, 0.0, 0.0), (0.0,) * 7, (0.1,) * 7) == ("the path",)
        answers = iter([None] * 10)
        assert km.plan_arm_motion((0.0, 0.0, 0.0), (0.0,) * 7, (0.1,) * 7) is None
    finally:
        ep.close()


def test_a_belief_that_lost_the_block_goes_back_to_where_the_camera_cannot_see():
    # Cook seed 17 ran out of cycles: the block's particles had gathered where the camera
    # saw all of them (the block stood behind the sugar box), every miss scaled them alike and
    # the belief never moved.  Misses of a belief in full view are scored against the prior
    # (belief/lost.py); a few of them hand the prior its mass back, where nothing was seen.
    from ssr_compile.streams.environments.kitchen import to_world

    from ssr_compile.belief.particles import PoseBelief

    with _episode("cook", 17) as ep:
        env, agent = ep.environment, ep.agent
        agent.update(None, env.observe())
        k = agent.known
        true = np.array(env.world.object_pose("block")[0][:2])
        old = k.beliefs["block"]

        def seen(belief):
            agent._arrange()
            return agent._seen("block", to_world(belief, k.drawers))

        def unseen_mass():
            return float(k.beliefs["block"].weights[~seen(k.beliefs["block"])].sum())

        # a tight cloud on the counter in plain view, at least 20 cm from the block
        far = np.linalg.norm(old.poses[:, :2] - true, axis=1) > 0.2
        at = old.poses[np.flatnonzero(seen(old) & far)[0], :2]
        rng = np.random.default_rng(0)
        xy = at + rng.normal(size=(100, 2)) * 0.005
        poses = np.column_stack([xy, np.full(100, old.poses[0, 2]), np.zeros(100)])
        k.beliefs["block"] = PoseBelief("block", old.surfaces[:1], np.zeros(100, int), poses,
                                        z_offset=old.z_offset)  # fmt: skip

        assert unseen_mass() == 0.0  # in full view: a plain filter's miss leaves it as it is
        looks = 0
        while unseen_mass() < 0.5 and looks < 12:
            agent.update(None, env.observe())
            looks += 1
        assert agent.lost.fired == 1 and 2 <= looks < 12
        near = np.linalg.norm(k.beliefs["block"].poses[:, :2] - true, axis=1)
        assert near.min() < 0.05  # some particle where the block truly is
        assert unseen_mass() >= 0.5


@pytest.mark.slow
def test_cook_seed_17_looks_where_its_belief_lost_the_block(minutes):
    # the episode behind the test above: it ran 100 cycles driving to one base to look again;
    # now the belief goes back to the prior, the sugar box is moved and the block cooked
    res, agent = _run("cook", 17, PolicySettings(variant="both", budget=600, max_cycles=100))
    assert res.success, (res.reason, res.actions)
    assert agent.lost.fired >= 1


@pytest.mark.slow
def test_cook_seed_9001_reaches_the_goal_in_the_true_world(minutes):
    # issue 39's held-out episode: it moved the cracker box, looked twice without seeing the
    # block behind the sugar box and ended after 13 cycles, "level 9 would pass the cap"; at
    # e51b065 it moves the cracker box twice, then the sugar box, and cooks the block (47
    # cycles, 108 s of planning; no attempt near its time limit)
    res, _ = _run("cook", 9001, PolicySettings(variant="both", budget=600, max_cycles=100))
    assert res.success, (res.reason, res.actions)
    names = [a.split()[0].lstrip("(") for a in res.actions]
    assert "press-on" in names and names[-1] == "press-off"


def test_the_object_in_the_hand_hides_from_the_camera_what_is_behind_it():
    # The inspect family's N = 2, seed 0: holding the box that had hidden the block, the robot
    # counted each miss behind the box in its hand as a look, and its belief left the counter
    # where the block was.  A particle on the camera's ray past the held box is not seen.
    from ssr_compile.sim.geometry import multiply
    from ssr_compile.sim.robot import ARM_CARRY
    from ssr_compile.sim.world import CAMERA_EYE

    from ssr_compile.belief.particles import PoseBelief

    ep = make_episode("cook", 0)
    try:
        agent = ep.agent
        _look(agent, {"top_drawer": 0.0, "bottom_drawer": 0.0})
        k = agent.known
        ((grasp,),) = itertools.islice(agent.km.ks.sample_grasps("cracker_box"), 1)
        k.arm = ARM_CARRY
        w = agent.world
        w.set_base(k.base)
        w.set_arm(k.arm)
        box = np.asarray(multiply(w.robot.tool_pose(), grasp.pose)[0])
        eye = np.asarray(CAMERA_EYE)
        past = box + 0.3 * (box - eye) / np.linalg.norm(box - eye)
        belief = PoseBelief.point("block", agent.surfaces["counter"], (*past, 0.0))

        def seen() -> bool:
            agent._arrange()
            try:
                return bool(agent._seen("block", belief)[0])
            finally:
                w.held = None

        assert seen()  # nothing else in the way: the test's point is in view
        k.held = ("cracker_box", grasp)
        assert not seen()
    finally:
        ep.close()


def test_a_look_again_after_no_plan_gives_a_belief_that_is_not_localized_some_of_its_prior(
    tmp_path,
):
    # The inspect family's N = 4, seed 1: a belief left where the camera cannot see, and none
    # of it on the counter where the block stood behind the box.  Looking again after no plan
    # (an update without a step) hands part of the prior back; a look with no plan asked
    # for does not.
    from ssr_compile.belief.particles import PoseBelief

    task = tmp_path / "hidden.toml"
    task.write_text(
        'goal = ["On block bottom_drawer", "Closed bottom_drawer"]\n'
        "[objects]\n"
        'block = { kind = "block", on = "counter" }\n'
        'cracker_box = { kind = "cracker_box", on = "counter" }\n'
        "[hide]\n"
        'target = "block"\n'
        'by = ["cracker_box"]\n'
        "[prior]\n"
        "block = { counter = 1, top_drawer = 1 }\n"
        'cracker_box = ["counter"]\n'
    )
    ep = make_episode(str(task), 0)
    try:
        agent = ep.agent
        closed = {"top_drawer": 0.0, "bottom_drawer": 0.0}
        _look(agent, closed)  # the first look
        pb = agent.known.beliefs["block"]
        weights = np.where(pb.surface_names == "top_drawer", pb.weights, 0.0)
        pb = PoseBelief(pb.obj, pb.surfaces, pb.labels, pb.poses, weights / weights.sum(),
                        pb.z_offset)  # fmt: skip
        agent.known.beliefs["block"] = pb  # the block all in the top drawer
        assert pb.prob_surface("counter") == 0.0
        assert _look(agent, closed).prob_surface("counter") == 0.0  # a look, no plan asked
        agent.problem()  # the policy asks for a plan, finds none, and looks again
        again = _look(agent, closed)
        assert again.prob_surface("counter") > 0.0
        assert again.prob_surface("top_drawer") < 1.0
    finally:
        ep.close()
