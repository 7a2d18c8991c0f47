"""The HTML viewer in a real browser (headless Chromium): the robot's pixels are where its pose says; and the
live viser view's meshes are posed by the robot's FK.

The projection is recomputed here from the viewer's documented camera model (``ferrobot.pipeline.viewer``
docstring); link poses come from Pinocchio-checked FK."""

from __future__ import annotations

import os
import shutil
import struct
import subprocess
import zlib

import numpy as np
import pytest

import ferrobot
from ferrobot.pipeline.viewer import DEFAULT_VIEW, robot_meshes, scene_data, write_viewer

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser") or shutil.which("google-chrome")
BG = np.array([43, 43, 43])


def read_png(path) -> np.ndarray:
    """RGB(A) 8-bit PNG decoder (zlib + the five PNG filters), independent of the code under test."""
    data = path.read_bytes()
    pos, chunks = 8, {}
    idat = b""
    while pos < len(data):
        n, kind = struct.unpack(">I4s", data[pos : pos + 8])
        body = data[pos + 8 : pos + 8 + n]
        if kind == b"IHDR":
            chunks["w"], chunks["h"], depth, ctype = struct.unpack(">IIBB", body[:10])
            assert depth == 8 and ctype in (2, 6)
            chunks["c"] = 3 if ctype == 2 else 4
        elif kind == b"IDAT":
            idat += body
        pos += 12 + n
    w, h, c = chunks["w"], chunks["h"], chunks["c"]
    raw = zlib.decompress(idat)
    out = np.zeros((h, w * c), dtype=np.int32)
    stride = w * c
    for y in range(h):
        f = raw[y * (stride + 1)]
        line = np.frombuffer(raw, np.uint8, stride, y * (stride + 1) + 1).astype(np.int32)
        prev = out[y - 1] if y else np.zeros(stride, np.int32)
        if f == 0:
            cur = line
        elif f == 2:
            cur = (line + prev) & 255
        else:
            cur = np.zeros(stride, np.int32)
            for x in range(stride):
                a = cur[x - c] if x >= c else 0
                b = prev[x]
                cc = prev[x - c] if x >= c else 0
                if f == 1:
                    pred = a
                elif f == 3:
                    pred = (a + b) // 2
                else:
                    p = a + b - cc
                    pa, pb, pc = abs(p - a), abs(p - b), abs(p - cc)
                    pred = a if pa <= pb and pa <= pc else (b if pb <= pc else cc)
                cur[x] = (line[x] + pred) & 255
        out[y] = cur
    return out.reshape(h, w, c)[:, :, :3].astype(np.uint8)


def screenshot(page, out, frame=0):
    w, h = DEFAULT_VIEW["width"], DEFAULT_VIEW["height"]
    cmd = [
        CHROMIUM,
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--hide-scrollbars",
        "--force-device-scale-factor=1",
        f"--window-size={w},{h}",
        f"--screenshot={out}",
        f"file://{page}#frame={frame}&paused=1&embed=1",
    ]
    subprocess.run(cmd, check=True, capture_output=True, timeout=120)
    return read_png(out)


def world_vertices(model, q, base):
    poses = base @ model.fk_all(q)
    return np.vstack([m["V"] @ poses[m["link"]][:3, :3].T + poses[m["link"]][:3, 3] for m in robot_meshes(model)])


def project(p):
    v = DEFAULT_VIEW
    t = np.asarray(v["target"])
    eye = t + v["dist"] * np.array(
        [np.cos(v["el"]) * np.cos(v["az"]), np.cos(v["el"]) * np.sin(v["az"]), np.sin(v["el"])]
    )
    f = (t - eye) / np.linalg.norm(t - eye)
    r = np.cross(f, [0, 0, 1])
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    d = p - eye
    z = d @ f
    return np.stack([v["width"] / 2 + v["F"] * (d @ r) / z, v["height"] / 2 - v["F"] * (d @ u) / z], 1)


def need_chromium():
    """Skips without Chromium, except in CI (``CI`` set), where a missing browser fails: ``.ci/run`` installs
    Debian's ``chromium``, so its absence there is a broken set-up, not an optional extra."""
    if CHROMIUM is not None:
        return
    if os.environ.get("CI"):
        pytest.fail("CI is set but Chromium is missing: install Debian's chromium (.ci/run does, as root or with sudo)")
    pytest.skip("needs Chromium (apt-get install chromium)")


def test_robot_pixels_where_its_pose_says(tmp_path):
    need_chromium()
    model = ferrobot.robots.panda()
    q = model.named_state("ready")
    base0 = np.eye(4)
    base0[:3, 3] = [0.1, -0.25, 0.2]
    base1 = base0.copy()
    base1[:3, 3] += [0.0, 0.35, 0.0]
    data = scene_data(model, [q, q], base=base0)
    # frame 1: the same configuration with the base moved 35 cm along y
    data["frames"][1] = scene_data(model, [q], base=base1)["frames"][0]
    for link in data["robot"]:  # one bright colour, so that every robot pixel stands out from the background
        link["c"] = [1.0, 0.6, 0.2]
    page = write_viewer(tmp_path / "v.html", data, "viewer test")
    for k, base in enumerate((base0, base1)):
        img = screenshot(page, tmp_path / f"shot{k}.png", frame=k)
        assert img.shape[:2] == (DEFAULT_VIEW["height"], DEFAULT_VIEW["width"])
        robot = np.abs(img.astype(int) - BG).sum(axis=2) > 30
        ys, xs = np.nonzero(robot)
        uv = project(world_vertices(model, q, base))
        # the robot's drawn extent is its projected extent, to a few pixels
        assert xs.min() == pytest.approx(uv[:, 0].min(), abs=4), k
        assert xs.max() == pytest.approx(uv[:, 0].max(), abs=4), k
        assert ys.min() == pytest.approx(uv[:, 1].min(), abs=4), k
        assert ys.max() == pytest.approx(uv[:, 1].max(), abs=4), k
        # the centre of the elbow's and the hand's geometry is covered
        for link in ("panda_link4", "panda_hand"):
            li = model.link_names.index(link)
            m = next(m for m in robot_meshes(model) if m["link"] == li)
            pose = base @ model.fk(q, link)
            c = project((pose[:3, :3] @ m["V"].mean(0) + pose[:3, 3])[None])[0]
            x, y = int(round(c[0])), int(round(c[1]))
            assert robot[y - 1 : y + 2, x - 1 : x + 2].all(), (k, link)
        # nothing drawn far from the robot
        far = np.ones_like(robot)
        far[int(uv[:, 1].min()) - 5 : int(uv[:, 1].max()) + 6, int(uv[:, 0].min()) - 5 : int(uv[:, 0].max()) + 6] = (
            False
        )
        assert not (robot & far).any()


def test_scene_data_frames_follow_fk():
    model = ferrobot.robots.panda()
    qs = np.array([model.named_state("ready"), model.neutral_configuration()])
    base = np.eye(4)
    base[:3, 3] = [0.3, 0.0, 0.1]
    cam = {
        "pose": ferrobot.look_at([1.2, 0, 1.0], [0.4, 0, 0.4]),
        "fx": 500.0,
        "fy": 500.0,
        "cx": 320.0,
        "cy": 240.0,
        "width": 640,
        "height": 480,
    }
    objects = [
        {"name": "box", "kind": "box", "size": [0.1, 0.2, 0.3], "color": [1, 0, 0]},
        {"name": "tet", "kind": "mesh", "vertices": np.eye(3), "faces": [[0, 1, 2]], "color": [0, 1, 0]},
    ]
    data = scene_data(model, qs, base=base, objects=objects, cameras=[cam])
    meshes = robot_meshes(model)
    assert len(data["robot"]) == len(meshes) > 5
    for fr, q in zip(data["frames"], qs, strict=True):
        poses = base @ model.fk_all(q)
        for m, link in zip(meshes, fr["links"], strict=True):
            assert np.reshape(link, (3, 4)) == pytest.approx(poses[m["link"]][:3], abs=1e-5)
    box = data["objects"][0]
    assert np.ptp(np.asarray(box["V"]), axis=0) == pytest.approx([0.1, 0.2, 0.3])
    assert len(data["cameras"]) == 1


def test_live_view_poses_meshes_by_fk():
    pytest.importorskip("viser")
    from ferrobot.pipeline.viewer_live import LiveView
    from ferrobot.transforms import quat_to_matrix

    model = ferrobot.robots.panda()
    qs = np.array([model.neutral_configuration(), model.named_state("ready")])
    data = scene_data(model, qs)
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    view = LiveView(data, port=port)
    try:
        meshes = robot_meshes(model)
        for k in (1, 0):
            view.set_frame(k)
            poses = model.fk_all(qs[k])
            for h, m in zip(view.links, meshes, strict=True):
                assert np.asarray(h.position) == pytest.approx(poses[m["link"]][:3, 3], abs=1e-4)
                assert quat_to_matrix(np.asarray(h.wxyz)) == pytest.approx(poses[m["link"]][:3, :3], abs=1e-4)
        with pytest.raises(ferrobot.errors.InvalidArgumentError, match="frame"):
            view.set_frame(5)
    finally:
        view.close()


def test_view_command_on_a_demo_folder_and_a_urdf(tmp_path):
    import json

    from conftest import UR5_URDF
    from ferrobot.cli import main
    from ferrobot.pipeline import random_scene
    from ferrobot.pipeline.scene import HOME

    spec = random_scene(3)
    folder = tmp_path / "demo"
    folder.mkdir()
    (folder / "report.json").write_text(json.dumps({"scene": spec.to_dict()}))
    qs = np.tile(HOME, (5, 1))
    qs[:, 0] += np.linspace(0, 0.5, 5)
    np.savez(folder / "trajectory.npz", positions=qs, times=np.arange(5) * 0.1, stage=np.array(["plan"] * 5))
    assert main(["view", str(folder), "--html", str(tmp_path / "demo.html")]) == 0
    page = (tmp_path / "demo.html").read_text()
    data = json.loads(page.split("const D = ", 1)[1].split(";\n", 1)[0])
    assert len(data["frames"]) == 5 and len(data["cameras"]) == 1
    assert {o["name"] for o in data["objects"]} >= {"table"} | {o.name for o in spec.objects}
    model = ferrobot.robots.panda()
    base = np.asarray(ferrobot.transforms.pose_to_matrix(spec.base_pose))
    meshes = robot_meshes(model)
    for fr, q in zip(data["frames"], qs, strict=True):
        poses = base @ model.fk_all(q)
        assert np.reshape(fr["links"][-1], (3, 4)) == pytest.approx(poses[meshes[-1]["link"]][:3], abs=1e-4)
    assert main(["view", str(UR5_URDF), "--html", str(tmp_path / "ur5.html")]) == 0
    assert (tmp_path / "ur5.html").stat().st_size > 10_000
    assert main(["view", str(tmp_path / "nothing.txt"), "--html", str(tmp_path / "x.html")]) == 2
