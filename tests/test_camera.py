"""ferrobot.camera: intrinsics, back-projection against a hand-derived pinhole, conventions against scipy."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import ferrobot
from ferrobot import camera, errors


def _pose(rotation: Rotation, t) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3] = rotation.as_matrix()
    m[:3, 3] = t
    return m


def test_intrinsics_validation_names_the_argument():
    k = camera.Intrinsics(64, 48, 50.0, 55.0, 31.5, 23.5)
    assert k.depth_scale == 1.0
    np.testing.assert_array_equal(k.matrix, [[50.0, 0.0, 31.5], [0.0, 55.0, 23.5], [0.0, 0.0, 1.0]])
    assert camera.Intrinsics.from_matrix(k.matrix, 64, 48) == k
    with pytest.raises(errors.InvalidArgumentError, match="fx must be positive"):
        camera.Intrinsics(64, 48, 0.0, 55.0, 31.5, 23.5)
    with pytest.raises(errors.NonFiniteError, match="fy must be finite"):
        camera.Intrinsics(64, 48, 50.0, float("nan"), 31.5, 23.5)
    with pytest.raises(errors.NonFiniteError, match="cx"):
        camera.Intrinsics(64, 48, 50.0, 50.0, float("inf"), 23.5)
    with pytest.raises(errors.InvalidArgumentError, match="size"):
        camera.Intrinsics(0, 48, 50.0, 50.0, 0.0, 0.0)
    with pytest.raises(errors.InvalidArgumentError, match="depth scale"):
        camera.Intrinsics(64, 48, 50.0, 50.0, 0.0, 0.0, depth_scale=-1000.0)
    with pytest.raises(errors.InvalidArgumentError, match="width"):
        camera.Intrinsics(64.5, 48, 50.0, 50.0, 0.0, 0.0)
    with pytest.raises(errors.InvalidArgumentError, match="k:"):
        camera.Intrinsics.from_matrix([[50.0, 1.0, 0.0], [0.0, 50.0, 0.0], [0.0, 0.0, 1.0]], 64, 48)


def test_projection_round_trip_against_the_hand_derived_pinhole():
    # Points in front of the camera projected by hand (u = fx x / z + cx, v = fy y / z + cy) onto integer
    # pixels; their depths written into a millimetre image; back-projection must return the same points.
    rng = np.random.default_rng(7)
    w, h = 40, 30
    fx, fy, cx, cy, scale = 52.0, 47.0, 19.3, 14.8, 1000.0
    k = camera.Intrinsics(w, h, fx, fy, cx, cy, depth_scale=scale)
    rows, cols = rng.integers(0, h, 60), rng.integers(0, w, 60)
    rows, cols = np.unique(np.stack([rows, cols], axis=1), axis=0).T
    z = rng.uniform(0.3, 2.5, rows.size).round(3)  # whole millimetres
    depth = np.zeros((h, w))
    depth[rows, cols] = z * scale
    depth[0, 0] = np.inf if depth[0, 0] == 0 else depth[0, 0]  # +inf is missing too
    want = np.stack([(cols - cx) / fx * z, (rows - cy) / fy * z, z], axis=1)
    pts, pix = camera.backproject(depth, k)
    assert pix.dtype == np.int64 and pix.shape == (rows.size, 2)
    np.testing.assert_array_equal(pix, np.stack([rows, cols], axis=1))  # row-major order, (row, column)
    np.testing.assert_allclose(pts, want, rtol=0, atol=1e-12)
    # and the points project back onto their pixels
    np.testing.assert_allclose(fx * pts[:, 0] / pts[:, 2] + cx, cols, atol=1e-9)
    np.testing.assert_allclose(fy * pts[:, 1] / pts[:, 2] + cy, rows, atol=1e-9)
    # workspace in the camera frame
    lims = [-0.2, 0.2, -0.2, 0.2, 0.0, 1.5]
    pts_ws, pix_ws = camera.backproject(depth, k, workspace=lims)
    keep = np.all((want >= lims[0::2]) & (want <= lims[1::2]), axis=1)
    np.testing.assert_allclose(pts_ws, want[keep], atol=1e-12)
    np.testing.assert_array_equal(pix_ws, np.stack([rows, cols], axis=1)[keep])


def test_missing_depth_policy():
    k = camera.Intrinsics(5, 4, 100.0, 100.0, 2.0, 1.5)
    depth = np.full((4, 5), 1.0)
    depth[0, 0] = 0.0
    depth[1, 1] = np.inf
    pts, pix = camera.backproject(depth, k)
    assert len(pts) == 18
    assert not ({(0, 0), (1, 1)} & {tuple(p) for p in pix})
    depth[2, 3] = np.nan
    with pytest.raises(errors.NonFiniteError, match="depth"):
        camera.backproject(depth, k)
    depth[2, 3] = -np.inf
    with pytest.raises(errors.NonFiniteError, match=r"row 2, column 3"):
        camera.backproject(depth, k)
    depth[2, 3] = -0.5
    with pytest.raises(errors.InvalidArgumentError, match=r"negative depth -0.5 at pixel \(row 2, column 3\)"):
        camera.backproject(depth, k)
    with pytest.raises(errors.ShapeError):
        camera.backproject(np.ones((3, 5)), k)


def test_deprecated_aliases_warn_and_agree():
    depth = np.full((4, 5), 1.0)
    depth[1, 2] = 0.0
    k = camera.Intrinsics(5, 4, 100.0, 90.0, 2.0, 1.5, depth_scale=2.0)
    pts, pix = camera.backproject(depth, k)
    with pytest.warns(DeprecationWarning, match="ferrobot.camera.backproject"):
        p2, pix2 = ferrobot.grasp.backproject(depth, 100.0, 90.0, 2.0, 1.5, 2.0)
    np.testing.assert_array_equal(p2, pts)
    np.testing.assert_array_equal(pix2, pix)
    with pytest.warns(DeprecationWarning, match="ferrobot.camera.backproject"):
        p3, flat = ferrobot.depth_to_points(depth * 0.5, 100.0, 90.0, 2.0, 1.5)
    np.testing.assert_allclose(p3, pts, atol=1e-15)
    np.testing.assert_array_equal(flat, pix[:, 0] * 5 + pix[:, 1])


def test_conventions_against_scipy_rotations():
    eye, target = np.array([1.0, -2.0, 1.5]), np.array([0.2, 0.3, 0.1])
    cv = camera.look_at(eye, target)
    fwd = (target - eye) / np.linalg.norm(target - eye)
    np.testing.assert_allclose(cv[:3, 2], fwd, atol=1e-12)
    np.testing.assert_allclose(cv[:3, 3], eye)
    # OpenGL / USD: the OpenCV frame turned by pi about its x axis.
    gl = camera.convert_pose(cv, "opencv", "opengl")
    np.testing.assert_allclose(gl, cv @ _pose(Rotation.from_euler("x", np.pi), [0, 0, 0]), atol=1e-12)
    np.testing.assert_allclose(camera.opencv_to_opengl(cv), gl, atol=1e-15)
    np.testing.assert_allclose(camera.opengl_to_opencv(gl), cv, atol=1e-12)
    np.testing.assert_allclose(camera.convert_pose(cv, "ros_optical", "usd"), gl, atol=1e-15)
    # ROS: camera_link -> camera_optical_frame is (yaw, pitch, roll) = (-pi/2, 0, -pi/2) (REP 103 practice),
    # i.e. R = Rz(yaw) Ry(pitch) Rx(roll).
    body_to_optical = Rotation.from_euler("ZYX", [-np.pi / 2, 0.0, -np.pi / 2])
    body = _pose(Rotation.from_quat([0.1, -0.3, 0.2, 0.9]), [0.4, 0.5, 0.6])
    optical = camera.convert_pose(body, "ros", "opencv")
    np.testing.assert_allclose(optical, body @ _pose(body_to_optical, [0, 0, 0]), atol=1e-12)
    np.testing.assert_allclose(camera.convert_pose(optical, "opencv", "ros"), body, atol=1e-12)
    np.testing.assert_allclose(camera.convert_pose(body, "world", "ros"), body, atol=1e-15)
    # camera_to_world maps OpenCV camera coordinates to the world whatever the pose's convention.
    p_cam = np.array([0.1, -0.2, 1.3])
    for conv, pose in (("opencv", cv), ("opengl", gl)):
        t = camera.camera_to_world(pose, conv)
        np.testing.assert_allclose(t[:3, :3] @ p_cam + t[:3, 3], cv[:3, :3] @ p_cam + cv[:3, 3], atol=1e-12)
    np.testing.assert_allclose(ferrobot.grasp.camera_to_world(gl, "usd"), cv, atol=1e-12)
    # The sim camera's Isaac-style accessor agrees with the one conversion.
    w = ferrobot.World()
    cam = ferrobot.Camera(w, 16, 12, 10.0, pose=cv)
    pos, quat = cam.get_world_pose("usd")
    want = Rotation.from_matrix(gl[:3, :3]).as_quat()  # x, y, z, w
    got = np.array([quat[1], quat[2], quat[3], quat[0]])
    assert min(np.abs(got - want).max(), np.abs(got + want).max()) < 1e-6
    with pytest.raises(errors.InvalidArgumentError, match="unknown camera convention"):
        camera.convert_pose(cv, "opencv", "blender")
    with pytest.raises(errors.InvalidArgumentError, match="parallel"):
        camera.look_at([0, 0, 1], [0, 0, 0], [0, 0, 1])
