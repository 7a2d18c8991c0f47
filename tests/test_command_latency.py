"""Command latency as a property of the simulated robot (issue 20).

Reference, derived by hand: a command issued at world time t through a robot with latency L
takes effect at the first step that starts at or after t + L, i.e. after ceil(L / dt) steps
(up to rounding). So a latency-L run must equal, step for step, a run without latency in
which every command is issued ceil(L / dt) steps later.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import ferrobot
from ferrobot.errors import InvalidArgumentError

DT = 1 / 240


def _world():
    model = ferrobot.robots.panda()
    world = ferrobot.World(dt=DT)
    robot = world.add_robot(model, name="panda")
    q0 = model.named_state("ready")
    robot.set_joint_positions(q0)
    robot.set_joint_position_targets(q0)
    return world, robot, q0


def _commands(q0, n):
    """A stream of position and velocity commands (a 0.4 rad/s ramp on joints 0 and 3)."""
    out = []
    for k in range(n):
        p = q0.copy()
        p[0] += 0.4 * k * DT
        p[3] += 0.4 * k * DT
        v = np.zeros_like(q0)
        v[[0, 3]] = 0.4
        out.append((p, v))
    return out


@pytest.mark.parametrize("latency", [12 * DT, 0.045])
def test_delayed_run_equals_the_shifted_undelayed_run(latency):
    shift = math.ceil(latency / DT - 1e-9)
    n = 60
    # Delayed: commands issued every step from step 0.
    world, robot, q0 = _world()
    robot.command_latency = latency
    assert robot.command_latency == pytest.approx(latency)
    cmds = _commands(q0, n)
    delayed = []
    for k in range(n + shift):
        if k < n:
            robot.set_joint_position_targets(cmds[k][0])
            robot.set_joint_velocity_targets(cmds[k][1])
        if k == 0:
            assert robot.pending_commands == 2
            # Nothing applied yet: the drives still hold q0.
            np.testing.assert_array_equal(robot.joint_position_targets, q0)
        world.step(1)
        delayed.append(robot.joint_positions)
    # Reference: no latency, every command issued `shift` steps later.
    world, robot, q0 = _world()
    reference = []
    for k in range(n + shift):
        if k >= shift:
            robot.set_joint_position_targets(cmds[k - shift][0])
            robot.set_joint_velocity_targets(cmds[k - shift][1])
        world.step(1)
        reference.append(robot.joint_positions)
    delayed, reference = np.array(delayed), np.array(reference)
    assert np.abs(delayed[shift] - q0).max() > 1e-4  # the robot did move
    np.testing.assert_allclose(delayed, reference, atol=1e-12, rtol=0)


def test_latency_applies_to_efforts_and_is_validated():
    world, robot, q0 = _world()
    robot.command_latency = 0.02  # 4.8 steps: applied at the start of step 5 (0-based), t = 5 dt
    robot.set_joint_efforts(np.full(robot.num_dof, 0.0))
    for bad in (-0.01, float("nan"), 11.0):
        with pytest.raises(InvalidArgumentError, match="latency"):
            robot.command_latency = bad
    assert robot.command_latency == pytest.approx(0.02)
    assert robot.pending_commands == 1
    world.step(5)  # steps 0-4 start before 0.02 s
    assert robot.pending_commands == 1
    world.step(1)
    assert robot.pending_commands == 0


def test_lookahead_compensates_a_known_trajectory():
    """Look-ahead by the robot's own latency (sample t + L issued at t) tracks the plan as well as
    the undelayed run does, up to the sub-step rounding."""
    world, robot, q0 = _world()
    robot.command_latency = 12 * DT
    cmds = _commands(q0, 72)
    positions = np.array([c[0] for c in cmds])
    err = []
    for k in range(60):
        t = k * DT
        p = ferrobot._core.trajectory_sample(positions, DT, t + robot.command_latency)
        robot.set_joint_position_targets(p)
        world.step(1)
        err.append(np.abs(robot.joint_positions - positions[k + 1]).max())
    world2, robot2, _ = _world()
    robot2.command_latency = 12 * DT
    err_uncomp = []
    for k in range(60):
        robot2.set_joint_position_targets(positions[k])
        world2.step(1)
        err_uncomp.append(np.abs(robot2.joint_positions - positions[k + 1]).max())
    assert max(err[20:]) < 0.25 * max(err_uncomp[20:])
