"""The detector's hand covers the robot's own hand (issue 18): a robot model's gripper grown by
``Gripper.covering`` (``PickPlaceConfig.hand_covers_model``) has finger and housing boxes grown to the model's
collision geometry of the hand and finger links, so grasps detected with it keep the model's own collision
primitives, placed by forward kinematics at the grasp with the fingers at the grasp's opening, out of the scene's
solids (objects, bin walls, table) and free of observed points. Checked with the analytic scenes of
``grasp_scenes`` and point-in-primitive tests written here, independently of the detector and of parry."""

from __future__ import annotations

import numpy as np
import pytest
from grasp_scenes import CX, CY, FX, FY, clutter_scene, inside, render

import ferrobot
import ferrobot.grasp as fg
from ferrobot import robots
from ferrobot.errors import FerrobotError

STEP = 0.002  # interior sample spacing of the primitives (m)
SHRINK = 1e-3  # as the other clutter tests: a point counts when more than 1 mm inside


def _grid(lo, hi, step=STEP):
    axes = [np.arange(a, b + 1e-12, step) if b > a else np.array([(a + b) / 2]) for a, b in zip(lo, hi, strict=True)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)


def _interior(geom, shrink=SHRINK):
    """Points filling a collision primitive (its own frame), ``shrink`` inside its surface."""
    kind = geom["type"]
    if kind == "box":
        h = np.asarray(geom["size"], float) / 2 - shrink
        return _grid(-h, h)
    if kind == "sphere":
        r = geom["radius"] - shrink
        p = _grid([-r] * 3, [r] * 3)
        return p[np.linalg.norm(p, axis=1) <= r]
    if kind in ("cylinder", "capsule"):
        r, hl = geom["radius"] - shrink, geom["length"] / 2
        if kind == "cylinder":
            hl -= shrink
            p = _grid([-r, -r, -hl], [r, r, hl])
            return p[np.hypot(p[:, 0], p[:, 1]) <= r]
        p = _grid([-r, -r, -hl - r], [r, r, hl + r])
        zc = np.clip(p[:, 2], -hl, hl)
        return p[np.linalg.norm(p - np.stack([0 * zc, 0 * zc, zc], 1), axis=1) <= r]
    raise AssertionError(f"primitive {kind!r} not handled by this test")


def _contains(geom, pts, shrink=SHRINK):
    """Which points (primitive frame) lie more than ``shrink`` inside the primitive."""
    kind = geom["type"]
    if kind == "box":
        return np.all(np.abs(pts) < np.asarray(geom["size"], float) / 2 - shrink, axis=1)
    if kind == "sphere":
        return np.linalg.norm(pts, axis=1) < geom["radius"] - shrink
    r, hl = geom["radius"] - shrink, geom["length"] / 2
    if kind == "cylinder":
        return (np.hypot(pts[:, 0], pts[:, 1]) < r) & (np.abs(pts[:, 2]) < hl - shrink)
    zc = np.clip(pts[:, 2], -hl, hl)
    return np.linalg.norm(pts - np.stack([0 * zc, 0 * zc, zc], 1), axis=1) < r


def _links_below(model, hand):
    """The hand link and every link below it, from the model's joint table (parent -> child)."""
    children = {}
    for j in model.joint_names:
        info = model.joint_info(j)
        children.setdefault(info.parent, []).append(info.child)
    out, todo = [], [hand]
    while todo:
        link = todo.pop()
        out.append(link)
        todo.extend(children.get(link, []))
    return out


@pytest.fixture(scope="module", params=["panda", "ur5e"])
def robot(request):
    model = robots.bundled(request.param)
    return model, ferrobot.Gripper.from_model(model).covering(model)


def _placed_primitives(model, gripper, links, hand_pose, opening):
    """World-frame interiors and inverse poses of every collision primitive of ``links`` with the fingers at
    ``opening`` and the hand link at ``hand_pose``."""
    q = np.asarray(model.neutral_configuration(), float).copy()
    q[list(model.dof_names).index(gripper.driver)] = gripper.driver_position(opening)
    inv_hand = np.linalg.inv(model.fk(q, gripper.hand_link))
    out = []
    for link in links:
        link_pose = hand_pose @ inv_hand @ model.fk(q, link)
        for geom in model.collision_geometry(link):
            pose = link_pose @ np.asarray(geom["origin"], float)
            out.append((link, geom, pose))
    return out


def test_covering_grows_the_boxes_to_the_model_and_keeps_the_description(robot):
    model, g = robot
    shipped = {"panda_hand": ferrobot.Gripper.panda_hand, "robotiq_2f85": ferrobot.Gripper.robotiq_2f85}[g.name]()
    ext = shipped.model_extents(model)
    for field, key in (
        ("thickness", "thickness"),
        ("height", "height"),
        ("palm_width", "palm_width"),
        ("palm_height", "palm_height"),
        ("palm_depth", "palm_depth"),
    ):
        want = max(getattr(shipped.fingers, field), ext[key])
        assert getattr(g.fingers, field) == pytest.approx(want, abs=1e-12), field
    assert g.fingers.depth == shipped.fingers.depth
    assert g.max_opening == shipped.max_opening
    # Covering again changes nothing; the bare description is kept for clouds without a robot.
    again = g.covering(model)
    assert again.fingers.palm_width == g.fingers.palm_width
    assert ferrobot.Gripper.panda_hand().fingers.palm_width == pytest.approx(0.208)
    with pytest.raises(FerrobotError, match="panda"):
        ferrobot.Gripper.panda_hand().covering(robots.bundled("ur5e"))


def test_extents_match_the_bundled_primitives_by_hand():
    """The Panda's bundled primitives (panda.urdf), worked by hand in the grasp frame (x = hand z - 0.1034,
    y = hand y, z = -hand x): finger box 2.15 (x) x 2.7 (y) x 5.4 (z) cm at (0, +-0.013, 0.027) in the finger
    frame, the finger frame at hand z 0.0584 and y +-q, the opening 2q -> the box reaches 2.65 cm beyond the pad's
    inner face, +-1.075 cm along the binormal and 0.1124 - 0.1034 = 9 mm beyond the TCP. Hand: the capsule (r 2.6
    cm, 11.95 cm long along y at y = -3.05 cm) reaches y = -11.63 cm, the cylinder (r 4.75 cm at y = 6.4 cm) 11.15
    cm; the box's x half 3.275 cm is the largest binormal reach; the capsule's bottom (z = -0.0045 - 0.026) is the
    deepest, 0.1034 - 0.05 + 0.0305 behind the fingers' base; the cylinder's top z = 0.031 + 0.0475 is 0.0785 -
    0.0534 in front of it."""
    model = robots.bundled("panda")
    e = ferrobot.Gripper.panda_hand().model_extents(model)
    # The openings are sampled (129 positions) and the extents padded by what a point can move between two
    # samples (here 0.3125 mm of finger travel plus 0.3125 mm of half opening): a bound, at most 1 mm loose.
    assert 0.0265 <= e["thickness"] <= 0.0265 + 1e-3
    assert e["height"] == pytest.approx(0.0215, abs=1e-6)
    assert e["tip"] == pytest.approx(0.009, abs=1e-6)
    assert e["palm_width"] == pytest.approx(2 * (0.0305 + 0.11950 / 2 + 0.026), abs=1e-6)
    assert e["palm_height"] == pytest.approx(0.0655, abs=1e-6)
    assert e["palm_depth"] == pytest.approx(0.1034 - 0.05 + 0.0305, abs=1e-6)
    assert e["palm_front"] == pytest.approx(0.0785 - 0.0534, abs=1e-6)


def _check_grasps(model, gripper, scene, cloud, grasps, modelled_only):
    """Every grasp's hand, as the model's primitives placed at it: the primitives whose interior points lie in
    the scene's solids or that hold observed points, with the offending link named. ``modelled_only``: only the
    parts the detector's boxes model (finger geometry up to the TCP, the hand's rigid geometry behind the
    fingers' base); else the whole hand."""
    links = _links_below(model, gripper.hand_link)
    g2h = gripper.grasp_to_hand()
    q0 = np.asarray(model.neutral_configuration(), float)
    # Finger links: those the driver moves relative to the hand.
    moved = set()
    for link in links:
        rel = []
        for opening in (gripper.min_opening, gripper.max_opening):
            q = q0.copy()
            q[list(model.dof_names).index(gripper.driver)] = gripper.driver_position(opening)
            rel.append(np.linalg.inv(model.fk(q, gripper.hand_link)) @ model.fk(q, link))
        if not np.allclose(rel[0], rel[1], atol=1e-9):
            moved.add(link)
    bad = []
    for g in grasps:
        tcp = np.eye(4)
        tcp[:3, :3] = g.rotation_matrix
        tcp[:3, 3] = g.translation + g.depth * g.rotation_matrix[:, 0]
        opening = float(np.clip(g.width, gripper.min_opening, gripper.max_opening))
        for link, geom, pose in _placed_primitives(model, gripper, links, tcp @ g2h, opening):
            world = _interior(geom) @ pose[:3, :3].T + pose[:3, 3]
            local = (cloud - pose[:3, 3]) @ pose[:3, :3]
            seen = _contains(geom, local)
            if modelled_only:
                # Along the approach from the TCP: fingers end there, the housing at the fingers' base.
                front = 0.0 if link in moved else -gripper.fingers.depth
                world = world[(world - tcp[:3, 3]) @ tcp[:3, 0] <= front]
                seen &= (cloud - tcp[:3, 3]) @ tcp[:3, 0] <= front
            hits = inside(scene, world, margin=SHRINK)
            if hits.any() or seen.any():
                bad.append((g, link, geom["type"], int(hits.sum()), int(seen.sum())))
    return bad


def _scene_and_grasps(gripper, with_bin):
    scene, cam = clutter_scene(with_bin)
    depth, labels = render(scene, cam)
    v, u = np.nonzero(depth > 0)
    z = depth[v, u]
    cloud = np.stack([(u - CX) / FX * z, (v - CY) / FY * z, z], axis=1) @ cam[:3, :3].T + cam[:3, 3]
    cloud = cloud[cloud[:, 2] > 0.003]
    gw = fg.detect_from_rgbd(depth, FX, FY, CX, CY, 1.0, mask=labels, gripper=gripper).transform(cam)
    return scene, cloud, gw


@pytest.mark.parametrize("with_bin", [False, True], ids=["table", "bin"])
def test_the_models_own_hand_at_returned_grasps_is_clear_of_the_scene_and_the_cloud(robot, with_bin):
    """The hand and finger links' primitives (the parts the detector's boxes model) at every returned grasp."""
    model, gripper = robot
    scene, cloud, gw = _scene_and_grasps(gripper, with_bin)
    assert len(gw) >= 3
    bad = _check_grasps(model, gripper, scene, cloud, gw, modelled_only=True)
    assert not bad, f"{len(bad)} hand primitives collide, first: {bad[:3]}"


def test_the_bare_description_is_not_enough_for_the_models_hand():
    """Without the covering (the Panda hand as typed: fingers 1 cm thick, a 20.8 cm housing), returned grasps in
    the bin put the bundled Panda's own hand into a wall, an object or observed points (the check above is not
    vacuous). (The bare 2F-85 happens to pass in this scene.)"""
    model = robots.bundled("panda")
    bare = ferrobot.Gripper.panda_hand()
    scene, cloud, gw = _scene_and_grasps(bare, True)
    assert len(gw) >= 3
    assert _check_grasps(model, bare, scene, cloud, gw, modelled_only=True)


def test_pick_place_uses_the_covering_hand_when_asked():
    from ferrobot.errors import InvalidArgumentError
    from ferrobot.pipeline import PickPlace, PickPlaceConfig

    model = robots.bundled("panda")
    covered = ferrobot.Gripper.from_model(model).covering(model)
    pp = PickPlace(PickPlaceConfig(hand_covers_model=True))
    assert pp.gripper.fingers.thickness == pytest.approx(covered.fingers.thickness, abs=1e-12)
    assert pp.gripper.fingers.palm_width == pytest.approx(covered.fingers.palm_width, abs=1e-12)
    assert PickPlace().gripper.fingers.thickness == pytest.approx(ferrobot.Gripper.panda_hand().fingers.thickness)
    with pytest.raises(InvalidArgumentError, match="hand_covers_model"):
        PickPlace(PickPlaceConfig(hand_covers_model=1))
