"""Datasets of any robot with real objects (issues 17 and 19): ``ferrobot generate --robot ur5e --objects DIR``.

A UR5e with a Robotiq 2F-85 picking mesh objects from pybullet_data, recorded in both formats, read back with
independent readers (h5py; pyarrow for the tables and PyAV for the videos):

* the joint features are the UR5e's joints and the 2F-85's driver (its five mimic followers are not degrees
  of freedom); the gripper opening is the 2F-85's linkage map at the driver, checked against the distance
  between the finger pads from forward kinematics; the end-effector pose is the gripper's TCP (hand-link FK
  moved by the TCP offset with scipy's rotation); the wrist camera rides on the 2F-85's hand link;
* the recorded actions, replayed in a fresh world built from the stored scene, give the recorded simulator
  states bit for bit, and the replaying environment (``ferrobot.envs``, the dataset's robot) renders exactly
  the recorded images because the episode's lighting and wrist-camera mount are re-applied;
* the scene camera keeps clear of the robot's reach.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

import ferrobot
from ferrobot.control import ControlStepper
from ferrobot.dataset import GenerateConfig, generate, parse_cameras, scene_from_dict
from ferrobot.pipeline.recording import sim_state
from ferrobot.pipeline.scene import CAMERA_CLEARANCE, SceneSpec, build_world, home_for, place_camera, robot_reach

h5py = pytest.importorskip("h5py")
pq = pytest.importorskip("pyarrow.parquet")
av = pytest.importorskip("av")
Rotation = pytest.importorskip("scipy.spatial.transform").Rotation

CAMS = "scene:64x48,wrist:32x24"


@pytest.fixture(scope="module")
def objects(tmp_path_factory):
    """Four pybullet_data objects (URDF + mesh), copied to a folder of their own."""
    pybullet_data = pytest.importorskip("pybullet_data")
    src = Path(pybullet_data.getDataPath()) / "random_urdfs"
    d = tmp_path_factory.mktemp("objects")
    for name in ("000", "001", "002", "003"):
        shutil.copytree(src / name, d / name)
    return d


@pytest.fixture(scope="module")
def datasets(tmp_path_factory, objects):
    """One UR5e episode with 3 mesh objects, as HDF5 and as LeRobot (the same seed: the same episode)."""
    out = {}
    for fmt in ("hdf5", "lerobot"):
        root = tmp_path_factory.mktemp(fmt) / "ds"
        cfg = GenerateConfig(
            episodes=1, seed=8, format=fmt, robot="ur5e", objects=str(objects), clutter=3, cameras=parse_cameras(CAMS)
        )
        out[fmt] = (root, cfg, generate(root, cfg, workers=1, ray="off", progress=False))
    return out


def _episode_world(scene: dict):
    """The episode's world as the pick-and-place pipeline builds it for the UR5e."""
    model, gripper = ferrobot.robots.ur5e(), ferrobot.Gripper.robotiq_2f85()
    world, robot, _ = build_world(scene_from_dict(scene), model, q=home_for(model, gripper), name="robot")
    robot.use_gripper(gripper)
    return world, robot


def test_features_are_the_ur5e_joints_and_the_2f85_driver(datasets):
    root, _, _ = datasets["lerobot"]
    info = json.loads((root / "meta/info.json").read_text())
    model = ferrobot.robots.ur5e()
    arm = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint"] + [f"wrist_{i}_joint" for i in (1, 2, 3)]
    names = info["features"]["observation.state"]["names"]
    assert names == list(model.dof_names) == [*arm, "finger_joint"]
    followers = {name for name, _ in model.mimic_joints}
    assert len(followers) == 5 and not followers & set(names)
    assert info["features"]["action"]["names"] == [*arm, "gripper"]
    assert info["robot_type"] == "ur5e"
    assert info["ferrobot"]["objects"].endswith("objects0") or Path(info["ferrobot"]["objects"]).is_dir()
    eps = pq.read_table(root / "meta/episodes/chunk-000/file-000.parquet").to_pylist()
    scene = json.loads(eps[0]["scene"])
    assert all(o["kind"] == "mesh" for o in scene["objects"]) and len(scene["objects"]) == 3
    assert eps[0]["tasks"][0].startswith("pick up the ") and " object and place it at " in eps[0]["tasks"][0]
    assert eps[0]["success"]
    labels = json.loads(eps[0]["segmentation_labels"])
    assert any(v.startswith("robot/robotiq") for v in labels.values()), labels


def _pads(model, q):
    """World positions of the two inner finger pads (link origins) of the 2F-85 at ``q``."""
    pads = [n for n in model.link_names if "inner_finger" in n and "pad" in n]
    if len(pads) != 2:
        pads = sorted(n for n in model.link_names if n.endswith("inner_finger"))
    return [model.fk(q, link=n)[:3, 3] for n in pads]


def test_hdf5_observations_against_fk_and_the_linkage(datasets):
    root, _, _ = datasets["hdf5"]
    model, gripper = ferrobot.robots.ur5e(), ferrobot.Gripper.robotiq_2f85()
    with h5py.File(root / "dataset.hdf5", "r") as f:
        g = f["data/demo_0"]
        q = g["obs/state"][:].astype(np.float64)
        ee = g["obs/ee_pose"][:]
        opening = g["obs/gripper_opening"][:, 0]
        n = int(g.attrs["num_samples"])
        assert g["obs/images.wrist"].shape == (n, 24, 32, 3)
        assert g["actions"].shape == (n, 7)
    drv = list(model.dof_names).index("finger_joint")
    closing = np.asarray(gripper.closing)
    hand_frames = [model.fk(qk, link=gripper.hand_link) for qk in q]
    for k in range(0, n, 7):
        # TCP: hand-link FK, then the TCP offset rotated by scipy (quaternions compared up to sign).
        hand = hand_frames[k]
        p = hand[:3, 3] + hand[:3, :3] @ np.asarray(gripper.tcp)
        np.testing.assert_allclose(ee[k, :3], p, atol=2e-6)
        ref = Rotation.from_matrix(hand[:3, :3]).as_quat()  # x, y, z, w
        got = np.array([ee[k, 4], ee[k, 5], ee[k, 6], ee[k, 3]])
        assert abs(abs(np.dot(ref, got)) - 1) < 1e-5
        # Opening: the linkage map at the driver equals the pads' separation along the closing axis (FK of
        # the mimic tree) up to a constant pad offset.
        a, b = _pads(model, q[k])
        sep = abs(float(np.dot(hand[:3, :3].T @ (a - b), closing)))
        if k == 0:
            offset = sep - opening[0]
        assert opening[k] == pytest.approx(float(gripper.opening(q[k, drv])), abs=1e-6)
        assert sep - opening[k] == pytest.approx(offset, abs=1.5e-3), k
    # The gripper closed on the object at some point: the opening shrank from the open stroke.
    assert opening[0] == pytest.approx(gripper.max_opening, abs=2e-3) and opening.min() < opening[0] - 0.01


def test_ur5e_mesh_episode_replays_bit_for_bit(datasets):
    """The stored float32 actions stepped in a fresh world built from the stored scene reproduce the HDF5's
    float64 simulator states after every action, and the LeRobot run of the same seed stored the same
    actions and states (pyarrow), and the same depth (PyAV, lossless) as the HDF5."""
    root, _, _ = datasets["hdf5"]
    with h5py.File(root / "dataset.hdf5", "r") as f:
        g = f["data/demo_0"]
        scene = json.loads(g.attrs["model_file"])
        actions, states = g["actions"][:], g["states"][:]
        depth_h5 = g["obs/depth.scene"][:]
        rgb_h5 = g["obs/images.scene"][:]
        state_h5 = g["obs/state"][:]
    world, robot = _episode_world(scene)
    stepper = ControlStepper(world, robot)
    for k, a in enumerate(actions):
        assert a.dtype == np.float32
        stepper.step(a.astype(np.float64))
        assert np.array_equal(sim_state(world, robot), states[k]), f"state differs after action {k}"
    lr, _, _ = datasets["lerobot"]
    data = pq.read_table(lr / "data/chunk-000/file-000.parquet")
    np.testing.assert_array_equal(np.stack(data["action"].to_numpy(zero_copy_only=False)), actions)
    np.testing.assert_array_equal(np.stack(data["observation.state"].to_numpy(zero_copy_only=False)), state_h5)
    with av.open(str(lr / "videos/observation.depth.scene/chunk-000/file-000.mp4")) as c:
        depth = [fr.to_ndarray(format="gray16le") for fr in c.decode(video=0)]
    with av.open(str(lr / "videos/observation.images.scene/chunk-000/file-000.mp4")) as c:
        rgb = [fr.to_ndarray(format="rgb24") for fr in c.decode(video=0)]
    assert len(depth) == len(rgb) == len(actions)
    for k in range(len(actions)):
        np.testing.assert_array_equal(depth[k], np.rint(depth_h5[k].astype(np.float64) * 1000).astype(np.uint16))
        mse = np.mean((rgb[k].astype(float) - rgb_h5[k].astype(float)) ** 2)
        assert 10 * np.log10(255**2 / max(mse, 1e-9)) > 28


def test_replay_in_the_environment_applies_the_recorded_lighting(datasets):
    """``ferrobot.envs`` replaying the dataset (its robot from ``ReplayPolicy.env_kwargs``): every observed
    image equals the recorded one exactly, states included; without the recorded randomisation (default
    lighting, nominal wrist mount) the images differ."""
    gym = pytest.importorskip("gymnasium")
    import ferrobot.envs  # noqa: F401
    from ferrobot.envs.replay import ReplayPolicy, load_episodes

    root, _, _ = datasets["hdf5"]
    pol = ReplayPolicy(load_episodes(root))
    assert pol.env_kwargs() == {"robot": "ur5e"}
    rand = pol.episodes[0].randomization
    assert set(rand) >= {"lighting", "wrist_camera", "objects", "camera_eye"}
    env = gym.make(
        "ferrobot/PickPlace-v0",
        obs_mode="rgbd",
        cameras=["scene:64x48", "wrist:32x24"],
        terminate_on_success=False,
        **pol.env_kwargs(),
    )
    with h5py.File(root / "dataset.hdf5", "r") as f:
        g = f["data/demo_0"]
        rec = {k: g[f"obs/{k}"][:] for k in ("images.scene", "images.wrist", "depth.wrist", "state")}
    obs, _ = env.reset(options=pol.reset_options(0))
    pol.reset(env)
    n = len(rec["state"])
    for k in range(n):
        for key in ("images.scene", "images.wrist", "depth.wrist", "state"):
            np.testing.assert_array_equal(obs[f"observation.{key}"], rec[key][k], err_msg=f"{key} at frame {k}")
        if k + 1 < n:
            obs, *_ = env.step(pol.act(obs))
    # The same scene without the rendering draws: other pixels.
    obs, _ = env.reset(options={"scene": pol.episodes[0].scene})
    assert not np.array_equal(obs["observation.images.scene"], rec["images.scene"][0])
    assert not np.array_equal(obs["observation.images.wrist"], rec["images.wrist"][0])


def test_scene_camera_clears_the_reach():
    """Both bundled robots keep the default view; an arm reaching further (the UR5e's base on a tall mount
    seen from a closer camera) gets the eye moved back along the same ray to reach + clearance."""
    for model, gripper in (
        (ferrobot.robots.panda(), ferrobot.Gripper.panda_hand()),
        (ferrobot.robots.ur5e(), ferrobot.Gripper.robotiq_2f85()),
    ):
        spec = SceneSpec(seed=0, objects=[], target="", place_xy=(0.5, 0.0))
        eye = spec.camera_eye
        place_camera(spec, model, gripper)
        assert spec.camera_eye == eye
        assert np.linalg.norm(np.subtract(eye, spec.base_pose[:3])) >= robot_reach(model, gripper) + CAMERA_CLEARANCE
    model, gripper = ferrobot.robots.ur5e(), ferrobot.Gripper.robotiq_2f85()
    spec = SceneSpec(seed=0, objects=[], target="", place_xy=(0.5, 0.0), camera_eye=(0.9, 0.0, 0.9))
    place_camera(spec, model, gripper)
    eye, target, base = (np.asarray(v, dtype=float) for v in (spec.camera_eye, spec.camera_target, spec.base_pose[:3]))
    assert np.linalg.norm(eye - base) == pytest.approx(robot_reach(model, gripper) + CAMERA_CLEARANCE, abs=1e-9)
    ray0 = np.subtract((0.9, 0.0, 0.9), target)
    assert np.linalg.norm(np.cross(eye - target, ray0)) < 1e-9 and np.dot(eye - target, ray0) > 0
    # The reach: no sampled TCP (hand-link FK + offset, computed here) lies beyond it.
    rng = np.random.default_rng(5)
    q = rng.uniform(model.lower_limits, model.upper_limits, (500, model.num_dof))
    tcp = [model.fk(qk, link=gripper.hand_link) @ np.append(gripper.tcp, 1.0) for qk in q]
    assert max(np.linalg.norm(t[:3]) for t in tcp) <= robot_reach(model, gripper) + 0.02


def test_a_urdf_path_robot_and_early_errors(tmp_path):
    """``--robot PATH.urdf --srdf FILE`` (the bundled Panda's files written out): recorded with its own joint
    names and the file's stem as LeRobot's robot_type; a robot without a usable gripper, or a gripper that does
    not fit the robot, fails before anything is written."""
    from ferrobot.errors import FerrobotError

    urdf, srdf = tmp_path / "my_arm.urdf", tmp_path / "my_arm.srdf"
    urdf.write_text(ferrobot.robots.panda_urdf())
    srdf.write_text(ferrobot.robots.panda_srdf())
    out = tmp_path / "ds"
    cfg = GenerateConfig(
        episodes=1, seed=2, format="lerobot", robot=str(urdf), srdf=str(srdf), cameras=parse_cameras("scene:32x24")
    )
    generate(out, cfg, workers=1, ray="off", progress=False)
    info = json.loads((out / "meta/info.json").read_text())
    assert info["robot_type"] == "my_arm" and info["ferrobot"]["robot"] == str(urdf.resolve())
    assert info["features"]["observation.state"]["names"] == list(ferrobot.robots.panda().dof_names)
    data = pq.read_table(out / "data/chunk-000/file-000.parquet")
    opening = data["observation.gripper_opening"].to_pylist()
    state = data["observation.state"].to_pylist()
    assert all(abs(o - 2 * s[7]) < 1e-6 for o, s in zip(opening, state, strict=True))  # Panda: 2 x finger
    from conftest import UR5_SRDF, UR5_URDF

    ur5 = {"robot": str(UR5_URDF), "srdf": str(UR5_SRDF)}  # an arm without a gripper
    for k, kw in enumerate(({"robot": "panda", "gripper": "robotiq_2f85"}, ur5)):
        bad = tmp_path / f"bad-{k}"
        with pytest.raises(FerrobotError):
            generate(bad, GenerateConfig(episodes=1, cameras=parse_cameras("scene:32x24"), **kw), ray="off")
        assert not bad.exists()


def test_viewer_draws_the_grippers_own_fingers(tmp_path):
    """A UR5e demo folder: report.json names the 2F-85's finger geometry, and both the in-page viewer data and
    ``ferrobot view``'s reading of the folder draw the grasp with its 37.5 mm fingers (the Panda's are 50 mm)."""
    from ferrobot.pipeline import PickPlace, random_scene
    from ferrobot.pipeline.report import write_episode
    from ferrobot.pipeline.viewer import viewer_data
    from ferrobot.pipeline.viewer_live import episode_scene

    result = PickPlace(robot="ur5e").run(random_scene(3), record_frames=True, frame_every=240)
    assert result.episode.choice is not None
    write_episode(tmp_path, result)
    report = json.loads((tmp_path / "report.json").read_text())
    depth = ferrobot.Gripper.robotiq_2f85().detection_options().finger_depth
    assert report["gripper"]["name"] == "robotiq_2f85" and report["gripper"]["finger_depth"] == depth == 0.0375
    for data in (viewer_data(result.episode), episode_scene(tmp_path)):
        seg = np.asarray(data["grasp"], dtype=float).reshape(-1, 2, 3)
        lengths = np.linalg.norm(seg[:, 1] - seg[:, 0], axis=1)
        assert np.any(np.isclose(lengths, depth, atol=1e-9)) and not np.any(np.isclose(lengths, 0.05, atol=1e-9))
    # `ferrobot view` rebuilt the UR5e (the robot the trajectory names), not the Panda, and draws the same grasp
    # outline (finger depth, width and height from the report) as the page written with the episode.
    live, page = episode_scene(tmp_path), viewer_data(result.episode)
    assert live["robot"] == page["robot"]
    np.testing.assert_allclose(np.asarray(live["grasp"], float), np.asarray(page["grasp"], float), atol=1e-6)
