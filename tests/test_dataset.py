"""Recorded episodes and the dataset formats (issue 19).

* Exact replay: the recorded actions, replayed through a ControlStepper in a fresh world built from the same
  scene, reproduce every recorded simulator state bit for bit.
* LeRobot v3.0 read back with independent readers: pyarrow for the tables (layout and field names as
  LeRobot's source writes them), PyAV decoding every video frame and comparing with the frames rendered by a
  second run of the same episodes (RGB within H.264 tolerance; depth exactly, as uint16 millimetres;
  segmentation label ids exactly, as uint16).
* robomimic HDF5 read back with h5py.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from ferrobot.control import ControlStepper, make_cameras
from ferrobot.dataset import GenerateConfig, generate, parse_cameras
from ferrobot.dataset.generate import apply_lighting, episode_cameras, episode_seed, episode_spec, scene_fov
from ferrobot.pipeline import PickPlace, build_world, random_scene
from ferrobot.pipeline.recording import ControlRecorder, sim_state

CAMS = "scene:64x48,wrist:32x24"


@pytest.fixture(scope="module")
def pp():
    from ferrobot.dataset.generate import _PP

    p = PickPlace()
    _PP[("panda", None, None)] = p  # in-process generation (workers=1) reuses it: a planner takes seconds to build
    return p


def record(pp, spec, cams=CAMS, rand=None):
    """Runs ``spec`` recording every frame; ``rand``: the episode's randomisation (lighting, wrist camera)."""
    frames = []
    labels = {}
    specs = episode_cameras({"cameras": parse_cameras(cams)}, rand or {})

    def factory(world, robot, camera, arm):
        apply_lighting(world, rand or {})
        cameras = make_cameras(world, robot, camera.world_transform, specs, scene_fov_deg=scene_fov(spec))
        labels.update(world.segmentation_labels)
        return ControlRecorder(
            world,
            robot,
            cameras,
            frames.append,
            arm_joint_names=[robot.dof_names[i] for i in arm],
            segmentation=True,
            gripper=pp.gripper,
        )

    result = pp.run(spec, recorder=factory)
    for f in frames:
        f["segmentation_labels"] = labels
    return result, frames


def test_replaying_recorded_actions_reproduces_the_states_bit_for_bit(pp):
    spec = random_scene(5)
    result, frames = record(pp, spec)
    assert result.success, result.reason
    assert len(frames) > 30
    stages = [f["stage"] for f in frames]
    assert stages[0] == "pregrasp" and stages[-1] == "verify" and "grasp" in stages
    world, robot, _ = build_world(spec)
    stepper = ControlStepper(world, robot, arm_joint_names=[robot.dof_names[i] for i in result.episode.arm_idx])
    for k, f in enumerate(frames):
        # The dataset's float32 action, as a replaying environment would read it.
        assert f["action"].dtype == np.float32
        np.testing.assert_array_equal(robot.joint_positions.astype(np.float32), f["observation.state"])
        stepper.step(f["action"].astype(np.float64))
        assert np.array_equal(sim_state(world, robot), f["state"]), f"state differs after action {k}"
    # And the object really ended at the place location (the replay is the episode).
    pose = world.get_object_pose(spec.target)
    assert np.hypot(pose[0, 3] - spec.place_xy[0], pose[1, 3] - spec.place_xy[1]) < 0.03


def test_recording_keeps_the_gripper_command_and_ee_target(pp):
    spec = random_scene(5)
    _, frames = record(pp, spec, "scene:32x24")
    grip = np.array([f["action"][-1] for f in frames])
    stages = [f["stage"] for f in frames]
    first_grasp = stages.index("grasp")
    assert np.all(grip[:first_grasp] == 0.0) and grip[first_grasp] == 1.0
    assert grip[stages.index("release")] == 0.0
    # action.ee_pose is the TCP (Franka: 103.4 mm along the hand's z) at the commanded arm targets, checked
    # with the model's hand FK directly.
    f = frames[first_grasp - 1]
    q = np.append(f["action"][:7].astype(np.float64), f["observation.state"][7])
    ref = pp.model.fk_batch(q[None])[0]
    hand = pp.model.fk(q)
    ref[:3] = hand[:3, 3] + 0.1034 * hand[:3, 2]
    np.testing.assert_allclose(f["action.ee_pose"], ref, atol=1e-6)
    # observation.gripper_opening: the distance between the fingers, 2 x the finger joint.
    for f in frames[::10]:
        assert f["observation.gripper_opening"][0] == pytest.approx(2 * f["observation.state"][7], abs=1e-6)


def psnr(a, b) -> float:
    mse = np.mean((a.astype(np.float64) - b.astype(np.float64)) ** 2)
    return float("inf") if mse == 0 else 10 * np.log10(255.0**2 / mse)


def _decode(path, fmt):
    import av

    with av.open(str(path)) as c:
        return [fr.to_ndarray(format=fmt) for fr in c.decode(video=0)]


@pytest.fixture(scope="module")
def lerobot_dataset(tmp_path_factory, pp):
    out = tmp_path_factory.mktemp("lr") / "ds"
    cfg = GenerateConfig(episodes=2, seed=11, format="lerobot", cameras=parse_cameras(CAMS))
    summary = generate(out, cfg, workers=1, ray="off", progress=False)
    return out, cfg, summary


def test_lerobot_layout_with_pyarrow(lerobot_dataset):
    import pyarrow.parquet as pq

    out, cfg, summary = lerobot_dataset
    info = json.loads((out / "meta/info.json").read_text())
    assert info["codebase_version"] == "v3.0" and info["fps"] == 10
    assert info["data_path"] == "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
    assert info["video_path"] == "videos/{video_key}/chunk-{chunk_index:03d}/file-{file_index:03d}.mp4"
    assert info["total_episodes"] == 2 and info["total_frames"] == summary["frames"]
    f = info["features"]
    for key in ("observation.state", "observation.velocity", "observation.ee_pose", "action", "action.ee_pose"):
        assert f[key]["dtype"] == "float32"
    assert f["observation.images.scene"]["dtype"] == "video" and f["observation.images.scene"]["shape"] == [48, 64, 3]
    assert info["depth_features"]["observation.depth.wrist"]["shape"] == [24, 32]
    # Segmentation (recorded by default): lossless uint16 label ids, beside depth, not in `features`.
    seg = info["segmentation_features"]
    assert sorted(seg) == ["observation.segmentation.scene", "observation.segmentation.wrist"]
    assert seg["observation.segmentation.scene"]["shape"] == [48, 64]
    assert seg["observation.segmentation.scene"]["dtype"] == "uint16"
    assert seg["observation.segmentation.wrist"]["info"]["video.pix_fmt"] == "gray16le"
    assert seg["observation.segmentation.wrist"]["info"]["video.codec"] == "ffv1"
    assert not any(k.startswith("observation.segmentation.") for k in f)
    data = pq.read_table(out / "data/chunk-000/file-000.parquet")
    assert data.num_rows == info["total_frames"]  # several episodes in one file
    assert sorted(set(data["episode_index"].to_pylist())) == [0, 1]
    assert data["index"].to_pylist() == list(range(data.num_rows))
    assert data.schema.field("action").type.list_size == 8
    assert data.schema.field("observation.gripper_opening").type == "float"
    eps = pq.read_table(out / "meta/episodes/chunk-000/file-000.parquet").to_pylist()
    assert [e["episode_index"] for e in eps] == [0, 1]
    start = 0
    for e in eps:
        assert e["dataset_from_index"] == start and e["dataset_to_index"] == start + e["length"]
        frames = data.filter(data["episode_index"].to_numpy() == e["episode_index"])
        assert frames.num_rows == e["length"]
        assert frames["frame_index"].to_pylist() == list(range(e["length"]))
        np.testing.assert_allclose(frames["timestamp"].to_numpy(), np.arange(e["length"]) / 10, atol=1e-6)
        assert e["videos/observation.images.scene/from_timestamp"] == pytest.approx(start / 10)
        assert e["videos/observation.segmentation.wrist/from_timestamp"] == pytest.approx(start / 10)
        assert e["videos/observation.segmentation.wrist/to_timestamp"] == pytest.approx((start + e["length"]) / 10)
        labels = json.loads(e["segmentation_labels"])
        assert labels["0"] == "background" and any(v.startswith("panda/") for v in labels.values())
        assert e["seed"] in [episode_seed(11, e["episode_index"], k) for k in range(10)]
        stages = json.loads(e["stages"])
        assert stages[0][1] == 0 and stages[-1][2] == e["length"]
        start += e["length"]
        # Per-episode stats: min/max of the stored action column.
        act = np.stack(frames["action"].to_numpy(zero_copy_only=False))
        np.testing.assert_allclose(e["stats/action/min"], act.min(axis=0), rtol=1e-6)
    tasks = pq.read_table(out / "meta/tasks.parquet").to_pandas()
    assert set(tasks.index) == {e["tasks"][0] for e in eps}
    assert all(t.startswith("pick up the ") for t in tasks.index)
    stats = json.loads((out / "meta/stats.json").read_text())
    act = np.stack(data["action"].to_numpy(zero_copy_only=False)).astype(np.float64)
    np.testing.assert_allclose(stats["action"]["mean"], act.mean(axis=0), rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(stats["action"]["std"], act.std(axis=0), rtol=1e-4, atol=1e-6)
    assert np.array(stats["observation.images.scene"]["mean"]).shape == (3, 1, 1)


def test_lerobot_videos_decode_to_what_was_rendered(lerobot_dataset, pp):
    import pyarrow.parquet as pq

    out, cfg, _ = lerobot_dataset
    eps = pq.read_table(out / "meta/episodes/chunk-000/file-000.parquet").to_pylist()
    rgb = _decode(out / "videos/observation.images.scene/chunk-000/file-000.mp4", "rgb24")
    depth = _decode(out / "videos/observation.depth.scene/chunk-000/file-000.mp4", "gray16le")
    wrist = _decode(out / "videos/observation.images.wrist/chunk-000/file-000.mp4", "rgb24")
    seg = {
        cam: _decode(out / f"videos/observation.segmentation.{cam}/chunk-000/file-000.mp4", "gray16le")
        for cam in ("scene", "wrist")
    }
    total = sum(e["length"] for e in eps)
    assert len(rgb) == len(depth) == len(wrist) == len(seg["scene"]) == len(seg["wrist"]) == total
    for e in eps:
        # Run the episode again (it depends only on its seed) and keep what the cameras rendered.
        spec, rand = episode_spec(cfg.to_dict(), e["seed"])
        assert json.loads(e["randomization"]) == json.loads(json.dumps(rand))
        _, frames = record(pp, spec, rand=rand)
        assert len(frames) == e["length"]
        a = e["dataset_from_index"]
        for k, f in enumerate(frames):
            mm = np.rint(f["observation.depth.scene"].astype(np.float64) * 1000).astype(np.uint16)
            np.testing.assert_array_equal(depth[a + k], mm)
            # H.264 with 4:2:0 chroma: lossy, most at colour edges (these test images are tiny).
            assert psnr(rgb[a + k], f["observation.images.scene"]) > 28.0, k
            assert psnr(wrist[a + k], f["observation.images.wrist"]) > 26.0, k
            for cam in ("scene", "wrist"):
                # Label ids exactly (int32 ids as rendered, compared as integers: no wrap-around possible).
                assert seg[cam][a + k].dtype == np.uint16
                np.testing.assert_array_equal(
                    seg[cam][a + k].astype(np.int64), f[f"observation.segmentation.{cam}"].astype(np.int64)
                )
        # The stored id -> name table is the rendered world's, and the images hold objects, robot and table.
        assert {int(i): n for i, n in json.loads(e["segmentation_labels"]).items()} == frames[0]["segmentation_labels"]
        ids = np.unique(np.concatenate([s.ravel() for s in seg["scene"][a : a + len(frames)]]))
        assert len(ids) >= 4 and set(ids.tolist()) <= set(frames[0]["segmentation_labels"])


def test_hdf5_layout_with_h5py(tmp_path, pp):
    import h5py

    out = tmp_path / "h5"
    cfg = GenerateConfig(episodes=2, seed=3, format="hdf5", cameras=parse_cameras("scene:32x24"), segmentation=True)
    summary = generate(out, cfg, workers=1, ray="off", progress=False)
    with h5py.File(out / "dataset.hdf5", "r") as f:
        data = f["data"]
        assert sorted(data.keys()) == ["demo_0", "demo_1"]
        env = json.loads(data.attrs["env_args"])
        assert env["env_name"] == "ferrobot-pick-place" and env["env_kwargs"]["seed"] == 3
        total = 0
        for name in ("demo_0", "demo_1"):
            g = data[name]
            n = int(g.attrs["num_samples"])
            total += n
            assert g["actions"].shape == (n, 8) and g["actions"].dtype == np.float32
            assert g["obs/images.scene"].shape == (n, 24, 32, 3) and g["obs/images.scene"].dtype == np.uint8
            assert g["obs/depth.scene"].shape == (n, 24, 32) and g["obs/segmentation.scene"].dtype == np.int32
            assert g["obs/state"].shape == (n, 8)
            assert g["dones"][-1] == 1 and g["dones"][:-1].sum() == 0
            assert g["rewards"][-1] == float(g.attrs["success"])
            assert g["states"].dtype == np.float64
        assert data.attrs["total"] == total == summary["frames"]
        assert [x.decode() for x in f["mask/train"][:]] == ["demo_0", "demo_1"]
    # The same episode recorded directly: the HDF5 arrays are exactly what was observed.
    with h5py.File(out / "dataset.hdf5", "r") as f:
        spec, rand = episode_spec(cfg.to_dict(), int(f["data/demo_0"].attrs["seed"]))
        assert json.loads(f["data/demo_0"].attrs["randomization"]) == json.loads(json.dumps(rand))
    _, frames = record(pp, spec, "scene:32x24", rand=rand)
    with h5py.File(out / "dataset.hdf5", "r") as f:
        g = f["data/demo_0"]
        np.testing.assert_array_equal(
            g["obs/images.scene"][:], np.stack([x["observation.images.scene"] for x in frames])
        )
        np.testing.assert_array_equal(g["obs/depth.scene"][:], np.stack([x["observation.depth.scene"] for x in frames]))
        np.testing.assert_array_equal(g["states"][:], np.stack([x["state"] for x in frames]))
        np.testing.assert_array_equal(
            g["obs/segmentation.scene"][:], np.stack([x["observation.segmentation.scene"] for x in frames])
        )
        labels = {int(i): n for i, n in json.loads(g.attrs["segmentation_labels"]).items()}
        assert labels == frames[0]["segmentation_labels"]


def test_segmentation_ids_outside_uint16_raise_instead_of_wrapping():
    from ferrobot.dataset.staging import labels_to_u16
    from ferrobot.errors import InvalidArgumentError

    ids = np.array([[0, 1], [65535, 7]], dtype=np.int32)
    assert labels_to_u16(ids).dtype == np.uint16
    np.testing.assert_array_equal(labels_to_u16(ids).astype(np.int64), ids)
    for bad in (65536, -1):
        with pytest.raises(InvalidArgumentError, match="segmentation"):
            labels_to_u16(np.array([[0, bad]], dtype=np.int32))


def test_replaying_a_lerobot_episode_from_its_files(lerobot_dataset, pp):
    """What an environment does with the dataset: the scene from the episodes table, the actions from the
    frame table, stepped through a ControlStepper; the stored float32 states match bit for bit."""
    import pyarrow.parquet as pq

    from ferrobot.dataset import scene_from_dict

    out, _, _ = lerobot_dataset
    eps = pq.read_table(out / "meta/episodes/chunk-000/file-000.parquet").to_pylist()
    data = pq.read_table(out / "data/chunk-000/file-000.parquet")
    e = eps[-1]
    rows = data.slice(e["dataset_from_index"], e["length"]).to_pydict()
    world, robot, _ = build_world(scene_from_dict(json.loads(e["scene"])))
    stepper = ControlStepper(world, robot)
    for k in range(e["length"]):
        np.testing.assert_array_equal(
            robot.joint_positions.astype(np.float32), np.asarray(rows["observation.state"][k], np.float32)
        )
        stepper.step(np.asarray(rows["action"][k], dtype=np.float32).astype(np.float64))
