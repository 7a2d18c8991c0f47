"""Planner: IK round trips (Panda, UR5), plans re-checked densely by an independent
collision checker, trajectory limits, joint reordering, statuses and bad input."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import ferrobot
from conftest import MBM, mbm_problem, random_configurations
from ferrobot import CollisionChecker, CollisionWorld, Planner, SphereModel
from ferrobot import errors as E
from ferrobot.transforms import base_to_world, matrix_to_pose, quat_xyzw_to_wxyz, world_to_base

SPHERIZED = MBM.parent.parent / "robots" / "panda" / "panda_spherized.urdf"


def pose_errors(model, q_full, pose7, link=None):
    got = model.fk(q_full, link) if link else model.fk(q_full)
    got, pose7 = (matrix_to_pose(x) if np.ndim(x) == 2 else x for x in (got, pose7))
    dp = np.linalg.norm(got[:3] - pose7[:3])
    r_got = Rotation.from_quat(np.r_[got[4:], got[3]])
    r_want = Rotation.from_quat(np.r_[pose7[4:], pose7[3]])
    return dp, (r_want * r_got.inv()).magnitude()


def full(planner, q_active):
    out = planner.locked_positions.copy()
    idx = [planner.dof_names.index(n) for n in planner.joint_names]
    out[idx] = q_active
    return out


@pytest.fixture(scope="module")
def panda_planner(bundled_panda):
    return Planner(bundled_panda)


@pytest.mark.parametrize("robot", ["bundled_panda", "ur5"])
def test_ik_round_trips(robot, request):
    model = request.getfixturevalue(robot)
    planner = Planner(model, spheres=None)
    qs = random_configurations(model, 60, seed=1)
    lo, hi = planner.limits.lower, planner.limits.upper
    for q in qs:
        pose = model.fk(q)
        r = planner.ik(pose)
        assert r.success, (q, r.position_error, r.rotation_error)
        qf = full(planner, r.q)
        dp, dr = pose_errors(model, qf, pose)
        assert dp <= 1e-3 and dr <= 0.01
        assert np.all(r.q >= lo - 1e-12) and np.all(r.q <= hi + 1e-12)
    # Batches in parallel: every pose solved, errors measured independently.
    poses = np.array([model.fk(q) for q in qs])
    b = planner.ik_batch(poses)
    assert b.success.shape == (60,) and b.success.all()
    for qa, pose in zip(b.q, poses, strict=True):
        dp, dr = pose_errors(model, full(planner, qa), pose)
        assert dp <= 1e-3 and dr <= 0.01


def test_ik_goalset_and_collision_free(bundled_panda, panda_planner):
    q = bundled_panda.named_state("ready")
    reachable = matrix_to_pose(bundled_panda.fk(q))
    far = reachable.copy()
    far[:3] = [3.0, 0.0, 0.5]
    r = panda_planner.ik_goalset(np.stack([far, reachable]))
    assert r.success and r.goal_index == 1
    assert not panda_planner.ik(far).success

    # A ball at the ready pose's elbow: IK seeded at ready returns ready
    # (in collision); collision-free IK finds another solution, free by an
    # independent checker.
    world = CollisionWorld()
    world.add_sphere("ball", 0.06, [0.1, 0.0, 0.75, 1, 0, 0, 0])
    p = Planner(bundled_panda, world)
    checker = CollisionChecker(bundled_panda, world)
    target = bundled_panda.fk(q)
    plain = p.ik(target, start=q[:7])
    assert plain.success and checker.in_collision(full(p, plain.q))
    sol = p.ik(target, start=q[:7], collision_free=True)
    assert sol.success
    assert not checker.in_collision(full(p, sol.q))
    dp, dr = pose_errors(bundled_panda, full(p, sol.q), target)
    assert dp <= 1e-3 and dr <= 0.01


def mbm_planner_for(scene):
    model = ferrobot.RobotModel.from_urdf(MBM.parent.parent / "robots/panda/panda.urdf")
    spheres = SphereModel.from_spherized_urdf(model, SPHERIZED)
    world = CollisionWorld.from_moveit_scene(scene)
    return model, Planner(model, world, spheres), CollisionChecker(model, world, spheres)


@pytest.mark.parametrize(
    "scene",
    [MBM / "table_pick_panda" / f"scene{i:04d}.yaml" for i in (2, 17, 45)]
    + [MBM / "bookshelf_small_panda" / f"scene{i:04d}.yaml" for i in (3, 58, 91)],
    ids=lambda p: f"{p.parent.name}-{p.stem}",
)
def test_mbm_plans_are_collision_free_and_within_limits(scene):
    model, planner, checker = mbm_planner_for(scene)
    start_d, goal_d = mbm_problem(scene)
    names = planner.joint_names
    start = np.array([start_d[n] for n in names])
    goal = np.array([goal_d[n] for n in names])
    r = planner.plan(start, goal_q=goal)
    assert r.success, r.message
    path = r.path
    np.testing.assert_array_equal(path[0], start)
    np.testing.assert_array_equal(path[-1], goal)
    # Path: each edge re-checked by an independent checker at 5 mrad.
    to_full = lambda q: full(planner, q)  # noqa: E731
    for a, b in zip(path[:-1], path[1:], strict=True):
        assert checker.motion_valid(to_full(a), to_full(b), 0.005)
    # Trajectory: sampled so that no joint moves more than 5 mrad between samples.
    vmax = planner.limits.velocity
    t = r.interpolated(dt=0.004 / vmax.max())
    steps = np.abs(np.diff(t.positions, axis=0)).max()
    assert steps <= 0.005
    assert not checker.in_collision_batch(np.array([to_full(q) for q in t.positions])).any()
    check_limits(planner, r, start, goal)


def check_limits(planner, r, start, goal):
    lim = planner.limits
    t = r.interpolated(dt=0.001)
    pos, vel, acc = t.positions, t.velocities, t.accelerations
    np.testing.assert_allclose(pos[0], start, atol=1e-12)
    np.testing.assert_allclose(pos[-1], goal, atol=1e-9)
    np.testing.assert_allclose(vel[[0, -1]], 0.0, atol=1e-9)
    np.testing.assert_allclose(acc[[0, -1]], 0.0, atol=1e-9)
    assert np.all(pos >= lim.lower - 1e-9) and np.all(pos <= lim.upper + 1e-9)
    assert np.all(np.abs(vel) <= lim.velocity * (1 + 1e-6))
    assert np.all(np.abs(acc) <= lim.acceleration * (1 + 1e-6))
    # Velocities match the positions' finite differences (the samples are consistent).
    dt = np.diff(t.times)
    fd = np.diff(pos, axis=0) / dt[:, None]
    mid = 0.5 * (vel[1:] + vel[:-1])
    assert np.abs(fd - mid).max() < 1e-3
    # Jerk: finite differences of the (piecewise-linear) acceleration.
    jerk = np.diff(acc, axis=0) / dt[:, None]
    assert np.all(np.abs(jerk) <= lim.jerk * (1 + 1e-6))


def test_scaled_limits_hold_and_slow_down(bundled_panda, panda_planner):
    q0 = bundled_panda.named_state("ready")[:7]
    q1 = np.array([0.5, -0.3, 0.2, -2.0, 0.1, 1.8, 0.5])
    fast = panda_planner.plan(q0, goal_q=q1)
    slow = panda_planner.plan(q0, goal_q=q1, velocity_scale=0.25, acceleration_scale=0.25)
    assert fast.success and slow.success
    assert slow.duration > 2 * fast.duration
    check_limits(panda_planner, fast, q0, q1)
    v = slow.interpolated(0.002).velocities
    assert np.all(np.abs(v) <= 0.25 * panda_planner.limits.velocity * (1 + 1e-6))


def test_joint_reordering(bundled_panda, panda_planner):
    q0 = bundled_panda.named_state("ready")[:7]
    q1 = np.array([0.5, -0.3, 0.2, -2.0, 0.1, 1.8, 0.5])
    # A simulator's order: fingers first (one of them a mimic joint), arm reversed.
    order = ["panda_finger_joint1", "panda_finger_joint2"] + [f"panda_joint{i}" for i in range(7, 0, -1)]
    perm = [6, 5, 4, 3, 2, 1, 0]
    ref = panda_planner.plan(q0, goal_q=q1, seed=3)
    sim_start = np.r_[0.04, 0.04, q0[perm]]
    sim_goal = np.r_[0.04, 0.04, q1[perm]]
    r = panda_planner.plan(sim_start, goal_q=sim_goal, joint_names=order, seed=3)
    assert r.success and r.joint_names == order
    np.testing.assert_allclose(r.path[:, 2:], ref.path[:, perm])
    np.testing.assert_allclose(r.interpolated(0.01).positions[:, 2:], ref.interpolated(0.01).positions[:, perm])
    # The finger the planner does not move keeps the start's value for this plan (its mimic follows);
    # the planner's own locked value is unchanged.
    np.testing.assert_allclose(r.path[:, :2], 0.04)
    np.testing.assert_allclose(r.interpolated(0.01).positions[:, :2], 0.04)
    finger = bundled_panda.dof_names.index("panda_finger_joint1")
    assert panda_planner.locked_positions[finger] == bundled_panda.neutral_configuration()[finger]
    # IK in the same order.
    ik = panda_planner.ik(bundled_panda.fk(np.r_[q1, 0.0]), start=sim_start, joint_names=order)
    assert ik.success and ik.q.shape == (9,)


def test_statuses(bundled_panda):
    world = CollisionWorld()
    world.add_box("block", [0.1, 0.1, 0.1], [0.5, 0.0, 0.4, 1, 0, 0, 0])
    planner = Planner(bundled_panda, world)
    q0 = bundled_panda.named_state("ready")[:7]
    # A goal whose hand sits inside the block: find one by IK.
    inside = planner.ik(np.array([0.5, 0.0, 0.4, 0, 1, 0, 0]))
    assert inside.success
    r = planner.plan(q0, goal_q=inside.q)
    assert not r.success and r.status == "goal_in_collision" and "block" in r.message
    r = planner.plan(inside.q, goal_q=q0)
    assert r.status == "start_in_collision" and r.path.shape[0] == 0
    r = planner.plan(q0, goal_pose=np.array([0.5, 0.0, 0.4, 0, 1, 0, 0]))
    assert r.status == "ik_failed"
    r = planner.plan(q0, goal_pose=np.array([3.0, 0.0, 0.4, 1, 0, 0, 0]))
    assert r.status == "ik_failed"
    bad = q0.copy()
    bad[0] = 5.0
    assert planner.plan(q0, goal_q=bad).status == "goal_out_of_limits"
    assert planner.plan(bad, goal_q=q0).status == "start_out_of_limits"
    with pytest.raises(E.InvalidArgumentError):
        r.interpolated()


def test_pose_goal_reaches_the_pose(bundled_panda, panda_planner):
    q0 = bundled_panda.named_state("ready")[:7]
    target = bundled_panda.fk(np.r_[0.4, -0.2, 0.1, -2.2, 0.0, 2.0, 0.6, 0.0])
    r = panda_planner.plan(q0, goal_pose=target)
    assert r.success
    dp, dr = pose_errors(bundled_panda, full(panda_planner, r.path[-1]), target)
    assert dp <= 1e-3 and dr <= 0.01


def test_bad_input(bundled_panda, panda_planner):
    q0 = bundled_panda.named_state("ready")[:7]
    with pytest.raises(E.ShapeError):
        panda_planner.plan(q0[:5], goal_q=q0)
    with pytest.raises(E.NonFiniteError):
        panda_planner.plan(np.r_[np.nan, q0[1:]], goal_q=q0)
    with pytest.raises(E.UnknownNameError):
        panda_planner.plan(q0, goal_q=q0, joint_names=["nope"] * 7)
    with pytest.raises(E.InvalidArgumentError):
        panda_planner.plan(q0, goal_q=q0, joint_names=[f"panda_joint{i}" for i in range(1, 7)])
    with pytest.raises(E.InvalidArgumentError):
        panda_planner.plan(q0, goal_q=q0, goal_pose=bundled_panda.fk(np.r_[q0, 0]))
    with pytest.raises(E.InvalidArgumentError):
        panda_planner.plan(q0, goal_q=q0, velocity_scale=2.0)
    with pytest.raises(E.InvalidArgumentError):
        panda_planner.ik(np.array([0.3, 0, 0.5, 2, 0, 0, 0]))
    with pytest.raises(E.ShapeError):
        panda_planner.ik_batch(np.zeros((3, 6)))
    with pytest.raises(E.InvalidArgumentError):
        panda_planner.set_limits(acceleration=-np.ones(7))


def test_frames_against_scipy():
    rng = np.random.default_rng(0)
    for _ in range(20):
        rb, rp = Rotation.random(random_state=rng), Rotation.random(random_state=rng)
        tb, tp = rng.normal(size=3), rng.normal(size=3)
        base = np.r_[tb, quat_xyzw_to_wxyz(rb.as_quat())]
        pose_w = np.r_[tp, quat_xyzw_to_wxyz(rp.as_quat())]
        got = world_to_base(pose_w, base)
        want_r = rb.inv() * rp
        want_t = rb.inv().apply(tp - tb)
        np.testing.assert_allclose(got[:3], want_t, atol=1e-12)
        got_r = Rotation.from_quat(np.r_[got[4:], got[3]])
        assert (got_r * want_r.inv()).magnitude() < 1e-9
        back = base_to_world(got, base)
        np.testing.assert_allclose(back[:3], tp, atol=1e-12)
        np.testing.assert_allclose(world_to_base(np.eye(4), np.eye(4)), np.eye(4))


def test_ik_start_and_seed_spellings(bundled_panda, panda_planner):
    """``start`` is the IK start configuration and ``seed`` the random seed (issue 16); the old spellings
    (``seed=<configuration>``, ``random_seed``, ``ik_batch(seeds=...)``) still work for one release, with a
    DeprecationWarning, and give the same solutions; mixing old and new for one argument is an error."""
    q = bundled_panda.named_state("ready")
    target = bundled_panda.fk(q)
    new = panda_planner.ik(target, start=q[:7], num_seeds=4, seed=5)
    assert new.success
    with pytest.warns(DeprecationWarning, match="start configuration is `start`"):
        old = panda_planner.ik(target, seed=q[:7], num_seeds=4)
    np.testing.assert_array_equal(old.q, panda_planner.ik(target, q[:7], num_seeds=4).q)
    with pytest.warns(DeprecationWarning, match="random_seed"):
        old = panda_planner.ik_goalset(target[None], num_seeds=4, random_seed=5)
    np.testing.assert_array_equal(old.q, panda_planner.ik_goalset(target[None], num_seeds=4, seed=5).q)
    far = target.copy()
    far[:3, 3] += [0.05, 0.0, -0.05]
    poses = np.stack([target, far])
    starts = np.tile(q[:7], (2, 1))
    new = panda_planner.ik_batch(poses, starts, num_seeds=4, seed=2)
    with pytest.warns(DeprecationWarning, match="starts"):
        old = panda_planner.ik_batch(poses, seeds=starts, num_seeds=4, seed=2)
    np.testing.assert_array_equal(old.q, new.q)
    with pytest.warns(DeprecationWarning, match="random_seed"):
        old = panda_planner.ik_batch(poses, starts, num_seeds=4, random_seed=2)
    np.testing.assert_array_equal(old.q, new.q)
    with pytest.raises(E.InvalidArgumentError, match="not both"), pytest.warns(DeprecationWarning):
        panda_planner.ik(target, q[:7], seed=q[:7])
    with pytest.raises(E.InvalidArgumentError, match="not both"):
        panda_planner.ik_batch(poses, starts, seeds=starts)
