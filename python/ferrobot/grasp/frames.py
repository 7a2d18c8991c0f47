"""Frames: camera to world, world to robot base, and moving points and grasps.

Clouds back-projected by :func:`ferrobot.camera.backproject` are in the camera's OpenCV optical frame
(x right, y down, z forward). A camera pose is the camera frame's pose in the world, in one of the
conventions ``"opencv"`` (= ROS optical), ``"opengl"`` (= USD / Isaac Sim: x right, y up, looking along -z)
or ``"ros"`` (REP 103 body frame: x forward, y left, z up). Poses are 4x4 matrices or
``[x, y, z, qw, qx, qy, qz]``.
"""

from __future__ import annotations

import numpy as np

from .. import camera as _camera
from .. import transforms
from ..errors import ShapeError
from ..transforms import as_matrix

__all__ = ["camera_to_world", "world_to_base", "transform_points"]


def _matrix(pose, name: str) -> np.ndarray:
    """One 4x4 matrix from a 4x4 matrix or a 7-vector (checked by ferrobot.transforms)."""
    m, _ = as_matrix(pose, name)
    if m.shape != (4, 4):
        raise ShapeError(f"{name}: expected a 4x4 matrix or [x, y, z, qw, qx, qy, qz], got shape {np.shape(pose)}")
    return m


def camera_to_world(camera_pose, convention: str = "opencv") -> np.ndarray:
    """4x4 transform from OpenCV-optical camera coordinates to the world, given the camera's world pose
    (:func:`ferrobot.camera.camera_to_world`)."""
    return _camera.camera_to_world(camera_pose, convention)


def world_to_base(base_pose) -> np.ndarray:
    """4x4 transform from world coordinates to the robot base frame, given the base's world pose."""
    return transforms.world_to_base(np.eye(4), _matrix(base_pose, "base_pose"))


def transform_points(points, transform) -> np.ndarray:
    """Applies a 4x4 transform (or 7-vector pose) to (N, 3) points."""
    m = _matrix(transform, "transform")
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3:
        raise ShapeError(f"points: expected shape (N, 3), got {p.shape}")
    return p @ m[:3, :3].T + m[:3, 3]
