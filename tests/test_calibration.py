"""Calibration: gravity torques against Pinocchio; payload, link masses and joint
friction recovered from a simulator whose parameters were perturbed by known
amounts (within 5% of the perturbed truth); the run-time inertial setter;
argument validation."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import ferrobot
from ferrobot import calibration as cal
from ferrobot.errors import InvalidArgumentError, NonFiniteError, ShapeError, UnknownNameError

G = np.array([0.0, 0.0, -9.81])
SOFT = {"stiffness": 2000.0, "damping": 40.0}


def _configs(model, n, seed):
    """Collision-free random configurations in the middle of the limits."""
    rng = np.random.default_rng(seed)
    checker = ferrobot.CollisionChecker(model)
    lo, hi = model.lower_limits, model.upper_limits
    out = []
    while len(out) < n:
        q = lo + (hi - lo) * rng.uniform(0.15, 0.85, size=len(lo))
        if not checker.in_collision(q):
            out.append(q)
    return np.array(out)


def _sim(dt=1 / 240):
    model = ferrobot.robots.panda()
    world = ferrobot.World(dt=dt, ground=False)
    robot = world.add_robot(model, name="panda", gravity_compensation=False)
    return model, world, robot


def test_gravity_torques_match_pinocchio():
    model = ferrobot.robots.panda()
    pm = pin.buildModelFromXML(ferrobot.robots.panda_urdf(), mimic=True)
    data = pm.createData()
    arm = [pm.idx_vs[pm.getJointId(n)] for n in model.dof_names[:7]]
    for q in _configs(model, 20, 1):
        qp = _pin_q(pm, model, q)
        ref = pin.computeGeneralizedGravity(pm, data, qp)
        ours = cal.gravity_torques(model, q, G)
        np.testing.assert_allclose(ours[:7], ref[arm], atol=1e-9)


def _pin_q(pm, model, q):
    qp = np.zeros(pm.nq)
    for i, name in enumerate(model.dof_names):
        qp[pm.idx_qs[pm.getJointId(name)]] = q[i]
    return qp


def test_payload_regressor_against_pinocchio_point_mass():
    # Pinocchio: add a point mass at c (hand frame) to the body carrying panda_hand and
    # difference the generalized gravity; ours: the regressor times [m, m c].
    model = ferrobot.robots.panda()
    pm = pin.buildModelFromXML(ferrobot.robots.panda_urdf(), mimic=True)
    arm = [pm.idx_vs[pm.getJointId(n)] for n in model.dof_names[:7]]
    frame = pm.frames[pm.getFrameId("panda_hand")]
    m, c = 1.3, np.array([0.03, -0.02, 0.09])
    loaded = pin.Model(pm)
    loaded.inertias[frame.parentJoint] = loaded.inertias[frame.parentJoint] + pin.Inertia(
        m, frame.placement.act(c), np.zeros((3, 3))
    )
    for q in _configs(model, 10, 2):
        qp = _pin_q(pm, model, q)
        ref = pin.computeGeneralizedGravity(loaded, loaded.createData(), qp) - pin.computeGeneralizedGravity(
            pm, pm.createData(), qp
        )
        y = cal.payload_regressor(model, q, "panda_hand", G)
        np.testing.assert_allclose((y @ np.r_[m, m * c])[:7], ref[arm], atol=1e-9)


def test_identify_payload_from_simulated_static_torques():
    # Against the model alone (no tare): soft drives during the measurement (see the README).
    model, world, robot = _sim()
    qs = _configs(model, 12, 3)
    true_m, true_c = 1.5, np.array([0.02, -0.01, 0.08])
    hand = robot.get_link_inertial("panda_hand")
    robot.set_link_inertial("panda_hand", *cal.add_payload(hand.mass, hand.com, hand.inertia, true_m, true_c))
    q_meas, efforts = cal.measure_static_efforts(world, robot, qs, settle_time=1.0, **SOFT)
    p = cal.identify_payload(model, "panda_hand", q_meas, efforts, cal.gravity_in_base(robot))
    assert abs(p.mass - true_m) <= 0.05 * true_m, p
    assert np.linalg.norm(p.com - true_c) <= 0.05 * np.linalg.norm(true_c), p


def test_identify_link_masses_from_simulated_static_torques():
    model, world, robot = _sim()
    qs = _configs(model, 16, 4)
    links = ["panda_link3", "panda_link4", "panda_link5", "panda_link6"]
    scale = [1.15, 0.9, 1.2, 1.1]
    truth = []
    for name, s in zip(links, scale, strict=True):
        li = robot.get_link_inertial(name)
        robot.set_link_inertial(name, li.mass * s, li.com, li.inertia * s)
        truth.append(li.mass * s)
    q_meas, efforts = cal.measure_static_efforts(world, robot, qs, settle_time=1.0, **SOFT)
    fit = cal.identify_link_masses(model, links, q_meas, efforts)
    nominal = np.array([model_link_mass(model, n) for n in links])
    np.testing.assert_allclose(nominal + fit.offsets, truth, rtol=0.05)


def model_link_mass(model, name):
    return model.inertial(name).mass


def test_identify_friction_from_simulated_sweeps():
    model, world, robot = ferrobot.robots.panda(), None, None
    world = ferrobot.World(dt=1 / 240, ground=False)
    robot = world.add_robot(model, name="panda")
    q = model.named_state("ready")
    robot.set_joint_positions(q)
    robot.set_joint_position_targets(q)
    truth = {"panda_joint1": (0.8, 0.6), "panda_joint4": (2.0, 1.5)}  # (viscous, coulomb)
    for j, (fv, fc) in truth.items():
        robot.set_joint_dynamics(j, fv, fc)
        assert robot.get_joint_dynamics(j) == pytest.approx((fv, fc), rel=1e-6)
    speeds = np.array([-0.8, -0.5, -0.25, 0.25, 0.5, 0.8])
    for j, (fv, fc) in truth.items():
        v, e = cal.friction_sweep(world, robot, j, speeds)
        f = cal.identify_friction(v, e)
        assert f.coulomb == pytest.approx(fc, rel=0.05), (j, f)
        assert f.viscous == pytest.approx(fv, rel=0.05), (j, f)


def test_identify_friction_exact_on_synthetic_data():
    v = np.array([-1.0, -0.5, 0.5, 1.0, 2.0])
    e = 0.7 * np.sign(v) + 0.3 * v
    f = cal.identify_friction(v, e)
    assert f.coulomb == pytest.approx(0.7) and f.viscous == pytest.approx(0.3) and f.rms_residual < 1e-12


def test_set_link_inertial_changes_the_dynamics():
    # Heavier hand -> more static torque at the shoulder: the drive effort change matches the model.
    model, world, robot = _sim()
    q = model.named_state("ready")
    _, e0 = cal.measure_static_efforts(world, robot, q[None])
    hand = robot.get_link_inertial("panda_hand")
    robot.set_link_inertial("panda_hand", hand.mass + 2.0, hand.com, hand.inertia)
    assert robot.get_link_inertial("panda_hand").mass == pytest.approx(hand.mass + 2.0)
    qm, e1 = cal.measure_static_efforts(world, robot, q[None])
    y = cal.payload_regressor(model, qm[0], "panda_hand", G)
    expected = y @ np.r_[2.0, 2.0 * hand.com]
    np.testing.assert_allclose((e1 - e0)[0, :7], expected[:7], atol=0.05 + 0.02 * np.abs(expected[:7]).max())


def test_validation():
    model, world, robot = _sim()
    eye = np.eye(3) * 0.01
    with pytest.raises(InvalidArgumentError, match="mass"):
        robot.set_link_inertial("panda_hand", -1.0, [0, 0, 0], eye)
    with pytest.raises(InvalidArgumentError, match="triangle"):
        robot.set_link_inertial("panda_hand", 1.0, [0, 0, 0], np.diag([0.01, 0.01, 0.05]))
    with pytest.raises(UnknownNameError):
        robot.set_link_inertial("no_link", 1.0, [0, 0, 0], eye)
    with pytest.raises(ShapeError):
        robot.set_link_inertial("panda_hand", 1.0, [0, 0], eye)
    with pytest.raises(NonFiniteError):
        robot.set_link_inertial("panda_hand", 1.0, [0, np.nan, 0], eye)
    with pytest.raises(InvalidArgumentError, match="friction"):
        robot.set_joint_dynamics("panda_joint1", 0.1, -1.0)
    with pytest.raises(UnknownNameError):
        robot.set_joint_dynamics("nope", 0.1, 0.1)
    q = np.tile(model.named_state("ready"), (3, 1))
    with pytest.raises(ShapeError, match="efforts"):
        cal.identify_payload(model, "panda_hand", q, np.zeros((2, 8)))
    with pytest.raises(InvalidArgumentError, match="determine"):
        cal.identify_payload(model, "panda_hand", q, np.zeros((3, 8)))  # one configuration repeated
    with pytest.raises(UnknownNameError):
        cal.identify_payload(model, "nope", q, np.zeros((3, 8)))
    with pytest.raises(InvalidArgumentError, match="min_speed"):
        cal.identify_friction([1.0, 2.0], [1.0, 2.0], min_speed=-1)
    with pytest.raises(ShapeError):
        cal.identify_friction([1.0, 2.0], [1.0])
    with pytest.raises(UnknownNameError, match="joint"):
        cal.friction_sweep(world, robot, "nope", [0.1])
    with pytest.raises(InvalidArgumentError, match="speeds"):
        cal.friction_sweep(world, robot, "panda_joint1", [0.0])
