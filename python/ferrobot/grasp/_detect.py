"""Grasp detection entry points (thin wrappers over the Rust crate ``ferrobot-grasp``)."""

from __future__ import annotations

import warnings

import numpy as np

from .. import camera as _camera
from .._core import DetectOptions, grasp_detect, grasp_detect_rgbd
from .._core import Gripper as _Gripper
from ..errors import InvalidArgumentError, NonFiniteError, ShapeError
from ._group import GraspGroup

__all__ = ["backproject", "detect", "detect_from_rgbd", "OPTIONS"]

#: Detection options accepted as keyword arguments, with their defaults: a snapshot of
#: ``DetectOptions().to_dict()`` (the defaults are defined once, in the Rust crate). Prefer
#: :class:`ferrobot.DetectOptions`.
OPTIONS = DetectOptions().to_dict()


def _mask(mask, shape) -> np.ndarray | None:
    if mask is None:
        return None
    m = np.asarray(mask)
    if m.shape != tuple(shape):
        raise ShapeError(f"mask: expected shape {tuple(shape)} like the depth image, got {m.shape}")
    if m.dtype == bool:
        return m.astype(np.int32)
    if not np.issubdtype(m.dtype, np.integer):
        raise InvalidArgumentError(f"mask: expected booleans or integer segmentation ids, got dtype {m.dtype}")
    if m.size and (m.min() < np.iinfo(np.int32).min or m.max() > np.iinfo(np.int32).max):
        raise InvalidArgumentError("mask: segmentation ids must fit in int32")
    return np.ascontiguousarray(m, dtype=np.int32)


def _check_colors(colors, shape) -> None:
    if colors is None:
        return
    c = np.asarray(colors)
    if c.shape not in (tuple(shape) + (3,), tuple(shape)):
        raise ShapeError(f"colors: expected shape {tuple(shape) + (3,)} like the depth image, got {c.shape}")
    if c.dtype.kind == "f" and not np.all(np.isfinite(c)):
        raise NonFiniteError("colors: contains NaN or infinite values")


def _depth(depth) -> np.ndarray:
    d = np.asarray(depth)
    if d.dtype.kind not in "uif":
        raise InvalidArgumentError(f"depth: expected numbers, got dtype {d.dtype}")
    if d.ndim != 2:
        raise ShapeError(f"depth: expected shape (H, W), got {d.shape}")
    return np.ascontiguousarray(d, dtype=np.float64)


def backproject(depth, fx: float, fy: float, cx: float, cy: float, scale: float = 1000.0, *, workspace=None):
    """Deprecated: use :func:`ferrobot.camera.backproject` with :class:`ferrobot.camera.Intrinsics`.

    Back-projects a depth image (H, W) to camera-frame points (OpenCV) with ``z = depth / scale``;
    returns ``(points (N, 3), pixels (N, 2))`` with each point's ``(row, column)``. The policy is the
    one of ``ferrobot.camera``: depth 0 or +inf is missing and skipped; NaN, -inf or negative depth raises.
    """
    warnings.warn(
        "ferrobot.grasp.backproject is deprecated; use ferrobot.camera.backproject(depth, "
        "ferrobot.camera.Intrinsics(width, height, fx, fy, cx, cy, depth_scale))",
        DeprecationWarning,
        stacklevel=2,
    )
    d = _depth(depth)
    k = _camera.Intrinsics(d.shape[1], d.shape[0], fx, fy, cx, cy, scale)
    return _camera.backproject(d, k, workspace=workspace)


def _gripper(gripper):
    """``gripper`` checked: None or a :class:`ferrobot.Gripper` (the detector derives its hand geometry and
    pad-scaled depths from it in the Rust crate, ``DetectOptions::for_gripper``)."""
    if gripper is not None and not isinstance(gripper, _Gripper):
        raise InvalidArgumentError(f"gripper: expected a ferrobot.Gripper, got {type(gripper).__name__}")
    return gripper


def detect(
    points,
    *,
    labels=None,
    seed_mask=None,
    workspace=None,
    options: DetectOptions | None = None,
    gripper=None,
    **overrides,
) -> GraspGroup:
    """Detects grasps in a point cloud (N, 3); returns a :class:`GraspGroup` sorted by score, after NMS.

    Every point is an obstacle for the gripper. ``seed_mask`` (N,) bool restricts where grasps are sought;
    ``labels`` (N,) int gives object ids copied to the grasps. ``workspace`` crops to
    ``[xmin, xmax, ymin, ymax, zmin, zmax]``. ``viewpoint`` (the camera position, default the origin) and
    ``approach_direction`` (default +z, the camera's view direction) are in the cloud's frame. Options:
    ``options`` (a :class:`ferrobot.DetectOptions`, default ``DetectOptions()``) with ``**overrides``
    (any of its fields, e.g. ``max_grasps=10``; unknown names and values out of range raise
    ``InvalidArgumentError``). ``gripper`` (a :class:`ferrobot.Gripper`) sets the hand's opening, finger and
    palm geometry and pad-scaled depths over ``options`` (``**overrides`` still win). An empty cloud gives an
    empty group.
    """
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3:
        raise ShapeError(f"points: expected shape (N, 3), got {p.shape}")
    n = p.shape[0]
    lab = None if labels is None else np.asarray(labels)
    seeds = None if seed_mask is None else np.asarray(seed_mask)
    for name, a in (("labels", lab), ("seed_mask", seeds)):
        if a is not None and a.shape != (n,):
            raise ShapeError(f"{name}: expected shape ({n},), got {a.shape}")
    if lab is not None and not np.issubdtype(lab.dtype, np.integer):
        raise InvalidArgumentError(f"labels: expected integers, got dtype {lab.dtype}")
    if lab is not None and lab.size and (lab.min() < np.iinfo(np.int32).min or lab.max() > np.iinfo(np.int32).max):
        raise InvalidArgumentError("labels: object ids must fit in int32")
    if seeds is not None and seeds.dtype != bool:
        raise InvalidArgumentError(f"seed_mask: expected booleans, got dtype {seeds.dtype}")
    if not np.all(np.isfinite(p)):
        bad = int(np.argwhere(~np.isfinite(p))[0][0])
        raise NonFiniteError(f"points: point {bad} is not finite")
    if workspace is not None:
        w = np.asarray(workspace, dtype=np.float64)
        if w.shape != (6,):
            raise ShapeError(f"workspace: expected [xmin, xmax, ymin, ymax, zmin, zmax], got shape {w.shape}")
        if np.isnan(w).any() or (w[0::2] > w[1::2]).any():
            raise InvalidArgumentError(f"workspace: each min must be <= its max and not NaN, got {w.tolist()}")
        keep = np.all((p >= w[0::2]) & (p <= w[1::2]), axis=1)
        p = p[keep]
        lab = None if lab is None else lab[keep]
        seeds = None if seeds is None else seeds[keep]
    arr = grasp_detect(
        np.ascontiguousarray(p),
        None if lab is None else np.ascontiguousarray(lab, dtype=np.int32),
        None if seeds is None else np.ascontiguousarray(seeds),
        options,
        _gripper(gripper),
        **overrides,
    )
    return GraspGroup(arr)


def detect_from_rgbd(
    depth,
    fx: float,
    fy: float,
    cx: float,
    cy: float,
    scale: float = 1000.0,
    *,
    colors=None,
    mask=None,
    object_id: int | None = None,
    workspace=None,
    options: DetectOptions | None = None,
    gripper=None,
    **overrides,
) -> GraspGroup:
    """Detects grasps in a depth image (H, W) with pinhole intrinsics; grasps are in the camera (OpenCV) frame.

    ``scale`` is raw depth units per metre (1000 for millimetres, 1 for metres). ``colors`` (H, W, 3) is
    checked for shape and otherwise unused: the detector is geometric. ``mask`` (H, W) is a boolean mask or
    integer segmentation ids: grasps are sought only on non-zero pixels and carry their id (``object_id``
    selects one id); all pixels remain obstacles. ``workspace`` crops to
    ``[xmin, xmax, ymin, ymax, zmin, zmax]`` in the camera frame. Options as :func:`detect`.
    """
    d = _depth(depth)
    _check_colors(colors, d.shape)
    m = _mask(mask, d.shape)
    arr = grasp_detect_rgbd(d, fx, fy, cx, cy, scale, m, object_id, workspace, options, _gripper(gripper), **overrides)
    return GraspGroup(arr)
