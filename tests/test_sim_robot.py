"""Robots in the world: articulation against the model's FK and pybullet's,
pendulum dynamics against analytic periods, drives, mimic fingers,
grasping (bundled Panda and pybullet's panda.urdf), controllers, errors."""

from __future__ import annotations

import os

import numpy as np
import pytest
from _sim_helpers import PANDA_Q0, ik, pose_at, straight_line
from scipy.special import ellipk

import ferrobot
from conftest import PANDA_SRDF, PANDA_URDF, UR5_URDF, random_configurations
from ferrobot import errors

G = 9.81
ARM = list(range(7))
ARM_NAMES = [f"panda_joint{i}" for i in range(1, 8)]  # the bundled Panda's first 7 DOFs


def pybullet_panda_path():
    pybullet_data = pytest.importorskip("pybullet_data")
    return os.path.join(pybullet_data.getDataPath(), "franka_panda", "panda.urdf")


def pendulum_urdf(length=0.5, mass=1.0, radius=0.05, z=1.0):
    i = 0.4 * mass * radius**2
    return f"""<robot name="pendulum">
  <link name="base"/>
  <joint name="hinge" type="continuous">
    <parent link="base"/><child link="bob"/>
    <origin xyz="0 0 {z}"/><axis xyz="0 1 0"/>
  </joint>
  <link name="bob">
    <inertial><origin xyz="0 0 {-length}"/><mass value="{mass}"/>
      <inertia ixx="{i}" iyy="{i}" izz="{i}" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0 0 {-length}"/><geometry><sphere radius="{radius}"/></geometry></collision>
  </link>
</robot>"""


def swing(theta0, length=0.5, mass=1.0, radius=0.05, dt=1 / 1000):
    w = ferrobot.World(dt=dt, ground=False)
    model = ferrobot.RobotModel.from_urdf_string(pendulum_urdf(length, mass, radius))
    r = w.add_robot(model, gravity_compensation=False, q=[theta0])
    r.set_drive_gains([0.0], [0.0])
    qs = []
    for _ in range(int(4.0 / dt)):
        w.step()
        qs.append(r.joint_positions[0])
    qs = np.array(qs)
    # period from successive upward zero crossings (linear interpolation)
    s = np.where((qs[:-1] < 0) & (qs[1:] >= 0))[0]
    t = (s + qs[s] / (qs[s] - qs[s + 1]) + 1) * dt
    return np.diff(t).mean(), qs


def pivot_inertia(length, mass, radius):
    return 0.4 * mass * radius**2 + mass * length**2


def test_pendulum_small_amplitude_period():
    length, mass, radius = 0.5, 1.0, 0.05
    period, _ = swing(0.05, length, mass, radius)
    expected = 2 * np.pi * np.sqrt(pivot_inertia(length, mass, radius) / (mass * G * length))
    assert period == pytest.approx(expected, rel=2e-3)


def test_pendulum_large_amplitude_period_and_energy():
    length, mass, radius, theta0 = 0.5, 1.0, 0.05, 1.2
    period, qs = swing(theta0, length, mass, radius)
    # exact period of a physical pendulum: 4 sqrt(I / (m g L)) K(sin^2(theta0 / 2))
    expected = 4 * np.sqrt(pivot_inertia(length, mass, radius) / (mass * G * length)) * ellipk(np.sin(theta0 / 2) ** 2)
    assert period == pytest.approx(expected, rel=5e-3)
    # amplitude (energy) is kept within 1%
    assert np.abs(qs).max() == pytest.approx(theta0, rel=1e-2)


def test_effort_gives_analytic_acceleration():
    # no gravity, no drive: a torque tau gives alpha = tau / I about the hinge
    w = ferrobot.World(ground=False, gravity=[0, 0, 0])
    model = ferrobot.RobotModel.from_urdf_string(pendulum_urdf())
    r = w.add_robot(model)
    r.set_drive_gains([0.0], [0.0])
    tau = 0.3
    r.set_joint_efforts([tau])
    n = 120
    w.step(n)
    alpha = tau / pivot_inertia(0.5, 1.0, 0.05)
    assert r.joint_velocities[0] == pytest.approx(alpha * n * w.dt, rel=1e-3)


@pytest.fixture(scope="module")
def pb_panda():
    return ferrobot.RobotModel.from_urdf(pybullet_panda_path(), ee_link="panda_hand")


@pytest.mark.parametrize("which", ["bundled", "mbm", "pybullet"])
def test_teleport_link_poses_match_model_fk(which, pb_panda):
    if which == "bundled":
        model = ferrobot.robots.panda()
    elif which == "mbm":
        model = ferrobot.RobotModel.from_urdf(PANDA_URDF, srdf=PANDA_SRDF)
    else:
        model = pb_panda
    base = np.eye(4)
    base[:3, :3] = np.array([[0, -1, 0], [1, 0, 0], [0, 0, 1]])
    base[:3, 3] = [0.2, -0.1, 0.3]
    w = ferrobot.World()
    r = w.add_robot(model, pose=base)
    for q in random_configurations(model, 5, seed=3):
        r.set_joint_positions(q)
        assert r.joint_positions == pytest.approx(q, abs=1e-5)
        for link in model.link_names:
            expected = base @ model.fk(q, link)
            got = r.get_link_pose(link)
            assert np.abs(got - expected).max() < 2e-5, link


def test_link_poses_match_pybullet_fk(pb_panda):
    pybullet = pytest.importorskip("pybullet")
    cid = pybullet.connect(pybullet.DIRECT)
    try:
        body = pybullet.loadURDF(pybullet_panda_path(), useFixedBase=True, physicsClientId=cid)
        names = {}
        for j in range(pybullet.getNumJoints(body, physicsClientId=cid)):
            info = pybullet.getJointInfo(body, j, physicsClientId=cid)
            names[info[12].decode()] = (j, info[1].decode())
        w = ferrobot.World()
        r = w.add_robot(pb_panda)
        for q in random_configurations(pb_panda, 4, seed=11):
            r.set_joint_positions(q)
            joint_q = dict(zip(pb_panda.dof_names, q, strict=True))
            joint_q["panda_finger_joint2"] = joint_q["panda_finger_joint1"]  # mimic
            for _link, (j, jname) in names.items():
                if jname in joint_q:
                    pybullet.resetJointState(body, j, joint_q[jname], physicsClientId=cid)
            for link, (j, _) in names.items():
                state = pybullet.getLinkState(body, j, computeForwardKinematics=True, physicsClientId=cid)
                pos = np.array(state[4])
                assert r.get_link_pose(link)[:3, 3] == pytest.approx(pos, abs=3e-5), link
    finally:
        pybullet.disconnect(cid)


def test_holds_pose_without_gravity_compensation():
    model = ferrobot.robots.panda()
    w = ferrobot.World()
    r = w.add_robot(model, gravity_compensation=False, q=PANDA_Q0)
    r.set_joint_position_targets(PANDA_Q0)
    w.step(480)
    err = np.abs(r.joint_positions - PANDA_Q0)
    assert err[:7].max() < 0.01  # stiff default drives against gravity


def test_position_and_velocity_targets():
    model = ferrobot.robots.panda()
    w = ferrobot.World()
    r = w.add_robot(model, q=PANDA_Q0)
    target = PANDA_Q0.copy()
    target[[0, 3]] += [0.4, 0.3]
    names = r.dof_names
    r.set_joint_position_targets(target[[0, 3]], joint_names=[names[0], names[3]])
    assert r.joint_position_targets == pytest.approx(target)
    w.step(480)
    assert r.joint_positions == pytest.approx(target, abs=2e-3)
    # pure velocity drive on joint 1
    r.set_drive_gains([0.0], [200.0], joint_names=[names[0]])
    r.set_joint_velocity_targets([0.5], joint_names=[names[0]])
    w.step(240)
    assert r.joint_velocities[0] == pytest.approx(0.5, abs=0.01)
    g = r.drive_gains
    assert g.stiffness[0] == 0 and g.damping[0] == 200 and g.max_force[0] == 87


def test_pd_targets_converge_within_one_second():
    # Unloaded (gravity compensated, nothing touching): every DOF within 1e-3 of a
    # target 0.2 rad (fingers 2 cm) away after 240 steps = 1 s, and still there later.
    # The default drives saturate at the URDF efforts (87 / 12 N m) for errors above
    # 9 / 1.2 mrad, and a saturated PD loses its damping: 0.3 rad on all seven joints
    # at once overshoots and needs 1.24 s.
    model = ferrobot.robots.panda()
    w = ferrobot.World(ground=False)
    r = w.add_robot(model, q=PANDA_Q0)
    target = PANDA_Q0 + np.r_[[0.2, -0.2, 0.2, 0.2, -0.2, -0.2, 0.2], -0.02]
    assert np.all((target >= model.lower_limits) & (target <= model.upper_limits))
    r.set_joint_position_targets(target)
    w.step(1)
    assert np.abs(r.joint_positions - target).max() > 0.15  # it starts far away
    w.step(239)
    assert w.time == pytest.approx(1.0)
    assert np.abs(r.joint_positions - target).max() < 1e-3
    assert np.abs(r.joint_velocities).max() < 1e-2
    w.step(240)
    assert np.abs(r.joint_positions - target).max() < 1e-3


def test_joint_limits_hold_against_drives_and_gravity():
    model = ferrobot.robots.panda()
    lo, hi = model.lower_limits, model.upper_limits
    # drives pulling 0.5 rad (fingers 2 cm) beyond every limit, at full effort
    # Rapier enforces a limit once it is crossed, so a joint driven into it at speed
    # overshoots briefly (measured: up to 42 mrad on the light joint 7, under 10 mrad
    # elsewhere) and is pushed back within the step after.
    for beyond in (lo - 0.5, hi + 0.5):
        w = ferrobot.World(ground=False)
        r = w.add_robot(model, q=PANDA_Q0)
        beyond = beyond.copy()
        beyond[7] = np.clip(beyond[7], -0.02, 0.06)
        r.set_joint_position_targets(beyond)
        worst, settled = 0.0, 0.0
        for k in range(480):
            w.step()
            q = r.joint_positions
            excess = float(np.max(np.r_[lo - q, q - hi]))
            worst = max(worst, excess)
            if k >= 240:
                settled = max(settled, excess)
        assert worst < 0.05, worst
        assert settled < 2e-3, settled
    # no drive, no gravity compensation: the arm falls onto its limits and stays inside
    w = ferrobot.World(ground=False)
    r = w.add_robot(model, q=PANDA_Q0, gravity_compensation=False)
    r.set_drive_gains([0.0] * 8, [0.0] * 8)
    worst = 0.0
    for _ in range(720):
        w.step()
        q = r.joint_positions
        worst = max(worst, float(np.max(np.r_[lo - q, q - hi])))
    assert worst < 0.05, worst
    q = r.joint_positions
    assert float(np.max(np.r_[lo - q, q - hi])) < 2e-3


def test_mimic_fingers_move_together():
    model = ferrobot.robots.panda()
    w = ferrobot.World()
    r = w.add_robot(model, q=PANDA_Q0)
    for opening in (0.01, 0.035):
        r.set_joint_position_targets([opening], joint_names=["panda_finger_joint1"])
        w.step(240)
        hand = r.get_link_pose("panda_hand")
        left = np.linalg.inv(hand) @ r.get_link_pose("panda_leftfinger")
        right = np.linalg.inv(hand) @ r.get_link_pose("panda_rightfinger")
        assert left[1, 3] == pytest.approx(opening, abs=5e-4)
        assert right[1, 3] == pytest.approx(-opening, abs=5e-4)


def test_mimic_fingers_stay_coupled_under_load():
    # A box 8 mm off the hand's centre line: the first finger to touch pushes it
    # while the other still moves freely; squeezed at 40 N the box is then carried
    # up with gravity acting on it. The mimic finger must mirror the driver throughout.
    model = ferrobot.robots.panda()
    tcp = "panda_hand_tcp"
    qg = ik(model, PANDA_Q0, pose_at([0.5, 0, 0.025]), tcp)
    w = ferrobot.World()
    r = w.add_robot(model, q=qg)
    r.set_joint_position_targets(qg)
    hand = r.get_link_pose("panda_hand")
    off = hand[:3, 1] * 0.008  # along the closing axis
    w.add_box("box", [0.05] * 3, np.r_[[0.5, 0, 0.025] + off, 1, 0, 0, 0], mass=0.5, friction=1.0)
    w.step(30)

    def asymmetry():
        h = np.linalg.inv(r.get_link_pose("panda_hand"))
        left = (h @ r.get_link_pose("panda_leftfinger"))[1, 3]
        right = (h @ r.get_link_pose("panda_rightfinger"))[1, 3]
        return abs(left + right), left

    r.close_gripper(force=40.0)
    # The fingers close at the finger joint's 0.2 m/s velocity limit; at the impacts
    # the coupling, solved as a constraint, lags for a step. Once squeezing, it holds
    # to 0.1 mm. The far finger starts 40 - 25 + 8 = 23 mm from the box and touches it
    # after 23 mm / 0.2 m/s = 115 ms (28 steps): the first 32 steps count as the
    # transient.
    transient, worst, opening = 0.0, 0.0, []
    for k in range(180):
        w.step()
        a, left = asymmetry()
        opening.append(left)
        if k < 32:
            transient = max(transient, a)
        else:
            worst = max(worst, a)
    assert transient < 1.5e-3, transient
    assert opening[-1] == pytest.approx(0.025, abs=2e-3)  # squeezing the 5 cm box
    lift = qg.copy()
    lift[[1, 3]] += [-0.25, 0.25]
    for leg in np.array_split(np.linspace(qg[:7], lift[:7], 121), 12):
        r.execute_trajectory(leg, 1 / 240, joint_names=ARM_NAMES)
        worst = max(worst, asymmetry()[0])
    r.execute_trajectory(lift[None, :7], 1 / 240, joint_names=ARM_NAMES, settle_time=0.3)
    assert w.get_object_pose("box")[2, 3] > 0.06  # lifted: the fingers carry its weight
    worst = max(worst, asymmetry()[0])
    assert worst < 1e-4, worst


def test_set_world_pose_moves_everything():
    model = ferrobot.robots.panda()
    w = ferrobot.World()
    r = w.add_robot(model, q=PANDA_Q0)
    new = np.eye(4)
    new[:3, 3] = [1.0, 2.0, 0.5]
    r.set_world_pose(new)
    assert r.world_transform == pytest.approx(new)
    assert r.get_link_pose("panda_hand") == pytest.approx(new @ model.fk(PANDA_Q0, "panda_hand"), abs=1e-5)
    w.step(10)
    assert r.joint_positions == pytest.approx(PANDA_Q0, abs=1e-3)


def grasp_and_carry(model, tcp, box_size, force):
    """Grasp a 0.5 kg box on the ground, carry it 0.5 m along a straight line at
    up to 1 m/s; returns the largest drift of the box relative to the hand (m)."""
    qg = ik(model, PANDA_Q0, pose_at([0.5, 0, box_size / 2]), tcp)
    w = ferrobot.World()
    r = w.add_robot(model, name="panda", q=qg)
    r.set_joint_position_targets(qg)
    w.add_box("box", [box_size] * 3, [0.5, 0, box_size / 2, 1, 0, 0, 0], mass=0.5, friction=1.0)
    w.step(30)
    r.close_gripper(force=force)
    w.step(120)

    def rel():
        return np.linalg.inv(r.get_link_pose("panda_hand")) @ w.get_object_pose("box")

    rel0 = rel()
    start = np.array([0.5, 0, box_size / 2])
    direction = np.array([-0.2, 0.3, 0.375])
    goal = start + 0.5 * direction / np.linalg.norm(direction)  # carried 0.5 m
    dt = 1 / 240
    qs = straight_line(model, qg, start, goal, tcp, peak_speed=1.0, dt=dt)
    speeds = np.linalg.norm(np.diff([model.fk(np.r_[q, qg[7]], tcp)[:3, 3] for q in qs], axis=0), axis=1) / dt
    assert 0.9 < speeds.max() <= 1.05
    drift = 0.0
    for k in range(0, len(qs) - 1, 10):
        r.execute_trajectory(qs[k : k + 11], dt, joint_names=ARM_NAMES)
        drift = max(drift, np.linalg.norm(rel()[:3, 3] - rel0[:3, 3]))
    r.execute_trajectory(qs[-1:], dt, joint_names=ARM_NAMES, settle_time=0.5)
    drift = max(drift, np.linalg.norm(rel()[:3, 3] - rel0[:3, 3]))
    assert w.get_object_pose("box")[2, 3] > 0.25  # lifted with the hand
    return drift


def test_grasp_hold_bundled_panda():
    assert grasp_and_carry(ferrobot.robots.panda(), "panda_hand_tcp", 0.05, force=40.0) < 0.005


def test_grasp_hold_pybullet_panda(pb_panda):
    assert grasp_and_carry(pb_panda, "panda_grasptarget", 0.04, force=40.0) < 0.005


def test_gripper_open_close_and_custom_gripper():
    model = ferrobot.robots.panda()
    w = ferrobot.World()
    r = w.add_robot(model, q=PANDA_Q0)
    r.close_gripper()
    w.step(240)
    assert r.gripper_positions[0] == pytest.approx(0.0, abs=1e-3)
    r.open_gripper()
    w.step(240)
    assert r.gripper_positions[0] == pytest.approx(0.04, abs=1e-3)
    r.set_gripper(["panda_finger_joint1"], [0.03], [0.01])
    r.open_gripper()
    w.step(240)
    assert r.gripper_positions[0] == pytest.approx(0.03, abs=1e-3)
    with pytest.raises(errors.UnknownNameError):
        r.set_gripper(["nope"], [0.03], [0.0])
    with pytest.raises(errors.InvalidArgumentError):
        r.close_gripper(force=-1.0)


def test_ur5_loads_and_holds(ur5):
    w = ferrobot.World()
    q = np.array([0.0, -1.2, 1.0, -1.4, -1.57, 0.0] + [0.0] * (ur5.num_dof - 6))
    r = w.add_robot(ur5, q=q, name="ur5")
    r.set_joint_position_targets(q)
    w.step(240)
    assert r.joint_positions[:6] == pytest.approx(q[:6], abs=2e-3)
    assert r.get_link_pose(ur5.ee_link) == pytest.approx(ur5.fk(r.joint_positions), abs=1e-4)


def test_trajectory_executor_reports_tracking():
    model = ferrobot.robots.panda()
    w = ferrobot.World()
    r = w.add_robot(model, q=PANDA_Q0)
    dt = 0.01
    t = np.arange(0, 1.0 + 1e-9, dt)
    q = PANDA_Q0[None, :7] + 0.15 * (1 - np.cos(2 * np.pi * t))[:, None] * np.ones(7)
    rep = r.execute_trajectory(q, dt, joint_names=ARM_NAMES, settle_time=0.1)
    n = len(rep.times)
    assert n == int(round(1.1 / w.dt))
    assert rep.desired.shape == (n, 7) and rep.actual.shape == (n, 7)
    # desired follows the samples; the robot tracks within a few mrad
    assert rep.desired[-1] == pytest.approx(q[-1], abs=1e-9)
    assert rep.max_error.max() < 0.01
    assert rep.final_error.max() < 2e-3
    assert np.all(rep.rms_error <= rep.max_error)
    assert r.joint_positions[:7] == pytest.approx(q[-1], abs=2e-3)


def test_execute_a_plan_matches_joints_by_name():
    model = ferrobot.robots.panda()
    w = ferrobot.World()
    r = w.add_robot(model, q=PANDA_Q0)
    r.set_joint_position_targets(PANDA_Q0)
    planner = ferrobot.Planner(model)
    goal = PANDA_Q0[:7] + np.array([0.3, -0.2, 0.2, 0.3, -0.2, 0.2, 0.3])
    # The planner's output in another order, with the mimic finger joint in it: Robot.execute maps by name.
    names = ["panda_finger_joint2", *reversed(planner.joint_names), "panda_finger_joint1"]
    start = [0.04, *PANDA_Q0[:7][::-1], 0.04]
    res = planner.plan(start, goal_q=[0.04, *goal[::-1], 0.04], joint_names=names)
    assert res.success
    traj = res.interpolated(0.01)
    rep = r.execute(traj, settle_time=0.2)
    assert rep.desired.shape[1] == 8  # 7 arm joints + finger_joint1; the mimic finger is skipped
    assert r.joint_positions[:7] == pytest.approx(goal, abs=2e-3)
    assert r.joint_positions[7] == pytest.approx(0.04, abs=1e-3)
    assert rep.max_error.max() < 0.02
    # A PlanResult directly: sampled at the world's time step.
    back = planner.plan(goal, goal_q=PANDA_Q0[:7])
    rep = r.execute(back, settle_time=0.2)
    assert (
        len(rep.times) == int(round((back.duration + 0.2) / w.dt))
        or abs(len(rep.times) - (back.duration + 0.2) / w.dt) <= 2
    )
    assert r.joint_positions[:7] == pytest.approx(PANDA_Q0[:7], abs=2e-3)
    with pytest.raises(errors.InvalidArgumentError, match="JointTrajectory"):
        r.execute(np.zeros((3, 7)))
    ur5_like = ferrobot.Planner(ferrobot.RobotModel.from_urdf(UR5_URDF))
    other = ur5_like.plan(np.zeros(6), goal_q=np.full(6, 0.1))
    with pytest.raises(errors.UnknownNameError, match="not a joint of robot"):
        r.execute(other.interpolated(0.01))


def test_resolved_rate_reaches_pose():
    model = ferrobot.robots.panda()
    w = ferrobot.World()
    r = w.add_robot(model, q=PANDA_Q0)
    ctl = ferrobot.ResolvedRateController(model, link="panda_hand_tcp")
    target = pose_at([0.45, 0.15, 0.3])
    target_q = r.joint_positions
    for _ in range(int(3.0 / w.dt)):
        q = r.joint_positions
        qd = ctl.compute(q, target)
        target_q = target_q + qd * w.dt
        r.set_joint_position_targets(target_q)
        r.set_joint_velocity_targets(qd)
        w.step()
    reached = r.get_link_pose("panda_hand_tcp")
    assert np.linalg.norm(reached[:3, 3] - target[:3, 3]) < 2e-3
    assert np.allclose(reached[:3, :3], target[:3, :3], atol=5e-3)


def test_pid_anti_windup_and_tracking():
    pid = ferrobot.JointPID([10.0], 5.0, 1.0, integral_limit=1.0, output_limit=2.0)
    # saturated: large error, the integral must not grow
    for _ in range(100):
        u = pid.update([0.0], [0.0], [10.0], 0.01)
    assert u[0] == 2.0
    assert pid.integral[0] == 0.0
    pid.reset()
    # unsaturated: integral accumulates e dt, clamped at the limit
    for _ in range(50):
        pid.update([0.0], [0.0], [0.1], 0.01)
    assert pid.integral[0] == pytest.approx(0.05)
    # effort control of the pendulum under gravity: the integral removes
    # the steady-state error of a pure PD
    w = ferrobot.World(ground=False, dt=1 / 500)
    model = ferrobot.RobotModel.from_urdf_string(pendulum_urdf())
    r = w.add_robot(model, gravity_compensation=False)
    r.set_drive_gains([0.0], [0.0])
    pid = ferrobot.JointPID([40.0], 40.0, 4.0, integral_limit=10.0, output_limit=20.0)
    for _ in range(int(6.0 / w.dt)):
        u = pid.update(r.joint_positions, r.joint_velocities, [0.5], w.dt)
        r.set_joint_efforts(u)
        w.step()
    assert r.joint_positions[0] == pytest.approx(0.5, abs=2e-3)
    # holding torque equals gravity's m g L sin(theta)
    assert u[0] == pytest.approx(1.0 * G * 0.5 * np.sin(0.5), rel=0.02)


def test_divergence_from_absurd_effort():
    w = ferrobot.World(ground=False)
    model = ferrobot.RobotModel.from_urdf_string(pendulum_urdf())
    r = w.add_robot(model)
    r.set_drive_gains([0.0], [0.0])
    # Efforts beyond the documented range (|effort| <= 1e6) are refused at the boundary (issue 15);
    # the largest valid one still blows this light pendulum up, which the step reports.
    with pytest.raises(errors.InvalidArgumentError, match="efforts"):
        r.set_joint_efforts([1e12])
    r.set_joint_efforts([1e6])
    with pytest.raises(errors.SimulationDiverged):
        w.step(10)


def test_robot_determinism_and_reset():
    model = ferrobot.robots.panda()

    def run():
        w = ferrobot.World()
        r = w.add_robot(model, q=PANDA_Q0)
        w.add_box("box", [0.05, 0.05, 0.05], [0.5, 0, 0.025, 1, 0, 0, 0])
        target = PANDA_Q0 + 0.2
        r.set_joint_position_targets(target)
        w.step(200)
        return w, r, np.r_[r.joint_positions, r.joint_velocities, w.get_object_pose("box").ravel()]

    w1, r1, s1 = run()
    _, _, s2 = run()
    assert np.array_equal(s1, s2)
    w1.reset()
    assert r1.joint_positions == pytest.approx(PANDA_Q0, abs=1e-6)
    w1.step(200)
    s3 = np.r_[r1.joint_positions, r1.joint_velocities, w1.get_object_pose("box").ravel()]
    assert np.array_equal(s1, s3)


def test_robot_invalid_inputs(ur5):
    model = ferrobot.robots.panda()
    w = ferrobot.World()
    r = w.add_robot(model, name="panda")
    # the deprecated index spelling still validates (and warns) for its last release
    with pytest.raises(errors.UnknownNameError, match="joint index 9"), pytest.warns(DeprecationWarning):
        r.set_joint_position_targets([0.0], joint_indices=[9])
    with pytest.raises(errors.UnknownNameError), pytest.warns(DeprecationWarning):
        r.set_joint_position_targets([0.0], joint_indices=[-1])
    with pytest.raises(errors.UnknownNameError, match="no_such_joint"):
        r.set_joint_position_targets([0.0], joint_names=["no_such_joint"])
    with pytest.raises(errors.ShapeError):
        r.set_joint_positions([0.0, 1.0])
    with pytest.raises(errors.ShapeError):
        r.set_joint_position_targets([0.0, 1.0], joint_names=["panda_joint1"])
    with pytest.raises(errors.NonFiniteError):
        r.set_joint_positions([np.nan] * 8)
    with pytest.raises(errors.NonFiniteError):
        r.set_joint_velocity_targets([np.inf] * 8)
    with pytest.raises(errors.InvalidArgumentError, match="twice"):
        r.set_joint_position_targets([0.0, 0.0], joint_names=["panda_joint2", "panda_joint2"])
    with pytest.raises(errors.InvalidArgumentError, match="stiffness"):
        r.set_drive_gains([-1.0] * 8, [0.0] * 8)
    with pytest.raises(errors.InvalidArgumentError, match="max_force"):
        r.set_drive_gains([1.0] * 8, [0.0] * 8, [-1.0] * 8)  # 0 is accepted: a passive joint (issue 17)
    with pytest.raises(errors.NonFiniteError):
        r.set_world_pose([np.nan, 0, 0, 1, 0, 0, 0])
    with pytest.raises(errors.DuplicateNameError):
        w.add_robot(model, name="panda")
    with pytest.raises(errors.ShapeError):
        w.add_robot(model, name="p2", q=[0.0])
    r5 = w.add_robot(ur5, name="ur5", pose=[2, 0, 0, 1, 0, 0, 0])
    if not any("finger" in n or "knuckle" in n for n in ur5.dof_names):
        with pytest.raises(errors.InvalidArgumentError, match="no gripper"):
            r5.close_gripper()
    with pytest.raises(errors.InvalidArgumentError):
        ferrobot.ResolvedRateController(model, damping=-1.0)
    with pytest.raises(errors.UnknownNameError):
        ferrobot.ResolvedRateController(model, link="nope")
    with pytest.raises(errors.ShapeError):
        ferrobot.JointPID([1.0, 2.0], [1.0], 0.0)
    with pytest.raises(errors.InvalidArgumentError):
        ferrobot.JointPID([1.0], [-1.0], 0.0)
    assert UR5_URDF.exists()


def test_pendulum_matches_pybullet(tmp_path):
    # the same URDF swung from 1 rad in pybullet (a second simulator, 240 Hz)
    pybullet = pytest.importorskip("pybullet")
    urdf = tmp_path / "pendulum.urdf"
    urdf.write_text(pendulum_urdf())
    cid = pybullet.connect(pybullet.DIRECT)
    try:
        pybullet.setGravity(0, 0, -G, physicsClientId=cid)
        pybullet.setTimeStep(1 / 240, physicsClientId=cid)
        body = pybullet.loadURDF(str(urdf), useFixedBase=True, physicsClientId=cid)
        pybullet.changeDynamics(body, 0, linearDamping=0, angularDamping=0, jointDamping=0, physicsClientId=cid)
        pybullet.setJointMotorControl2(body, 0, pybullet.VELOCITY_CONTROL, force=0, physicsClientId=cid)
        pybullet.resetJointState(body, 0, 1.0, physicsClientId=cid)
        ref = []
        for _ in range(240):
            pybullet.stepSimulation(physicsClientId=cid)
            ref.append(pybullet.getJointState(body, 0, physicsClientId=cid)[0])
    finally:
        pybullet.disconnect(cid)
    w = ferrobot.World(ground=False)
    r = w.add_robot(ferrobot.RobotModel.from_urdf(urdf), gravity_compensation=False, q=[1.0])
    r.set_drive_gains([0.0], [0.0])
    ours = []
    for _ in range(240):
        w.step()
        ours.append(r.joint_positions[0])
    # measured: 7.7e-3 rad at most over the second (both integrators are first order)
    assert np.abs(np.array(ours) - np.array(ref)).max() < 0.015
