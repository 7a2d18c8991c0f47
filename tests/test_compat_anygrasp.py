"""AnyGrasp / graspnetAPI call shapes: AnyGrasp.get_grasp, GraspGroup's file and sampling methods, and
GraspClient talking to an AnyGrasp-style Flask ``/process`` server.

References: the hand-rendered scenes of grasp_scenes (independent ray casting and back-projection), numpy's
own file reader, and the data the fake server sent."""

from __future__ import annotations

import sys
import threading
import types
from argparse import Namespace

import numpy as np
import pytest
from grasp_scenes import CX, CY, FX, FY, default_scene, hand_boxes, inside, render

import ferrobot.grasp as fg
from ferrobot import errors
from ferrobot.compat.anygrasp import AnyGrasp
from ferrobot.grasp import GraspGroup


@pytest.fixture(scope="module")
def cloud():
    scene, cam = default_scene()
    depth, _ = render(scene, cam)
    v, u = np.nonzero(depth > 0)
    z = depth[v, u]
    pts = np.stack([(u - CX) / FX * z, (v - CY) / FY * z, z], axis=1).astype(np.float32)
    colors = np.full_like(pts, 0.5)
    return scene, cam, pts, colors


def test_anygrasp_get_grasp_as_the_sdk_demo(cloud):
    scene, cam, pts, colors = cloud
    cfgs = Namespace(
        checkpoint_path="log/checkpoint_detection.tar",
        max_gripper_width=0.07,
        gripper_height=0.03,
        top_down_grasp=True,
        debug=False,
    )
    anygrasp = AnyGrasp(cfgs)
    anygrasp.load_net()
    anygrasp.load_net()
    lims = [-0.25, 0.25, -0.2, 0.2, 0.3, 0.9]
    gg, out_cloud = anygrasp.get_grasp(
        pts, colors, lims=lims, apply_object_mask=True, dense_grasp=False, collision_detection=True
    )
    keep = np.all((pts >= np.array(lims[0::2])) & (pts <= np.array(lims[1::2])), axis=1)
    assert np.asarray(out_cloud).shape == (int(keep.sum()), 3)
    assert len(gg) > 0
    gg = gg.nms().sort_by_score()
    assert np.all(np.diff(gg.scores) <= 0)
    assert np.all(gg.widths <= 0.07 + 1e-9) and np.all(gg.heights == pytest.approx(0.03))
    # a thin adapter: the same grasps as ferrobot.grasp.detect on the cropped cloud
    ref = fg.detect(pts[keep].astype(np.float64), max_width=0.07, height=0.03)
    assert gg.to_array() == pytest.approx(ref.nms().sort_by_score().to_array())
    # in the world: every hand clear of the objects and the table (the object mask: no grasps on the table)
    world = gg.transform(cam)
    for g in world:
        for lo, hi in hand_boxes(g.width, g.depth, g.height):
            from grasp_scenes import sample_box

            p = sample_box(lo, hi) @ g.rotation_matrix.T + g.translation
            assert not inside(scene, p, margin=0.003).any()
        tip = g.translation + g.depth * g.rotation_matrix[:, 0]
        assert tip[2] > 0.005
    dense, _ = anygrasp.get_grasp(pts, colors, lims=lims, dense_grasp=True)
    assert len(dense) >= len(gg)


def test_anygrasp_bad_input():
    a = AnyGrasp()
    with pytest.raises(errors.ShapeError, match="points"):
        a.get_grasp(np.zeros((5, 2)), None)
    with pytest.raises(errors.ShapeError, match="colors"):
        a.get_grasp(np.zeros((5, 3)), np.zeros((4, 3)))
    with pytest.raises(errors.InvalidArgumentError, match="lims"):
        a.get_grasp(np.zeros((5, 3)), None, lims=[1, 0, 0, 1, 0, 1])
    with pytest.raises(errors.InvalidArgumentError, match="max_gripper_width"):
        AnyGrasp({"max_gripper_width": -1})
    gg, c = a.get_grasp(np.zeros((0, 3)), None)
    assert len(gg) == 0


def _group(n=12, seed=0):
    rng = np.random.default_rng(seed)
    rows = np.zeros((n, 17))
    rows[:, 0] = rng.uniform(0.1, 1, n)
    rows[:, 1] = rng.uniform(0.01, 0.08, n)
    rows[:, 2] = 0.02
    rows[:, 3] = rng.uniform(0.01, 0.04, n)
    from scipy.spatial.transform import Rotation

    rows[:, 4:13] = Rotation.random(n, random_state=seed).as_matrix().reshape(n, 9)
    rows[:, 13:16] = rng.uniform(-0.3, 0.3, (n, 3))
    rows[:, 16] = -1
    return GraspGroup(rows)


def test_grasp_group_graspnetapi_methods(tmp_path):
    gg = _group()
    path = tmp_path / "gg.npy"
    gg.save_npy(path)
    raw = np.load(path)
    assert raw.dtype == np.float32 and raw.shape == (12, 17)
    assert raw == pytest.approx(gg.grasp_group_array.astype(np.float32))
    g2 = GraspGroup().from_npy(path)  # graspnetAPI's form
    g3 = GraspGroup.from_npy(path)
    assert isinstance(g2, GraspGroup) and len(g2) == 12 and g3.to_array() == pytest.approx(raw)

    s = gg.random_sample(5, rng=1)
    assert len(s) == 5 and len(gg) == 12
    rows = {tuple(r) for r in gg.grasp_group_array.round(12)}
    picked = [tuple(r) for r in s.grasp_group_array.round(12)]
    assert set(picked) <= rows and len(set(picked)) == 5
    with pytest.raises(errors.InvalidArgumentError, match="numGrasp"):
        gg.random_sample(13)

    expected = np.delete(gg.grasp_group_array, [0, 3], axis=0)
    assert gg.remove([0, 3]) is gg and len(gg) == 10
    assert gg.grasp_group_array == pytest.approx(expected)
    mask = np.zeros(10, bool)
    mask[-1] = True
    gg.remove(mask)
    assert gg.grasp_group_array == pytest.approx(expected[:-1])
    assert sum(1 for _ in gg) == len(gg) == 9


def test_to_open3d_geometry_list_boxes(monkeypatch):
    class Mesh:
        def __init__(self, v, f):
            self.vertices, self.triangles = np.asarray(v), np.asarray(f)

        def compute_vertex_normals(self):
            pass

        def paint_uniform_color(self, c):
            self.color = c

    fake = types.SimpleNamespace(
        geometry=types.SimpleNamespace(TriangleMesh=Mesh),
        utility=types.SimpleNamespace(Vector3dVector=np.asarray, Vector3iVector=np.asarray),
    )
    monkeypatch.setitem(sys.modules, "open3d", fake)
    gg = _group(3)
    meshes = gg.to_open3d_geometry_list()
    assert len(meshes) == 3
    for g, m in zip(gg, meshes, strict=True):
        assert m.vertices.shape == (24, 3) and m.triangles.shape == (36, 3)
        local = (m.vertices - g.translation) @ g.rotation_matrix
        for k, (lo, hi) in enumerate(hand_boxes(g.width, g.depth, g.height)):
            box = local[8 * k : 8 * k + 8]
            assert box.min(0) == pytest.approx(lo, abs=1e-9) and box.max(0) == pytest.approx(hi, abs=1e-9)
            # every triangle is a face of the box: its three corners share one coordinate at a bound
            for tri in m.triangles[12 * k : 12 * k + 12]:
                c = local[tri]
                assert any(np.ptp(c[:, a]) < 1e-12 for a in range(3))
    monkeypatch.setitem(sys.modules, "open3d", None)
    with pytest.raises(ImportError, match="open3d"):
        gg.to_open3d_geometry_list()


@pytest.fixture()
def anygrasp_server():
    """A Flask server answering as AnyGrasp's example servers do: POST /process with colors, depths, fx, fy,
    cx, cy, scale; ``{"grasp_groups": [{translation, rotation_matrix, score, depth}]}`` (no width, no height,
    no object_id); no /health, no /process_npz."""
    flask = pytest.importorskip("flask")
    from werkzeug.serving import make_server

    app = flask.Flask("fake_anygrasp")
    seen = []
    answer = [
        {"translation": [0.01, 0.02, 0.5], "rotation_matrix": np.eye(3).tolist(), "score": 0.9, "depth": 0.03},
        {
            "translation": [0.0, -0.02, 0.45],
            "rotation_matrix": np.diag([1.0, -1.0, -1.0]).tolist(),
            "score": 0.4,
            "depth": 0.02,
            "width": 0.05,
        },
    ]

    @app.route("/process", methods=["POST"])
    def process():
        data = flask.request.get_json()
        seen.append(data)
        for key in ("depths", "fx", "fy", "cx", "cy", "scale"):
            if key not in data:
                return flask.jsonify({"error": f"missing {key}"}), 400
        return flask.jsonify({"grasp_groups": answer})

    server = make_server("127.0.0.1", 0, app)
    t = threading.Thread(target=server.serve_forever, daemon=True)
    t.start()
    yield f"http://127.0.0.1:{server.server_port}", seen, answer
    server.shutdown()


def test_grasp_client_speaks_to_an_anygrasp_flask_server(anygrasp_server):
    from ferrobot.grasp._group import DICT_DEFAULTS
    from ferrobot.grasp.client import GraspClient

    url, seen, answer = anygrasp_server
    depth = np.full((4, 5), 500, dtype=np.uint16)
    colors = np.zeros((4, 5, 3), dtype=np.uint8)
    with GraspClient(url, timeout=5.0, retries=0) as client:
        gg = client.process(depth, 600.0, 600.0, 2.0, 1.5, 1000.0, colors=colors)
    assert len(seen) == 1 and np.asarray(seen[0]["depths"]).shape == (4, 5) and seen[0]["fx"] == 600.0
    assert np.asarray(seen[0]["colors"]).shape == (4, 5, 3)
    assert len(gg) == 2
    assert gg.translations == pytest.approx(np.array([a["translation"] for a in answer]))
    assert gg.rotation_matrices == pytest.approx(np.array([a["rotation_matrix"] for a in answer]))
    assert gg.scores == pytest.approx([0.9, 0.4]) and gg.depths == pytest.approx([0.03, 0.02])
    assert gg.widths == pytest.approx([DICT_DEFAULTS["width"], 0.05])
    assert gg.heights == pytest.approx([DICT_DEFAULTS["height"]] * 2)
    assert gg.object_ids.tolist() == [-1, -1]


def test_from_dicts_needs_the_pose():
    with pytest.raises(errors.InvalidArgumentError, match="rotation_matrix"):
        GraspGroup.from_dicts([{"translation": [0, 0, 0], "score": 1.0}])
    with pytest.raises(errors.NonFiniteError):
        GraspGroup.from_dicts([{"translation": [np.nan, 0, 0], "rotation_matrix": np.eye(3).tolist()}])
