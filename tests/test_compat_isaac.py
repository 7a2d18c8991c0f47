"""Isaac Sim call shapes on ferrobot.World / Robot / Camera, as an Isaac Sim script writes them.

References: scipy's Rotation for quaternions and matrices, hand-derived camera axes."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import ferrobot
from ferrobot import errors
from ferrobot.compat.isaac import ArticulationAction, JointsState


def wxyz_to_matrix(q):
    return Rotation.from_quat([q[1], q[2], q[3], q[0]]).as_matrix()


@pytest.fixture()
def scene():
    world = ferrobot.World(dt=1 / 240)
    robot = world.add_robot(ferrobot.robots.panda(), name="franka")
    return world, robot


def test_isaac_script_shapes(scene):
    world, robot = scene
    # the seed workflow's set-up calls
    robot.initialize()
    robot.initialize()  # safe to repeat
    robot.set_solver_position_iteration_count(8)
    assert robot.get_solver_position_iteration_count() == 8
    with pytest.warns(UserWarning, match="no effect"):
        robot.set_solver_velocity_iteration_count(1)
    with pytest.warns(UserWarning, match="no effect"):
        robot.set_stabilization_threshold(0.001)

    robot_p, robot_q = robot.get_world_pose()
    assert robot_p.shape == (3,) and robot_q.shape == (4,)
    assert robot_p == pytest.approx([0, 0, 0]) and robot_q == pytest.approx([1, 0, 0, 0])

    yaw = 0.7
    q_wxyz = np.array([np.cos(yaw / 2), 0, 0, np.sin(yaw / 2)])
    robot.set_world_pose(position=np.array([0.3, -0.2, 0.1]), orientation=q_wxyz)
    p, q = robot.get_world_pose()
    assert p == pytest.approx([0.3, -0.2, 0.1], abs=1e-12)
    assert wxyz_to_matrix(q) == pytest.approx(Rotation.from_euler("z", yaw).as_matrix(), abs=1e-12)
    T = robot.world_transform
    assert T[:3, :3] == pytest.approx(Rotation.from_euler("z", yaw).as_matrix(), abs=1e-12)
    assert T[:3, 3] == pytest.approx([0.3, -0.2, 0.1])
    # one part at a time keeps the other
    robot.set_world_pose(position=[0.0, 0.0, 0.2])
    p, q = robot.get_world_pose()
    assert p == pytest.approx([0, 0, 0.2]) and wxyz_to_matrix(q) == pytest.approx(T[:3, :3], abs=1e-12)
    robot.set_world_pose(orientation=[1.0, 0, 0, 0])
    p, q = robot.get_world_pose()
    assert p == pytest.approx([0, 0, 0.2]) and q == pytest.approx([1, 0, 0, 0])
    # the old whole-pose form still works
    robot.set_world_pose([0.1, 0, 0, 1, 0, 0, 0])
    assert robot.get_world_pose()[0] == pytest.approx([0.1, 0, 0])

    t0 = world.time
    world.step(render=False)
    assert world.time == pytest.approx(t0 + 1 / 240)
    world.step(render=True, step_sim=False)
    assert world.time == pytest.approx(t0 + 1 / 240)

    state = robot.get_joints_state()
    assert isinstance(state, JointsState)
    assert state.positions == pytest.approx(robot.joint_positions)
    assert state.velocities == pytest.approx(robot.joint_velocities)
    assert state.efforts == pytest.approx(np.zeros(robot.num_dof))


def test_apply_action_drives_the_arm(scene):
    world, robot = scene
    q0 = robot.model.named_state("ready")
    robot.set_joint_positions(q0)
    robot.set_joint_position_targets(q0)
    target = q0.copy()
    target[:7] += np.array([0.2, -0.1, 0.1, 0.15, -0.1, 0.1, 0.2])
    robot.apply_action(ArticulationAction(joint_positions=target[:7], joint_indices=np.arange(7)))
    assert robot.joint_position_targets[:7] == pytest.approx(target[:7])
    world.step(480)
    assert robot.joint_positions[:7] == pytest.approx(target[:7], abs=2e-3)

    # None entries leave those joints' targets unchanged (Isaac Sim's behaviour)
    before = robot.joint_position_targets
    robot.apply_action(ArticulationAction(joint_positions=[0.5, None], joint_indices=[0, 3]))
    after = robot.joint_position_targets
    assert after[0] == 0.5 and after[3] == before[3]
    assert np.delete(after, 0) == pytest.approx(np.delete(before, 0))

    # efforts and velocities go to the drives and show in get_joints_state
    efforts = np.zeros(robot.num_dof)
    efforts[6] = 0.3
    robot.apply_action(ArticulationAction(joint_efforts=efforts, joint_velocities=np.zeros(robot.num_dof)))
    assert robot.get_joints_state().efforts == pytest.approx(efforts)
    assert robot.applied_joint_efforts == pytest.approx(efforts)


def test_apply_action_checks_everything_first(scene):
    _, robot = scene
    before = robot.joint_position_targets
    with pytest.raises(errors.ShapeError, match="joint_positions"):
        robot.apply_action(ArticulationAction(joint_positions=[0.1, 0.2], joint_indices=[0]))
    with pytest.raises(errors.NonFiniteError, match="joint_velocities"):
        robot.apply_action(ArticulationAction(joint_positions=[0.1], joint_velocities=[np.nan], joint_indices=[0]))
    with pytest.raises(errors.UnknownNameError, match="out of range"):
        robot.apply_action(ArticulationAction(joint_positions=[0.1], joint_indices=[99]))
    with pytest.raises(errors.InvalidArgumentError, match="ArticulationAction"):
        robot.apply_action(object())
    assert robot.joint_position_targets == pytest.approx(before)
    with pytest.raises(errors.InvalidArgumentError, match="orientation"):
        robot.set_world_pose(orientation=[2.0, 0, 0, 0])
    with pytest.raises(errors.NonFiniteError, match="position"):
        robot.set_world_pose(position=[np.nan, 0, 0])
    with pytest.raises(errors.ShapeError, match="position"):
        robot.set_world_pose(position=[0, 0])
    with pytest.raises(errors.InvalidArgumentError, match="threshold"):
        robot.set_stabilization_threshold(-1.0)


def test_camera_world_pose_axes():
    world = ferrobot.World()
    eye, target = np.array([1.2, 0.3, 1.0]), np.array([0.4, 0.0, 0.2])
    cam = ferrobot.Camera(world, 64, 48, fx=50.0, pose=ferrobot.look_at(eye, target))
    forward = (target - eye) / np.linalg.norm(target - eye)
    for axes, axis_index, sign in (("world", 0, 1), ("ros", 2, 1), ("usd", 2, -1)):
        p, q = cam.get_world_pose(camera_axes=axes)
        assert p == pytest.approx(eye)
        R = wxyz_to_matrix(q)
        assert sign * R[:, axis_index] == pytest.approx(forward, abs=1e-9), axes
    # Isaac Sim's default is "world": x forward, z up (image up has a positive world z)
    _, q = cam.get_world_pose()
    R = wxyz_to_matrix(q)
    assert R[:, 0] == pytest.approx(forward, abs=1e-9) and R[2, 2] > 0
    # "ros" is the OpenCV frame of get_world_transform
    _, q = cam.get_world_pose(camera_axes="ros")
    assert wxyz_to_matrix(q) == pytest.approx(cam.world_transform[:3, :3], abs=1e-9)
    with pytest.raises(errors.InvalidArgumentError, match="camera_axes"):
        cam.get_world_pose(camera_axes="opengl")
