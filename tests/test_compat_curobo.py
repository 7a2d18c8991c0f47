"""cuRobo call shapes (MotionGen, IKSolver, JointState, Pose, robot and world configs) over ferrobot's planner.

References: Pinocchio's FK for reached poses, hand-derived signed distances for the world obstacles."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
import yaml
from scipy.spatial.transform import Rotation

import ferrobot
from conftest import PANDA_URDF
from ferrobot import errors
from ferrobot.compat.curobo import (
    IKSolver,
    IKSolverConfig,
    JointState,
    MotionGen,
    MotionGenConfig,
    MotionGenPlanConfig,
    Pose,
    WorldConfig,
)

ARM = [f"panda_joint{i}" for i in range(1, 8)]
SPHERIZED = PANDA_URDF.parent / "panda_spherized.urdf"
READY = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785]


@pytest.fixture(scope="module")
def robot_yaml(tmp_path_factory):
    """cuRobo's robot config file with a spheres file beside it, relative paths as cuRobo's configs use."""
    d = tmp_path_factory.mktemp("curobo")
    model = ferrobot.RobotModel.from_urdf(PANDA_URDF)
    ferrobot.SphereModel.from_spherized_urdf(model, SPHERIZED).save(d / "panda_spheres.yml")
    cfg = {
        "robot_cfg": {
            "kinematics": {
                "urdf_path": str(PANDA_URDF),
                "base_link": "panda_link0",
                "ee_link": "panda_hand",
                "collision_spheres": "panda_spheres.yml",
                "collision_sphere_buffer": 0.0,
                "collision_link_names": ["panda_link1"],
                "extra_links": {"attached_object": {"parent_link_name": "panda_hand"}},
                "cspace": {
                    "joint_names": ARM,
                    "retract_config": READY,
                    "max_acceleration": 15.0,
                    "max_jerk": 500.0,
                },
            }
        }
    }
    path = d / "panda.yml"
    path.write_text(yaml.safe_dump(cfg))
    return path


WORLD = {
    "cuboid": {"table": {"dims": [1.0, 1.2, 0.04], "pose": [0.5, 0.0, -0.1, 1, 0, 0, 0]}},
    "sphere": {"ball": {"radius": 0.05, "pose": [0.4, 0.5, 0.6, 1, 0, 0, 0]}},
    "capsule": {"rod": {"radius": 0.02, "base": [0, 0, 0], "tip": [0, 0, 0.3], "pose": [-0.4, 0.4, 0.0, 1, 0, 0, 0]}},
    "cylinder": {"post": {"radius": 0.03, "height": 0.4, "pose": [-0.4, -0.4, 0.2, 1, 0, 0, 0]}},
}


def pin_fk(q7, link="panda_hand"):
    pm = pin.buildModelFromUrdf(str(PANDA_URDF))
    data = pm.createData()
    pin.framesForwardKinematics(pm, data, np.asarray(q7))
    M = data.oMf[pm.getFrameId(link)]
    return M.translation.copy(), M.rotation.copy()


def test_world_config_obstacles_match_hand_distances(tmp_path):
    obj = tmp_path / "tet.obj"
    obj.write_text("v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nv 0 0 0.1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n")
    cfg = dict(WORLD)
    cfg["mesh"] = {"tet": {"file_path": str(obj), "pose": [0.0, -0.8, 0.0, 1, 0, 0, 0], "scale": [2, 2, 2]}}
    w = WorldConfig.from_dict(cfg).to_collision_world()
    assert sorted(w.names) == ["ball", "post", "rod", "table", "tet"]
    pts = np.array(
        [
            [0.5, 0.0, 0.30],  # 0.38 above the table top (z = -0.08)
            [0.4, 0.5, 0.80],  # 0.15 from the ball's surface
            [-0.4, 0.5, 0.15],  # 0.1 beside the rod's axis: 0.08 from its surface
            [-0.4, 0.4, 0.50],  # 0.2 above the rod's tip: 0.18
            [-0.4, -0.3, 0.2],  # 0.1 from the post's axis: 0.07
            [0.3, -0.8, 0.0],  # 0.1 beyond the scaled tetrahedron's vertex at x = 0.2
        ]
    )
    expected = [0.38, 0.15, 0.08, 0.18, 0.07, 0.1]
    d = w.signed_distance(pts)
    assert d == pytest.approx(expected, abs=1e-6)


def test_motion_gen_plan_single_as_a_curobo_script(robot_yaml):
    config = MotionGenConfig.load_from_robot_config(
        str(robot_yaml), WORLD, tensor_args=None, interpolation_dt=0.01, use_cuda_graph=True
    )
    motion_gen = MotionGen(config)
    motion_gen.warmup()
    retract = motion_gen.get_retract_config()
    assert retract == pytest.approx(READY)
    start = JointState.from_position(retract.reshape(1, -1), joint_names=ARM)
    goal = Pose.from_list([0.45, 0.2, 0.35, 0.0, 1.0, 0.0, 0.0])
    result = motion_gen.plan_single(start, goal, MotionGenPlanConfig(max_attempts=3, timeout=2.0))
    assert result.success.item(), result.status
    assert result.interpolation_dt == 0.01
    traj = result.get_interpolated_plan()
    assert traj.position.shape[1] == 7 and traj.joint_names == ARM
    assert len(traj.position) == pytest.approx(result.motion_time.item() / 0.01 + 1, abs=1.5)
    assert traj.position[0] == pytest.approx(retract, abs=1e-9)
    # the reached pose, by Pinocchio
    p, R = pin_fk(traj.position[-1])
    assert p == pytest.approx([0.45, 0.2, 0.35], abs=0.005)
    target = Rotation.from_quat([1.0, 0.0, 0.0, 0.0]).as_matrix()  # (x, y, z, w) of wxyz (0, 1, 0, 0)
    assert Rotation.from_matrix(R.T @ target).magnitude() < 0.05
    # velocities by finite differences of positions
    fd = np.gradient(traj.position, 0.01, axis=0)
    assert np.abs(fd[1:-1] - traj.velocity[1:-1]).max() < 0.05
    # a simulator's joint order
    sim_names = ARM[::-1]
    ordered = traj.get_ordered_joint_state(sim_names)
    assert ordered.position == pytest.approx(traj.position[:, ::-1])
    assert ordered.joint_names == sim_names
    with pytest.raises(errors.UnknownNameError):
        traj.get_ordered_joint_state(["panda_finger_joint9"])

    # joint-space goal and a goal inside an obstacle
    js = motion_gen.plan_single_js(start, JointState.from_position(traj.position[-1], joint_names=ARM))
    assert js.success.item()
    bad = motion_gen.plan_single(
        start, Pose.from_list([0.4, 0.5, 0.6, 0, 1, 0, 0]), MotionGenPlanConfig(max_attempts=1)
    )
    assert not bad.success.item() and bad.status
    with pytest.raises(errors.InvalidArgumentError, match="planning failed"):
        bad.get_interpolated_plan()


def test_ik_solver_solve_single_and_batch(robot_yaml):
    cfg = yaml.safe_load(robot_yaml.read_text())
    # the dict form, spheres given inline as a dict
    spheres = yaml.safe_load((robot_yaml.parent / "panda_spheres.yml").read_text())
    cfg["robot_cfg"]["kinematics"]["collision_spheres"] = spheres["collision_spheres"]
    ik_config = IKSolverConfig.load_from_robot_config(
        cfg, None, rotation_threshold=0.05, position_threshold=0.005, num_seeds=20, self_collision_check=True
    )
    ik = IKSolver(ik_config)
    goal = Pose(np.array([[0.4, -0.1, 0.5]]), np.array([[0.0, 1.0, 0.0, 0.0]]))
    result = ik.solve_single(goal)
    assert result.success.shape == (1, 1) and result.success.item()
    q = result.solution[0, 0]
    p, _ = pin_fk(q)
    assert p == pytest.approx([0.4, -0.1, 0.5], abs=0.005)
    assert result.js_solution.joint_names == ARM
    # ik.fk agrees with Pinocchio
    k = ik.fk(q)
    assert k.ee_position[0] == pytest.approx(p, abs=1e-9)

    goals = Pose(np.array([[0.4, -0.1, 0.5], [0.3, 0.3, 0.4], [3.0, 0.0, 0.0]]), np.tile([0.0, 1.0, 0.0, 0.0], (3, 1)))
    batch = ik.solve_batch(goals)
    assert batch.success[:, 0].tolist() == [True, True, False]
    for i in range(2):
        assert pin_fk(batch.solution[i, 0])[0] == pytest.approx(goals.position[i], abs=0.005)


def test_bad_configs_raise_clear_errors(robot_yaml, tmp_path):
    cfg = yaml.safe_load(robot_yaml.read_text())
    cfg["robot_cfg"]["kinematics"]["collision_spheres"] = str(robot_yaml.parent / "panda_spheres.yml")
    with pytest.raises(errors.InvalidArgumentError, match="not_a_curobo_option"):
        MotionGenConfig.load_from_robot_config(cfg, None, not_a_curobo_option=1)
    broken = yaml.safe_load(robot_yaml.read_text())
    broken["robot_cfg"]["kinematics"]["urdf_path"] = "nowhere/robot.urdf"
    with pytest.raises(errors.InvalidArgumentError, match="urdf_path"):
        MotionGenConfig.load_from_robot_config(broken)
    named = yaml.safe_load(robot_yaml.read_text())
    named["robot_cfg"]["kinematics"]["collision_spheres"] = str(robot_yaml.parent / "panda_spheres.yml")
    named["robot_cfg"]["kinematics"]["cspace"]["joint_names"] = ARM + ["elbow_joint"]
    with pytest.raises(errors.UnknownNameError, match="elbow_joint"):
        MotionGenConfig.load_from_robot_config(named)
    with pytest.raises(errors.InvalidArgumentError, match="interpolation_dt"):
        MotionGenConfig.load_from_robot_config(cfg, interpolation_dt=0.0)
    with pytest.raises(errors.InvalidArgumentError, match="not supported"):
        WorldConfig.from_dict({"voxel": {"v": {}}})
    with pytest.raises(errors.ShapeError, match="quaternion"):
        Pose([0, 0, 0], [1, 0, 0])
    with pytest.raises(errors.InvalidArgumentError, match="NaN"):
        JointState.from_position([np.nan] * 7)
