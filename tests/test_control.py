"""The control-rate stepper and the observation contract (issue 19): an action's effect is checked against
the contract written out by hand (targets interpolated per physics step with the slope as velocity
feed-forward), determinism bit for bit, argument errors, and observations against the simulator's own
link poses and the renderer's raw output."""

from __future__ import annotations

import numpy as np
import pytest

from ferrobot.control import CameraSpec, ControlStepper, features, make_cameras, observe
from ferrobot.errors import InvalidArgumentError, NonFiniteError, ShapeError
from ferrobot.pipeline import build_world, random_scene
from ferrobot.transforms import matrix_to_pose, world_to_base


def _world(seed=1):
    spec = random_scene(seed)
    world, robot, camera = build_world(spec)
    return spec, world, robot, camera


def _actions(robot, n=6):
    arm = list(robot.model.group_dof_indices)
    q0 = robot.joint_position_targets[arm]
    out = []
    for k in range(n):
        a = q0 + 0.05 * np.sin(np.arange(len(arm)) + 0.7 * k)
        out.append(np.append(a, 1.0 if k >= 3 else 0.0))
    return out


def test_step_matches_the_contract_written_by_hand():
    _, w1, r1, _ = _world()
    _, w2, r2, _ = _world()
    stepper = ControlStepper(w1, r1, control_hz=10.0)
    assert stepper.substeps == 24
    arm = list(r2.model.group_dof_indices)
    prev = r2.joint_position_targets[arm]
    closed = False
    for a in _actions(r1):
        stepper.step(a)
        new = a[:-1]
        if (a[-1] > 0.5) != closed:
            closed = a[-1] > 0.5
            r2.close_gripper(force=40.0) if closed else r2.open_gripper()
        slope = (new - prev) / 0.1
        for k in range(1, 25):
            r2.set_joint_position_targets(
                prev + (k * (1 / 240) / 0.1) * (new - prev), joint_names=[r2.dof_names[i] for i in arm]
            )
            r2.set_joint_velocity_targets(slope, joint_names=[r2.dof_names[i] for i in arm])
            w2.step(1)
        prev = new
        np.testing.assert_array_equal(r1.joint_positions, r2.joint_positions)
        np.testing.assert_array_equal(r1.joint_velocities, r2.joint_velocities)
    assert w1.time == pytest.approx(0.25 + 0.6)  # build_world settles 60 steps first


def test_same_actions_same_state_bit_for_bit():
    runs = []
    for _ in range(2):
        spec, world, robot, _ = _world(4)
        s = ControlStepper(world, robot)
        for a in _actions(robot, 5):
            s.step(a)
        runs.append((robot.joint_positions, robot.joint_velocities, world.get_object_pose(spec.objects[0].name)))
    for x, y in zip(*runs, strict=True):
        np.testing.assert_array_equal(x, y)


def test_bad_arguments():
    _, world, robot, _ = _world()
    with pytest.raises(InvalidArgumentError, match="control_hz"):
        ControlStepper(world, robot, control_hz=7.0)
    with pytest.raises(InvalidArgumentError, match="control_hz"):
        ControlStepper(world, robot, control_hz=480.0)
    with pytest.raises(InvalidArgumentError, match="control_hz"):
        ControlStepper(world, robot, control_hz=float("nan"))
    with pytest.raises(InvalidArgumentError, match="arm_joint_indices"), pytest.warns(DeprecationWarning):
        ControlStepper(world, robot, arm_joint_indices=[0, 99])
    s = ControlStepper(world, robot)
    a = s.hold_action()
    with pytest.raises(ShapeError, match="action"):
        s.step(a[:-1])
    bad = a.copy()
    bad[2] = np.nan
    with pytest.raises(NonFiniteError, match="action"):
        s.step(bad)
    bad = a.copy()
    bad[-1] = 1.5
    with pytest.raises(InvalidArgumentError, match="action"):
        s.step(bad)
    assert world.num_steps == 60  # nothing stepped by the rejected actions (build_world settles 60 steps)


def test_observation_contract():
    spec, world, robot, camera = _world(2)
    cams = make_cameras(
        world,
        robot,
        camera.world_transform,
        [CameraSpec("scene", 64, 48), CameraSpec("wrist", 32, 24)],
        scene_fov_deg=60.0,
    )
    s = ControlStepper(world, robot)
    s.step(s.hold_action())
    obs = observe(world, robot, cams, segmentation=True)
    n = robot.num_dof
    assert obs["observation.state"].dtype == np.float32 and obs["observation.state"].shape == (n,)
    assert obs["observation.velocity"].shape == (n,)
    assert obs["observation.images.scene"].shape == (48, 64, 3) and obs["observation.images.scene"].dtype == np.uint8
    assert obs["observation.images.wrist"].shape == (24, 32, 3)
    assert obs["observation.depth.scene"].dtype == np.float32 and obs["observation.depth.scene"].shape == (48, 64)
    assert obs["observation.segmentation.wrist"].dtype == np.int32
    # End-effector pose vs the simulator's own link pose moved to the base frame.
    hand = world_to_base(robot.get_link_pose(robot.model.ee_link), robot.world_transform)
    ref = matrix_to_pose(hand)
    got = obs["observation.ee_pose"].astype(np.float64)
    np.testing.assert_allclose(got[:3], ref[:3], atol=2e-5)
    assert abs(abs(np.dot(got[3:], ref[3:])) - 1) < 1e-5
    # Gripper opening: both Panda fingers open at 4 cm each.
    assert obs["observation.gripper_opening"][0] == pytest.approx(0.08, abs=2e-3)
    # Depth: the renderer's metres, 0 where it returned inf.
    raw = cams["scene"].render(rgb=False).depth
    np.testing.assert_array_equal(obs["observation.depth.scene"], np.where(np.isfinite(raw), raw, 0))
    f = features(robot, s, cams, segmentation=True)
    for key, value in obs.items():
        assert list(value.shape) == f[key]["shape"], key
    assert f["action"]["shape"] == [8] and f["action"]["names"][-1] == "gripper"


def test_wrist_camera_moves_with_the_hand():
    spec, world, robot, camera = _world(2)
    cams = make_cameras(world, robot, camera.world_transform, [CameraSpec("wrist", 32, 24)])
    before = cams["wrist"].world_transform
    s = ControlStepper(world, robot)
    a = s.hold_action()
    a[0] += 0.3
    for _ in range(5):
        s.step(a)
    after = cams["wrist"].world_transform
    hand = robot.get_link_pose("panda_hand")
    assert np.linalg.norm(after[:3, 3] - before[:3, 3]) > 0.05
    # Its pose relative to the hand is the configured one.
    np.testing.assert_allclose(np.linalg.inv(hand) @ after, cams["wrist"].local_pose, atol=1e-9)
