"""Cameras against analytic ray/primitive depth, segmentation, camera
conventions and back-projection."""

from __future__ import annotations

import numpy as np
import pytest

import ferrobot
from ferrobot import errors


def rays(cam):
    """Unit-z ray directions (H, W, 3) in the OpenCV camera frame."""
    k = cam.intrinsic_matrix
    v, u = np.mgrid[0 : cam.height, 0 : cam.width].astype(float)
    return np.stack([(u - k[0, 2]) / k[0, 0], (v - k[1, 2]) / k[1, 1], np.ones_like(u)], axis=-1)


def test_depth_of_ground_plane_from_tilted_camera():
    w = ferrobot.World()
    pose = ferrobot.look_at([0.3, -1.2, 0.9], [0.1, 2.0, 0.5])
    cam = ferrobot.Camera(w, 160, 120, 140.0, 150.0, 81.0, 57.5, pose, far=20.0)
    depth = cam.render(rgb=False).depth
    assert depth.dtype == np.float32 and depth.shape == (120, 160)
    # ray origin c, direction R d (d.z = 1): hits z = 0 at t = -c_z / (R d)_z, and depth = t
    d_world = rays(cam) @ pose[:3, :3].T
    t = -pose[2, 3] / d_world[..., 2]
    expected = np.where((t > 0) & (t < 20.0), t, np.inf)
    hit = np.isfinite(expected)
    assert hit.sum() > 1000 and (~hit).sum() > 100  # the horizon is in view
    assert np.allclose(depth[hit], expected[hit], rtol=1e-5)
    assert np.all(np.isinf(depth[~hit]))
    seg = cam.render(rgb=False).segmentation
    assert np.all(seg[hit] == 1) and np.all(seg[~hit] == 0)
    assert w.segmentation_labels[1] == "ground"


def test_depth_of_sphere_matches_ray_sphere_intersection():
    w = ferrobot.World(ground=False)
    center, radius = np.array([0.05, -0.02, 1.0]), 0.2
    w.add_sphere("ball", radius, [*center, 1, 0, 0, 0], fixed=True, color=[1.0, 0.0, 0.0])
    cam = ferrobot.Camera(w, 128, 96, 100.0)  # at the origin looking along +z
    out = cam.render()
    d = rays(cam)
    # |t d - c|^2 = r^2  ->  t = (d.c - sqrt((d.c)^2 - |d|^2 (|c|^2 - r^2))) / |d|^2
    dd = (d * d).sum(-1)
    dc = d @ center
    disc = dc**2 - dd * (center @ center - radius**2)
    hit = disc > 0
    t = (dc - np.sqrt(np.where(hit, disc, 0))) / dd
    # pixels whose ray grazes the silhouette may differ; compare away from it
    inner = disc > 1e-3 * dd
    outer = disc < -1e-3 * dd
    assert inner.sum() > 500
    assert np.allclose(out.depth[inner], t[inner], atol=1e-5)
    assert np.all(np.isinf(out.depth[outer]))
    ball_id = [k for k, v in w.segmentation_labels.items() if v == "ball"][0]
    assert np.all(out.segmentation[inner] == ball_id)
    assert np.all(out.segmentation[outer] == 0)
    # flat red, shaded by the angle to the surface: brightest at the centre
    rgb = out.rgb
    assert rgb.shape == (96, 128, 3) and rgb.dtype == np.uint8
    assert np.all(rgb[inner][:, 1:] == 0) and rgb[inner][:, 0].min() > 50


def test_capsule_depth_along_the_centre_row():
    # capsule along the camera's x axis at depth D: the centre row sees the
    # cylinder at D - r where |x| <= L / 2 and the end spheres beyond
    w = ferrobot.World(ground=False)
    depth_c, r, length = 1.0, 0.1, 0.6
    c = np.cos(np.pi / 4)
    w.add_capsule("cap", r, length, [0, 0, depth_c, c, 0, c, 0], fixed=True)  # z axis -> x axis
    cam = ferrobot.Camera(w, 200, 41, 100.0)
    row = cam.render(rgb=False).depth[20]
    a = (np.arange(200) - cam.intrinsic_matrix[0, 2]) / 100.0
    expected = np.full(200, np.inf)
    body = np.abs(a * (depth_c - r)) <= length / 2
    expected[body] = depth_c - r
    for sx in (-length / 2, length / 2):
        d = np.stack([a, np.zeros_like(a), np.ones_like(a)], -1)
        cen = np.array([sx, 0.0, depth_c])
        dd, dc = (d * d).sum(-1), d @ cen
        disc = dc**2 - dd * (cen @ cen - r * r)
        t = np.where(disc > 0, (dc - np.sqrt(np.abs(disc))) / dd, np.inf)
        expected = np.minimum(expected, t)
    finite = np.isfinite(expected)
    assert finite.sum() > 60
    assert np.allclose(row[finite], expected[finite], atol=1e-5)
    assert np.all(np.isinf(row[~finite]))


def test_cylinder_and_rotated_box_depth():
    # a cylinder whose axis points at the camera shows its cap: a disc of
    # radius r at depth D - L / 2; a box rotated about the optical axis shows
    # its front face at a constant depth
    w = ferrobot.World(ground=False)
    w.add_cylinder("cyl", 0.1, 0.4, [-0.3, 0, 2.0, 1, 0, 0, 0], fixed=True)
    w.add_box("box", [0.2, 0.2, 0.2], [0.3, 0, 2.0, np.cos(0.15), 0, 0, np.sin(0.15)], fixed=True)  # 0.3 rad
    c, s_ = np.cos(0.3), np.sin(0.3)
    cam = ferrobot.Camera(w, 120, 60, 100.0)
    out = cam.render(rgb=False)
    labels = {v: k for k, v in w.segmentation_labels.items()}
    d = rays(cam)
    zc = 2.0 - 0.2
    r2 = (d[..., 0] * zc + 0.3) ** 2 + (d[..., 1] * zc) ** 2
    inside = r2 < (0.1 - 0.003) ** 2
    outside_cap = r2 > (0.1 + 0.003) ** 2
    assert inside.sum() > 40
    assert np.allclose(out.depth[inside], zc, atol=1e-5)
    assert np.all(out.segmentation[inside] == labels["cyl"])
    # beyond the cap only the side (farther than the cap plane) can be seen
    side = outside_cap & (out.segmentation == labels["cyl"])
    assert np.all(out.depth[side] > zc)
    # pixels whose ray meets the plane z = 1.9 inside the rotated square see the front face
    px, py = d[..., 0] * 1.9 - 0.3, d[..., 1] * 1.9
    lx, ly = c * px + s_ * py, -s_ * px + c * py
    face = (np.abs(lx) < 0.1 - 0.003) & (np.abs(ly) < 0.1 - 0.003)
    assert face.sum() > 40
    assert np.all(out.segmentation[face] == labels["box"])
    assert np.allclose(out.depth[face], 1.9, atol=1e-5)


def test_box_face_depth_and_occlusion():
    w = ferrobot.World(ground=False)
    w.add_box("back", [2.0, 2.0, 0.1], [0, 0, 2.05, 1, 0, 0, 0], fixed=True)
    w.add_box("front", [0.2, 0.2, 0.2], [0, 0, 1.1, 1, 0, 0, 0], fixed=True)
    cam = ferrobot.Camera(w, 64, 64, 64.0)
    out = cam.render(rgb=False)
    labels = {v: k for k, v in w.segmentation_labels.items()}
    # centre pixel: the front box's near face at z = 1.0
    assert out.depth[32, 32] == pytest.approx(1.0, abs=1e-6)
    assert out.segmentation[32, 32] == labels["front"]
    # a corner pixel sees the back wall's face at z = 2.0
    assert out.depth[2, 2] == pytest.approx(2.0, abs=1e-6)
    assert out.segmentation[2, 2] == labels["back"]
    # the front box (0.2 wide at 1.0 m, f = 64) covers about 12.8 pixels
    assert 144 <= (out.segmentation == labels["front"]).sum() <= 196


def test_backprojection_lands_on_the_plane():
    w = ferrobot.World()
    pose = ferrobot.look_at([0.0, -0.8, 1.0], [0.0, 0.2, 0.0])
    cam = ferrobot.Camera(w, 96, 72, 80.0, pose=pose)
    depth = cam.render(rgb=False).depth
    pts, idx = cam.depth_to_points(depth)
    assert len(pts) == np.isfinite(depth).sum() == len(idx)
    world = pts @ pose[:3, :3].T + pose[:3, 3]
    assert np.abs(world[:, 2]).max() < 1e-5
    # the free function with explicit intrinsics agrees (ferrobot.camera's, pixels as (row, column)), and so
    # does the deprecated ferrobot.depth_to_points (flat indices) for its last release
    k = cam.intrinsic_matrix
    intr = ferrobot.camera.Intrinsics(depth.shape[1], depth.shape[0], k[0, 0], k[1, 1], k[0, 2], k[1, 2], 1.0)
    pts2, pix2 = ferrobot.camera.backproject(depth, intr)
    assert np.array_equal(pts, pts2) and np.array_equal(idx, pix2[:, 0] * depth.shape[1] + pix2[:, 1])
    with pytest.warns(DeprecationWarning, match="depth_to_points"):
        pts3, idx3 = ferrobot.depth_to_points(depth, k[0, 0], k[1, 1], k[0, 2], k[1, 2])
    assert np.array_equal(pts, pts3) and np.array_equal(idx, idx3)
    # points project back onto their pixels
    uv = pts[:, :2] / pts[:, 2:] * [k[0, 0], k[1, 1]] + [k[0, 2], k[1, 2]]
    assert np.allclose(uv[:, 0], idx % 96, atol=1e-6) and np.allclose(uv[:, 1], idx // 96, atol=1e-6)


def test_camera_conventions():
    pose = ferrobot.look_at([1.0, 2.0, 3.0], [0.0, 0.0, 0.0], [0.0, 0.0, 1.0])
    # OpenCV: z towards the target, y (image down) has a negative world-z component
    fwd = -np.array([1.0, 2.0, 3.0]) / np.linalg.norm([1.0, 2.0, 3.0])
    assert pose[:3, 2] == pytest.approx(fwd)
    assert pose[2, 1] < 0
    gl = ferrobot.opencv_to_opengl(pose)
    # OpenGL / USD: looks along -z, y up, same x and position
    assert -gl[:3, 2] == pytest.approx(fwd)
    assert gl[:3, 1] == pytest.approx(-pose[:3, 1])
    assert gl[:3, 0] == pytest.approx(pose[:3, 0])
    assert gl[:3, 3] == pytest.approx(pose[:3, 3])
    assert ferrobot.opengl_to_opencv(gl) == pytest.approx(pose)
    with pytest.raises(errors.InvalidArgumentError, match="parallel"):
        ferrobot.look_at([0, 0, 1], [0, 0, 0], [0, 0, 1])


def test_camera_on_link_follows_the_robot():
    model = ferrobot.robots.panda()
    w = ferrobot.World()
    r = w.add_robot(model)
    local = np.eye(4)
    local[:3, 3] = [0.0, 0.0, 0.03]
    cam = ferrobot.Camera(w, 64, 48, 20.0, pose=local, robot=r, link="panda_hand")
    for q in (model.neutral_configuration(), np.array([0.5, -0.3, 0.2, -2.0, 0.1, 1.8, 0.3, 0.02])):
        r.set_joint_positions(q)
        assert cam.world_transform == pytest.approx(model.fk(q, "panda_hand") @ local, abs=1e-5)
    # looking down the hand's z axis the fingers are seen
    out = cam.render(rgb=False)
    ids = {w.segmentation_labels[i] for i in np.unique(out.segmentation)}
    assert "robot/panda_leftfinger" in ids or "robot/panda_rightfinger" in ids


def test_camera_invalid_inputs():
    w = ferrobot.World()
    with pytest.raises(errors.InvalidArgumentError, match="size"):
        ferrobot.Camera(w, 0, 10, 10.0)
    with pytest.raises(errors.InvalidArgumentError, match="fx"):
        ferrobot.Camera(w, 10, 10, -1.0)
    with pytest.raises(errors.NonFiniteError):
        ferrobot.Camera(w, 10, 10, 10.0, pose=[np.nan, 0, 0, 1, 0, 0, 0])
    with pytest.raises(errors.InvalidArgumentError, match="near"):
        ferrobot.Camera(w, 10, 10, 10.0, near=1.0, far=0.5)
    with pytest.raises(errors.InvalidArgumentError, match="robot"):
        ferrobot.Camera(w, 10, 10, 10.0, link="panda_hand")
    cam = ferrobot.Camera(w, 10, 8, 10.0)
    with pytest.raises(errors.ShapeError):
        cam.depth_to_points(np.zeros((3, 3)))
