"""Pose and quaternion conversions (quaternions are ``(w, x, y, z)``).

The documented boundary to scipy's ``Rotation`` (``x, y, z, w``) is
:func:`quat_wxyz_to_xyzw` / :func:`quat_xyzw_to_wxyz`.
"""

from __future__ import annotations

import numpy as np

from .errors import InvalidArgumentError, NonFiniteError, ShapeError

__all__ = [
    "matrix_to_pose",
    "pose_to_matrix",
    "quat_to_matrix",
    "matrix_to_quat",
    "quat_wxyz_to_xyzw",
    "quat_xyzw_to_wxyz",
    "world_to_base",
    "base_to_world",
    "as_matrix",
    "ROTATION_TOLERANCE",
]

#: Largest deviation ``max |R^T R - I|`` accepted for a rotation matrix (the
#: same tolerance as the pose arguments of the Rust bindings); the
#: determinant must also be positive. Anything else (zeros, a scaled or
#: singular matrix, a reflection) raises ``InvalidArgumentError``.
ROTATION_TOLERANCE = 1e-6


def _check_rotation(r: np.ndarray, name: str) -> None:
    """Raises unless every (..., 3, 3) matrix is a rotation within ROTATION_TOLERANCE."""
    flat = r.reshape(-1, 3, 3)
    if flat.shape[0] == 0:
        return
    # Entries near the float64 limit overflow to inf or NaN (inf - inf) here; the comparisons below are
    # written so that NaN counts as "not a rotation", and the overflow itself is expected, not a warning.
    with np.errstate(over="ignore", invalid="ignore"):
        err = np.abs(np.swapaxes(flat, -1, -2) @ flat - np.eye(3)).max(axis=(-1, -2))
        det = np.linalg.det(flat)
    bad = np.flatnonzero(~(err <= ROTATION_TOLERANCE) | ~(det > 0))
    if bad.size:
        i = int(bad[0])
        raise InvalidArgumentError(
            f"{name}: matrix {i} is not a rotation (max |R^T R - I| = {err[i]:.2e}, "
            f"det = {det[i]:.3g}; tolerance {ROTATION_TOLERANCE:g})"
        )


def _check_homogeneous(m: np.ndarray, name: str) -> None:
    """Raises unless every (..., 4, 4) matrix is a rigid transform."""
    flat = m.reshape(-1, 4, 4)
    bad = np.flatnonzero(np.any(flat[:, 3, :] != np.array([0.0, 0.0, 0.0, 1.0]), axis=-1))
    if bad.size:
        raise InvalidArgumentError(f"{name}: matrix {int(bad[0])}: the last row of a 4x4 pose must be [0, 0, 0, 1]")
    _check_rotation(flat[:, :3, :3], name)


def _array(x, name: str, shape_tail: tuple[int, ...]) -> np.ndarray:
    a = np.asarray(x, dtype=np.float64)
    if a.shape[a.ndim - len(shape_tail) :] != shape_tail or a.ndim not in (
        len(shape_tail),
        len(shape_tail) + 1,
    ):
        want = ", ".join(str(d) for d in shape_tail)
        raise ShapeError(f"{name}: expected shape ({want}) or (N, {want}), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise NonFiniteError(f"{name}: contains NaN or infinite values")
    return a


def quat_to_matrix(q) -> np.ndarray:
    """Rotation matrices (..., 3, 3) from quaternions (..., 4) ``(w, x, y, z)`` (normalised first)."""
    q = _array(q, "quaternion", (4,))
    n = np.linalg.norm(q, axis=-1, keepdims=True)
    if np.any(n < 1e-12):
        raise NonFiniteError("quaternion: zero-length quaternion")
    w, x, y, z = np.moveaxis(q / n, -1, 0)
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
        ],
        -2,
    )


def matrix_to_quat(r) -> np.ndarray:
    """Quaternions (..., 4) ``(w, x, y, z)`` with ``w >= 0`` from rotation matrices (..., 3, 3).

    Each matrix must be a rotation (orthonormal within :data:`ROTATION_TOLERANCE`, determinant > 0):
    anything else raises ``InvalidArgumentError``.
    """
    r = _array(r, "rotation", (3, 3))
    _check_rotation(r, "rotation")
    flat = r.reshape(-1, 3, 3)
    out = np.empty((flat.shape[0], 4))
    for i, m in enumerate(flat):
        tr = m[0, 0] + m[1, 1] + m[2, 2]
        if tr > 0:
            s = 2.0 * np.sqrt(tr + 1.0)
            q = [0.25 * s, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s]
        elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
            s = 2.0 * np.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
            q = [(m[2, 1] - m[1, 2]) / s, 0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s]
        elif m[1, 1] > m[2, 2]:
            s = 2.0 * np.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2])
            q = [(m[0, 2] - m[2, 0]) / s, (m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s]
        else:
            s = 2.0 * np.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1])
            q = [(m[1, 0] - m[0, 1]) / s, (m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s]
        q = np.asarray(q)
        out[i] = q / np.linalg.norm(q) * (1.0 if q[0] >= 0 else -1.0)
    return out.reshape(r.shape[:-2] + (4,))


def pose_to_matrix(pose) -> np.ndarray:
    """4x4 matrices (..., 4, 4) from 7-vectors (..., 7) ``[x, y, z, qw, qx, qy, qz]``."""
    p = _array(pose, "pose", (7,))
    out = np.zeros(p.shape[:-1] + (4, 4))
    out[..., :3, :3] = quat_to_matrix(p[..., 3:])
    out[..., :3, 3] = p[..., :3]
    out[..., 3, 3] = 1.0
    return out


def matrix_to_pose(m) -> np.ndarray:
    """7-vectors (..., 7) ``[x, y, z, qw, qx, qy, qz]`` from 4x4 matrices (..., 4, 4)."""
    m = _array(m, "pose matrix", (4, 4))
    _check_homogeneous(m, "pose matrix")
    return np.concatenate([m[..., :3, 3], matrix_to_quat(m[..., :3, :3])], axis=-1)


def quat_wxyz_to_xyzw(q) -> np.ndarray:
    """``(w, x, y, z)`` to scipy's ``(x, y, z, w)``."""
    q = _array(q, "quaternion", (4,))
    return np.concatenate([q[..., 1:], q[..., :1]], axis=-1)


def quat_xyzw_to_wxyz(q) -> np.ndarray:
    """scipy's ``(x, y, z, w)`` to ``(w, x, y, z)``."""
    q = _array(q, "quaternion", (4,))
    return np.concatenate([q[..., 3:], q[..., :3]], axis=-1)


def as_matrix(pose, name: str) -> tuple[np.ndarray, bool]:
    """4x4 matrices (..., 4, 4) from 7-vectors or matrices; True if given as 7-vectors."""
    a = np.asarray(pose, dtype=np.float64)
    if not np.all(np.isfinite(a)):
        raise NonFiniteError(f"{name}: non-finite value")
    if a.shape[-1:] == (7,):
        return pose_to_matrix(a), True
    if a.shape[-2:] == (4, 4):
        _check_homogeneous(a, name)
        return a, False
    raise ShapeError(f"{name}: expected (..., 7) [x, y, z, qw, qx, qy, qz] or (..., 4, 4), got {a.shape}")


def world_to_base(pose_world, base_pose_world) -> np.ndarray:
    """Poses given in the world frame, expressed in the robot base frame.

    ``base_pose_world`` is the robot base's pose in the world (as a simulator
    reports it). Poses are 7-vectors ``[x, y, z, qw, qx, qy, qz]`` or 4x4
    matrices, batched over leading dimensions; the result has the form of
    ``pose_world``.
    """
    p, as7 = as_matrix(pose_world, "pose_world")
    b, _ = as_matrix(base_pose_world, "base_pose_world")
    # The rigid inverse [R^T, -R^T t] (as_matrix checked b is rigid).
    inv = np.zeros_like(b)
    rt = np.swapaxes(b[..., :3, :3], -1, -2)
    inv[..., :3, :3] = rt
    inv[..., :3, 3] = -(rt @ b[..., :3, 3:4])[..., 0]
    inv[..., 3, 3] = 1.0
    out = inv @ p
    return matrix_to_pose(out) if as7 else out


def base_to_world(pose_base, base_pose_world) -> np.ndarray:
    """Poses given in the robot base frame, expressed in the world frame (inverse of :func:`world_to_base`)."""
    p, as7 = as_matrix(pose_base, "pose_base")
    b, _ = as_matrix(base_pose_world, "base_pose_world")
    out = b @ p
    return matrix_to_pose(out) if as7 else out
