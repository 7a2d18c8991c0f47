"""Grasps on thin and flat objects lying on a table (a flat ring, a torus, a bent tube, a plate, a flat bar):
detected from one rendered RGB-D frame (``benches/grasp_eval.py``'s scene), the top grasps' finger and palm
boxes are checked against the object's true shape (point in each convex part: scipy's hull half-spaces, at the
pose the object settled to) and against the table top, and the top grasp lifts the object with a floating Panda hand
in ferrobot's simulator and in PyBullet (``grasp_eval.evaluate``)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pybullet")
pytest.importorskip("scipy")
from scipy.spatial import ConvexHull  # noqa: E402

BENCHES = Path(__file__).resolve().parents[1] / "benches"
sys.path.insert(0, str(BENCHES))
import grasp_eval  # noqa: E402
import heldout_objects  # noqa: E402
import thin_objects  # noqa: E402

import ferrobot  # noqa: E402
import ferrobot.grasp as fg  # noqa: E402

PANDA = ferrobot.Gripper.panda_hand()
FINGER_DEPTH = 0.05
FINGER_WIDTH = 0.01
FINGER_HEIGHT = 0.02
#: The finger and palm boxes may touch the true surface within this (m): the detector's cloud is 5 mm voxel
#: centroids of a rendered depth image and every hand keeps 2 mm of clearance plus a voxel margin.
SURFACE_TOLERANCE = 0.001
#: How far a box corner may reach below the table top (m): the detector allows 1 mm.
TABLE_TOLERANCE = 0.001

# One object per kind, fixed sizes within the ranges of benches/thin_objects.py.
OBJECTS = {
    "flatring": heldout_objects.wall(0.017, 0.029, 0.017, 0.029, 0.0, 0.015),
    "torus": thin_objects.tube_segments(0.022, 0.0075, 0.0, 2 * np.pi, 16),
    "benttube": thin_objects.tube_segments(0.055, 0.008, -0.9, 0.9, 10),
    "plate": [heldout_objects.box([0, 0, 0], [0.09, 0.055, 0.011])],
    "flatbar": [heldout_objects.box([0, 0, 0], [0.12, 0.025, 0.012])],
}


def write_urdf(folder: Path, name: str, parts: list[np.ndarray]) -> Path:
    collisions = []
    for k, part in enumerate(parts):
        heldout_objects.write_obj(folder / f"{name}_{k}.obj", part)
        collisions.append(f'<collision><geometry><mesh filename="{name}_{k}.obj"/></geometry></collision>')
    mass = 700.0 * sum(heldout_objects.hull_volume(p) for p in parts)
    path = folder / f"{name}.urdf"
    path.write_text(heldout_objects.URDF.format(name=name, mass=mass, friction=0.8, collisions="\n".join(collisions)))
    return path


def box_samples(lo, hi, n: int = 6) -> np.ndarray:
    axes = [np.linspace(a, b, n) for a, b in zip(lo, hi, strict=True)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)


def hand_boxes(depth: float, width: float) -> list[tuple[np.ndarray, np.ndarray]]:
    """The fingers and the palm of a grasp in its own frame (x approach, y closing), shrunk by the tolerance."""
    t = SURFACE_TOLERANCE
    half, hz, base = width / 2, FINGER_HEIGHT / 2, depth - FINGER_DEPTH
    boxes = [
        ([base, half, -hz], [depth, half + FINGER_WIDTH, hz]),
        ([base, -half - FINGER_WIDTH, -hz], [depth, -half, hz]),
        ([base - FINGER_WIDTH, -half - FINGER_WIDTH, -hz], [base, half + FINGER_WIDTH, hz]),
    ]
    return [(np.array(lo) + t, np.array(hi) - t) for lo, hi in boxes]


@pytest.fixture(scope="module")
def scenes(tmp_path_factory):
    folder = tmp_path_factory.mktemp("thin")
    out = {}
    for k, (name, parts) in enumerate(OBJECTS.items()):
        path = write_urdf(folder, name, parts)
        spec = grasp_eval.make_spec(path)
        assert spec.scale_factor == 1.0
        scene = grasp_eval.Scene(spec, __import__("random").Random(k))
        down = tuple(scene.cam_pose[:3, :3].T @ np.array([0.0, 0.0, -1.0]))
        gg, _, _ = scene.detect(approach_direction=down)
        out[name] = (path, spec, scene, gg.transform(fg.camera_to_world(scene.cam_pose, "opencv")))
    return out


@pytest.mark.parametrize("name", list(OBJECTS))
def test_grasps_are_clear_of_the_true_mesh_and_the_table(scenes, name):
    _, spec, scene, gg = scenes[name]
    assert len(gg) >= 1, f"{name}: no grasp"
    pose = scene.settled
    posed = [p @ pose[:3, :3].T + pose[:3, 3] for p in (spec.parts or [spec.points])]
    planes = [ConvexHull(p).equations for p in posed]  # rows (n, c): inside where n . x + c < 0
    top = max(p[:, 2].max() for p in posed)
    for i in range(min(len(gg), 5)):
        r, t = gg.rotation_matrices[i], gg.translations[i]
        pts = np.concatenate([box_samples(lo, hi) for lo, hi in hand_boxes(gg.depths[i], gg.widths[i])]) @ r.T + t
        inside = np.zeros(len(pts), bool)
        for eq in planes:
            inside |= np.all(pts @ eq[:, :3].T + eq[:, 3] < 0.0, axis=1)
        assert not inside.any(), f"{name} grasp {i}: {inside.sum()} hand samples inside the object"
        assert pts[:, 2].min() >= grasp_eval.TABLE_TOP - TABLE_TOLERANCE - SURFACE_TOLERANCE, (name, i)
        # the fingertips reach below the object's top: the fingers hold the object, not the air above it
        tips = t + r[:, 0] * gg.depths[i]
        assert tips[2] < top - 0.004, (name, i, tips[2] - grasp_eval.TABLE_TOP, top - grasp_eval.TABLE_TOP)


@pytest.mark.parametrize("name", list(OBJECTS))
def test_the_top_grasp_lifts_it_in_both_simulators(scenes, name):
    res = grasp_eval.evaluate([scenes[name][0]], seed=0, progress=False)
    rec = res["objects"][0]
    for judge in ("ferrobot", "pybullet"):
        assert rec[judge]["success"], (judge, rec[judge])
        assert rec[judge]["rise"] >= grasp_eval.MIN_RISE
