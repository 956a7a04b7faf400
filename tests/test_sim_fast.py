"""The kitchen's faster kinematics and collision checks answer as before (issue 39).

Each shortcut is compared with the computation it replaced, written out here, bit for bit; the
IK attempts kept per robot are checked for what a stale answer would look like (the same tool
pose from another base, another seed) and for drawing from the random generator as ever.
"""

import math
import struct

import numpy as np
import pybullet as p
import pytest
from ssr_compile.sim import robot as robot_mod
from ssr_compile.sim import world as world_mod
from ssr_compile.sim.geometry import angle_between, invert, multiply, norm, pose, quat_inv, quat_mul
from ssr_compile.sim.robot import (
    ARM_REST,
    ARM_TUCK,
    BASE_CLEARANCE,
    BASE_HALF_EXTENTS,
    STALL,
    STALL_GAIN,
    Robot,
)
from ssr_compile.sim.world import World


def _bits(values) -> list[bytes]:
    return [struct.pack("<d", float(v)) for v in values]


def _pose_before(pos, quat=(0.0, 0.0, 0.0, 1.0)):
    q = np.asarray(quat, dtype=float)
    q = q / np.linalg.norm(q)
    return (tuple(float(v) for v in pos), tuple(float(v) for v in q))


def test_pose_and_norm_give_the_same_floats_as_numpy():
    rng = np.random.default_rng(3)
    cases = [((1, 2, 3), (0, 0, 0, 1)), ((-0.0, 0.0, 1e-300), (0.0, -0.0, 0.0, 2.0))]
    cases += [
        (rng.normal(size=3), rng.normal(size=4) * 10 ** rng.uniform(-3, 3)) for _ in range(2000)
    ]
    cases += [(tuple(rng.normal(size=3)), tuple(rng.normal(size=4))) for _ in range(500)]
    for pos, quat in cases:
        got, want = pose(pos, quat), _pose_before(pos, quat)
        assert _bits(got[0] + got[1]) == _bits(want[0] + want[1])
        assert all(type(v) is float for v in got[0] + got[1])
    assert pose((0.5, -0.0, 1)) == ((0.5, -0.0, 1.0), (0.0, 0.0, 0.0, 1.0))
    assert math.copysign(1.0, pose((0.5, -0.0, 1))[0][1]) == -1.0
    for v in rng.normal(size=(2000, 3)) * 10 ** rng.uniform(-5, 5, size=(2000, 1)):
        assert _bits([norm(v)]) == _bits([np.linalg.norm(v)])
        assert _bits([norm(tuple(v))]) == _bits([np.linalg.norm(v)])


@pytest.fixture(scope="module")
def world():
    w = World()
    yield w
    w.close()


def _arm_over_base_before(w: World, inflate: float = 0.08) -> bool:
    r = w.robot
    base = w.link_pose(r.body, r.base_link)
    inv = invert(base)
    hx, hy, hz = BASE_HALF_EXTENTS
    top = BASE_CLEARANCE + 2 * hz
    for link in list(r.arm_joints[3:]) + sorted(r.hand_links):
        st = p.getLinkState(r.body, link, physicsClientId=w.client)
        x, y, z = multiply(inv, pose(st[4]))[0]
        if abs(x) < hx + inflate and abs(y) < hy + inflate and z < top + inflate:
            return True
    return False


def test_arm_over_base_answers_as_before(world):
    rng = np.random.default_rng(5)
    r = world.robot
    answers = []
    with world.saved():
        for _ in range(400):
            world.set_base((*rng.uniform(-2, 2, size=2), rng.uniform(-np.pi, np.pi)))
            world.set_arm(r.sample_arm(rng))
            answers.append(world._arm_over_base())
            assert answers[-1] == _arm_over_base_before(world)
    assert 0 < sum(answers) < len(answers)  # both answers were compared


def test_joints_reset_in_one_call_as_one_by_one(world):
    rng = np.random.default_rng(6)
    r, c = world.robot, world.client
    with world.saved():
        for _ in range(50):
            base = tuple(rng.uniform(-1, 1, size=3))
            arm = r.sample_arm(rng)
            world.set_base(base)
            world.set_arm(arm)
            r.set_fingers(0.013)
            ours = [p.getLinkState(r.body, k, computeForwardKinematics=1, physicsClientId=c)
                    for k in range(p.getNumJoints(r.body, physicsClientId=c))]  # fmt: skip
            assert r.get_base() == base and r.get_arm() == arm
            for j, v in zip(r.base_joints + r.arm_joints, base + arm, strict=True):
                p.resetJointState(r.body, j, v, physicsClientId=c)
            for j in r.finger_joints:
                p.resetJointState(r.body, j, 0.013, physicsClientId=c)
            theirs = [p.getLinkState(r.body, k, computeForwardKinematics=1, physicsClientId=c)
                      for k in range(p.getNumJoints(r.body, physicsClientId=c))]  # fmt: skip
            assert ours == theirs
    with pytest.raises(ValueError, match="7 joint values expected, got 6"):
        r.set_arm(ARM_TUCK[:6])


@pytest.fixture
def robots():
    c = p.connect(p.DIRECT)
    a, b = Robot(c), Robot(c)
    yield a, b
    a.close()
    b.close()
    p.disconnect(c)


def _tool(robot: Robot, base, arm):
    return robot.forward_kinematics(base, arm)


def test_a_kept_ik_attempt_answers_as_a_fresh_one(robots, monkeypatch):
    warm, fresh = robots
    base = (0.0, 0.0, 0.0)
    rng = np.random.default_rng(7)
    queries = []
    for _ in range(12):
        tool = _tool(warm, base, warm.sample_arm(rng))
        seed = None if len(queries) % 2 else warm.sample_arm(rng)
        queries.append((tool, seed))
    queries.append((pose((3.0, 0.0, 0.5)), None))  # out of reach: every restart fails
    monkeypatch.setattr(robot_mod, "IK_ATTEMPTS_KEPT", 50_000, raising=True)
    for tool, seed in queries:  # fill the warm robot's attempts
        warm.inverse_kinematics(base, tool, np.random.default_rng(0), seed_conf=seed, restarts=3)
    assert warm.ik_attempts_reused == 0
    monkeypatch.setattr(robot_mod, "IK_ATTEMPTS_KEPT", 0, raising=True)  # fresh keeps none
    solved = 0
    for k, (tool, seed) in enumerate(queries):
        r1, r2 = np.random.default_rng(k), np.random.default_rng(k)
        got = warm.inverse_kinematics(base, tool, r1, seed_conf=seed, restarts=3)
        want = fresh.inverse_kinematics(base, tool, r2, seed_conf=seed, restarts=3)
        assert got == want
        # the random restarts drew the same numbers: the generators are in the same state
        assert r1.bit_generator.state == r2.bit_generator.state
        solved += got is not None
    assert warm.ik_attempts_reused == len(queries)
    assert fresh.ik_attempts_reused == 0 and not fresh._ik_attempts
    assert 0 < solved < len(queries)


def test_a_kept_ik_attempt_is_not_used_for_another_base_or_seed(robots):
    r, _ = robots
    rng = np.random.default_rng(8)
    near = (0.0, 0.0, 0.0)
    tool = _tool(r, near, ARM_REST)
    first = r.inverse_kinematics(near, tool, rng, restarts=1)
    assert first is not None
    # The same tool pose in the world from a base 2 m away: out of reach, whatever was kept.
    assert r.inverse_kinematics((-2.0, 0.0, 0.0), tool, rng, restarts=1) is None
    # From a base a little off: another target in the arm's frame, another answer.
    moved = r.inverse_kinematics((0.05, 0.0, 0.0), tool, rng, restarts=1)
    assert moved is not None and moved.conf != first.conf
    # Another seed: solved anew, not the kept answer (the same pose, another posture).
    other = r.inverse_kinematics(near, tool, rng, seed_conf=ARM_TUCK, restarts=1)
    assert r.ik_attempts_reused == 0
    assert other is not None and other.conf != first.conf
    assert r.inverse_kinematics(near, tool, rng, restarts=1) == first
    assert r.ik_attempts_reused == 1


def test_kept_ik_attempts_are_bounded(robots, monkeypatch):
    r, _ = robots
    monkeypatch.setattr(robot_mod, "IK_ATTEMPTS_KEPT", 3, raising=True)
    rng = np.random.default_rng(9)
    tools = [_tool(r, (0.0, 0.0, 0.0), r.sample_arm(rng)) for _ in range(5)]
    for t in tools:
        r.inverse_kinematics((0.0, 0.0, 0.0), t, rng, restarts=1)
    assert len(r._ik_attempts) == 3
    r.inverse_kinematics((0.0, 0.0, 0.0), tools[0], rng, restarts=1)  # dropped: solved again
    assert r.ik_attempts_reused == 0
    r.inverse_kinematics((0.0, 0.0, 0.0), tools[-1], rng, restarts=1)
    assert r.ik_attempts_reused == 1


def _refine_before(r: Robot, conf, target, pos_tol, ori_tol, iters=60, stall=None):
    """The refinement as it was, with the configurations it went through; ``stall``: (steps,
    gain) of the stall rule, written out step by step (the best iterate so far, and where its
    error last fell below ``gain`` times the best before)."""
    zeros = [0.0] * 9
    went = [conf]
    best, best_at, best_conf = np.inf, 0, conf
    for i in range(iters):
        reached = r._ik_fk(conf)
        e_pos = np.subtract(target[0], reached[0])
        dq = quat_mul(target[1], quat_inv(reached[1]))
        if dq[3] < 0:
            dq = tuple(-v for v in dq)
        s = np.linalg.norm(dq[:3])
        e_rot = np.zeros(3) if s < 1e-12 else np.asarray(dq[:3]) / s * 2 * np.arctan2(s, dq[3])
        pos_err, ori_err = float(np.linalg.norm(e_pos)), float(np.linalg.norm(e_rot))
        if pos_err < pos_tol * 0.5 and ori_err < ori_tol * 0.5:
            break
        if stall is not None:
            e = max(pos_err / pos_tol, ori_err / ori_tol)
            if e < best:
                best_at = i if e < best * stall[1] else best_at
                best, best_conf = e, conf
            if i - best_at >= stall[0]:
                conf = best_conf
                break
        lin, ang = p.calculateJacobian(
            r.ik_body, r.ik_tool, [0.0, 0.0, 0.0], list(conf) + [0.04, 0.04], zeros, zeros,
            physicsClientId=r.ik_client,
        )  # fmt: skip
        jac = np.vstack([np.asarray(lin)[:, :7], np.asarray(ang)[:, :7]])
        err = np.concatenate([e_pos, e_rot])
        step = jac.T @ np.linalg.solve(jac @ jac.T + 1e-4 * np.eye(6), err)
        conf = np.clip(conf + step, r.arm_lower, r.arm_upper)
        went.append(conf)
    reached = r._ik_fk(conf)
    pos_err = float(np.linalg.norm(np.subtract(reached[0], target[0])))
    return (conf, pos_err, angle_between(reached[1], target[1])), went


def test_refinement_answers_as_written_out_cycles_and_stalls_included(robots):
    r, _ = robots
    rng = np.random.default_rng(10)
    cycled = solved = stalled = 0
    for _ in range(150):
        target = pose(rng.uniform((-0.2, -0.8, 0.0), (1.0, 0.8, 1.2)), rng.normal(size=4))
        start = np.asarray(r.sample_arm(rng))
        for rule in (None, (STALL, STALL_GAIN)):  # off (the default), and the planner's
            r.stall = rule
            want, went = _refine_before(r, start, target, 2e-3, 2e-2, stall=rule)
            got = r._refine(start, target, 2e-3, 2e-2)
            assert got[0].tobytes() == want[0].tobytes() and got[1:] == want[1:]
            cycled += len({q.tobytes() for q in went}) < len(went)
            solved += want[1] < 2e-3 and want[2] < 2e-2
            stalled += rule is not None and len(went) < 61 and not want[1] < 1e-3
    r.stall = None
    assert cycled > 0 and solved > 0 and stalled > 0  # each case was compared


def test_stalled_refinements_stop_early_and_lose_few_solutions(robots, monkeypatch):
    """Against the refinement without the stall rule, from where pybullet's IK leaves random
    targets (as in an IK attempt): a few of its solutions are lost (they wandered from a poor
    start and converged late, by chance), for a fraction of the steps."""
    r, _ = robots
    rng = np.random.default_rng(11)
    starts = []
    refine = r._refine

    def keep(conf, target, *args, **kwargs):
        starts.append((conf.copy(), target))
        return refine(conf, target, *args, **kwargs)

    monkeypatch.setattr(r, "_refine", keep)
    for _ in range(200):
        target = pose(rng.uniform((-0.2, -0.8, 0.0), (1.0, 0.8, 1.2)), rng.normal(size=4))
        r._ik_attempt(target, ARM_REST if rng.uniform() < 0.5 else r.sample_arm(rng), 2e-3, 2e-2)
    monkeypatch.undo()
    steps = {"before": 0, "now": 0}
    solved = {"before": 0, "now": 0, "lost": 0}
    for start, target in starts:
        ok = {}
        for name, stall in (("before", None), ("now", (STALL, STALL_GAIN))):
            (_, pos_err, ori_err), went = _refine_before(r, start, target, 2e-3, 2e-2, stall=stall)
            steps[name] += len(went)
            ok[name] = pos_err < 2e-3 and ori_err < 2e-2
            solved[name] += ok[name]
        solved["lost"] += ok["before"] and not ok["now"]
    assert solved["before"] >= 40
    assert solved["lost"] <= solved["before"] / 10
    assert steps["now"] < 0.4 * steps["before"]


@pytest.fixture
def kitchen(world):
    with world.saved():
        world.held = None
        for d in ("top_drawer", "bottom_drawer"):
            world.set_drawer(d, 0.0)
        world.set_object("block", "counter", 1.0, 0.8, 0.0)
        world.set_object("sugar_box", "counter", 1.15, 1.05, 0.0)
        world.set_object("cracker_box", "counter", 1.15, 0.55, 0.0)
        world.set_base((0.45, 0.0, 0.0))
        world.set_arm(ARM_TUCK)
        yield world


def _fresh(w: World, **kw) -> bool:
    return w._robot_collision(kw.get("ignore", ()), kw.get("ignore_hand", ()))


def test_kept_collision_answers_follow_every_change_of_the_scene(kitchen):
    w = kitchen
    assert not w.robot_collision()
    # A drawer opened into the robot's base.
    w.set_drawer("bottom_drawer", 0.38)
    assert w.robot_collision() and _fresh(w)
    w.set_drawer("bottom_drawer", 0.0)
    reused = w.collisions_reused
    assert not w.robot_collision()
    assert w.collisions_reused == reused + 1  # the same scene as the first check: kept
    # An object put where the hand is: by the world, and behind its back (pybullet directly).
    hand = p.getLinkState(w.robot.body, w.robot.links["panda_hand"], physicsClientId=w.client)[4]
    w.place_object("block", "counter", ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0)))
    p.resetBasePositionAndOrientation(
        w.objects["block"], hand, (0, 0, 0, 1), physicsClientId=w.client
    )
    assert w.robot_collision() and _fresh(w)
    assert not w.robot_collision(ignore=("block",))  # what is ignored is part of the question
    w.set_object("block", "counter", 1.0, 0.8, 0.0)
    assert not w.robot_collision()
    # The arm moved into the counter, one joint at a time, also behind the world's back.
    p.resetJointState(w.robot.body, w.robot.arm_joints[1], 1.2, physicsClientId=w.client)
    assert w.robot_collision() == _fresh(w)
    w.set_arm(ARM_TUCK)
    # Holding the block inside the base: the held object is checked.
    w.grab("block", pose((0.0, 0.0, 0.0)))
    assert w.robot_collision() == _fresh(w)
    held = w.robot_collision()
    w.held = None
    w.set_object("block", "counter", 1.0, 0.8, 0.0)
    assert w.robot_collision() == _fresh(w) != held


def test_kept_collision_answers_equal_fresh_ones_on_a_random_walk(kitchen):
    w = kitchen
    rng = np.random.default_rng(11)
    states = []
    for _ in range(60):
        base = (*rng.uniform((0.0, -0.6), (0.6, 0.9)), float(rng.uniform(-0.5, 0.5)))
        states.append((base, w.robot.sample_arm(rng), float(rng.uniform(0.0, 0.38)),
                       float(rng.uniform(0.85, 1.25)), ("block",) if rng.random() < 0.3 else ()))  # fmt: skip
    answers = []
    reused = w.collisions_reused
    for k in list(range(60)) + list(rng.permutation(60)):  # each state twice, out of order
        base, arm, q, x, hand = states[k]
        w.set_drawer("top_drawer", q)
        w.set_object("block", "counter", x, 0.8, 0.0)
        w.set_base(base)
        w.set_arm(arm)
        answers.append(w.robot_collision(ignore_hand=hand))
        assert answers[-1] == _fresh(w, ignore_hand=hand)
    assert w.collisions_reused - reused >= 60
    assert 0 < sum(answers) < len(answers)


def test_kept_collision_answers_are_bounded(kitchen, monkeypatch):
    w = kitchen
    monkeypatch.setattr(world_mod, "COLLISIONS_KEPT", 2, raising=True)
    w._collisions.clear()
    for x in (0.1, 0.2, 0.3):
        w.set_base((x, 0.0, 0.0))
        w.robot_collision()
    assert len(w._collisions) == 2
    w.set_base((0.1, 0.0, 0.0))  # the oldest, dropped: checked again
    reused = w.collisions_reused
    w.robot_collision()
    assert w.collisions_reused == reused and len(w._collisions) == 2
    monkeypatch.setattr(world_mod, "COLLISIONS_KEPT", 0, raising=True)
    w.set_base((0.4, 0.0, 0.0))
    w.robot_collision()
    w.robot_collision()
    assert w.collisions_reused == reused and not w._collisions
