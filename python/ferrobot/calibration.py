"""Calibration against measurements: payload and link masses from static joint
efforts (gravity calibration), joint friction from constant-velocity sweeps,
and the procedures that take those measurements on a simulated robot.

What is measured. On a real robot: the joint torques logged while it holds
still at several configurations (drives on, or the brake-release sag times
the joint stiffness), and the torque along constant-velocity sweeps. In the
simulator the same numbers come from :meth:`ferrobot.Robot.measured_joint_efforts`:
the drive law ``clamp(stiffness (q* - q) + damping (qd* - qd))`` at the
current state, which equals the force the simulator's implicit motor applies
once the joint is static (gravity) or at constant velocity (friction).

The fits are linear least squares in Rust (``ferrobot._core``): joint torques
are linear in a payload's ``(m, m c)``, in per-link mass offsets, and in
Coulomb and viscous friction.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import _core
from .errors import InvalidArgumentError, ShapeError

__all__ = [
    "Payload",
    "Friction",
    "gravity_in_base",
    "gravity_torques",
    "payload_regressor",
    "identify_payload",
    "identify_link_masses",
    "identify_friction",
    "measure_static_efforts",
    "friction_sweep",
    "add_payload",
]

GRAVITY = (0.0, 0.0, -9.81)


@dataclass
class Payload:
    """An identified payload: mass (kg), centre of mass (m, link frame) and fit quality."""

    mass: float
    com: np.ndarray
    rms_residual: float
    condition: float
    equations: int


@dataclass
class Friction:
    """Identified joint friction: ``tau = coulomb sign(qd) + viscous qd``."""

    coulomb: float
    viscous: float
    rms_residual: float
    condition: float
    equations: int


def _finite(x, what: str, shape: tuple | None = None) -> np.ndarray:
    a = np.asarray(x, dtype=np.float64)
    if shape is not None and a.shape != shape:
        raise ShapeError(f"{what}: expected shape {shape}, got {a.shape}")
    if not np.all(np.isfinite(a)):
        from .errors import NonFiniteError

        raise NonFiniteError(f"{what}: non-finite values")
    return a


def gravity_in_base(robot, gravity=GRAVITY) -> np.ndarray:
    """The world gravity vector (3,) expressed in ``robot``'s base frame."""
    g = _finite(gravity, "gravity", (3,))
    return robot.world_transform[:3, :3].T @ g


def gravity_torques(model, q, gravity=GRAVITY) -> np.ndarray:
    """Joint efforts holding ``model`` still at ``q`` (Pinocchio's generalized gravity)."""
    return _core.gravity_torques(model, q, gravity)


def payload_regressor(model, q, link: str, gravity=GRAVITY) -> np.ndarray:
    """(num_dof, 4) matrix Y: efforts holding a payload = Y @ [m, m cx, m cy, m cz]."""
    return _core.payload_regressor(model, q, link, gravity)


def _tare(model, qs, efforts, baseline, gravity):
    """Efforts with ``baseline`` (the same configurations measured without the
    unknown) subtracted, plus the model's gravity torques (which the fit removes again)."""
    if baseline is None:
        return efforts
    e = _finite(efforts, "efforts")
    b = _finite(baseline, "baseline")
    if b.shape != e.shape:
        raise ShapeError(f"baseline: expected shape {e.shape} like efforts, got {b.shape}")
    q = _finite(qs, "qs")
    if q.shape != e.shape:
        raise ShapeError(f"efforts: expected shape {q.shape} like qs, got {e.shape}")
    return e - b + np.array([_core.gravity_torques(model, qi, gravity) for qi in q])


def identify_payload(model, link: str, qs, efforts, gravity=GRAVITY, dofs=None, baseline=None) -> Payload:
    """A payload on ``link`` from static efforts ``(N, num_dof)`` measured at ``qs``.

    Without ``baseline`` the model's own gravity torques are subtracted, so the
    result is what the model lacks. With ``baseline`` (efforts measured at the same
    configurations without the payload, a "tare") the difference is fitted, which
    cancels what the model gets wrong about the robot itself. ``dofs`` selects which
    joints' equations are used.
    """
    efforts = _tare(model, qs, efforts, baseline, gravity)
    d = _core.identify_payload(model, link, qs, efforts, gravity, dofs)
    return Payload(d.mass, d.com, d.rms_residual, d.condition, d.equations)


def identify_link_masses(model, links, qs, efforts, gravity=GRAVITY, baseline=None) -> _core.LinkMassFit:
    """Mass offsets (kg) of ``links`` (names) from static efforts: a :class:`ferrobot.LinkMassFit`
    with ``offsets`` (in ``links`` order), ``rms_residual``, ``condition``, ``equations``.
    ``baseline``: efforts at the same configurations before the change (see
    :func:`identify_payload`); the offsets are then the change since the baseline."""
    if isinstance(links, str):
        raise InvalidArgumentError("links: expected a list of link names, got a string")
    efforts = _tare(model, qs, efforts, baseline, gravity)
    return _core.identify_link_masses(model, list(links), qs, efforts, gravity)


def identify_friction(velocities, efforts, min_speed: float = 1e-3) -> Friction:
    """Fits ``effort = coulomb sign(v) + viscous v`` (samples with |v| <= min_speed ignored)."""
    d = _core.identify_friction(velocities, efforts, min_speed)
    return Friction(d.coulomb, d.viscous, d.rms_residual, d.condition, d.equations)


def add_payload(mass: float, com, inertia, p_mass: float, p_com, p_inertia=None):
    """Mass properties of a link carrying a payload: (mass, com, inertia about the
    combined com), all in the link frame; ``p_inertia`` defaults to a point mass."""
    c1 = _finite(com, "com", (3,))
    c2 = _finite(p_com, "p_com", (3,))
    i1 = _finite(inertia, "inertia", (3, 3))
    i2 = np.zeros((3, 3)) if p_inertia is None else _finite(p_inertia, "p_inertia", (3, 3))
    if not (np.isfinite(mass) and mass >= 0 and np.isfinite(p_mass) and p_mass >= 0):
        raise InvalidArgumentError("mass and p_mass must be finite and >= 0")
    m = mass + p_mass
    if m <= 0:
        raise InvalidArgumentError("the combined mass is zero")
    c = (mass * c1 + p_mass * c2) / m

    def shift(i, mm, d):
        return i + mm * (np.dot(d, d) * np.eye(3) - np.outer(d, d))

    return m, c, shift(i1, mass, c1 - c) + shift(i2, p_mass, c2 - c)


def measure_static_efforts(
    world,
    robot,
    qs,
    settle_time: float = 0.6,
    average_time: float = 0.1,
    *,
    stiffness: float | None = None,
    damping: float | None = None,
):
    """Holds ``robot`` at each configuration of ``qs`` (N, num_dof) with its drives
    and returns ``(q_measured, efforts)``, both (N, num_dof): the joint positions
    reached (drives sag under load) and the mean applied drive efforts over the
    last ``average_time`` s of ``settle_time`` + ``average_time``. The robot must
    feel gravity (``add_robot(..., gravity_compensation=False)``). ``stiffness`` /
    ``damping`` (> 0) replace the drive gains during the measurement (restored after):
    the drive law matches the force of the simulator's implicit motor best when the
    drive is soft for the joint's inertia (measured: see the README)."""
    qs = _finite(qs, "qs")
    if qs.ndim != 2 or qs.shape[1] != robot.num_dof:
        raise ShapeError(f"qs: expected shape (N, {robot.num_dof}), got {qs.shape}")
    for v, what in ((settle_time, "settle_time"), (average_time, "average_time")):
        if not (np.isfinite(v) and v > 0):
            raise InvalidArgumentError(f"{what} must be finite and > 0, got {v}")
    dt = world.dt
    n_settle = max(1, int(round(settle_time / dt)))
    n_avg = max(1, int(round(average_time / dt)))
    q_out, e_out = [], []
    zero = np.zeros(robot.num_dof)
    g = robot.drive_gains
    gains = (g.stiffness, g.damping, g.max_force)
    if stiffness is not None or damping is not None:
        k = gains[0] if stiffness is None else np.full(robot.num_dof, _positive_scalar(stiffness, "stiffness"))
        d = gains[1] if damping is None else np.full(robot.num_dof, _positive_scalar(damping, "damping"))
        robot.set_drive_gains(k, d, gains[2])
    try:
        _hold_all(world, robot, qs, n_settle, n_avg, zero, q_out, e_out)
    finally:
        robot.set_drive_gains(*gains)
    return np.array(q_out), np.array(e_out)


def _positive_scalar(v, what: str) -> float:
    v = float(v)
    if not (np.isfinite(v) and v > 0):
        raise InvalidArgumentError(f"{what} must be finite and > 0, got {v}")
    return v


def _hold_all(world, robot, qs, n_settle, n_avg, zero, q_out, e_out):
    for q in qs:
        robot.set_joint_positions(q)
        robot.set_joint_position_targets(q)
        robot.set_joint_velocity_targets(zero)
        world.step(n_settle)
        acc_e = np.zeros(robot.num_dof)
        acc_q = np.zeros(robot.num_dof)
        for _ in range(n_avg):
            world.step(1)
            acc_e += robot.measured_joint_efforts
            acc_q += robot.joint_positions
        q_out.append(acc_q / n_avg)
        e_out.append(acc_e / n_avg)


def friction_sweep(
    world,
    robot,
    joint: str,
    speeds,
    *,
    damping: float = 30.0,
    settle_time: float = 0.15,
    measure_time: float = 0.25,
):
    """Constant-velocity sweeps of one joint: for each speed (rad/s or m/s,
    non-zero), the joint's drive becomes a velocity drive (stiffness 0,
    ``damping``) from the far end of its range while the other joints hold;
    returns ``(velocities, efforts)``: the mean measured velocity and applied
    effort over the last ``measure_time`` s. Drive gains and targets are
    restored afterwards. Use a robot with gravity compensation (the default)
    so that only friction loads the joint."""
    names = list(robot.dof_names)
    if joint not in names:
        from .errors import UnknownNameError

        raise UnknownNameError(f"joint: '{joint}' is not a DOF of the robot (dof_names: {names})")
    dof = names.index(joint)
    speeds = _finite(speeds, "speeds")
    if speeds.ndim != 1 or len(speeds) == 0 or np.any(speeds == 0):
        raise InvalidArgumentError("speeds: expected a non-empty 1-D array of non-zero speeds")
    for v, what in ((damping, "damping"), (settle_time, "settle_time"), (measure_time, "measure_time")):
        if not (np.isfinite(v) and v > 0):
            raise InvalidArgumentError(f"{what} must be finite and > 0, got {v}")
    lo = robot.model.lower_limits[dof]
    hi = robot.model.upper_limits[dof]
    lo, hi = (lo, hi) if np.isfinite(lo) and np.isfinite(hi) else (-np.pi, np.pi)
    travel = 0.9 * (hi - lo)
    dt = world.dt
    g = robot.drive_gains
    stiff0, damp0, max0 = g.stiffness, g.damping, g.max_force
    q0 = robot.joint_positions
    targets0 = robot.joint_position_targets
    vel_out, eff_out = [], []
    try:
        for v in speeds:
            duration = settle_time + measure_time
            if abs(v) * duration > travel:
                raise InvalidArgumentError(
                    f"speeds: {v} moves the joint {abs(v) * duration:.3f} in {duration:.2f} s, "
                    f"more than 90% of its range ({travel:.3f}); lower the speed or the times"
                )
            q = q0.copy()
            q[dof] = lo + 0.05 * (hi - lo) if v > 0 else hi - 0.05 * (hi - lo)
            robot.set_joint_positions(q)
            robot.set_joint_position_targets(q)
            robot.set_drive_gains([0.0], [damping], joint_names=[robot.dof_names[dof]])
            vt = np.zeros(robot.num_dof)
            vt[dof] = v
            robot.set_joint_velocity_targets(vt)
            robot.set_joint_velocities(vt)
            world.step(max(1, int(round(settle_time / dt))))
            n = max(1, int(round(measure_time / dt)))
            acc_v = acc_e = 0.0
            for _ in range(n):
                world.step(1)
                acc_v += robot.joint_velocities[dof]
                acc_e += robot.measured_joint_efforts[dof]
            vel_out.append(acc_v / n)
            eff_out.append(acc_e / n)
    finally:
        robot.set_drive_gains(stiff0, damp0, max0)
        robot.set_joint_velocity_targets(np.zeros(robot.num_dof))
        robot.set_joint_positions(q0)
        robot.set_joint_position_targets(targets0)
    return np.array(vel_out), np.array(eff_out)
