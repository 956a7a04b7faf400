"""Reaching in the kitchen as a closed loop meets it (issue 11, Cook): bases that stay free
where a noisy base motion lands, side grasps no base reaches, grasps reached at an object's
believed pose tried first, and arm paths that start where the arm is although the object's
estimate moved a little."""

import itertools
import math

import numpy as np
import pytest
import ssr_compile.sim.samplers as samplers
from ssr_compile.sim.geometry import invert, multiply, rotate, yaw_of
from ssr_compile.sim.robot import ARM_TUCK
from ssr_compile.sim.samplers import KitchenStreams
from ssr_compile.sim.tasks import make_task


@pytest.fixture(scope="module")
def cook0():
    task = make_task("cook", 0)
    yield task
    task.close()


def _bearing(ks, p, g) -> float | None:
    """The horizontal direction a side grasp's hand moves in (None for a top grasp)."""
    _, q = multiply(ks.world_pose(p), invert(g.pose))
    a = rotate(q, (0.0, 0.0, 1.0))
    return float(np.arctan2(a[1], a[0])) if np.hypot(a[0], a[1]) > 0.7 else None


def test_a_base_flush_against_the_counter_is_not_free(cook0, monkeypatch):
    # Drive towards the stove in 5 mm steps until the tucked robot touches it (where a Cook
    # seed 3 placement once left it): the last free base is collision-free itself, but a
    # landing 5 mm further is not.
    w = cook0.world
    ks = KitchenStreams(w, np.random.default_rng(0))
    x, y, yaw = 0.25, -0.626, -0.154
    with w.saved():
        w.set_arm(ARM_TUCK)
        last = None
        for k in range(400):
            b = (x + 0.005 * k, y, yaw)
            w.set_base(b)
            if w.robot_collision():
                break
            last = b
    assert last is not None and last[0] > x  # it moved, then touched something
    assert not ks.base_free(last)  # within the landing margin of the counter
    far = (last[0] - 0.05, last[1], last[2])
    assert ks.base_free(far)  # 5 cm back it is free with the margin
    monkeypatch.setattr(samplers, "BASE_MARGIN", (0.0, 0.0))
    assert ks.base_free(last)  # without a margin the flush base would be accepted


def test_a_free_base_stays_free_where_x_y_and_yaw_are_off_together(cook0):
    # Cook seed 18 landed 14 mm and 9 mm off along x and y at once, within the margin of each
    # axis, where the tucked arm entered the stove.  Bases near the stove whose axis offsets
    # are all free but a corner of the margin box is not must be refused; and every base
    # accepted is free at every corner.
    w = cook0.world
    ks = KitchenStreams(w, np.random.default_rng(0))
    dx, dyaw = samplers.BASE_MARGIN
    rng = np.random.default_rng(7)

    def free(b) -> bool:
        w.set_base(b)
        return not w.robot_collision()

    axes = [(dx, 0, 0), (-dx, 0, 0), (0, dx, 0), (0, -dx, 0), (0, 0, dyaw), (0, 0, -dyaw)]
    corners = list(itertools.product((dx, -dx), (dx, -dx), (dyaw, -dyaw)))
    refused_at_a_corner = accepted = 0
    with w.saved():
        w.set_arm(ARM_TUCK)
        for _ in range(400):
            # up to 5 cm back from where driving +x from (0.25, -0.626, -0.154) touches the
            # counter (x = 0.455: the test above)
            b = (0.45 - rng.uniform(0, 0.05), -0.626 + rng.uniform(-0.15, 0.15),
                 -0.154 + rng.uniform(-0.5, 0.5))  # fmt: skip
            near = [tuple(np.add(b, o)) for o in axes]
            at_corners = [tuple(np.add(b, o)) for o in corners]
            if not free(b) or not all(free(q) for q in near):
                continue
            if all(free(q) for q in at_corners):
                accepted += 1
                assert ks.base_free(b)
            else:
                refused_at_a_corner += 1
                assert not ks.base_free(b)
    assert refused_at_a_corner > 0 and accepted > 0


def test_side_grasps_whose_hand_faces_the_robot_have_no_base(cook0):
    w = cook0.world
    ks = KitchenStreams(w, np.random.default_rng(1), max_attempts=60)
    seen_refused = seen_reached = False
    for obj in ("cracker_box", "sugar_box"):
        p = ks.current_pose(obj)
        with w.saved():
            for o in list(w.objects):
                if w.support.get(o) is not None:
                    w.remove_object(o)
            for g in ks.grasps(obj):
                bearing = _bearing(ks, p, g)
                if bearing is None:
                    continue
                calls = []
                kin = ks.inv_kin
                ks.inv_kin = lambda *a, _c=calls, _k=kin, **k: _c.append(a) or _k(*a, **k)
                bases = list(ks.inv_reach(obj, p, g))
                ks.inv_kin = kin
                if abs(bearing) > samplers.SIDE_BEARING_LIMIT:
                    assert bases == [] and calls == []  # refused without trying IK once
                    seen_refused = True
                elif bases:
                    seen_reached = True
                    for (b,) in bases:  # each one really reaches the grasp
                        assert ks.inv_kin(obj, p, g, b) is not None
    assert seen_refused and seen_reached


def test_grasps_reached_at_the_believed_pose_come_first(cook0):
    # The cracker box of Cook seed 0 stands so that one of its four grasps is reached from
    # some base; sample-grasp yields that one first once the box's pose is believed.
    from ssr_compile.streams.kitchen_module import KitchenModule

    from ssr_compile.belief.particles import PoseBelief

    w = cook0.world
    km = KitchenModule(cook0, np.random.default_rng(2))
    (x, y, z), q = w.object_pose("cracker_box")
    yaw = yaw_of(q)
    pb = PoseBelief.point("cracker_box", w.surfaces and _counter(w), (x, y, z, yaw))
    p = km.obj_pose(pb)
    probe = KitchenStreams(w, np.random.default_rng(3), max_attempts=100)
    with km.planning():
        reached = {g: next(iter(probe.inv_reach("cracker_box", p, g)), None) is not None
                   for g in probe.grasps("cracker_box")}  # fmt: skip
    assert 0 < sum(reached.values()) < len(reached)
    k = sum(reached.values())
    for seed in range(6):  # whatever the random order of the grasps
        km = KitchenModule(cook0, np.random.default_rng(seed))
        km.obstacles = {"cracker_box": pb}
        order = [g for (g,) in km.sample_grasp("cracker_box")]
        assert len(order) == len(reached) and all(g in reached for g in order)
        assert all(reached[g] for g in order[:k]) and not any(reached[g] for g in order[k:])


def _counter(w):
    from ssr_compile.sim.tasks import belief_surface

    return belief_surface(w, "counter")


def test_a_path_from_where_the_arm_is_starts_there_after_the_estimate_moved(cook0, monkeypatch):
    # The arm is at the pre-grasp configuration of an earlier estimate; the block's estimate
    # has since moved (here: the arm's last joint is 0.12 rad off, as a yaw update does).  The
    # approach solved from there starts exactly at the arm's configuration, through a short
    # collision-checked lead-in.
    w = cook0.world
    ks = KitchenStreams(w, np.random.default_rng(4))
    p = ks.current_pose("block")
    found = None
    with w.saved():
        for o in ("cracker_box", "sugar_box"):
            w.remove_object(o)
        for (g,) in ks.sample_grasps("block"):
            if g.kind != "top":
                continue
            for (base,) in ks.inv_reach("block", p, g):
                found = (g, base)
                break
            if found:
                break
        assert found is not None
        g, base = found
        pre, _ = ks.inv_kin("block", p, g, base)
        arm = tuple(np.add(pre, [0, 0, 0, 0, 0, 0, 0.12]))
        out = ks.inv_kin("block", p, g, base, seed=arm)
        assert out is not None
        path = out[1]
        assert np.allclose(path[0], arm)
        steps = np.max(np.abs(np.diff(np.asarray(path[:4]), axis=0)), axis=1)
        assert np.all(steps <= samplers.LEAD_STEP + 1e-9)
        monkeypatch.setattr(samplers, "LEAD_IN", 0.0)
        ks2 = KitchenStreams(w, np.random.default_rng(4))
        again = ks2.inv_kin("block", p, g, base, seed=arm)
        assert again is None or np.max(np.abs(np.subtract(again[1][0], arm))) > 0.05


def test_the_lead_in_is_straight_and_bounded():
    start = (0.0,) * 7
    path = [(0.2,) + (0.0,) * 6, (0.3,) + (0.0,) * 6]
    out = samplers._lead_in(start, path)
    assert out[0] == start and out[-2:] == path
    assert len(out) == 2 + 4  # 0.2 rad in steps of 0.05
    lead = out[:5]  # start .. path[0]
    assert all(abs(b[0] - a[0]) <= samplers.LEAD_STEP + 1e-12 for a, b in zip(lead, lead[1:]))
    far = [(0.5,) + (0.0,) * 6]
    assert samplers._lead_in(start, far) == far  # beyond LEAD_IN: unchanged


def test_the_next_arm_motion_carries_what_the_robot_holds(cook0):
    # The motion from the arm's configuration now is the one the robot may execute next: it is
    # planned with the held object in the hand; motions from elsewhere (later in the plan) are
    # planned again when their turn comes.
    from ssr_compile.sim.robot import ARM_CARRY
    from ssr_compile.streams.kitchen_module import KitchenModule

    km = KitchenModule(cook0, np.random.default_rng(5))
    grasp = km.ks.grasps("cracker_box")[0]
    seen, asked = [], []

    def record(base, q1, q2, blocked=None):
        w = km.world
        seen.append(None if w.held is None else (w.held.obj, w.held.grasp))
        asked.append((q1, q2))
        return ((q1, q2),)

    km.ks.plan_arm_motion = record
    base = km.world.robot.get_base()
    other = tuple(v + 0.2 for v in ARM_TUCK)
    km.holding, km.arm_now = ("cracker_box", grasp), ARM_CARRY
    assert km.plan_arm_motion(base, ARM_CARRY, ARM_TUCK) == ((ARM_CARRY, ARM_TUCK),)
    km.plan_arm_motion(base, ARM_TUCK, other)
    # A motion is certified both ways: one that ends where the arm is may run next, reversed.
    # It is planned from here, with the held object, and handed back in the asked direction.
    assert km.plan_arm_motion(base, ARM_TUCK, ARM_CARRY) == ((ARM_CARRY, ARM_TUCK)[::-1],)
    km.holding = None
    km.plan_arm_motion(base, ARM_CARRY, ARM_TUCK)
    held = ("cracker_box", grasp.pose)
    assert seen == [held, None, held, None]
    assert asked[2] == (ARM_CARRY, ARM_TUCK)  # planned from where the arm is
    assert km.world.held is None  # the planning state is undone


def test_a_drawer_object_is_reached_from_estimates_near_its_pose():
    # What the robot plans with is an estimate: a block in a drawer is placed where a grasp
    # reaches it although the estimate is 1.5 cm off (Swap seed 2's block was reached at its
    # true pose only, and the episode ended "no relaxed solution" in front of the open drawer).
    from ssr_compile.sim.samplers import ObjPose
    from ssr_compile.sim.world import DRAWER_TRAVEL

    task = make_task("swap", 2)
    try:
        w = task.world
        ks = KitchenStreams(w, np.random.default_rng(7), max_attempts=40)
        p = ks.current_pose("block")
        (x, y, _), q = p.rel
        yaw = yaw_of(q)
        shifted = [p]
        for ox, oy in ((0.015, 0.0), (-0.015, 0.0), (0.0, 0.015), (0.0, -0.015)):
            rel = w.rest_pose("block", p.surface, x + ox, y + oy, yaw)
            if w.inside_surface("block", p.surface, rel):
                shifted.append(ObjPose("block", p.surface, rel))
        assert len(shifted) >= 4
        with w.saved():
            w.remove_object("block")
            w.set_drawer(p.surface, DRAWER_TRAVEL)
            reached = [
                g for g in ks.grasps("block")
                if all(next(iter(ks.inv_reach("block", s, g)), None) is not None for s in shifted)
            ]  # fmt: skip
        assert reached
    finally:
        task.close()


def test_a_pre_grasp_inside_an_object_the_robot_put_down_is_refused(cook0):
    # Cook seed 1 put both boxes down beside the block, then drove to the same base 80 times:
    # the pre-grasp was inside a box, and the arm motion to it (deferred) failed each time it
    # came next.  Objects where they were found are not checked (a plan may move them first).
    from ssr_compile.streams.kitchen_module import KitchenModule

    from ssr_compile.belief.particles import PoseBelief

    w = cook0.world
    km = KitchenModule(cook0, np.random.default_rng(6))
    (x, y, z), q = w.object_pose("block")
    block = PoseBelief.point("block", _counter(w), (x, y, z, yaw_of(q)))
    found = None
    for (g,) in km.sample_grasp("block"):
        for b in km.inv_reach("block", block, g):
            if b is not None and km.inv_kin("block", block, g, b[0]) is not None:
                found = (g, b[0])
                break
        if found:
            break
    assert found is not None
    g, base = found
    pre, _ = km.inv_kin("block", block, g, base)
    hand = w.robot.forward_kinematics(base, pre)[0]
    (_, _, sz), sq = w.object_pose("sugar_box")
    box = PoseBelief.point("sugar_box", _counter(w), (hand[0], hand[1], sz, yaw_of(sq)))
    km.obstacles = {"sugar_box": box, "block": block}
    assert km.inv_kin("block", block, g, base) is not None  # found there: a plan may move it
    km.settled = {"sugar_box"}
    assert km.inv_kin("block", block, g, base) is None  # put down there by the robot
    km.settled = {"block"}  # the object reached for is no obstacle to its own grasp
    assert km.inv_kin("block", block, g, base) is not None


def test_a_placement_the_world_refused_is_not_proposed_again(cook0):
    # Cook seed 8 placed the block on the burner from one arm configuration 76 times: the same
    # configuration lands it at the same pose, and the true world refused it each time.
    from types import SimpleNamespace

    from ssr_compile.streams.environments.kitchen import make_episode
    from ssr_compile.streams.kitchen_module import REFUSED_NEAR, KitchenModule

    from ssr_compile.belief.particles import PoseBelief

    km = KitchenModule(cook0, np.random.default_rng(7))
    stove = [pb for (pb,) in (next(iter(km.sample_placement("block", "stove"))),)][0]
    s, (x, y, z, yaw) = stove.point_estimate()
    near = PoseBelief.point("block", stove.surfaces[0], (x + 0.01, y, z, yaw + 0.1))
    far = PoseBelief.point("block", stove.surfaces[0], (x + 2 * REFUSED_NEAR[0], y, z, yaw))
    assert not km.refused("block", near)
    episode = make_episode("cook", 0)
    try:
        agent = episode.agent
        agent.update(None, episode.environment.observe())
        agent.km = km
        step = SimpleNamespace(name="place", values=("block", stove))
        agent._effects(step, SimpleNamespace(ok=False, held="block", stove_on=False))
    finally:
        episode.close()
    assert km.failed_places == [("block", stove)]
    assert km.refused("block", near) and not km.refused("block", far)
    assert not km.refused(
        "sugar_box", PoseBelief.point("sugar_box", stove.surfaces[0], (x, y, z, yaw))
    )
    # sample-placement does not yield it again: every draw is far from it or nothing
    for out in itertools.islice(km.sample_placement("block", "stove"), 20):
        assert out is None or not km.refused("block", out[0])


def test_placements_are_drawn_clear_of_the_objects_the_robot_localized(cook0):
    # Issue 40: on a crowded counter most placements drawn blind to the other objects failed
    # test-cfree in the stream plan (84 in one cycle of a kitchen of eight objects).  With
    # the boxes localized, sample-placement draws the block's placements clear of them; a
    # module that knows of no obstacle draws some on top of them.
    from ssr_compile.streams.kitchen_module import KitchenModule

    def module(obstacles):
        km = KitchenModule(cook0, np.random.default_rng(11))
        km.obstacles = obstacles
        return km

    km = module({})
    boxes = {o: km.belief_of(km.ks.current_pose(o)) for o in ("cracker_box", "sugar_box")}

    def on_a_box(draws):
        return sum(
            not all(km.test_cfree("block", out[0], o, pb) for o, pb in boxes.items())
            for out in draws
            if out is not None
        )

    blind = list(itertools.islice(km.sample_placement("block", "counter"), 60))
    assert on_a_box(blind) >= 3
    seeing = module(boxes)
    clear = list(itertools.islice(seeing.sample_placement("block", "counter"), 60))
    assert sum(out is not None for out in clear) >= 50
    assert on_a_box(clear) == 0


def _corner_failures(task, bases, obj, p, g) -> int:
    """Corners (landings) of ``bases`` from which a fresh sampler finds no grasp path."""
    check = KitchenStreams(task.world, np.random.default_rng(99))
    return sum(check.inv_kin(obj, p, g, c) is None for b in bases for c in samplers._landings(b))


def test_a_reached_base_is_reached_from_where_a_motion_to_it_lands(monkeypatch):
    # Stow seed 0 drove to eight bases in a row: where each motion landed (about a centimetre
    # off), the grasp it drove there for was out of the arm's reach.  inv-reach now returns
    # bases whose landing corners reach the grasp too.
    task = make_task("stow", 0)
    try:
        ks = KitchenStreams(task.world, np.random.default_rng(2))
        p = ks.current_pose("block")
        g = next(g for (g,) in ks.sample_grasps("block") if g.kind == "top")
        checked = [b for (b,) in itertools.islice(ks.inv_reach("block", p, g), 20)]
        assert len(checked) == 20
        monkeypatch.setattr(KitchenStreams, "lands", lambda *a: True)
        loose = KitchenStreams(task.world, np.random.default_rng(2))
        unchecked = [b for (b,) in itertools.islice(loose.inv_reach("block", p, g), 20)]
        assert len(unchecked) == 20
        with_check = _corner_failures(task, checked, "block", p, g)
        without = _corner_failures(task, unchecked, "block", p, g)
        assert without >= 4  # without the check, landings miss the grasp
        assert with_check <= 1
    finally:
        task.close()


def test_drawer_bases_reach_the_handle_from_near_too_and_are_reused():
    # The bottom drawer's handle is low: about 1 sampled base in 20 reaches it over the
    # drawer's travel, fewer from where a motion lands; the scripted Swap once found no push
    # from 6 mm off the base it drove to.
    from ssr_compile.sim.world import DRAWER_TRAVEL

    task = make_task("inspect", 0)
    try:
        ks = KitchenStreams(task.world, np.random.default_rng(0))
        first = next(iter(ks.sample_drawer_base("bottom_drawer")))[0]
        for b in samplers._landings(first):
            assert ks.plan_drawer("bottom_drawer", 0.0, DRAWER_TRAVEL, b) is not None
        # asked again, the base that served comes first
        assert next(iter(ks.sample_drawer_base("bottom_drawer")))[0] == first
    finally:
        task.close()


def test_drawer_bases_are_sampled_beside_the_drawers_axis():
    # Seen from the open handle, a base in front of the drawer has the hand pull the handle
    # into the robot; beside the axis, on the side that serves, 1 base in 6 serves the bottom
    # drawer from where it lands too, 1 in 16 within +-60 deg.  The bases drawn are beside it,
    # three in four on that side, and serve.
    from ssr_compile.sim.robot import mount_position
    from ssr_compile.sim.world import DRAWER_TRAVEL

    task = make_task("inspect", 0)
    try:
        ks = KitchenStreams(task.world, np.random.default_rng(3))
        handle = np.asarray(ks.handle_tool("bottom_drawer", DRAWER_TRAVEL)[0][:2])
        lo, hi = samplers.DRAWER_BEARING
        drawn = []
        near = ks._sample_base_near

        def record(target, r_range, bearing):
            base = near(target, r_range, bearing)
            drawn.append(base)
            return base

        ks._sample_base_near = record
        bases = [b for (b,), _ in zip(ks.sample_drawer_base("bottom_drawer"), range(2))]
        assert len(bases) == 2 and len(drawn) >= 8
        bearings = []
        for base in drawn:
            away = handle - np.asarray(mount_position(base))[:2]
            bearings.append(math.atan2(away[1], away[0]))
            assert lo - 0.05 <= abs(bearings[-1]) <= hi + 0.05, bearings[-1]
        assert [b > 0 for b in bearings[:8]] == [True, True, True, False] * 2
        for base in bases:
            assert ks.plan_drawer("bottom_drawer", 0.0, DRAWER_TRAVEL, base) is not None
    finally:
        task.close()


def _carry_episode():
    """The Cook episode after its first look, and a straight arm path tuck -> carry of 11
    waypoints: ``(episode, agent, km, base, path, step)``, ``step`` that path as a move-arm."""
    from types import SimpleNamespace

    from ssr_compile.sim.robot import ARM_CARRY
    from ssr_compile.streams.environments.kitchen import make_episode

    episode = make_episode("cook", 0)
    agent, env = episode.agent, episode.environment
    agent.update(None, env.observe())
    base = agent.known.base
    tuck, carry = np.asarray(ARM_TUCK, float), np.asarray(ARM_CARRY, float)
    path = tuple(tuple(tuck + (carry - tuck) * k / 10) for k in range(11))
    step = SimpleNamespace(name="move-arm", args=("bq0", "aq0", "t-1", "aq-carry"),
                           values=(base, path[0], path, path[-1]))  # fmt: skip
    return episode, agent, agent.km, base, path, step


def test_an_arm_motion_the_world_stopped_is_not_planned_again():
    # Cook seed 5 executed one carry motion 90 times: the true world stopped the arm at the
    # same waypoint each time (the planning world did not know what it hit), and the motion
    # stream, asked again from where the arm stood, planned through it again.
    from types import SimpleNamespace

    from ssr_compile.streams.kitchen_motion import BLOCKED

    episode, agent, km, base, path, step = _carry_episode()
    try:
        assert km.plan_arm_motion(base, path[3], path[-1]) is not None
        assert km.blocked(base) is None  # nothing refused yet
        # the world stopped the arm at waypoint 3 of the path: waypoint 4 collided
        obs = SimpleNamespace(ok=False, arm=path[3], base=base, held=None, stove_on=False)
        agent._collided(step, path[0], obs)
        ((b, stop, hit, held),) = km.collided
        assert np.allclose(stop, path[3]) and np.allclose(hit, path[4]) and held is None
        test = km.blocked(base)
        assert test(np.asarray(path[4])) and test(np.asarray(path[5]))
        assert not test(np.asarray(path[3]))  # the arm can leave where it stopped
        assert km.blocked((base[0] + 0.2, base[1], base[2])) is None  # another base
        # what the empty hand's motion hit says nothing of the motions with the block in it
        km.holding = ("block", None)
        assert km.blocked(base) is None
        km.holding = None
        (motion,) = km.plan_arm_motion(base, path[3], path[-1])
        for q in motion:
            q = np.asarray(q)
            d_hit = np.max(np.abs(q - path[4]))
            assert not (d_hit <= BLOCKED and d_hit <= np.max(np.abs(q - np.asarray(path[3]))))
    finally:
        episode.close()


def test_an_arm_motion_is_checked_with_the_drawers_where_the_plan_has_them():
    # Swap without deferral opened the bottom drawer, saw nothing, and then could not plan
    # to pull it open again later (after closing it to open the top one): every motion to the
    # pull's approach at the closed handle was checked against the drawer open, where the
    # hand is inside it, and failed level after level until the instance cap.  The motion is
    # checked with the drawers as its reach end was computed (the approach: drawer closed).
    from ssr_compile.sim.robot import ARM_TUCK
    from ssr_compile.sim.world import DRAWER_TRAVEL
    from ssr_compile.streams.kitchen_module import KitchenModule

    task = make_task("swap", 0)
    try:
        km = KitchenModule(task, np.random.default_rng(0))
        task.world.set_drawer("bottom_drawer", DRAWER_TRAVEL)
        km.drawers["bottom_drawer"] = DRAWER_TRAVEL  # what the robot saw: the bottom one open
        closed, opened = ("bottom_drawer-closed", 0.0), ("bottom_drawer-open", DRAWER_TRAVEL)
        tried = 0
        for draw in itertools.islice(km.sample_drawer_base("bottom_drawer"), 20):
            if draw is None:
                continue
            (bq,) = draw
            pull = km._plan_drawer("bottom_drawer", closed, opened, bq)
            if pull is None:
                continue
            aq1, aq2, _ = pull
            # the approach has both drawers closed, the pull's end the bottom one open
            assert km._openings_at(ARM_TUCK, aq1) == {"top_drawer": 0.0, "bottom_drawer": 0.0}
            assert km._openings_at(aq2, ARM_TUCK)["bottom_drawer"] == DRAWER_TRAVEL
            assert km.plan_arm_motion(bq, ARM_TUCK, aq1) is not None
            saved = dict(km._reach_openings)
            km._reach_openings.clear()  # as before: the drawers where the robot saw them
            assert km.plan_arm_motion(bq, ARM_TUCK, aq1) is None  # the hand in the open drawer
            km._reach_openings.update(saved)
            tried += 1
            if tried == 2:
                break
        assert tried == 2
    finally:
        task.close()


def test_inv_reach_tries_no_base_where_the_hand_itself_meets_the_cabinet(monkeypatch):
    # Swap's drawers: the block's top grasps at placements all over the open drawer.  Where the
    # hand alone (whatever the arm) enters the cabinet on its approach, inv-reach returns at
    # once, without an IK call; and no such placement is reached from any base by a full
    # batch of 30 attempts.  Some placements are hand-blocked, some reached.
    from ssr_compile.sim.samplers import ObjPose
    from ssr_compile.sim.world import DRAWER_TRAVEL

    task = make_task("swap", 0)
    try:
        w = task.world
        ks = KitchenStreams(w, np.random.default_rng(0), hand_check=True)
        for o in list(w.objects):
            if w.support.get(o) is not None:
                w.remove_object(o)
        w.set_drawer("bottom_drawer", DRAWER_TRAVEL)
        s = w.surfaces["bottom_drawer"]
        grasps = [g for g in ks.grasps("block") if g.kind == "top"]
        # rel x along the drawer: 0.05-0.07 and 0.3 towards its ends, 0.2 in the middle (where
        # Swap seed 0's placements failed and were reached)
        pairs = [
            (ObjPose("block", "bottom_drawer", w.rest_pose("block", "bottom_drawer", x, y, 0.0)), g)
            for x, y in ((0.052, 0.201), (0.304, -0.027), (0.2, 0.0), (0.07, 0.025))
            for g in grasps
        ]
        assert all(ks.placement_valid(p) for p, _ in pairs)
        blocked = [(p, g) for p, g in pairs if ks.hand_blocked("block", p, g)]
        assert blocked and len(blocked) < len(pairs)
        iks = []
        real_ik = w.robot.inverse_kinematics
        monkeypatch.setattr(
            w.robot, "inverse_kinematics", lambda *a, **k: iks.append(1) or real_ik(*a, **k)
        )
        for p, g in blocked:
            assert next(iter(ks.inv_reach("block", p, g)), None) is None
        assert not iks
        # a full batch from bases sampled as ever: none reaches a blocked pair
        monkeypatch.setattr(ks, "hand_blocked", lambda *a: False)
        for p, g in blocked:
            assert next(iter(ks.inv_reach("block", p, g)), None) is None
        assert iks  # the batches tried bases this time
        reached = [
            next(iter(ks.inv_reach("block", p, g)), None) for p, g in pairs if (p, g) not in blocked
        ]
        assert any(r is not None for r in reached)
        assert s.lo[0] < 0.052 and s.hi[0] > 0.304
    finally:
        task.close()


def test_a_reach_no_base_can_make_ends_the_inv_reach_stream(cook0):
    # The planner's inv-reach for a side grasp of the cracker box whose hand would move in
    # facing the robot: no base reaches it in this scene, so the stream ends (its instance is
    # used up for the solve) instead of answering "nothing this time" at every level.  A grasp
    # some base may reach answers per batch and is not used up by a batch that found nothing.
    from ssr_compile.streams.kitchen_module import KitchenModule

    from ssr_compile.belief.particles import PoseBelief
    from ssr_compile.stream import Generator

    km = KitchenModule(cook0, np.random.default_rng(0))
    pos, quat = cook0.world.object_pose("cracker_box")
    surface = cook0.prior_surfaces()["cracker_box"][0][0]
    pb = PoseBelief.point("cracker_box", surface, (pos[0], pos[1], pos[2], yaw_of(quat)))
    ks, p = km.ks, km.obj_pose(pb)
    grasps = ks.grasps("cracker_box")
    facing = [g for g in grasps if abs(_bearing(ks, p, g) or 0.0) > samplers.SIDE_BEARING_LIMIT]
    others = [g for g in grasps if _bearing(ks, p, g) is None]
    assert facing and others
    for g in facing:
        gen = Generator(km.inv_reach, ("cracker_box", pb, g), "generator", "inv-reach")
        assert gen.next() is None and gen.exhausted
    gen = Generator(km.inv_reach, ("cracker_box", pb, others[0]), "generator", "x")
    for _ in range(2):
        out = gen.next()
        assert not gen.exhausted
        if out is not None:  # a base that really reaches the grasp
            assert ks.inv_kin("cracker_box", p, others[0], out[0]) is not None


def test_a_motion_refused_with_one_object_in_hand_is_refused_only_with_that_object():
    # The cluttered kitchen (cook, 8 objects, 6 boxes, seed 2): three carry motions with a box
    # in the hand hit other boxes and were refused around the carry configuration; later,
    # with the block in the hand, every motion to carry was refused as well, and the robot
    # moved its arm from one reach configuration to the next for 40 cycles.
    from types import SimpleNamespace

    episode, agent, km, base, path, step = _carry_episode()
    try:
        agent.known.held = ("sugar_box", None)  # as the agent knows it after a pick
        obs = SimpleNamespace(ok=False, arm=path[8], base=base, held="sugar_box", stove_on=False)
        agent._collided(step, path[0], obs)
        assert km.collided[0][3] == "sugar_box"
        for holding, refused in ((("sugar_box", None), True), (("block", None), False),
                                 (None, False)):  # fmt: skip
            km.holding = holding
            test = km.blocked(base)
            assert (test is not None and test(np.asarray(path[9]))) == refused, holding
    finally:
        episode.close()
