"""AnyGrasp's detector interface over ferrobot's analytic grasp detection (no weights, no GPU, no licence file).

Code written for the AnyGrasp SDK keeps its shape::

    from ferrobot.compat.anygrasp import AnyGrasp

    anygrasp = AnyGrasp(cfgs)            # cfgs: argparse.Namespace / dict / None
    anygrasp.load_net()                  # nothing to load
    gg, cloud = anygrasp.get_grasp(points, colors, lims=lims, apply_object_mask=True,
                                   dense_grasp=False, collision_detection=True)
    gg = gg.nms().sort_by_score()

The grasps are ferrobot's (:func:`ferrobot.grasp.detect`: force closure on the observed geometry), in
graspnetAPI's layout and gripper frame, not AnyGrasp's learned ones.

Arguments as AnyGrasp's:

* ``points`` (N, 3) in metres in the camera frame (OpenCV: x right, y down, z forward), ``colors`` (N, 3)
  (checked for shape; the detector is geometric and does not use them);
* ``lims`` ``[xmin, xmax, ymin, ymax, zmin, zmax]`` crops the cloud (camera frame);
* ``apply_object_mask``: ferrobot never returns grasps on the dominant support plane (the table), which is
  what AnyGrasp's object mask does; ``False`` is accepted and changes nothing;
* ``dense_grasp=True`` searches four times as many seed points;
* ``collision_detection``: ferrobot's grasps are always collision-checked against the cloud; ``False`` is
  accepted and gives the same collision-free grasps.

``cfgs`` fields used: ``max_gripper_width`` (m, in (0, 0.2]; default 0.08, the Panda's opening),
``gripper_height`` (m, > 0; default 0.02); ``checkpoint_path``, ``top_down_grasp`` and ``debug`` are read and
have no counterpart (the approach direction preferred is the camera's view direction either way).

The returned ``cloud`` is an ``open3d.geometry.PointCloud`` of the cropped points (with colours) when open3d is
installed, else the cropped points as an (M, 3) float64 array.
"""

from __future__ import annotations

import numpy as np

from ..errors import InvalidArgumentError, NonFiniteError, ShapeError
from ..grasp import OPTIONS, GraspGroup, detect

__all__ = ["AnyGrasp", "GraspGroup"]


def _cfg(cfgs, name, default):
    if cfgs is None:
        return default
    if isinstance(cfgs, dict):
        return cfgs.get(name, default)
    return getattr(cfgs, name, default)


class AnyGrasp:
    """AnyGrasp's ``AnyGrasp(cfgs)`` detector (see the module docstring)."""

    def __init__(self, cfgs=None):
        self.cfgs = cfgs
        width = _cfg(cfgs, "max_gripper_width", OPTIONS["max_width"])
        height = _cfg(cfgs, "gripper_height", OPTIONS["height"])
        if not (0 < float(width) <= 0.2):
            raise InvalidArgumentError(f"cfgs.max_gripper_width: expected in (0, 0.2] m, got {width}")
        if not (0 < float(height) < np.inf):
            raise InvalidArgumentError(f"cfgs.gripper_height: expected > 0 m, got {height}")
        self.max_gripper_width = float(width)
        self.gripper_height = float(height)
        self.net_loaded = False

    def load_net(self) -> None:
        """Nothing to load: the detector has no weights. Safe to call repeatedly."""
        self.net_loaded = True

    def get_grasp(
        self,
        points,
        colors=None,
        lims=None,
        apply_object_mask: bool = True,
        dense_grasp: bool = False,
        collision_detection: bool = True,
        **options,
    ):
        """Grasps for a camera-frame cloud: ``(GraspGroup, cloud)``. ``options`` go to :func:`ferrobot.grasp.detect`."""
        p = np.asarray(points, dtype=np.float64)
        if p.ndim != 2 or p.shape[1] != 3:
            raise ShapeError(f"points: expected shape (N, 3), got {p.shape}")
        c = None
        if colors is not None:
            c = np.asarray(colors, dtype=np.float64)
            if c.shape != p.shape:
                raise ShapeError(f"colors: expected shape {p.shape} like points, got {c.shape}")
            if not np.all(np.isfinite(c)):
                raise NonFiniteError("colors: contains NaN or infinite values")
        if not np.all(np.isfinite(p)):
            raise NonFiniteError(f"points: point {int(np.argwhere(~np.isfinite(p))[0][0])} is not finite")
        if lims is not None:
            w = np.asarray(lims, dtype=np.float64)
            if w.shape != (6,):
                raise ShapeError(f"lims: expected [xmin, xmax, ymin, ymax, zmin, zmax], got shape {w.shape}")
            if np.isnan(w).any() or (w[0::2] > w[1::2]).any():
                raise InvalidArgumentError(f"lims: each min must be <= its max and not NaN, got {w.tolist()}")
            keep = np.all((p >= w[0::2]) & (p <= w[1::2]), axis=1)
            p = p[keep]
            c = None if c is None else c[keep]
        opts = {"max_width": self.max_gripper_width, "height": self.gripper_height}
        if dense_grasp:
            opts["num_seeds"] = 4 * OPTIONS["num_seeds"]
        opts.update(options)
        gg = detect(p, **opts) if len(p) else GraspGroup()
        return gg, _cloud(p, c)


def _cloud(points: np.ndarray, colors: np.ndarray | None):
    try:
        import open3d as o3d
    except ImportError:
        return points
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    if colors is not None:
        cloud.colors = o3d.utility.Vector3dVector(colors)
    return cloud
