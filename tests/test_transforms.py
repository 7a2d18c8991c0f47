"""Quaternion and pose conversions against scipy's Rotation (x, y, z, w)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from ferrobot import errors as E
from ferrobot import transforms as T


def test_quaternion_matrix_round_trip_against_scipy():
    rots = Rotation.random(500, random_state=3)
    xyzw = rots.as_quat()
    wxyz = T.quat_xyzw_to_wxyz(xyzw)
    assert np.allclose(T.quat_wxyz_to_xyzw(wxyz), xyzw)
    assert np.allclose(T.quat_to_matrix(wxyz), rots.as_matrix(), atol=1e-12)
    back = T.matrix_to_quat(rots.as_matrix())
    assert np.all(back[:, 0] >= 0)
    assert np.allclose(np.abs(np.sum(back * wxyz, axis=1)), 1.0, atol=1e-12)


def test_pose_round_trip():
    rng = np.random.default_rng(0)
    rots = Rotation.random(50, random_state=4)
    poses = np.concatenate([rng.normal(size=(50, 3)), T.quat_xyzw_to_wxyz(rots.as_quat())], axis=1)
    poses[:, 3:] *= np.sign(poses[:, 3:4])
    mats = T.pose_to_matrix(poses)
    assert mats.shape == (50, 4, 4)
    assert np.allclose(mats[:, :3, :3], rots.as_matrix())
    assert np.allclose(T.matrix_to_pose(mats), poses)
    assert T.pose_to_matrix(poses[0]).shape == (4, 4)


def test_bad_input():
    with pytest.raises(E.ShapeError):
        T.pose_to_matrix(np.zeros(6))
    with pytest.raises(E.NonFiniteError):
        T.quat_to_matrix([np.nan, 0, 0, 1])
    with pytest.raises(E.NonFiniteError, match="zero-length"):
        T.quat_to_matrix([0, 0, 0, 0])


@pytest.mark.filterwarnings("error")
def test_matrices_near_the_float64_limit_are_rejected_without_numpy_warnings():
    """Huge finite entries overflow R^T R to inf and, with mixed signs, to NaN (inf - inf); NaN must count
    as "not a rotation" (a NaN comparison is False) and the overflow must not leak a RuntimeWarning."""
    big = 1e200
    mixed = np.array([[big, -big, big], [-big, big, -big], [big, big, -big]])
    with np.errstate(over="ignore", invalid="ignore"):
        gram = mixed.T @ mixed - np.eye(3)
    assert np.isnan(gram).any() or np.isinf(gram).any()  # the case this test is about
    for m in (mixed, np.full((3, 3), big), np.diag([big, 1.0, 1.0])):
        with pytest.raises(E.InvalidArgumentError, match="not a rotation"):
            T.matrix_to_quat(m)
        pose = np.eye(4)
        pose[:3, :3] = m
        with pytest.raises(E.InvalidArgumentError, match="not a rotation"):
            T.matrix_to_pose(pose)
