"""Helpers shared by the simulation tests: a tiny IK by resolved-rate
iterations on the model (kinematics only) and a straight-line carry."""

from __future__ import annotations

import numpy as np

import ferrobot

DOWN = np.diag([1.0, -1.0, -1.0, 1.0])  # gripper pointing down (rotation of pi about x)


def pose_at(p) -> np.ndarray:
    """A gripper-down pose at position ``p``."""
    t = DOWN.copy()
    t[:3, 3] = p
    return t


def ik(model, q0, target, link, iters=400, joints=None):
    """Inverse kinematics by iterating the resolved-rate controller on the model."""
    ctl = ferrobot.ResolvedRateController(
        model,
        link=link,
        joint_names=None if joints is None else [model.dof_names[i] for i in joints],
        linear_gain=1.0,
        angular_gain=1.0,
        max_linear_speed=10.0,
        max_angular_speed=10.0,
        damping=0.01,
    )
    q = np.array(q0, dtype=float)
    for _ in range(iters):
        q = np.clip(q + 0.5 * ctl.compute(q, target), model.lower_limits, model.upper_limits)
    return q


def straight_line(model, q_start, start, goal, link, peak_speed, dt):
    """Arm joint positions (N, 7) moving ``link`` along a straight line with a
    quintic time law whose peak Cartesian speed is ``peak_speed``."""
    dist = np.linalg.norm(np.subtract(goal, start))
    duration = 1.875 * dist / peak_speed  # quintic: peak speed = 1.875 x mean
    n = int(np.ceil(duration / dt)) + 1
    s = np.linspace(0.0, 1.0, n)
    s = 10 * s**3 - 15 * s**4 + 6 * s**5
    qs = [np.array(q_start, dtype=float)]
    for k in range(1, n):
        p = np.asarray(start) + s[k] * (np.asarray(goal) - np.asarray(start))
        qs.append(ik(model, qs[-1], pose_at(p), link, iters=5, joints=list(range(7))))
    return np.array(qs)[:, :7]


PANDA_Q0 = np.array([0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.785, 0.04])
