"""Pick-and-place end to end (issue 7): episodes on fixed seeds, stage failures, batch summaries, the
demo's output folder, and the scene sync from the simulation to the planner's world.

Success is judged from the simulator's state, not from the pipeline's own verdict: where the target
rests (position, upright), that the other objects were not disturbed, and that the executed joint
trajectory stayed within the joint limits.
"""

from __future__ import annotations

import copy
import json
import struct
import zlib

import numpy as np
import pytest

import ferrobot
from ferrobot.cli import main as cli
from ferrobot.errors import InvalidArgumentError
from ferrobot.pipeline import STAGES, TABLE_TOP, Episode, PickPlace, PickPlaceConfig, random_scene
from ferrobot.pipeline.images import encode_png
from ferrobot.pipeline.report import grasp_image, write_episode
from ferrobot.pipeline.viewer import viewer_data


@pytest.fixture(scope="module")
def pp():
    return PickPlace()


def decode_png(data: bytes) -> np.ndarray:
    """A minimal PNG reader for what encode_png writes (8-bit RGB, filter 0), checking the chunk CRCs."""
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    pos, chunks = 8, {}
    while pos < len(data):
        (n,) = struct.unpack(">I", data[pos : pos + 4])
        kind, body = data[pos + 4 : pos + 8], data[pos + 8 : pos + 8 + n]
        (crc,) = struct.unpack(">I", data[pos + 8 + n : pos + 12 + n])
        assert crc == zlib.crc32(kind + body) & 0xFFFFFFFF
        chunks[kind] = chunks.get(kind, b"") + body
        pos += 12 + n
    w, h, depth, color = struct.unpack(">IIBB", chunks[b"IHDR"][:10])
    assert (depth, color) == (8, 2)
    raw = np.frombuffer(zlib.decompress(chunks[b"IDAT"]), np.uint8).reshape(h, 1 + 3 * w)
    assert (raw[:, 0] == 0).all()
    return raw[:, 1:].reshape(h, w, 3)


@pytest.mark.parametrize("seed", [2, 3, 4])
def test_episode_places_the_target(pp, seed):
    spec = random_scene(seed)
    before = {o.name: np.array(o.pose[:3]) for o in spec.objects}
    syncs = pp.planner.world_sync_stats
    result = pp.run(spec)
    ep = result.episode
    assert result.success, (result.failed_stage, result.reason)
    # The planner's world was built once and then kept in sync with the simulation in place (issue 16):
    # every motion, IK goal set and attach re-syncs it.
    after = pp.planner.world_sync_stats
    assert after.full_builds - syncs.full_builds == 1
    assert after.incremental - syncs.incremental >= 10
    assert [s.name for s in result.stages] == list(STAGES)
    assert all(s.ok for s in result.stages)

    # Where the simulator says the target is: at the place location, resting upright on the table.
    target = spec.object(spec.target)
    pose = ep.world.get_object_pose(spec.target)
    assert np.hypot(*(pose[:2, 3] - spec.place_xy)) < 0.03
    assert abs(pose[2, 3] - (TABLE_TOP + target.height / 2)) < 0.005
    if target.kind != "sphere":
        assert pose[2, 2] > 0.99  # its axis still vertical
    lin, ang = ep.world.get_object_velocity(spec.target)
    assert np.linalg.norm(lin) < 0.01

    # Collision-free motions: no other object was pushed.
    for o in spec.objects:
        if o.name != spec.target:
            moved = np.linalg.norm(ep.world.get_object_pose(o.name)[:3, 3] - before[o.name])
            assert moved < 0.01, f"{o.name} moved {moved * 1e3:.1f} mm"

    # The executed trajectory stayed within the joint limits.
    q = ep.recorder.arrays()["positions"]
    assert q.shape[1] == ep.robot.num_dof and len(q) > 100
    assert (q >= pp.model.lower_limits - 0.01).all() and (q <= pp.model.upper_limits + 0.01).all()


def test_retreat_backs_out_while_the_released_object_follows():
    # Pre-shaped, seed 67: the released box follows a finger while the hand backs out of contact; the retreat
    # re-checks the executed state and backs out further (before: "start in collision" at the planned retreat).
    pp = PickPlace(PickPlaceConfig(preshape_margin=0.01))
    result = pp.run(random_scene(67))
    assert result.success, (result.failed_stage, result.reason)
    retreat = next(s for s in result.stages if s.name == "retreat")
    assert retreat.ok


def test_stage_failures_are_reported_not_raised(pp):
    spec = random_scene(3)

    unreachable = copy.deepcopy(spec)
    o = unreachable.object(unreachable.target)
    o.pose = [0.9, 0.0, o.pose[2], *o.pose[3:]]  # 0.9 m in front of the base: beyond the Panda's reach
    r = pp.run(unreachable)
    assert not r.success and r.failed_stage == "select"
    assert "reachable" in r.reason
    assert r.stages[-1].name == "select" and not r.stages[-1].ok and r.stages[-1].reason == r.reason

    far_place = copy.deepcopy(spec)
    far_place.place_xy = (0.93, -0.45)
    r = pp.run(far_place)
    assert not r.success and r.failed_stage == "transport"
    assert "place location" in r.reason

    bad = copy.deepcopy(spec)
    bad.objects[0].kind = "cone"
    r = pp.run(bad)
    assert not r.success and r.failed_stage == "scene"
    assert "InvalidArgumentError" in r.reason and "cone" in r.reason
    record = r.to_dict()
    assert record["failed_stage"] == "scene" and record["stages"][0]["ok"] is False


def test_batch_summary_matches_episode_lines(tmp_path, capsys):
    out = tmp_path / "batch"
    assert cli(["demo", "--episodes", "3", "--seed", "20", "--out", str(out), "--quiet"]) == 0
    lines = [json.loads(s) for s in (out / "episodes.jsonl").read_text().splitlines()]
    summary = json.loads((out / "summary.json").read_text())
    assert len(lines) == summary["episodes"] == 3
    assert [rec["seed"] for rec in lines] == [20, 21, 22]
    assert summary["successes"] == sum(rec["success"] for rec in lines)
    assert summary["success_rate"] == pytest.approx(summary["successes"] / 3)
    fails: dict[str, int] = {}
    for rec in lines:
        if not rec["success"]:
            fails[rec["failed_stage"]] = fails.get(rec["failed_stage"], 0) + 1
    assert summary["failures_by_stage"] == fails
    assert summary["episodes_per_hour"] == pytest.approx(3 * 3600 / summary["wall_time_s"])
    printed = capsys.readouterr().out
    assert f"{summary['successes']}/3 succeeded" in printed


def test_episode_record_and_deprecated_spellings(pp, tmp_path):
    """run() returns its episode record (issue 16); the old per-episode attributes of PickPlace and the old
    report/viewer calls taking the PickPlace still work for one release, with a DeprecationWarning."""
    spec = random_scene(3)
    unreachable = copy.deepcopy(spec)
    o = unreachable.object(unreachable.target)
    o.pose = [0.9, 0.0, o.pose[2], *o.pose[3:]]  # fails at select: frame and grasps, no choice
    r = pp.run(unreachable, record_frames=True)
    ep = r.episode
    assert isinstance(ep, Episode) and ep.result is r and ep.spec is unreachable
    assert ep.frame.depth.shape == (480, 640) and len(ep.grasps_world) > 0
    assert ep.choice is None and ep.q_pre is None and ep.hand_grasp is None
    assert "episode" not in r.to_dict()

    with pytest.warns(DeprecationWarning, match="result.episode.world"):
        assert pp.world is ep.world
    with pytest.warns(DeprecationWarning, match="result.episode.recorder"):
        assert pp.rec is ep.recorder
    with pytest.raises(AttributeError):
        _ = pp.not_an_attribute

    paths = write_episode(tmp_path / "new", r)
    with pytest.warns(DeprecationWarning, match="write_episode"):
        old = write_episode(tmp_path / "old", pp, r)
    assert json.loads(paths["report"].read_text()) == json.loads(old["report"].read_text())
    with pytest.warns(DeprecationWarning, match="grasp_image"):
        np.testing.assert_array_equal(grasp_image(pp), grasp_image(ep))
    with pytest.warns(DeprecationWarning, match="viewer_data"):
        assert viewer_data(pp) == viewer_data(ep)

    # The next episode gets a new record; the previous one keeps what its episode made.
    bad = copy.deepcopy(spec)
    bad.objects[0].kind = "cone"
    r2 = pp.run(bad)
    assert r2.episode is not ep and r2.episode.world is None and r2.episode.frame is None
    assert ep.frame is not None and len(ep.grasps_world) > 0


def test_demo_writes_its_folder(tmp_path, capsys):
    out = tmp_path / "demo"
    assert cli(["demo", "--seed", "3", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    for stage in STAGES:
        assert stage in printed
    assert "SUCCESS" in printed

    report = json.loads((out / "report.json").read_text())
    assert report["result"]["success"] is True
    assert [s["name"] for s in report["result"]["stages"]] == list(STAGES)
    assert report["scene"]["target"] == report["result"]["target"]
    assert np.array(report["grasp"]["hand_pose_base"]).shape == (4, 4)

    traj = np.load(out / "trajectory.npz")
    assert traj["positions"].shape == traj["desired"].shape == (len(traj["times"]), 8)
    assert (np.diff(traj["times"]) > 0).all()
    assert set(traj["stage"]) >= {"pregrasp", "approach", "lift", "transport", "lower", "retreat"}
    assert list(traj["joint_names"])[:7] == [f"panda_joint{i}" for i in range(1, 8)]

    img = decode_png((out / "grasp.png").read_bytes())
    assert img.shape == (480, 640, 3)
    green = np.all(img == (40, 230, 60), axis=2)
    assert green.sum() > 50  # the chosen grasp is drawn

    page = (out / "animation.html").read_text()
    frames = page.count("data:image/png;base64,")
    assert frames > 20

    # The 3D viewer's data: one robot state per animation frame, every sphere of the robot, every object.
    viewer = (out / "viewer.html").read_text()
    data = json.loads(viewer.split("const D = ", 1)[1].split(";\n", 1)[0])
    assert len(data["frames"]) == frames
    n_spheres = len(data["radii"])
    assert n_spheres > 20 and all(len(f["spheres"]) == n_spheres for f in data["frames"])
    names = {o["name"] for o in data["objects"]}
    assert {"table", report["scene"]["target"]} <= names
    assert all(set(f["objects"]) == names for f in data["frames"])
    # The robot's spheres move with the robot: the last frame's differ from the first's.
    assert np.abs(np.subtract(data["frames"][0]["spheres"], data["frames"][-1]["spheres"])).max() > 0.05


def test_png_round_trip():
    rng = np.random.default_rng(0)
    img = rng.integers(0, 256, size=(7, 5, 3), dtype=np.uint8)
    assert (decode_png(encode_png(img)) == img).all()


def test_random_scenes_are_deterministic_and_free():
    a, b = random_scene(5), random_scene(5)
    assert a.to_dict() == b.to_dict()
    assert random_scene(6).to_dict() != a.to_dict()
    for seed in range(20):
        s = random_scene(seed)
        assert 3 <= len(s.objects) <= 5 and s.target in [o.name for o in s.objects]
        xy = [np.array(o.pose[:2]) for o in s.objects]
        for i in range(len(xy)):
            for j in range(i):
                gap = np.linalg.norm(xy[i] - xy[j]) - s.objects[i].footprint - s.objects[j].footprint
                assert gap > 0.05
            assert np.linalg.norm(xy[i] - s.place_xy) > s.objects[i].footprint
    with pytest.raises(InvalidArgumentError, match="num_objects"):
        random_scene(0, num_objects=9)


def test_scene_sync_to_planner_world():
    w = ferrobot.World()
    w.add_box("table", [0.8, 1.2, 0.4], [0.6, 0.0, 0.2, 1, 0, 0, 0], fixed=True)
    w.add_cylinder("target_can", 0.03, 0.12, [0.5, 0.1, 0.46, 1, 0, 0, 0], mass=0.2)
    # A base raised 0.4 m and turned 90 degrees about z: world (x, y, z) -> base (y, -x, z - 0.4).
    base = np.array([0.0, 0.0, 0.4, np.cos(np.pi / 4), 0.0, 0.0, np.sin(np.pi / 4)])
    cw = ferrobot.CollisionWorld.from_sim(w, base_pose=base)
    assert cw.names == ["ground", "table", "target_can"]
    # Analytic: the can's axis at world (0.5, 0.1) is at base (0.1, -0.5); 1 cm inside its side wall.
    # World (0.8, -0.3), 1 cm above the table top, is at base (-0.3, -0.8, 0.01).
    d = cw.signed_distance(np.array([[0.1 + 0.02, -0.5, 0.06], [-0.3, -0.8, 0.01]]))
    assert d[0] == pytest.approx(-0.01, abs=1e-6)
    assert d[1] == pytest.approx(0.01, abs=1e-6)
    # The ground's top face is world z = 0, base z = -0.4.
    assert cw.signed_distance(np.array([[3.0, 3.0, -0.39]]))[0] == pytest.approx(0.01, abs=1e-6)

    assert ferrobot.CollisionWorld.from_sim(w, ignore="target").names == ["ground", "table"]
    assert ferrobot.CollisionWorld.from_sim(w, ignore=["target", "ground"]).names == ["table"]

    panda = ferrobot.robots.panda()
    planner = ferrobot.Planner(panda)
    planner.update_world(w, ignore=["ground"])
    assert planner.world.names == ["table", "target_can"]
    q = panda.named_state("ready")
    planner.attach_world_object("target_can", q)
    assert planner.attached == ["target_can"] and planner.world.names == ["table"]
    planner.update_world(w)  # attached objects stay out of a re-synced world
    assert planner.world.names == ["ground", "table"]
    planner.detach("target_can")
    assert planner.attached == []
    with pytest.raises(InvalidArgumentError, match="expected a ferrobot.CollisionWorld"):
        planner.update_world("table")
    with pytest.raises(InvalidArgumentError, match="ignore"):
        planner.update_world(w, ignore=3)
    with pytest.raises(InvalidArgumentError, match="base_pose"):
        planner.update_world(cw, base_pose=base)
    with pytest.raises(ferrobot.errors.NonFiniteError):
        ferrobot.CollisionWorld.from_sim(w, base_pose=[0, 0, np.nan, 1, 0, 0, 0])
