"""Analytic 6-DoF parallel-jaw grasps from RGB-D frames or point clouds (Rust crate ``ferrobot-grasp``).

No learned weights: a cloud is voxel-downsampled, given normals, searched for collision-free hands in the
local frame of seed points over approach rotations, scored by two-contact force closure at a friction
coefficient, contact support and approach direction, then thinned by non-maximum suppression (0.03 m, 30°).

Output is a :class:`GraspGroup` in graspnetAPI's layout and gripper frame (x approach, y closing); use
:meth:`GraspGroup.to_hand` with a :class:`ferrobot.Gripper` for its hand link's frame (the Panda hand's
approaches along its z).

    gg = ferrobot.grasp.detect_from_rgbd(depth, fx, fy, cx, cy, scale=1000.0, workspace=lims)
    gg = gg.nms().sort_by_score()
    poses = gg.to_hand(ferrobot.Gripper.panda_hand())

The HTTP service (``ferrobot serve-grasp``) is :mod:`ferrobot.grasp.server`; its client is
:class:`ferrobot.grasp.client.GraspClient`.
"""

from __future__ import annotations

import numpy as np

from .._core import DetectOptions
from ._detect import OPTIONS, backproject, detect, detect_from_rgbd
from ._group import (
    GRASP_COLUMNS,
    GRASP_TO_PANDA_HAND,
    PANDA_TCP_OFFSET,
    Grasp,
    GraspGroup,
    _panda_poses,
    _warn_panda_hand,
)
from .frames import camera_to_world, transform_points, world_to_base


def to_panda_hand(grasps: GraspGroup | Grasp, tcp_offset: float = PANDA_TCP_OFFSET):
    """Poses of the Panda's ``panda_hand`` frame for grasps: (N, 4, 4) for a group, (4, 4) for one grasp.

    See :meth:`GraspGroup.to_panda_hand` (hand z = approach, hand y = closing axis, TCP at the fingertips).
    Deprecated like the method: use ``grasps.to_hand(ferrobot.Gripper.panda_hand())`` (any gripper works).
    """
    _warn_panda_hand()  # points at this function's caller
    if isinstance(grasps, Grasp):
        return _panda_poses(grasps.rotation_matrix, grasps.translation, np.asarray(grasps.depth), tcp_offset)
    return _panda_poses(grasps.rotation_matrices, grasps.translations, grasps.depths, tcp_offset)


__all__ = [
    "DetectOptions",
    "GRASP_COLUMNS",
    "GRASP_TO_PANDA_HAND",
    "OPTIONS",
    "PANDA_TCP_OFFSET",
    "Grasp",
    "GraspGroup",
    "backproject",
    "camera_to_world",
    "detect",
    "detect_from_rgbd",
    "to_panda_hand",
    "transform_points",
    "world_to_base",
]
