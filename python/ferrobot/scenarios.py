"""Fault scenarios: how a controller copes with what goes wrong on a real robot.

Each scenario builds a simulated Panda, runs a controlled motion with one
fault injected and returns a :class:`ScenarioResult`: pass/fail against stated
bounds, the measured values and the bounds themselves.

* :func:`payload_change` - a payload is added to the hand while it tracks a
  planned motion (mass changed at run time with ``Robot.set_link_inertial``);
  bounds on the tracking error before and after, the time to recover, no
  self-collision.
* :func:`stream_interruption` - the command stream stops for a while and comes
  back; a :class:`ferrobot.StreamGuard` holds the last command and catches up at
  a bounded rate; bounds on the commanded step after resume, on the motion
  while holding and on the recovery time.
* :func:`sensor_noise` - joint encoder noise in the feedback of a PID loop
  (:class:`EncoderNoise`) and depth noise on a camera frame (:class:`DepthNoise`);
  bounds on the hold error and on the noise statistics matching the model.
* :func:`conflicting_targets` - two sources command overlapping joints; an
  :class:`Arbiter` decides (priority, then the latest command) and reports the
  conflicts; bounds on following the winner.

Noise models, documented:

* Encoder: ``q_measured = round((q + n) / resolution) * resolution`` with
  ``n ~ N(0, sigma^2)`` per joint and sample (resolution 0: no quantisation).
* Depth (structured-light / ToF style, after Nguyen, Izadi and Lovell 2012 for
  the axial term): a valid depth ``z`` becomes ``z + n`` with
  ``n ~ N(0, (sigma0 + sigma2 (z - z0)^2)^2)`` (defaults 1.2 mm, 1.9 mm/m^2,
  0.4 m); a pixel is missing with probability ``dropout``; a pixel on a depth
  discontinuity (a 4-neighbour differs by more than ``edge_threshold``) is
  missing with probability ``edge_dropout``; missing pixels get
  ``missing_value`` (0.0, the "no reading" of ``ferrobot.grasp``); pixels
  without a reading (inf, NaN, <= 0) stay missing.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from . import _core
from .errors import InvalidArgumentError, ShapeError

__all__ = [
    "ScenarioResult",
    "EncoderNoise",
    "DepthNoise",
    "Arbiter",
    "payload_change",
    "stream_interruption",
    "sensor_noise",
    "conflicting_targets",
    "run_all",
]


@dataclass
class ScenarioResult:
    """Outcome of a scenario: ``passed`` is true when every bound holds."""

    name: str
    passed: bool
    metrics: dict
    bounds: dict
    failures: list = field(default_factory=list)

    def __str__(self) -> str:
        state = "PASS" if self.passed else "FAIL"
        parts = ", ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in self.metrics.items())
        return f"{self.name}: {state} ({parts})" + (f"; failed: {'; '.join(self.failures)}" if self.failures else "")


def _check(name: str, metrics: dict, bounds: dict) -> ScenarioResult:
    """Bounds are (metric, op, value) with op '<=' or '>=' (or '==')."""
    failures = []
    for key, (op, value) in bounds.items():
        got = metrics[key]
        ok = {"<=": got <= value, ">=": got >= value, "==": got == value}[op]
        if not ok:
            failures.append(f"{key} = {got} (bound {op} {value})")
    return ScenarioResult(name, not failures, metrics, bounds, failures)


def _positive(v, what: str, allow_zero: bool = False) -> float:
    v = float(v)
    if not np.isfinite(v) or v < 0 or (v == 0 and not allow_zero):
        raise InvalidArgumentError(f"{what} must be finite and {'>= 0' if allow_zero else '> 0'}, got {v}")
    return v


class EncoderNoise:
    """Joint encoder noise: Gaussian ``sigma`` (rad or m, scalar or per joint) then
    quantisation to ``resolution`` (0: none). Seeded, reproducible. The sampling runs in
    Rust (``ferrobot_control::faults::EncoderNoise``)."""

    def __init__(self, sigma, resolution: float = 0.0, seed: int = 0):
        s = np.asarray(sigma, dtype=np.float64)
        if s.ndim > 1 or not np.all(np.isfinite(s)) or np.any(s < 0):
            raise InvalidArgumentError(f"sigma must be finite and >= 0 (a number or one per joint), got {sigma}")
        self.sigma = s
        self.resolution = _positive(resolution, "resolution", allow_zero=True)
        self._inner = _core.EncoderNoise(s.reshape(-1), self.resolution, int(seed))

    def apply(self, q) -> np.ndarray:
        """A noisy reading of joint positions ``q``: a number, ``(n,)`` or ``(batch, n)``
        (a per-joint sigma must have ``n`` values)."""
        q = np.asarray(q, dtype=np.float64)
        if not np.all(np.isfinite(q)):
            raise InvalidArgumentError("q: non-finite values")
        return np.asarray(self._inner.apply(q)).reshape(q.shape)


class DepthNoise:
    """Depth camera noise (see the module docs for the model). The sampling and the edge
    detection run in Rust (``ferrobot_control::faults::DepthNoise``)."""

    def __init__(
        self,
        sigma0: float | None = None,
        sigma2: float | None = None,
        z0: float | None = None,
        dropout: float | None = None,
        edge_threshold: float | None = None,
        edge_dropout: float | None = None,
        missing_value: float | None = None,
        seed: int | None = None,
    ):
        """Each parameter left out takes its default from Rust (``DepthNoiseParams::default()``: sigma0 0.0012 m,
        sigma2 0.0019 1/m, z0 0.4 m, dropout 0.01, edge_threshold 0.02 m, edge_dropout 0.5, missing_value 0,
        seed 0); ranges: sigma0, sigma2 >= 0, z0 finite, dropout and edge_dropout in [0, 1], edge_threshold > 0.
        """
        self._inner = _core.DepthNoise(
            sigma0=sigma0,
            sigma2=sigma2,
            z0=z0,
            dropout=dropout,
            edge_threshold=edge_threshold,
            edge_dropout=edge_dropout,
            missing_value=missing_value,
            seed=seed,
        )
        for k, v in self._inner.params().to_dict().items():
            setattr(self, k, v)

    def sigma(self, z) -> np.ndarray:
        """Axial standard deviation (m) at depth ``z`` (m)."""
        return np.asarray(self._inner.sigma(np.asarray(z, dtype=np.float64)))

    @staticmethod
    def _depth(depth) -> np.ndarray:
        d = np.asarray(depth, dtype=np.float64)
        if d.ndim != 2:
            raise ShapeError(f"depth: expected shape (H, W), got {d.shape}")
        return np.where(np.isnan(d), np.inf, d)  # NaN: no reading, like inf

    def edges(self, depth) -> np.ndarray:
        """Boolean mask of depth discontinuities: valid pixels with a 4-neighbour
        whose depth differs by more than ``edge_threshold`` or that has no reading."""
        return np.asarray(self._inner.edges(self._depth(depth)))

    def apply(self, depth):
        """Noisy copy of ``depth`` (H, W) in metres; returns (depth, missing_mask)."""
        out, missing = self._inner.apply(self._depth(depth))
        return np.asarray(out), np.asarray(missing)


class Arbiter:
    """Arbitration between command sources for the same joints (runs in Rust:
    ``ferrobot_control::faults::Arbiter``).

    Rule (documented): for each joint, among the sources whose latest command
    for it is fresh (issued within ``timeout`` s before the query time, and not
    after it), the source with the highest priority wins; among equal priorities
    the latest command wins; among equal times the source registered first wins.
    Every resolution where two or more fresh sources command one joint with
    values differing by more than ``tolerance`` is recorded as a conflict
    (``conflicts``: :class:`ferrobot.ArbiterConflict` objects with ``t``, ``joint``, ``winner``, ``losers``).
    """

    def __init__(self, num_joints: int, timeout: float = 0.1, tolerance: float = 1e-9):
        if int(num_joints) <= 0:
            raise InvalidArgumentError(f"num_joints must be >= 1, got {num_joints}")
        self.n = int(num_joints)
        self.timeout = _positive(timeout, "timeout")
        self.tolerance = _positive(tolerance, "tolerance", allow_zero=True)
        self._inner = _core.Arbiter(self.n, self.timeout, self.tolerance)

    @property
    def order(self) -> list[str]:
        """Source names in registration order."""
        return list(self._inner.sources)

    @property
    def conflicts(self) -> list[_core.ArbiterConflict]:
        return list(self._inner.conflicts)

    def add_source(self, name: str, priority: int) -> None:
        self._inner.add_source(str(name), int(priority))

    def command(self, source: str, t: float, joints, values) -> None:
        """Source ``source`` commands ``values`` for joint indices ``joints`` at time ``t``."""
        j = np.asarray(joints, dtype=np.int64).reshape(-1)
        v = np.asarray(values, dtype=np.float64).reshape(-1)
        if j.shape != v.shape:
            raise ShapeError(f"values: expected shape {j.shape} like joints, got {v.shape}")
        if not np.isfinite(float(t)):
            raise InvalidArgumentError("t: non-finite time")
        if not np.all(np.isfinite(v)):
            raise InvalidArgumentError("values: non-finite values")
        self._inner.command(str(source), float(t), j.tolist(), v)

    def resolve(self, t: float):
        """Per joint, the winning value (NaN: no fresh command) and source (None)."""
        values, winners = self._inner.resolve(float(t))
        return np.asarray(values), list(winners)


# --- scenarios -------------------------------------------------------------


def _panda_world(gravity_compensation: bool, dt: float):
    from . import World, robots

    model = robots.panda()
    world = World(dt=dt)
    robot = world.add_robot(model, name="panda", gravity_compensation=gravity_compensation)
    q0 = model.named_state("ready")
    robot.set_joint_positions(q0)
    robot.set_joint_position_targets(q0)
    return model, world, robot, q0


def _planned_motion(model, q0, dt: float):
    from . import Planner

    planner = Planner(model)
    goal = q0.copy()
    goal[:7] += np.array([0.8, 0.4, -0.5, 0.5, 0.6, -0.4, 0.8])
    goal = np.clip(goal, model.lower_limits + 0.05, model.upper_limits - 0.05)
    result = planner.plan(q0, goal_q=goal)
    if not result.success:
        raise RuntimeError(f"planning the scenario's motion failed: {result.status}")
    traj = result.interpolated(dt=dt)
    names = list(traj.joint_names) if hasattr(traj, "joint_names") else list(model.dof_names[:7])
    idx = [list(model.dof_names).index(n) for n in names]
    return np.asarray(traj.positions), np.asarray(traj.velocities), idx


def _self_collisions(model, qs) -> int:
    from . import CollisionChecker

    checker = CollisionChecker(model)
    return int(np.sum(checker.in_collision_batch(np.asarray(qs))))


def payload_change(
    payload: float = 2.0,
    at_fraction: float = 0.4,
    max_error: float = 0.02,
    recovery_error: float = 0.005,
    max_recovery_time: float = 0.5,
    dt: float = 1 / 240,
) -> ScenarioResult:
    """Tracks a planned motion with gravity acting (drives hold against it); at
    ``at_fraction`` of the motion ``payload`` kg is added to the hand 10 cm along
    its z axis. Bounds: max joint tracking error <= ``max_error`` rad throughout,
    back under ``recovery_error`` within ``max_recovery_time`` s of the change,
    no self-collision of the executed states."""
    from .calibration import add_payload

    _positive(payload, "payload", allow_zero=True)
    if not 0 < at_fraction < 1:
        raise InvalidArgumentError(f"at_fraction must be in (0, 1), got {at_fraction}")
    model, world, robot, q0 = _panda_world(False, dt)
    world.step(int(0.3 / dt))  # settle under gravity
    positions, velocities, idx = _planned_motion(model, q0, dt)
    change = int(at_fraction * len(positions))
    before = robot.get_link_inertial("panda_hand")
    errors, states = [], []
    names = [robot.dof_names[j] for j in idx]
    for k in range(len(positions) + int(0.5 / dt)):
        if k == change:
            m, c, inertia = add_payload(before.mass, before.com, before.inertia, payload, [0.0, 0.0, 0.1])
            robot.set_link_inertial("panda_hand", m, c, inertia)
        i = min(k, len(positions) - 1)
        v = velocities[i] if k < len(positions) else np.zeros(len(idx))
        robot.set_joint_position_targets(positions[i], joint_names=names)
        robot.set_joint_velocity_targets(v, joint_names=names)
        world.step(1)
        q = robot.joint_positions
        states.append(q)
        errors.append(np.max(np.abs(q[idx] - positions[i])))
    errors = np.array(errors)
    after = errors[change:]
    bad = np.nonzero(after > recovery_error)[0]
    recovery = 0.0 if len(bad) == 0 else (bad[-1] + 1) * dt
    metrics = {
        "max_error_before": float(errors[:change].max()),
        "max_error_after": float(after.max()),
        "recovery_time": float(recovery),
        "self_collisions": _self_collisions(model, states),
        "hand_mass": float(robot.get_link_inertial("panda_hand").mass),
    }
    bounds = {
        "max_error_before": ("<=", max_error),
        "max_error_after": ("<=", max_error),
        "recovery_time": ("<=", max_recovery_time),
        "self_collisions": ("==", 0),
    }
    return _check("payload_change", metrics, bounds)


def stream_interruption(
    gap_start: float = 0.4,
    gap: float = 0.3,
    timeout: float = 0.05,
    speed_fraction: float = 0.5,
    max_recovery_time: float = 1.5,
    max_hold_speed: float = 0.05,
    dt: float = 1 / 240,
) -> ScenarioResult:
    """A planned motion is streamed as position commands every step; between
    ``gap_start`` and ``gap_start + gap`` s nothing arrives. A
    :class:`ferrobot.StreamGuard` (``timeout`` s, ``speed_fraction`` x the URDF
    velocity limits) holds the last command and, when the stream returns,
    catches up without a jump. Bounds: every commanded step <= max velocity x
    dt; joint speed while holding (after 0.2 s of braking) <= ``max_hold_speed``
    rad/s; caught up within ``max_recovery_time`` s of the stream's return;
    no self-collision."""
    _positive(gap, "gap")
    model, world, robot, q0 = _panda_world(True, dt)
    positions, velocities, idx = _planned_motion(model, q0, dt)
    vmax = speed_fraction * np.asarray(model.velocity_limits)[idx]
    guard = _core.StreamGuard(timeout, vmax)
    t0, t1 = gap_start, gap_start + gap
    steps_max, hold_speed, states = 0.0, 0.0, []
    resumed_at, caught_at = None, None
    allowed = float(np.max(vmax)) * dt * (1 + 1e-9)
    worst_ratio = 0.0
    n = len(positions) + int((gap + max_recovery_time + 0.5) / dt)
    prev = None
    names = [robot.dof_names[j] for j in idx]
    for k in range(n):
        t = k * dt
        i = min(k, len(positions) - 1)
        incoming = None if t0 <= t < t1 else positions[i]
        current = robot.joint_positions[idx]
        out = guard.update(t, incoming, current)
        cmd = out.command
        if prev is not None:
            worst_ratio = max(worst_ratio, float(np.max(np.abs(cmd - prev) / (vmax * dt))))
        prev = cmd
        steps_max = max(steps_max, out.step)
        vel = np.zeros(len(idx)) if (out.holding or out.catching_up) else velocities[i]
        robot.set_joint_position_targets(cmd, joint_names=names)
        robot.set_joint_velocity_targets(vel, joint_names=names)
        world.step(1)
        states.append(robot.joint_positions)
        if out.holding and t > t0 + timeout + 0.2:
            hold_speed = max(hold_speed, float(np.max(np.abs(robot.joint_velocities[idx]))))
        if t >= t1 and resumed_at is None:
            resumed_at = t
        if resumed_at is not None and caught_at is None and not out.catching_up and not out.holding:
            caught_at = t
    recovery = (caught_at - resumed_at) if caught_at is not None else float("inf")
    metrics = {
        "max_command_step": float(steps_max),
        "step_over_limit": float(worst_ratio),
        "max_hold_speed": hold_speed,
        "recovery_time": float(recovery),
        "self_collisions": _self_collisions(model, states),
    }
    bounds = {
        "max_command_step": ("<=", allowed),
        "step_over_limit": ("<=", 1.0 + 1e-9),
        "max_hold_speed": ("<=", max_hold_speed),
        "recovery_time": ("<=", max_recovery_time),
        "self_collisions": ("==", 0),
    }
    return _check("stream_interruption", metrics, bounds)


def sensor_noise(
    encoder_sigma: float = 1e-3,
    max_hold_error: float = 0.01,
    depth_frames: int = 1,
    dt: float = 1 / 240,
    seed: int = 0,
) -> ScenarioResult:
    """(a) The Panda holds ``ready`` under a joint PID (drives off, efforts from
    the PID) fed by encoder readings with ``encoder_sigma`` noise; bound: true
    joint error <= ``max_hold_error`` rad after 0.5 s. (b) A camera frame of a
    box on a table gets :class:`DepthNoise`; bounds: the measured axial std over
    valid pixels within 10% of the model's, the random dropout rate within
    5 binomial standard errors of the stated rate, and every edge-dropped
    pixel on a discontinuity."""
    from . import Camera, JointPID, look_at

    model, world, robot, q0 = _panda_world(True, dt)
    arm = robot.dof_names[:7]  # the finger keeps its drive
    robot.set_drive_gains(np.zeros(7), np.zeros(7), joint_names=arm)
    enc = EncoderNoise(encoder_sigma, seed=seed)
    kp = np.array([400.0, 400.0, 400.0, 400.0, 100.0, 100.0, 40.0])
    pid = JointPID(kp, kp / 10, kp / 40, integral_limit=5.0, output_limit=87.0)
    # The start is perturbed by 0.05 rad so that the loop has something to correct.
    robot.set_joint_positions(q0 + np.r_[np.full(7, 0.05), 0.0])
    max_err = 0.0
    for k in range(int(1.5 / dt)):
        q = robot.joint_positions[:7]
        qd = robot.joint_velocities[:7]
        u = pid.update(enc.apply(q), qd, q0[:7], dt)
        robot.set_joint_efforts(u, joint_names=arm)
        world.step(1)
        if k * dt > 0.5:
            max_err = max(max_err, float(np.max(np.abs(robot.joint_positions[:7] - q0[:7]))))
    # Depth noise on a rendered frame.
    world.add_box("table", [0.8, 1.0, 0.4], [0.6, 0.0, 0.2, 1, 0, 0, 0], fixed=True)
    world.add_box("box", [0.1, 0.1, 0.1], [0.55, 0.0, 0.45, 1, 0, 0, 0], fixed=True)
    cam = Camera(world, 160, 120, fx=140.0, pose=look_at([1.3, 0.0, 1.1], [0.55, 0.0, 0.4]))
    depth = cam.render(rgb=False).depth.astype(np.float64)
    noise = DepthNoise(seed=seed, dropout=0.05, edge_dropout=0.5)
    valid = np.isfinite(depth) & (depth > 0)
    edges = noise.edges(depth)
    interior = valid & ~edges
    z_err, dropped_interior, dropped_edge = [], [], []
    for _ in range(max(1, depth_frames) * 20):
        out, missing = noise.apply(depth)
        keep = interior & ~missing
        z_err.append((out[keep] - depth[keep]) / noise.sigma(depth[keep]))
        dropped_interior.append(missing[interior])
        dropped_edge.append(missing[valid & edges])
    z = np.concatenate(z_err)
    rate = float(np.mean(np.concatenate(dropped_interior)))
    n_int = sum(len(d) for d in dropped_interior)
    se = np.sqrt(noise.dropout * (1 - noise.dropout) / n_int)
    edge_rate = float(np.mean(np.concatenate(dropped_edge))) if edges.any() else 0.0
    expect_edge = noise.dropout + (1 - noise.dropout) * noise.edge_dropout
    metrics = {
        "max_hold_error": max_err,
        "normalised_std": float(np.std(z)),
        "dropout_rate": rate,
        "dropout_z": float(abs(rate - noise.dropout) / se),
        "edge_dropout_rate": edge_rate,
        "edge_dropout_error": float(abs(edge_rate - expect_edge)),
        "edge_pixels": int(edges.sum()),
    }
    bounds = {
        "max_hold_error": ("<=", max_hold_error),
        "normalised_std": ("<=", 1.1),
        "dropout_z": ("<=", 5.0),
        "edge_dropout_error": ("<=", 0.05),
        "edge_pixels": (">=", 1),
    }
    res = _check("sensor_noise", metrics, bounds)
    if metrics["normalised_std"] < 0.9:
        res.passed = False
        res.failures.append(f"normalised_std = {metrics['normalised_std']} (bound >= 0.9)")
    return res


def conflicting_targets(dt: float = 1 / 240, tolerance: float = 0.01) -> ScenarioResult:
    """A planner (priority 0) streams the hold of ``ready`` for joints 0-6 while a
    teleoperator (priority 1) commands joints 0-2 from 0.3 s to 0.8 s, and a
    second, equal-priority planner sends one conflicting command for joint 3 at
    0.5 s (the later command wins). Bounds: each joint ends within ``tolerance``
    of its winner's target; conflicts are reported for exactly the contested
    joints (0-3); the teleoperator wins joints 0-2 while it is active."""
    model, world, robot, q0 = _panda_world(True, dt)
    arb = Arbiter(robot.num_dof, timeout=0.05)
    arb.add_source("planner", 0)
    arb.add_source("teleop", 1)
    arb.add_source("planner2", 0)
    arm = list(range(7))
    teleop_q = q0[:3] + np.array([0.3, -0.2, 0.25])
    contested_ok = True
    for k in range(int(1.6 / dt)):
        t = k * dt
        arb.command("planner", t, arm, q0[:7])
        if 0.3 <= t < 0.8:
            arb.command("teleop", t, [0, 1, 2], teleop_q)
            if abs(t - 0.5) < dt / 2:
                arb.command("planner2", t + 1e-6, [3], [q0[3] + 0.2])
        values, winners = arb.resolve(t + 1e-6)
        if 0.3 <= t < 0.8 and winners[:3] != ["teleop"] * 3:
            contested_ok = False
        ix = [j for j in range(robot.num_dof) if winners[j] is not None]
        robot.set_joint_position_targets(values[ix], joint_names=[robot.dof_names[j] for j in ix])
        if abs(t - 0.75) < dt / 2:
            q_teleop = robot.joint_positions[:3].copy()
        world.step(1)
    q_end = robot.joint_positions
    joints = sorted({c.joint for c in arb.conflicts})
    metrics = {
        "teleop_error": float(np.max(np.abs(q_teleop - teleop_q))),
        "final_error": float(np.max(np.abs(q_end[:7] - q0[:7]))),
        "conflicts": len(arb.conflicts),
        "contested_joints": joints,
        "teleop_won_while_active": contested_ok,
    }
    bounds = {"teleop_error": ("<=", tolerance), "final_error": ("<=", tolerance)}
    res = _check("conflicting_targets", metrics, bounds)
    if joints != [0, 1, 2, 3]:
        res.passed = False
        res.failures.append(f"contested_joints = {joints} (expected [0, 1, 2, 3])")
    if not contested_ok:
        res.passed = False
        res.failures.append("the teleoperator did not win joints 0-2 while active")
    return res


def run_all() -> list[ScenarioResult]:
    """Every scenario with its default bounds."""
    return [payload_change(), stream_interruption(), sensor_noise(), conflicting_targets()]
