"""Helpers shared by the bin tests (slides, drags, wall moves): the bench camera's frame and detection, the
simulated Panda hand's collision-mesh vertices and how many of them lie inside the bin's walls."""

from __future__ import annotations

from pathlib import Path

import numpy as np

import ferrobot
import ferrobot.grasp as fg


def obj_vertices(path: Path) -> np.ndarray:
    """The ``v`` rows of an OBJ file as (N, 3)."""
    rows = [line.split()[1:4] for line in path.read_text().splitlines() if line.startswith("v ")]
    return np.array(rows, dtype=np.float64)


def hand_mesh_points(robot, mesh_dir: Path, cache: dict) -> np.ndarray:
    """The simulated hand's collision-mesh vertices (world) at its current link poses (the URDF of
    ``grasp_eval.hand_files``: the right finger's mesh turned by pi about z); ``cache`` keeps the meshes."""
    if not cache:
        cache["hand"] = obj_vertices(mesh_dir / "hand.obj")
        cache["finger"] = obj_vertices(mesh_dir / "finger.obj")
    rz = np.diag([-1.0, -1.0, 1.0])
    out = []
    for link, verts, r in (
        ("panda_hand", cache["hand"], np.eye(3)),
        ("panda_leftfinger", cache["finger"], np.eye(3)),
        ("panda_rightfinger", cache["finger"], rz),
    ):
        t = robot.get_link_pose(link)
        out.append(verts @ (t[:3, :3] @ r).T + t[:3, 3])
    return np.vstack(out)


def inside_walls(points: np.ndarray, spec, table_top: float, tol: float) -> int:
    """How many points lie deeper than ``tol`` inside one of the bin's wall boxes."""
    count = 0
    for _, size, pose in spec.bin.walls(table_top):
        half = np.asarray(size) / 2 - tol
        count += int(np.all(np.abs(points - np.asarray(pose[:3])) < half, axis=1).sum())
    return count


def bench_frame(bench, w, names):
    """The bench camera's depth frame of ``w`` (missing depth as 0) and the segmentation ids of ``names``."""
    g = bench.ge
    cam_pose = bench.camera_pose()
    frame = ferrobot.Camera(w, g.WIDTH, g.HEIGHT, fx=g.F, cx=g.CX, cy=g.CY, pose=cam_pose).render(rgb=False)
    depth = np.where(np.isfinite(frame.depth), frame.depth, 0.0)
    ids = {i: n for i, n in w.segmentation_labels.items() if n in names}
    return frame, depth, cam_pose, ids


def bench_grasps(bench, frame, depth, cam_pose, ids) -> int:
    """How many grasps the bench's detection finds on the pieces ``ids`` (every other pixel an obstacle)."""
    g = bench.ge
    seg = np.where(np.isin(frame.segmentation, list(ids)), frame.segmentation, 0).astype(np.int32)
    down = tuple(cam_pose[:3, :3].T @ np.array([0.0, 0.0, -1.0]))
    return len(fg.detect_from_rgbd(depth, g.F, g.F, g.CX, g.CY, scale=1.0, mask=seg, approach_direction=down))
