"""``ferrobot generate`` (issue 19): nothing lost, nothing duplicated, bad arguments refused without touching
existing data. Runs are killed with SIGKILL (the whole command from outside; a worker from inside through
the test hook ``FERROBOT_GENERATE_FAULT``), re-run, and compared with an uninterrupted run read back with
pyarrow and PyAV."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from ferrobot.cli import main as cli
from ferrobot.dataset import GenerateConfig, generate, parse_cameras
from ferrobot.errors import InvalidArgumentError

CAMS = "scene:32x24,wrist:16x12"
ARGS = ["--episodes", "3", "--seed", "7", "--cameras", CAMS, "--ray", "off", "--quiet"]


def _cmd(out, *extra, env=None, fault=None):
    e = dict(os.environ, **(env or {}))
    e["RAYON_NUM_THREADS"] = "1"
    if fault:
        e["FERROBOT_GENERATE_FAULT"] = fault
    code = "import sys; from ferrobot.cli import main; sys.exit(main(sys.argv[1:]))"
    return [sys.executable, "-c", code, "generate", "--out", str(out), *ARGS, *extra], e


def _content(out: Path) -> dict:
    """What a user reads: the frame table, the episode table's identity columns, every decoded depth and
    wrist segmentation frame and the scene video's packets (bytes)."""
    import av
    import pyarrow.parquet as pq

    data = pq.read_table(out / "data/chunk-000/file-000.parquet").to_pydict()
    eps = pq.read_table(out / "meta/episodes/chunk-000/file-000.parquet").to_pydict()
    with av.open(str(out / "videos/observation.depth.scene/chunk-000/file-000.mp4")) as c:
        depth = [f.to_ndarray(format="gray16le") for f in c.decode(video=0)]
    with av.open(str(out / "videos/observation.segmentation.wrist/chunk-000/file-000.mp4")) as c:
        seg = [f.to_ndarray(format="gray16le") for f in c.decode(video=0)]
    with av.open(str(out / "videos/observation.images.scene/chunk-000/file-000.mp4")) as c:
        packets = [bytes(p) for p in c.demux(video=0) if p.size]
    return {
        "data": data,
        "eps": {k: eps[k] for k in ("episode_index", "seed", "length", "success", "tasks", "dataset_from_index")},
        "depth": np.stack(depth),
        "seg": np.stack(seg),
        "packets": packets,
        "info": json.loads((out / "meta/info.json").read_text())["total_frames"],
    }


def _same(a: dict, b: dict) -> None:
    assert a["eps"] == b["eps"]
    assert a["data"] == b["data"]
    np.testing.assert_array_equal(a["depth"], b["depth"])
    np.testing.assert_array_equal(a["seg"], b["seg"])
    assert len(a["seg"]) == len(a["data"]["index"])
    assert a["packets"] == b["packets"]
    assert a["info"] == b["info"]


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    out = tmp_path_factory.mktemp("gen") / "ref"
    cmd, env = _cmd(out, "--workers", "1")
    subprocess.run(cmd, env=env, check=True, timeout=300)
    return _content(out)


def _no_duplicates(out: Path, n: int) -> None:
    import pyarrow.parquet as pq

    eps = pq.read_table(out / "meta/episodes/chunk-000/file-000.parquet")
    assert eps["episode_index"].to_pylist() == list(range(n))
    data = pq.read_table(out / "data/chunk-000/file-000.parquet")
    assert data["index"].to_pylist() == list(range(data.num_rows))
    assert sorted(set(data["episode_index"].to_pylist())) == list(range(n))
    assert not list((out / ".ferrobot").glob("episodes/*")), "staged episodes are removed once published"
    assert not list((out / ".ferrobot/tmp").iterdir())


def test_killed_run_resumes_to_the_same_dataset(tmp_path, reference):
    out = tmp_path / "ds"
    cmd, env = _cmd(out, "--workers", "1")
    proc = subprocess.Popen(cmd, env=env, start_new_session=True)
    episodes = out / ".ferrobot" / "episodes"
    deadline = time.time() + 240
    while time.time() < deadline and len(list(episodes.glob("ep-*"))) < 1:
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGKILL)  # the whole run, mid-way through an episode
    proc.wait()
    assert not (out / ".ferrobot" / "done.json").exists()
    published = len(list(episodes.glob("ep-*")))
    assert 1 <= published < 3
    subprocess.run(cmd, env=env, check=True, timeout=300)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["resumed_from"] >= published and summary["episodes"] == 3
    _same(_content(out), reference)
    _no_duplicates(out, 3)


def test_kill_during_finalisation_then_rerun(tmp_path, reference):
    out = tmp_path / "ds"
    cmd, env = _cmd(out, "--workers", "1", fault="finalize")
    r = subprocess.run(cmd, env=env, timeout=300)
    assert r.returncode == -signal.SIGKILL
    assert (out / "meta/info.json").exists() and not (out / "data").exists()  # killed between the moves
    assert not (out / ".ferrobot/done.json").exists()
    cmd, env = _cmd(out, "--workers", "1")
    subprocess.run(cmd, env=env, check=True, timeout=300)
    _same(_content(out), reference)
    _no_duplicates(out, 3)
    # Running the finished command again changes nothing.
    before = (out / "data/chunk-000/file-000.parquet").read_bytes()
    r = subprocess.run(cmd, env=env, check=True, timeout=300, capture_output=True, text=True)
    assert "already complete" in r.stdout
    assert (out / "data/chunk-000/file-000.parquet").read_bytes() == before


def test_worker_killed_mid_episode_is_retried(tmp_path, reference):
    out = tmp_path / "ds"
    marker = tmp_path / "killed"
    cmd, env = _cmd(out, "--workers", "2", fault=f"worker:1:{marker}")
    subprocess.run(cmd, env=env, check=True, timeout=300)
    assert marker.exists()  # a worker really died with episode 1 half-recorded
    pid = int(marker.read_text())
    with pytest.raises(ProcessLookupError):
        os.kill(pid, 0)
    _same(_content(out), reference)
    _no_duplicates(out, 3)


def test_no_segmentation_leaves_the_streams_out(tmp_path):
    import pyarrow.parquet as pq

    out = tmp_path / "ds"
    cmd, env = _cmd(out, "--workers", "1", "--no-segmentation")
    cmd[cmd.index("--episodes") + 1] = "1"
    subprocess.run(cmd, env=env, check=True, timeout=300)
    info = json.loads((out / "meta/info.json").read_text())
    assert info["segmentation_features"] == {} and info["ferrobot"]["segmentation"] is False
    assert sorted(p.name for p in (out / "videos").iterdir()) == [
        "observation.depth.scene",
        "observation.depth.wrist",
        "observation.images.scene",
        "observation.images.wrist",
    ]
    eps = pq.read_table(out / "meta/episodes/chunk-000/file-000.parquet")
    assert not any(c.startswith("videos/observation.segmentation.") for c in eps.column_names)


def test_bad_arguments_leave_existing_data_untouched(tmp_path, capsys):
    cams = parse_cameras(CAMS)
    with pytest.raises(InvalidArgumentError, match="format"):
        generate(tmp_path / "a", GenerateConfig(episodes=1, format="tfrecord", cameras=cams), ray="off")
    assert not (tmp_path / "a").exists()
    f = tmp_path / "file"
    f.write_text("x")
    with pytest.raises(InvalidArgumentError, match="out"):
        generate(f, GenerateConfig(episodes=1, cameras=cams), ray="off")
    with pytest.raises(InvalidArgumentError, match="out: cannot write"):
        generate(f / "sub", GenerateConfig(episodes=1, cameras=cams), ray="off")
    other = tmp_path / "other"
    other.mkdir()
    (other / "notes.txt").write_text("mine")
    with pytest.raises(InvalidArgumentError, match="not empty"):
        generate(other, GenerateConfig(episodes=1, cameras=cams), ray="off")
    assert sorted(p.name for p in other.iterdir()) == ["notes.txt"]
    # A dataset made with another configuration is refused, byte for byte untouched.
    ds = tmp_path / "ds"
    ds.mkdir()
    (ds / ".ferrobot").mkdir()
    cfg = GenerateConfig(episodes=1, seed=1, cameras=cams).to_dict()
    (ds / ".ferrobot/config.json").write_text(json.dumps(cfg))
    snapshot = {p: p.read_bytes() for p in ds.rglob("*") if p.is_file()}
    with pytest.raises(InvalidArgumentError, match="another configuration"):
        generate(ds, GenerateConfig(episodes=1, seed=2, cameras=cams), ray="off")
    assert {p: p.read_bytes() for p in ds.rglob("*") if p.is_file()} == snapshot
    # The same configuration while another run holds the directory: refused.
    import fcntl

    (ds / ".ferrobot/episodes").mkdir()
    with (ds / ".ferrobot/lock").open("w") as held:
        fcntl.flock(held, fcntl.LOCK_EX)
        with pytest.raises(InvalidArgumentError, match="another 'ferrobot generate'"):
            generate(ds, GenerateConfig(episodes=1, seed=1, cameras=cams), ray="off")
    for argv, what in [
        (["--format", "zarr"], "format"),
        (["--robot", "ur5"], "robot"),
        (["--objects", str(tmp_path / "no-such-folder")], "objects"),
        (["--gripper", "claw"], "gripper"),
        (["--robot", "panda", "--srdf", str(tmp_path / "x.srdf")], "srdf"),
        (["--clutter", "9"], "clutter"),
        (["--cameras", "top:10x10"], "cameras"),
        (["--fps", "7"], "control_hz"),
    ]:
        assert cli(["generate", "--episodes", "1", "--out", str(tmp_path / "x"), *argv]) == 1
        assert what in capsys.readouterr().err
    assert not (tmp_path / "x").exists()
    with pytest.raises(InvalidArgumentError, match="workers"):
        generate(tmp_path / "y", GenerateConfig(episodes=1, cameras=cams), workers=0, ray="off")
    assert not (tmp_path / "y").exists()


def test_ray_retries_a_killed_worker(tmp_path, reference):
    pytest.importorskip("ray")
    out = tmp_path / "ds"
    marker = tmp_path / "killed"
    cmd, env = _cmd(out, "--workers", "2", fault=f"worker:2:{marker}")
    cmd[cmd.index("off")] = "auto"  # --ray auto: a local Ray instance
    r = subprocess.run(cmd, env=env, check=True, timeout=300, capture_output=True, text=True)
    assert '"executor": "ray"' in r.stdout
    assert marker.exists()
    _same(_content(out), reference)
    _no_duplicates(out, 3)
