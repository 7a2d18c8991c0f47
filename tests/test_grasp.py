"""Grasp detection on analytic RGB-D scenes, checked against the true geometry (not the detector's cloud)."""

from __future__ import annotations

import numpy as np
import pytest
from grasp_scenes import (
    CX,
    CY,
    FX,
    FY,
    Box,
    Cylinder,
    Scene,
    default_scene,
    hand_boxes,
    inside,
    look_at,
    object_volume,
    render,
    sample_box,
)
from scipy.spatial.transform import Rotation

import ferrobot.camera
import ferrobot.grasp as fg
from ferrobot.errors import InvalidArgumentError, NonFiniteError, ShapeError
from ferrobot.transforms import quat_wxyz_to_xyzw

L_FINGER, HEIGHT, MAX_WIDTH = 0.05, 0.02, 0.08


@pytest.fixture(scope="module")
def scene_frame():
    scene, cam = default_scene()
    depth, labels = render(scene, cam)
    return scene, cam, depth, labels


@pytest.fixture(scope="module")
def detected(scene_frame):
    scene, cam, depth, labels = scene_frame
    mm = np.round(depth * 1000).astype(np.uint16)  # a 16-bit millimetre depth image, as cameras give
    gg = fg.detect_from_rgbd(mm, FX, FY, CX, CY, 1000.0, mask=labels)
    return gg, gg.transform(cam)


def _rotation_angle(a, b):
    return np.degrees(np.arccos(np.clip((np.trace(a.T @ b) - 1) / 2, -1, 1)))


# --- back-projection -------------------------------------------------------------------------


def _backproject(depth, fx, fy, cx, cy, scale):
    """The supported back-projection (``ferrobot.camera``) for a (H, W) depth image."""
    k = ferrobot.camera.Intrinsics(depth.shape[1], depth.shape[0], fx, fy, cx, cy, scale)
    return ferrobot.camera.backproject(depth, k)


def test_backproject_equals_the_pinhole_formula():
    """The deprecated ``ferrobot.grasp.backproject`` still works (and warns) for one release."""
    rng = np.random.default_rng(1)
    depth = rng.integers(0, 3000, size=(24, 32)).astype(np.uint16)
    depth[rng.random(depth.shape) < 0.2] = 0
    fx, fy, cx, cy, scale = 410.0, 420.0, 15.2, 11.7, 1000.0
    with pytest.warns(DeprecationWarning, match="backproject"):
        pts, pix = fg.backproject(depth, fx, fy, cx, cy, scale)
    v, u = np.nonzero(depth)
    z = depth[v, u] / scale
    want = np.stack([(u - cx) / fx * z, (v - cy) / fy * z, z], axis=1)
    np.testing.assert_array_equal(pix, np.stack([v, u], axis=1))
    np.testing.assert_allclose(pts, want, rtol=0, atol=1e-12)
    lims = [-0.5, 0.5, -0.4, 0.4, 0.5, 2.0]
    with pytest.warns(DeprecationWarning, match="backproject"):
        pts_ws, _ = fg.backproject(depth, fx, fy, cx, cy, scale, workspace=lims)
    keep = np.all((want >= np.array(lims[0::2])) & (want <= np.array(lims[1::2])), axis=1)
    np.testing.assert_allclose(pts_ws, want[keep], atol=1e-12)


def test_rendered_frame_back_projects_onto_the_true_surfaces(scene_frame):
    scene, cam, depth, labels = scene_frame
    pts, pix = _backproject(depth, FX, FY, CX, CY, 1.0)
    world = fg.transform_points(pts, cam)
    on_object = labels[pix[:, 0], pix[:, 1]] > 0
    # table pixels lie on z = 0; object pixels on the objects' surfaces (not inside them by > 1 mm)
    np.testing.assert_allclose(world[~on_object, 2], 0.0, atol=1e-9)
    assert not inside(scene, world[on_object], margin=1e-3).any()


# --- detection against the true geometry ------------------------------------------------------


def test_grasps_on_both_objects_sorted_and_bounded(detected):
    gg, _ = detected
    assert len(gg) >= 10
    assert set(np.unique(gg.object_ids)) == {1, 2}
    s = gg.scores
    assert np.all(np.diff(s) <= 0) and np.all(s > 0) and np.all(s <= 1)
    assert np.all(gg.widths <= MAX_WIDTH + 1e-12) and np.all(gg.widths > 0)
    np.testing.assert_allclose(gg.heights, HEIGHT)
    assert set(np.round(gg.depths, 6)) <= {round(d, 6) for d in fg.OPTIONS["depths"]}
    R = gg.rotation_matrices
    np.testing.assert_allclose(R @ R.transpose(0, 2, 1), np.broadcast_to(np.eye(3), R.shape), atol=1e-9)
    np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=1e-9)


def test_hands_do_not_collide_with_the_true_objects_or_table(scene_frame, detected):
    scene, *_ = scene_frame
    _, gw = detected
    for g in gw:
        local = np.concatenate([sample_box(lo, hi) for lo, hi in hand_boxes(g.width, g.depth)])
        world = local @ g.rotation_matrix.T + g.translation
        hits = inside(scene, world, margin=1e-3)
        assert not hits.any(), f"{g} penetrates the scene at {world[hits][0]}"


def test_the_object_is_between_the_fingers_and_no_wider_than_the_opening(scene_frame, detected):
    scene, *_ = scene_frame
    _, gw = detected
    volumes = {obj.label: object_volume(obj) for obj in scene.objects}
    for g in gw:
        q = (volumes[g.object_id] - g.translation) @ g.rotation_matrix
        slab = (np.abs(q[:, 2]) <= HEIGHT / 2) & (q[:, 0] >= g.depth - L_FINGER) & (q[:, 0] <= g.depth)
        assert slab.sum() > 0, f"{g}: no part of object {g.object_id} between the fingers"
        # width >= the object's true extent along the closing axis where the fingers are
        assert np.all(np.abs(q[slab, 1]) <= g.width / 2 + 1e-9), f"{g}: object wider than the opening"


def test_box_grasps_close_across_opposite_faces(detected):
    _, gw = detected
    box = gw[gw.object_ids == 1]
    assert len(box) >= 3
    yaw = np.deg2rad(20)
    normals = np.array([[np.cos(yaw), np.sin(yaw), 0], [-np.sin(yaw), np.cos(yaw), 0], [0, 0, 1]])
    angle = np.degrees(np.arccos(np.clip(np.max(np.abs(box.rotation_matrices[:, :, 1] @ normals.T), axis=1), 0, 1)))
    # the best grasps are antipodal across a pair of faces, half of all within 25° (lower-ranked ones also
    # pinch edges, where the contact normal is the finger pad's). Two of the best three: since the hand's
    # housing is checked against the cloud (issue 18), two former top grasps whose housing clipped the
    # box's top edge by about 2 mm are gone, and a grasp 16° off the faces ranks among the first three.
    assert np.sum(angle[:3] < 10.0) >= 2, angle
    assert np.mean(angle < 25.0) >= 0.5, angle


def test_cylinder_grasps_close_across_the_axis(scene_frame, detected):
    scene, *_ = scene_frame
    _, gw = detected
    cyl_obj = next(o for o in scene.objects if isinstance(o, Cylinder))
    cyl = gw[gw.object_ids == 2]
    assert len(cyl) >= 3
    y = cyl.rotation_matrices[:, :, 1]
    tilt = np.degrees(np.arcsin(np.clip(np.abs(y[:, 2]), 0, 1)))
    # two of the best three (the housing check drops top grasps that pass within its 3.75 mm margin of the
    # cylinder's top; a 15° one then ranks third)
    assert np.sum(tilt[:3] < 10.0) >= 2 and np.all(tilt < 45.0), tilt
    # the cylinder's axis passes through the closing region for side grasps; top grasps hold the top disc
    assert np.all(cyl.widths >= 2 * cyl_obj.radius - 1e-3) or np.all(cyl.depths > 0)
    axis_pts = np.stack(
        [np.full(200, cyl_obj.center_xy[0]), np.full(200, cyl_obj.center_xy[1]), np.linspace(0, cyl_obj.height, 200)],
        axis=1,
    )
    through = 0
    for g in cyl:
        q = (axis_pts - g.translation) @ g.rotation_matrix
        between = (np.abs(q[:, 2]) <= HEIGHT / 2) & (q[:, 0] >= g.depth - L_FINGER) & (q[:, 0] <= g.depth)
        through += bool(np.any(between & (np.abs(q[:, 1]) <= g.width / 2)))
    assert through >= len(cyl) // 2


def test_nms_spacing_is_respected(detected):
    gg, _ = detected
    t, R = gg.translations, gg.rotation_matrices
    flip = np.diag([1.0, -1.0, -1.0])
    for i in range(len(gg)):
        for j in range(i + 1, len(gg)):
            if np.linalg.norm(t[i] - t[j]) < 0.03:
                ang = min(_rotation_angle(R[i], R[j]), _rotation_angle(R[i], R[j] @ flip))
                assert ang >= 30.0 - 1e-6, (i, j, ang)


def test_mask_and_object_id_select_where_grasps_are_sought(scene_frame):
    scene, cam, depth, labels = scene_frame
    only_cyl = fg.detect_from_rgbd(depth, FX, FY, CX, CY, 1.0, mask=labels, object_id=2)
    assert len(only_cyl) > 0 and set(only_cyl.object_ids) == {2}
    boolean = fg.detect_from_rgbd(depth, FX, FY, CX, CY, 1.0, mask=labels == 1)
    assert len(boolean) > 0 and set(boolean.object_ids) == {1}
    world = boolean.transform(cam).translations
    box = scene.objects[0]
    assert np.all(np.linalg.norm(world[:, :2] - np.array(box.center_xy), axis=1) < 0.06)
    unmasked = fg.detect_from_rgbd(depth, FX, FY, CX, CY, 1.0)
    assert len(unmasked) > 0 and set(unmasked.object_ids) == {-1}


def test_point_cloud_input_in_the_world_frame(scene_frame):
    scene, cam, depth, labels = scene_frame
    pts, pix = _backproject(depth, FX, FY, CX, CY, 1.0)
    world = fg.transform_points(pts, cam)
    gg = fg.detect(
        world,
        labels=labels[pix[:, 0], pix[:, 1]],
        viewpoint=cam[:3, 3],
        approach_direction=(0.0, 0.0, -1.0),
        workspace=[-0.3, 0.3, -0.3, 0.3, -0.01, 0.3],
    )
    assert len(gg) > 0
    for g in gg:
        local = np.concatenate([sample_box(lo, hi) for lo, hi in hand_boxes(g.width, g.depth)])
        assert not inside(scene, local @ g.rotation_matrix.T + g.translation, margin=1e-3).any()
    # preferring a top-down approach: the best grasp comes from above
    assert gg.rotation_matrices[0][2, 0] < -0.5


def test_a_single_box_seen_from_above():
    scene = Scene(objects=[Box(size=(0.04, 0.06, 0.05), yaw=0.3)])
    cam = look_at(eye=(0.0, 0.0, 0.6), target=(0.0, 0.0, 0.0), up=(0.0, 1.0, 0.0))
    depth, labels = render(scene, cam)
    gw = fg.detect_from_rgbd(depth, FX, FY, CX, CY, 1.0).transform(cam)
    assert len(gw) > 0
    best = gw[0]
    assert best.rotation_matrix[2, 0] < -0.9  # approaches from above
    ex, ey = np.array([np.cos(0.3), np.sin(0.3), 0.0]), np.array([-np.sin(0.3), np.cos(0.3), 0.0])
    y = best.rotation_matrix[:, 1]
    across = max((abs(y @ ex), 0.04), (abs(y @ ey), 0.06))  # closes across the 4 cm or the 6 cm faces
    assert across[0] > np.cos(np.deg2rad(10))
    assert across[1] <= best.width <= MAX_WIDTH


# --- GraspGroup --------------------------------------------------------------------------------


def test_to_array_layout_is_graspnet(detected):
    gg, _ = detected
    a = gg.to_array()
    assert a.dtype == np.float32 and a.shape == (len(gg), 17)
    np.testing.assert_allclose(a[:, 0], gg.scores, rtol=1e-6)
    np.testing.assert_allclose(a[:, 1], gg.widths, rtol=1e-6)
    np.testing.assert_allclose(a[:, 2], gg.heights, rtol=1e-6)
    np.testing.assert_allclose(a[:, 3], gg.depths, rtol=1e-6)
    np.testing.assert_allclose(a[:, 4:13].reshape(-1, 3, 3), gg.rotation_matrices, atol=1e-6)
    np.testing.assert_allclose(a[:, 13:16], gg.translations, atol=1e-6)
    np.testing.assert_array_equal(a[:, 16].astype(int), gg.object_ids)


def test_group_indexing_sorting_nms_and_dicts(detected):
    gg, _ = detected
    g0 = gg[0]
    assert isinstance(g0, fg.Grasp) and g0.score == gg.scores[0]
    np.testing.assert_array_equal(g0.rotation_matrix, gg.rotation_matrices[0])
    sub = gg[1:4]
    assert isinstance(sub, fg.GraspGroup) and len(sub) == 3
    assert len(gg[gg.scores > np.median(gg.scores)]) < len(gg)
    assert len(gg[[0, 2]]) == 2
    shuffled = gg[np.random.default_rng(0).permutation(len(gg))]
    np.testing.assert_array_equal(shuffled.sort_by_score().scores, gg.scores)
    np.testing.assert_array_equal(
        fg.GraspGroup(gg.grasp_group_array).sort_by_score(reverse=True).scores, gg.scores[::-1]
    )
    assert len(gg.nms()) == len(gg)  # detection output is already suppressed
    twice = fg.GraspGroup(gg.grasp_group_array).add(gg)
    assert len(twice.nms()) == len(gg)
    back = fg.GraspGroup.from_dicts(gg.to_dicts())
    np.testing.assert_allclose(back.grasp_group_array, gg.grasp_group_array)
    assert len(fg.GraspGroup().nms()) == 0 and repr(fg.GraspGroup()) == "GraspGroup(0 grasps)"
    assert len(list(iter(sub))) == 3


def test_nms_against_a_reference():
    rng = np.random.default_rng(3)
    n = 60
    rows = np.zeros((n, 17))
    rows[:, 0] = rng.random(n)
    rows[:, 1:4] = [0.05, 0.02, 0.02]
    rows[:, 4:13] = Rotation.random(n, random_state=4).as_matrix().reshape(n, 9)
    rows[:, 13:16] = rng.uniform(-0.05, 0.05, size=(n, 3))
    rows[:, 16] = -1
    kept = fg.GraspGroup(rows).nms(0.03, np.deg2rad(30))
    order = np.argsort(-rows[:, 0])
    flip = np.diag([1.0, -1.0, -1.0])
    ref = []
    for i in order:
        Ri = rows[i, 4:13].reshape(3, 3)
        ok = True
        for k in ref:
            Rk = rows[k, 4:13].reshape(3, 3)
            close = np.linalg.norm(rows[i, 13:16] - rows[k, 13:16]) < 0.03
            ang = min(_rotation_angle(Rk, Ri), _rotation_angle(Rk, Ri @ flip))
            if close and ang < 30.0:
                ok = False
                break
        if ok:
            ref.append(i)
    np.testing.assert_array_equal(kept.grasp_group_array, rows[ref])


def test_gripper_lines_outline_the_modelled_hand(detected):
    gg, _ = detected
    sub = gg[:3]
    lines = sub.gripper_lines()
    assert lines.shape == (3, 36, 2, 3)
    for g, segs in zip(sub, lines, strict=True):
        local = (segs.reshape(-1, 3) - g.translation) @ g.rotation_matrix
        want = np.concatenate([[lo, hi] for lo, hi in hand_boxes(g.width, g.depth)])
        np.testing.assert_allclose(local.min(0), want.min(0), atol=1e-12)
        np.testing.assert_allclose(local.max(0), want.max(0), atol=1e-12)
        lengths = np.linalg.norm(segs[:, 1] - segs[:, 0], axis=1)
        finger = [0.01] * 4 + [0.02] * 4 + [0.05] * 4  # thickness, height, length
        np.testing.assert_allclose(np.sort(lengths[:12]), finger, atol=1e-12)
        np.testing.assert_allclose(np.sort(lengths[12:24]), finger, atol=1e-12)
        palm = sorted([0.02] * 4 + [0.04] * 4 + [g.width + 0.02] * 4)  # height, depth, span
        np.testing.assert_allclose(np.sort(lengths[24:]), palm, atol=1e-12)


# --- frames ------------------------------------------------------------------------------------


def test_camera_to_world_conventions_against_scipy():
    rng = np.random.default_rng(5)
    q_wxyz = rng.normal(size=4)
    q_wxyz /= np.linalg.norm(q_wxyz)
    pos = rng.normal(size=3)
    pose7 = np.concatenate([pos, q_wxyz])
    R = Rotation.from_quat(quat_wxyz_to_xyzw(q_wxyz)).as_matrix()
    cv_to = {
        "opencv": np.eye(3),
        "opengl": np.diag([1.0, -1.0, -1.0]),
        "ros": np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]]),
    }
    p_cv = rng.normal(size=(10, 3))
    for conv, M in cv_to.items():
        T = fg.camera_to_world(pose7, conv)
        want = p_cv @ (R @ M).T + pos
        np.testing.assert_allclose(fg.transform_points(p_cv, T), want, atol=1e-12)
    # ROS body frame: a camera looking straight down has x forward = world -z
    down = np.concatenate([[0, 0, 1.0], [np.cos(np.pi / 4), 0, np.sin(np.pi / 4), 0]])
    T = fg.camera_to_world(down, "ros")
    np.testing.assert_allclose(fg.transform_points([[0, 0, 1.0]], T), [[0, 0, 0]], atol=1e-12)
    with pytest.raises(InvalidArgumentError, match="camera convention"):
        fg.camera_to_world(pose7, "directx")


def test_world_to_base_and_group_transform():
    rng = np.random.default_rng(6)
    base = np.eye(4)
    base[:3, :3] = Rotation.from_euler("z", 0.7).as_matrix()
    base[:3, 3] = [0.4, -0.1, 0.0]
    W2B = fg.world_to_base(base)
    np.testing.assert_allclose(W2B @ base, np.eye(4), atol=1e-12)
    rows = np.zeros((5, 17))
    rows[:, 0] = rng.random(5)
    rows[:, 1:4] = [0.05, 0.02, 0.03]
    rows[:, 4:13] = Rotation.random(5, random_state=7).as_matrix().reshape(5, 9)
    rows[:, 13:16] = rng.normal(size=(5, 3))
    gg = fg.GraspGroup(rows)
    moved = gg.transform(W2B)
    np.testing.assert_allclose(moved.rotation_matrices, W2B[:3, :3] @ gg.rotation_matrices, atol=1e-12)
    np.testing.assert_allclose(moved.translations, gg.translations @ W2B[:3, :3].T + W2B[:3, 3], atol=1e-12)
    np.testing.assert_array_equal(moved.widths, gg.widths)


def test_panda_hand_frame():
    rows = np.zeros((1, 17))
    rows[0, :4] = [0.9, 0.05, 0.02, 0.03]
    R = Rotation.from_euler("xyz", [0.3, -0.2, 1.1]).as_matrix()
    rows[0, 4:13] = R.ravel()
    rows[0, 13:16] = [0.1, 0.2, 0.3]
    gg = fg.GraspGroup(rows)
    with pytest.warns(DeprecationWarning, match="to_panda_hand"):
        H = gg.to_panda_hand()[0]
    np.testing.assert_allclose(H[:3, 2], R[:, 0], atol=1e-12)  # hand z = grasp approach (x)
    np.testing.assert_allclose(H[:3, 1], R[:, 1], atol=1e-12)  # hand y = closing axis
    np.testing.assert_allclose(np.linalg.det(H[:3, :3]), 1.0, atol=1e-12)
    tcp = H[:3, 3] + fg.PANDA_TCP_OFFSET * H[:3, 2]
    np.testing.assert_allclose(tcp, rows[0, 13:16] + 0.03 * R[:, 0], atol=1e-12)
    with pytest.warns(DeprecationWarning, match="to_panda_hand") as caught:
        np.testing.assert_allclose(gg[0].to_panda_hand(), H, atol=1e-12)
        np.testing.assert_allclose(fg.to_panda_hand(gg)[0], H, atol=1e-12)
        np.testing.assert_allclose(fg.to_panda_hand(gg[0]), H, atol=1e-12)
    # Each warning points at the caller (this file), not into the package.
    assert [w.filename for w in caught] == [__file__] * 3


# --- errors ------------------------------------------------------------------------------------


def test_bad_inputs_raise_clear_errors():
    d = np.full((4, 5), 500, dtype=np.uint16)
    with pytest.raises(ShapeError, match=r"depth: expected shape \(H, W\)"):
        fg.detect_from_rgbd(np.ones(5), 1, 1, 0, 0)
    bad = d.astype(float)
    bad[1, 2] = np.nan
    with pytest.raises(NonFiniteError, match=r"depth: non-finite value NaN at index \[1, 2\]"):
        fg.detect_from_rgbd(bad, 500, 500, 2, 2)
    bad[1, 2] = -1
    with pytest.raises(InvalidArgumentError, match="negative depth"):
        fg.detect_from_rgbd(bad, 500, 500, 2, 2)
    with pytest.raises(InvalidArgumentError, match="fx must be positive"):
        fg.detect_from_rgbd(d, 0, 500, 2, 2)
    with pytest.raises(NonFiniteError, match="fy must be finite"):
        fg.detect_from_rgbd(d, 500, float("nan"), 2, 2)
    with pytest.raises(InvalidArgumentError, match="depth scale"), pytest.warns(DeprecationWarning):
        fg.backproject(d, 500, 500, 2, 2, scale=-1)
    with pytest.raises(ShapeError, match="mask"):
        fg.detect_from_rgbd(d, 500, 500, 2, 2, mask=np.ones((3, 3), dtype=bool))
    with pytest.raises(InvalidArgumentError, match="object_id needs a segmentation mask"):
        fg.detect_from_rgbd(d, 500, 500, 2, 2, object_id=1)
    with pytest.raises(ShapeError, match="colors"):
        fg.detect_from_rgbd(d, 500, 500, 2, 2, colors=np.zeros((4, 4, 3)))
    with pytest.raises(InvalidArgumentError, match="xmin"):
        fg.detect_from_rgbd(d, 500, 500, 2, 2, workspace=[1, 0, 0, 1, 0, 1])
    with pytest.raises(ShapeError, match="workspace"):
        fg.detect_from_rgbd(d, 500, 500, 2, 2, workspace=[0, 1, 0, 1])
    with pytest.raises(InvalidArgumentError, match="unknown grasp option"):
        fg.detect_from_rgbd(d, 500, 500, 2, 2, voxel=0.01)
    with pytest.raises(InvalidArgumentError, match="voxel_size must be positive"):
        fg.detect(np.zeros((3, 3)), voxel_size=0.0)
    with pytest.raises(InvalidArgumentError, match="depth 0.06"):
        fg.detect(np.zeros((3, 3)), depths=[0.06])
    with pytest.raises(ShapeError, match=r"points: expected shape \(N, 3\)"):
        fg.detect(np.zeros((4, 2)))
    with pytest.raises(NonFiniteError, match="point 1"):
        fg.detect(np.array([[0, 0, 1.0], [np.inf, 0, 1]]))
    with pytest.raises(ShapeError, match="labels"):
        fg.detect(np.zeros((3, 3)), labels=np.zeros(2, dtype=int))
    with pytest.raises(ShapeError, match="grasp array"):
        fg.GraspGroup(np.zeros((2, 16)))


def test_empty_input_gives_an_empty_group():
    assert len(fg.detect(np.zeros((0, 3)))) == 0
    assert len(fg.detect_from_rgbd(np.zeros((10, 12)), 500, 500, 6, 5)) == 0
    gg = fg.detect_from_rgbd(np.full((10, 12), 800.0), 500, 500, 6, 5, workspace=[5, 6, 5, 6, 5, 6])
    assert len(gg) == 0 and gg.to_array().shape == (0, 17)


# --- hand body and centre of mass -------------------------------------------------------------------

PALM = (0.092, 0.208, 0.063)  # the Panda hand's housing: along approach, closing axis, z (OPTIONS palm_*)


def _body_corners(g) -> np.ndarray:
    """World corners of the hand's housing: centred on the fingers, from their base back by its depth."""
    base = g.depth - L_FINGER
    lo = np.array([base - PALM[0], -PALM[1] / 2, -PALM[2] / 2])
    hi = np.array([base, PALM[1] / 2, PALM[2] / 2])
    return sample_box(lo, hi, n=2) @ g.rotation_matrix.T + g.translation


def test_the_hand_housing_stays_above_the_table():
    # A low 8 x 5 x 3 cm box seen at a grazing angle: side grasps fit the fingers but put the
    # 6.3 cm tall, 20.8 cm wide housing under the table top unless it is modelled.
    scene = Scene(objects=[Box(size=(0.08, 0.05, 0.03), yaw=0.4)])
    cam = look_at(eye=(-0.5, -0.1, 0.25), target=(0.0, 0.0, 0.015))
    depth, labels = render(scene, cam)
    gw = fg.detect_from_rgbd(depth, FX, FY, CX, CY, 1.0, mask=labels).transform(cam)
    assert len(gw) > 0
    for g in gw:
        assert _body_corners(g)[:, 2].min() >= -1.5e-3, f"{g}: the housing goes under the table"
    tiny = fg.detect_from_rgbd(
        depth, FX, FY, CX, CY, 1.0, mask=labels, palm_width=1e-3, palm_height=1e-3, palm_depth=1e-3
    ).transform(cam)
    assert min(_body_corners(g)[:, 2].min() for g in tiny) < -0.01  # the check is what keeps them out


def test_the_best_grasp_holds_a_long_box_near_its_middle():
    # A 22 x 3.5 x 3.5 cm bar lying on the table: its centre of mass is its middle (x = 0.05); a grasp
    # far along it must hold the weight as a torque. The best grasp closes across the bar within 1.5 cm
    # of the middle, the true lever arm.
    scene = Scene(objects=[Box(size=(0.22, 0.035, 0.035), center_xy=(0.05, 0.0))])
    cam = look_at(eye=(-0.3, -0.35, 0.5), target=(0.05, 0.0, 0.02))
    depth, labels = render(scene, cam)
    gw = fg.detect_from_rgbd(depth, FX, FY, CX, CY, 1.0, mask=labels).transform(cam)
    assert len(gw) > 0
    best = gw[0]
    assert abs(best.rotation_matrix[0, 1]) < np.sin(np.deg2rad(20))  # closes across, not along, the bar
    assert abs(best.translation[0] - 0.05) < 0.015, best
    # without the preference, the best grasp's arm is not constrained (it is found anywhere along the bar)
    spread = fg.detect_from_rgbd(depth, FX, FY, CX, CY, 1.0, mask=labels, torque_scale=0.0).transform(cam)
    assert np.ptp(spread.translations[:, 0]) > 0.1


def test_a_cube_is_pinched_across_its_faces_not_its_edges():
    # A 5 cm cube seen from 50 degrees above the table: its hidden faces come from completing the
    # volume under the top. The best grasp closes square to a pair of faces (within 15 degrees), not
    # across the vertical edges, where the faces are at 45 degrees to the fingers.
    yaw = 0.5
    scene = Scene(objects=[Box(size=(0.05, 0.05, 0.05), yaw=yaw)])
    el = np.deg2rad(50)
    cam = look_at(eye=(0.6 * np.cos(el), 0.0, 0.025 + 0.6 * np.sin(el)), target=(0.0, 0.0, 0.025))
    depth, labels = render(scene, cam)
    down = cam[:3, :3].T @ np.array([0.0, 0.0, -1.0])
    gw = fg.detect_from_rgbd(depth, FX, FY, CX, CY, 1.0, mask=labels, approach_direction=tuple(down)).transform(cam)
    assert len(gw) > 0
    y = gw[0].rotation_matrix[:, 1]
    faces = [np.array([np.cos(yaw), np.sin(yaw), 0.0]), np.array([-np.sin(yaw), np.cos(yaw), 0.0])]
    assert max(abs(y @ f) for f in faces) > np.cos(np.deg2rad(15)), gw[0]
    assert gw[0].width < 0.05 + 0.015  # the 5 cm between faces, not the 7.1 cm diagonal
