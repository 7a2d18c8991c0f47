"""Reactive and potential-field controllers: distances against hand geometry, closed-loop behaviour, validation.

References are independent of the controllers: sphere centres are placed with ``RobotModel.fk`` (checked against
Pinocchio elsewhere) and ``SphereModel.spheres``; distances to spheres and boxes are written out by hand; gradients
are central finite differences of those hand distances.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import ferrobot
from ferrobot import errors


@pytest.fixture(scope="module")
def panda():
    model = ferrobot.robots.panda()
    return model, ferrobot.SphereModel.automatic(model, total_budget=59)


def placed_spheres(model, spheres, q):
    """(S, 4) sphere centres (base frame) and radii, placed by the model's FK."""
    out = []
    for link in model.link_names:
        s = spheres.spheres(link)
        if len(s) == 0:
            continue
        T = model.fk(q, link)
        out.extend(np.c_[(T[:3, :3] @ s[:, :3].T).T + T[:3, 3], s[:, 3]])
    return np.array(out)


def box_distance(p, center, half):
    d = np.abs(p - center) - half
    outside = np.linalg.norm(np.maximum(d, 0.0))
    return outside + min(max(d.max(), -np.inf), 0.0)


def hand_distances(P, ball_c, ball_r, box_c, box_h):
    """Signed distance of each sphere (rows of P: x, y, z, r) to the nearer of a ball and an axis-aligned box."""
    db = np.linalg.norm(P[:, :3] - ball_c, axis=1) - ball_r
    dx = np.array([box_distance(p, box_c, box_h) for p in P[:, :3]])
    return np.minimum(db, dx) - P[:, 3]


def test_sphere_distances_and_gradients_match_hand_geometry(panda):
    model, spheres = panda
    ball_c, ball_r = np.array([0.45, 0.25, 0.45]), 0.07
    box_c, box_h = np.array([0.4, -0.3, 0.3]), np.array([0.1, 0.15, 0.05])
    world = ferrobot.CollisionWorld()
    world.add_sphere("ball", ball_r, [*ball_c, 1, 0, 0, 0])
    world.add_box("crate", 2 * box_h, [*box_c, 1, 0, 0, 0])
    ctl = ferrobot.ReactiveController(model, world, spheres)
    q = model.named_state("ready")
    got = ctl.sphere_distances(q, reach=10.0)
    P = placed_spheres(model, spheres, q)
    assert len(P) == ctl.num_spheres == 59
    # Match the controller's spheres to the independently placed ones.
    order = []
    for c, r in zip(got.centers, got.radii, strict=True):
        i = int(np.argmin(np.linalg.norm(P[:, :3] - c, axis=1) + np.abs(P[:, 3] - r)))
        assert np.linalg.norm(P[i, :3] - c) < 1e-9 and abs(P[i, 3] - r) < 1e-12
        order.append(i)
    expect = hand_distances(P[order], ball_c, ball_r, box_c, box_h)
    np.testing.assert_allclose(got.distance, expect, atol=1e-9)
    h = 1e-6
    for dof in range(7):
        qp, qm = q.copy(), q.copy()
        qp[dof] += h
        qm[dof] -= h
        fd = (
            hand_distances(placed_spheres(model, spheres, qp)[order], ball_c, ball_r, box_c, box_h)
            - hand_distances(placed_spheres(model, spheres, qm)[order], ball_c, ball_r, box_c, box_h)
        ) / (2 * h)
        np.testing.assert_allclose(got.gradient[:, dof], fd, atol=1e-5)


def run(ctl, q, n, dt=0.01, each=None):
    qd = np.zeros_like(q)
    for k in range(n):
        if each is not None:
            each(ctl, k * dt)
        q, qd, _ = ctl.step(q, qd, dt)
    return q, qd


@pytest.mark.parametrize("cls", [ferrobot.ReactiveController, ferrobot.PotentialFieldController])
def test_converges_to_a_reachable_target_without_obstacles(panda, cls):
    model, spheres = panda
    q0 = model.named_state("ready")
    goal = q0.copy()
    goal[:7] += [0.4, 0.2, -0.3, -0.4, 0.2, 0.3, -0.3]
    target = model.fk(goal)
    ctl = cls(model, None, spheres)
    ctl.set_target(target)
    q, _ = run(ctl, q0, 600 if cls is ferrobot.ReactiveController else 2000)
    T = model.fk(q)
    assert np.linalg.norm(T[:3, 3] - target[:3, 3]) < 0.01
    r = T[:3, :3].T @ target[:3, :3]
    assert np.arccos(np.clip((np.trace(r) - 1) / 2, -1, 1)) < 0.05


def test_never_enters_a_ball_flying_at_the_hand(panda):
    model, spheres = panda
    q0 = model.named_state("ready")
    hand = model.fk(q0)[:3, 3]
    for direction in ([0.0, -1.0, 0.0], [-0.6, 0.8, 0.0], [0.0, 0.0, -1.0]):
        v = 0.5 * np.asarray(direction)
        start = hand - 1.2 * v  # reaches the hand after 1.2 s
        world = ferrobot.CollisionWorld()
        world.add_sphere("ball", 0.05, [*start, 1, 0, 0, 0])
        ctl = ferrobot.ReactiveController(model, world, spheres)
        ctl.set_target(model.fk(q0))
        q, qd = q0.copy(), np.zeros(8)
        worst = np.inf
        for k in range(300):
            c = start + v * k * 0.01
            ctl.set_obstacle_pose("ball", [*c, 1, 0, 0, 0], v)
            q, qd, _ = ctl.step(q, qd, 0.01)
            P = placed_spheres(model, spheres, q)
            worst = min(worst, (np.linalg.norm(P[:, :3] - c, axis=1) - 0.05 - P[:, 3]).min())
            assert ctl.exact_clearance(q).distance > 0.0
        assert worst > 0.0, direction


def test_joint_limits_and_velocities_are_respected(panda):
    model, spheres = panda
    ctl = ferrobot.ReactiveController(model, None, spheres)
    ctl.set_target([1.6, 0.9, -0.2, 1, 0, 0, 0], orientation=False)  # out of reach
    q, qd = model.named_state("ready"), np.zeros(8)
    lo, hi, vmax = model.lower_limits, model.upper_limits, model.velocity_limits
    for _ in range(300):
        q, qd, _ = ctl.step(q, qd, 0.01)
        assert np.all(q >= lo) and np.all(q <= hi)
        assert np.all(np.abs(qd) <= vmax + 1e-12)


def test_joint_names_reorder_inputs_and_outputs(panda):
    model, spheres = panda
    a = ferrobot.ReactiveController(model, None, spheres)
    b = ferrobot.ReactiveController(model, None, spheres)
    target = [0.4, 0.2, 0.4, 0, 1, 0, 0]
    a.set_target(target)
    b.set_target(target)
    q = model.named_state("ready")
    qd = np.linspace(-0.1, 0.1, 8)
    perm = np.arange(8)[::-1]
    names = [model.dof_names[i] for i in perm]
    ref = a.step(q, qd, 0.01)
    got = b.step(q[perm], qd[perm], 0.01, joint_names=names)
    for x, y in zip(ref, got, strict=True):
        np.testing.assert_allclose(x[perm], y, atol=1e-12)


def test_bad_inputs_raise_ferrobot_errors(panda):
    model, spheres = panda
    world = ferrobot.CollisionWorld()
    world.add_sphere("ball", 0.05, [0.5, 0, 0.5, 1, 0, 0, 0])
    ctl = ferrobot.ReactiveController(model, world, spheres)
    q, qd = model.named_state("ready"), np.zeros(8)
    with pytest.raises(errors.NonFiniteError, match="pose"):
        ctl.set_target([np.nan, 0, 0.5, 1, 0, 0, 0])
    with pytest.raises(errors.ShapeError, match="q"):
        ctl.step(q[:7], qd, 0.01)
    with pytest.raises(errors.NonFiniteError, match="qd"):
        ctl.step(q, np.full(8, np.nan), 0.01)
    with pytest.raises(errors.InvalidArgumentError, match="dt"):
        ctl.step(q, qd, 0.0)
    with pytest.raises(errors.UnknownNameError, match="elbow"):
        ctl.step(q, qd, 0.01, joint_names=["elbow", *model.dof_names[1:]])
    with pytest.raises(errors.InvalidArgumentError, match="missing"):
        ctl.step(q, qd, 0.01, joint_names=model.dof_names[:7])
    with pytest.raises(errors.UnknownNameError, match="nothing"):
        ctl.set_obstacle_pose("nothing", [0, 0, 0, 1, 0, 0, 0])
    with pytest.raises(errors.ShapeError, match="velocity"):
        ctl.set_obstacle_pose("ball", [0, 0, 0, 1, 0, 0, 0], [1.0, 2.0])
    with pytest.raises(errors.UnknownNameError, match="target_gian"):
        ferrobot.ReactiveController(model, None, spheres, config={"target_gian": 1.0})
    with pytest.raises(errors.InvalidArgumentError, match="collision_distance"):
        ctl.set_config({"collision_distance": -1.0})
    with pytest.raises(errors.UnknownNameError, match="no_link"):
        ferrobot.ReactiveController(model, None, spheres, ee_link="no_link")
    with pytest.raises(errors.InvalidArgumentError, match="field_padding"):
        ferrobot.PotentialFieldController(model, None, spheres, config={"field_padding": 0.05})
    lo, hi = ferrobot.ReactiveController.config_ranges()["target_gain"]
    assert lo <= ctl.config["target_gain"] <= hi
    # Global guidance waypoints: (N, num_dof) or (N, 7) rows, finite, inside the limits' shape rules.
    with pytest.raises(errors.InvalidArgumentError, match="waypoints"):
        ctl.set_waypoints(np.zeros((2, 3)))
    with pytest.raises(errors.NonFiniteError, match="waypoints"):
        ctl.set_waypoints(np.full((1, 8), np.nan))
    with pytest.raises(errors.ShapeError, match="waypoints"):
        ctl.set_waypoints(np.zeros(8))
    ctl.set_waypoints(np.tile(q[:7], (3, 1)))
    assert ctl.waypoints_remaining == 3
    ctl.clear_waypoints()
    assert ctl.waypoints_remaining == 0


def test_closed_loop_with_the_simulator(panda):
    """The controller drives the simulated Panda through its position drives (state in, targets out)."""
    model, spheres = panda
    world = ferrobot.World(dt=1 / 240)
    q0 = model.named_state("ready")
    robot = world.add_robot(model, q=q0)
    goal = q0.copy()
    goal[:7] += [0.3, 0.2, -0.2, -0.3, 0.1, 0.2, -0.2]
    target = model.fk(goal)
    ctl = ferrobot.ReactiveController(model, None, spheres)
    ctl.set_target(target)
    dt = 4 / 240  # 60 Hz control, 4 physics steps per control step
    for _ in range(240):
        q_t, _, _ = ctl.step(robot.joint_positions, robot.joint_velocities, dt)
        robot.set_joint_position_targets(q_t)
        world.step(4)
    T = model.fk(robot.joint_positions)
    assert np.linalg.norm(T[:3, 3] - target[:3, 3]) < 0.01


def hand_self_clearance(model, spheres, q, pairs):
    """Smallest sphere-surface distance over the given link pairs, spheres placed by ``RobotModel.fk``."""
    placed = {}
    for a, b in pairs:
        for link in (a, b):
            if link not in placed:
                s = spheres.spheres(link)
                T = model.fk(q, link)
                placed[link] = np.c_[(T[:3, :3] @ s[:, :3].T).T + T[:3, 3], s[:, 3]]
    best = np.inf
    for a, b in pairs:
        A, B = placed[a], placed[b]
        d = np.linalg.norm(A[:, None, :3] - B[None, :, :3], axis=2) - A[:, None, 3] - B[None, :, 3]
        best = min(best, float(d.min()))
    return best


def test_self_collision_filter_keeps_links_apart_when_the_target_presses_them_together(panda):
    """Targets whose configuration has two links' geometry overlapping: the attractor presses them together. With
    the self-avoidance policy off (metric 0), the first such target (seeded search) where the arm reaches
    self-contact without the velocity filter is run again with it (the default): the links' exact geometry (parry
    on the collision shapes) stays apart and the collision checker never reports a self-collision."""
    model, spheres = panda
    checker = ferrobot.CollisionChecker(model, spheres=spheres)
    probe = ferrobot.ReactiveController(model, None, spheres, self_collision_samples=0)
    no_policy = {"self_metric": 0.0, "self_gain": 0.0, "guidance_plans": 0}

    def run(goal, cfg):
        ctl = ferrobot.ReactiveController(model, None, spheres, config={**cfg, **no_policy}, self_collision_samples=0)
        ctl.set_target(model.fk(goal))
        q, qd = q0.copy(), np.zeros(model.num_dof)
        exact, contact = np.inf, False
        for _ in range(300):
            q, qd, _ = ctl.step(q, qd, 0.01)
            exact = min(exact, ctl.exact_self_clearance(q).distance)
            contact |= checker.in_collision(q)
        return exact, contact

    rng = np.random.default_rng(3)
    q0 = model.named_state("ready")
    for _ in range(400):
        goal = q0.copy()
        goal[:7] += rng.uniform(-1.2, 1.2, 7)
        goal = np.clip(goal, model.lower_limits, model.upper_limits)
        if not (checker.in_collision(goal) and probe.exact_self_clearance(goal).distance <= 0.0):
            continue
        off = run(goal, {"self_filter_distance": 0.0})
        if off[1]:
            break
    else:
        pytest.fail("no target pressed links into contact without the filter")
    assert off[0] <= 0.0, off  # parry agrees with the checker
    exact, contact = run(goal, {})
    assert exact > 0.0 and not contact, (exact, contact, off)


def test_guidance_status_and_config_validation(panda):
    """Guidance reports its status each step; its counts must be whole numbers."""
    model, spheres = panda
    q = model.named_state("ready")
    ctl = ferrobot.ReactiveController(model, None, spheres)
    ctl.step(q, np.zeros(model.num_dof), 0.01)
    assert ctl.last_step.guidance == "idle" and ctl.last_step.guidance_plans == 0
    assert ctl.guidance_error is None and ctl.guidance_last_plan is None
    ctl.set_target(model.fk(q))
    ctl.step(q, np.zeros(model.num_dof), 0.01)
    assert ctl.last_step.guidance == "reached"
    off = ferrobot.ReactiveController(model, None, spheres, config={"guidance_plans": 0})
    off.step(q, np.zeros(model.num_dof), 0.01)
    assert off.last_step.guidance == "off"
    for name, value in (("guidance_plans", 1.5), ("guidance_blocking", 0.5)):
        with pytest.raises(errors.InvalidArgumentError, match=name):
            ferrobot.ReactiveController(model, None, spheres, config={name: value})
        with pytest.raises(errors.InvalidArgumentError, match=name):
            ctl.set_config({name: value})


SHARED = Path(__file__).resolve().parent.parent.parent / "shared"
# Two episodes of benches/reactive.py on the UR5 with its spherized URDF (seed 0, episodes 6 and 12): q0, goal,
# obstacles (kind, half size, start, velocity). With the spheres alone, the first drives forearm_link into
# wrist_2_link (about 15 mm deep) and the second upper_arm_link into the box (9 mm) while every sphere stays apart.
UR5_EPISODES = [
    (
        [
            0.0794584628203639,
            0.13102867929232093,
            0.01782969708872023,
            0.06300104205990148,
            -0.0547215103789831,
            -0.1234374851011607,
        ],
        [
            0.3550324783930562,
            -0.8948117861031558,
            0.510985694338911,
            -0.8869802032834749,
            0.21024165713690335,
            0.17030493118921186,
        ],
        [
            (
                "box",
                0.047766068753999684,
                [-0.27204118955913176, 0.7494031422967611, 1.3195426838311055],
                [-0.14592408588690955, -0.16235138228783602, -0.07542108581001469],
            )
        ],
    ),
    (
        [
            0.04262539964864734,
            0.1342969216818981,
            -0.1159110565020935,
            0.03742152213203914,
            0.18956970951791047,
            0.13191411808180814,
        ],
        [
            0.7557932276518161,
            0.04247143105151774,
            -0.7632207339118713,
            0.2926272934131101,
            0.5907064197036797,
            -0.38431600727464266,
        ],
        [
            (
                "box",
                0.03850366495772059,
                [-0.7063761300465192, 0.7713345621247012, 1.217349384081479],
                [0.14242617223356646, -0.3444575704247799, -0.1717929542241922],
            ),
            (
                "sphere",
                0.04720163096197874,
                [-0.18718944407547378, 0.4631498980959754, 1.624951090883227],
                [-0.27872930464535006, 0.02870000983621513, -0.34884384653026596],
            ),
        ],
    ),
]


@pytest.mark.skipif(not (SHARED / "robots/ur5/ur5_spherized.urdf").exists(), reason="needs ../shared/robots/ur5")
def test_exact_filter_keeps_the_ur5s_uncovered_links_apart():
    """The spherized UR5 (one sphere for base_link and shoulder_link, spheres not covering the links): with the
    exact layer of the velocity filter (the default) neither episode touches, judged by coal on the URDF's own
    collision meshes (convex hulls), independent of ferrobot's geometry; without it (``exact_filter 0``) both do.
    The episodes were picked with a fixed world-avoidance reach (``collision_horizon 0``); the counterfactual run keeps
    it so that it still shows the contacts the exact layer prevents (with the default, closing-speed reach, the first
    episode's self pair passes 4 mm apart without the exact layer too)."""
    pytest.importorskip("coal")
    pytest.importorskip("trimesh")
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "benches"))
    from coal_judge import CoalJudge
    from reactive import load_robot

    model, spheres, _, (urdf, mesh_dir) = load_robot("ur5", 3.15, "spherized")
    coal = CoalJudge(model, urdf, mesh_dir)
    pairs = ferrobot.ReactiveController(model, None, spheres, self_collision_samples=0).self_link_pairs
    dt = 0.01
    for exact in (1.0, 0.0):
        worst = []
        for (q0, qg, obstacles), steps in zip(UR5_EPISODES, (150, 250), strict=True):
            world = ferrobot.CollisionWorld()
            for i, (kind, size, p0, _) in enumerate(obstacles):
                if kind == "sphere":
                    world.add_sphere(f"obs{i}", size, [*p0, 1, 0, 0, 0])
                else:
                    world.add_box(f"obs{i}", [2 * size] * 3, [*p0, 1, 0, 0, 0])
            ctl = ferrobot.ReactiveController(
                model,
                world,
                spheres,
                config={"guidance_plans": 0, "exact_filter": exact, **({} if exact else {"collision_horizon": 0.0})},
            )
            ctl.set_target(model.fk(np.array(qg)))
            q, qd = np.array(q0), np.zeros(6)
            self_min = world_min = np.inf
            for k in range(steps):
                t = k * dt
                for i, (_, _, p0, v) in enumerate(obstacles):
                    ctl.set_obstacle_pose(f"obs{i}", [*(np.array(p0) + np.array(v) * t), 1, 0, 0, 0], v)
                q, qd, _ = ctl.step(q, qd, dt)
                obs = [(kind, size, np.array(p0) + np.array(v) * (t + dt)) for kind, size, p0, v in obstacles]
                world_min = min(world_min, coal.obstacle_distance(q, obs)[0])
                self_min = min(self_min, min(coal.pair_distances(q, pairs).values()))
            worst.append((self_min, world_min))
        if exact:
            assert all(s > 0 and w > 0 for s, w in worst), worst
        else:
            assert worst[0][0] < 0 and worst[1][1] < 0, worst
