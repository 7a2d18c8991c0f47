"""Cameras: intrinsics, frame conventions, ``look_at`` and depth back-projection.

The one home of camera concepts (the Rust crate ``ferrobot-camera``); the simulator's
:class:`ferrobot.Camera`, grasp detection from RGB-D and this module share it.

* Camera frame of every image and back-projected cloud: OpenCV / ROS optical (x right, y down,
  z forward). Pixel ``(u, v)`` is column u, row v, pixel centres at integer coordinates.
* Conventions of a camera *pose*: ``"opencv"`` (also ``"ros_optical"``), ``"opengl"`` (also ``"usd"``:
  x right, y up, looking along -z) and ``"ros"`` (also ``"world"``: REP 103 body frame, x forward,
  y left, z up).
* Missing depth: 0 and +inf are "no reading" and skipped; NaN, -inf and negative depths raise
  (``NonFiniteError`` / ``InvalidArgumentError``) naming the pixel. Pixels are returned as
  ``(row, column)``.

Poses are 4x4 matrices or ``[x, y, z, qw, qx, qy, qz]``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import _core
from .errors import InvalidArgumentError, ShapeError

__all__ = [
    "CONVENTIONS",
    "Intrinsics",
    "backproject",
    "camera_to_world",
    "convert_pose",
    "look_at",
    "opencv_to_opengl",
    "opengl_to_opencv",
]

#: The camera pose conventions (each also has the aliases listed in the module docstring).
CONVENTIONS = ("opencv", "opengl", "ros")


@dataclass(frozen=True)
class Intrinsics:
    """Pinhole intrinsics of a ``width`` x ``height`` image and the units of its depth images.

    ``fx``, ``fy`` (pixels) finite and > 0; ``cx``, ``cy`` (pixels) finite; sides in 1..16384;
    ``depth_scale``: raw depth units per metre, finite and > 0 (1 for metres, 1000 for millimetres):
    ``z = depth / depth_scale``. Checked on construction by the one validation in ``ferrobot-camera``.
    """

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    depth_scale: float = 1.0

    def __post_init__(self) -> None:
        for name in ("width", "height"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int | np.integer):
                raise InvalidArgumentError(f"{name}: expected an integer number of pixels, got {v!r}")
            if v < 0:
                raise InvalidArgumentError(f"{name}: must be >= 1, got {v}")
        _core.camera_check_intrinsics(
            int(self.width), int(self.height), self.fx, self.fy, self.cx, self.cy, self.depth_scale
        )

    @classmethod
    def from_matrix(cls, k, width: int, height: int, depth_scale: float = 1.0) -> Intrinsics:
        """Intrinsics from a 3x3 matrix ``K = [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]`` (no skew)."""
        m = np.asarray(k, dtype=np.float64)
        if m.shape != (3, 3):
            raise ShapeError(f"k: expected a 3x3 matrix, got shape {m.shape}")
        if m[0, 1] != 0.0 or m[1, 0] != 0.0 or np.any(m[2] != [0.0, 0.0, 1.0]):
            raise InvalidArgumentError(f"k: expected [[fx, 0, cx], [0, fy, cy], [0, 0, 1]], got {m.tolist()}")
        return cls(width, height, float(m[0, 0]), float(m[1, 1]), float(m[0, 2]), float(m[1, 2]), depth_scale)

    @property
    def matrix(self) -> np.ndarray:
        """The 3x3 matrix K."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])


def backproject(depth, intrinsics: Intrinsics, *, workspace=None) -> tuple[np.ndarray, np.ndarray]:
    """Back-projects a depth image (height, width) to camera-frame points (OpenCV).

    ``z = depth / depth_scale``, ``x = (u - cx) / fx * z``, ``y = (v - cy) / fy * z`` for column u, row v.
    Depth 0 or +inf is missing and skipped; NaN, -inf or negative depth raises. ``workspace`` is
    ``[xmin, xmax, ymin, ymax, zmin, zmax]`` in the camera frame (points outside are dropped).
    Returns ``(points (N, 3), pixels (N, 2))`` with each point's ``(row, column)``.
    """
    if not isinstance(intrinsics, Intrinsics):
        raise InvalidArgumentError(f"intrinsics: expected ferrobot.camera.Intrinsics, got {type(intrinsics).__name__}")
    k = intrinsics
    return _core.camera_backproject(depth, k.width, k.height, k.fx, k.fy, k.cx, k.cy, k.depth_scale, workspace)


def look_at(eye, target, up=(0.0, 0.0, 1.0)) -> np.ndarray:
    """The OpenCV camera pose (4x4) at ``eye`` looking at ``target``, image "up" towards ``up``."""
    return _core.look_at(eye, target, up)


def convert_pose(pose, from_: str = "opencv", to: str = "opengl") -> np.ndarray:
    """The pose (4x4) in convention ``to`` of a camera whose pose in convention ``from_`` is ``pose``."""
    return _core.camera_convert_pose(pose, from_, to)


def opencv_to_opengl(pose) -> np.ndarray:
    """The OpenGL/USD camera pose (-z forward, y up) of an OpenCV camera pose."""
    return convert_pose(pose, "opencv", "opengl")


def opengl_to_opencv(pose) -> np.ndarray:
    """The OpenCV camera pose (z forward, y down) of an OpenGL/USD camera pose."""
    return convert_pose(pose, "opengl", "opencv")


def camera_to_world(camera_pose, convention: str = "opencv") -> np.ndarray:
    """4x4 transform from OpenCV-optical camera coordinates to the world, given the camera's world pose
    in ``convention`` (that is, the camera's OpenCV pose)."""
    return convert_pose(camera_pose, convention, "opencv")
