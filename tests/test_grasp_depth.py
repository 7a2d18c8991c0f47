"""How deep the fingers go (issue 18): one depth policy in the detector, on a table and in a bin alike.

The policy (``DetectOptions.depths``): per orientation the deepest fixed depth whose hand clears the cloud and the
support plane and whose pads overlap the object between the fingers by at least the pad's width (``height``, 2 cm
for the Panda hand); where the support plane (the table, the bin's floor) stops every fixed depth, the deepest
depth the plane allows. Checked against analytic boxes of known height, with the depths worked by hand from the
hand's documented boxes, and against the boxes' true solids, independently of the detector."""

from __future__ import annotations

import numpy as np
import pytest
from grasp_scenes import CX, CY, FX, FY, Box, Scene, bench_bin_walls, hand_boxes, inside, look_at, object_volume, render

import ferrobot.grasp as fg

L_FINGER, PAD_WIDTH = 0.05, 0.02  # the default (Panda) hand: finger length and the pads' size across (height)
PALM_T, APPROACH = 0.01, 0.03  # palm thickness (finger_width) and approach corridor behind it
# The plane's tolerance: a hand corner may dip 1 mm below the support plane; the plane-limited depth aims at half.
PLANE_TOL = 0.001


def _detect(objects, in_bin):
    scene = Scene(objects=[*objects, *(bench_bin_walls() if in_bin else [])], table_half=0.4)
    cam = look_at(eye=(-0.25, -0.15, 0.6), target=(0.0, 0.0, 0.0))
    depth, labels = render(scene, cam)
    down = tuple(cam[:3, :3].T @ np.array([0.0, 0.0, -1.0]))
    gw = fg.detect_from_rgbd(depth, FX, FY, CX, CY, 1.0, mask=labels, object_id=1, approach_direction=down)
    return scene, gw.transform(cam)


def _grid(lo, hi, step=0.002):
    axes = [np.linspace(a, b, max(2, int(np.ceil((b - a) / step)) + 1)) for a, b in zip(lo, hi, strict=True)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)


def _check_hand_clear_and_engaged(scene, g, obj):
    """Fingers, palm (the hand's front) and approach corridor out of every solid (the object, the walls, the
    table: 1 mm of tolerance, the plane's), and the pads overlapping the object between the fingers along the
    approach by the pad's width, unless the fingertips are at the support plane (nothing deeper fits)."""
    for lo, hi in hand_boxes(g.width, g.depth):
        world = _grid(lo, hi) @ g.rotation_matrix.T + g.translation
        hits = inside(scene, world, margin=PLANE_TOL)
        assert not hits.any(), f"{g}: the hand is inside a solid at {world[hits][0]}"
    q = (object_volume(obj, step=0.001) - g.translation) @ g.rotation_matrix
    between = (np.abs(q[:, 2]) <= PAD_WIDTH / 2) & (q[:, 0] <= g.depth) & (np.abs(q[:, 1]) <= g.width / 2)
    assert between.any(), f"{g}: the object is not between the fingers"
    engaged = g.depth - q[between, 0].min()
    corners = [
        g.translation + g.rotation_matrix @ np.array([g.depth, y, z])
        for y in (-g.width / 2 - PALM_T, -g.width / 2, g.width / 2, g.width / 2 + PALM_T)
        for z in (-PAD_WIDTH / 2, PAD_WIDTH / 2)
    ]
    at_floor = min(c[2] for c in corners) < 0.002
    # The volume grid is 1 mm and the cloud's voxels 5 mm: the detector sees the top within ~2.5 mm.
    assert engaged >= PAD_WIDTH - 0.003 or at_floor, f"{g}: pads overlap the object by {engaged * 1e3:.1f} mm only"
    return engaged


@pytest.mark.parametrize("in_bin", [False, True], ids=["table", "bin"])
def test_a_tall_box_is_grasped_at_the_deepest_depth_from_its_top(in_bin):
    # A 4 x 5 x 12 cm box: from its top face (z = 12 cm) straight down, the deepest depth, 4 cm, puts the fingertips
    # 8 cm above the floor, the palm's front (fingertips - 5 cm) 1 cm above the top and the housing behind it above
    # the bin's 10 cm walls: nothing deeper is tried, and it clears, so every top grasp is 4 cm deep.
    box = Box(size=(0.04, 0.05, 0.12), center_xy=(0.0, 0.0), yaw=0.3, label=1)
    scene, gw = _detect([box], in_bin)
    assert len(gw) > 0
    top = 0
    for g in gw:
        _check_hand_clear_and_engaged(scene, g, box)
        vertical = g.rotation_matrix[:, 0] @ np.array([0.0, 0.0, -1.0]) > np.cos(np.radians(5))
        if vertical and abs(g.translation[2] - 0.12) < 0.003:
            top += 1
            assert g.depth == pytest.approx(0.04), g
            # The hand's front (the palm) above the top face.
            assert g.translation[2] - (g.depth - L_FINGER) > 0.12 + 0.009, g
    assert top > 0, "no straight-down grasp from the top face"


@pytest.mark.parametrize("in_bin", [False, True], ids=["table", "bin"])
@pytest.mark.parametrize("height", [0.012, 0.017])
def test_a_piece_lower_than_the_pads_width_is_grasped_as_deep_as_the_floor_allows(height, in_bin):
    # A 7 x 3 cm piece 1.2 or 1.7 cm tall lying on the table or the bin's floor. Straight down from its top
    # (z = height), a fixed depth d puts the fingertips at height - d: 2 cm (the shallowest fixed depth) is below
    # the floor, so no fixed depth fits, and the deepest the floor allows is height + 0.5 mm (the plane-limited
    # depth aims half the 1 mm tolerance below it). The fingertips then sit at the floor, below the piece's mid
    # height, and the pads overlap the whole piece. (Before depth18i the default list held 1.5 cm, which the
    # 1.7 cm piece got: 2 mm shallower than what fits, with 2 mm of the piece's side above the fingertips
    # unused.)
    piece = Box(size=(0.07, 0.03, height), center_xy=(0.02, -0.01), yaw=0.4, label=1)
    scene, gw = _detect([piece], in_bin)
    assert len(gw) > 0, "no grasp on a low piece"
    straight = 0
    for g in gw:
        engaged = _check_hand_clear_and_engaged(scene, g, piece)
        vertical = g.rotation_matrix[:, 0] @ np.array([0.0, 0.0, -1.0]) > np.cos(np.radians(2))
        if vertical and abs(g.translation[2] - height) < 0.002:
            straight += 1
            # Hand derivation: the hand approaches fully open (8 cm) and its fingertips' lowest corner (at
            # y = +-(4 cm + finger thickness), z = +-1 cm in the hand frame) may go half the tolerance below the
            # floor (z = 0): depth = (t_z - |R_zy| (4 + 1 cm) - |R_zz| 1 cm + 0.5 mm) / -R_zx, i.e. the seed's height
            # + 0.5 mm for an exactly vertical hand. Within 1 mm: the fitted floor plane against the true one, and
            # where the hand at that depth meets a point, the search's conservative plane depth (fingers anywhere
            # within 9 cm of the seed), up to ~1 mm shallower for a hand rolled by 1-2 degrees.
            r = g.rotation_matrix
            reach_y = max(g.width, 0.08) / 2 + PALM_T
            deepest = (g.translation[2] - abs(r[2, 1]) * reach_y - abs(r[2, 2]) * PAD_WIDTH / 2 + PLANE_TOL / 2) / -r[
                2, 0
            ]
            assert deepest - 1e-3 <= g.depth <= deepest + 5e-4, (g, deepest)
            if height > 0.016:
                assert g.depth > 0.015 + 1e-3, g  # deeper than the 15 mm hand it got before
            # The pads cover the piece's side down to within 2 mm of the floor.
            assert engaged >= height - 2e-3, g
    assert straight > 0, "no straight-down grasp from the top face"


def test_a_low_piece_ranks_below_an_equally_good_tall_one():
    # Two identical footprints (3 x 7 cm) side by side, one 8 cm tall, one 1.2 cm: the low one's hands engage
    # 12.5 of the pad's 20 mm (score x 0.625), the tall one's a full pad's width. The best grasp is on the tall one.
    tall = Box(size=(0.03, 0.07, 0.08), center_xy=(-0.05, 0.0), label=1)
    low = Box(size=(0.03, 0.07, 0.012), center_xy=(0.05, 0.0), label=2)
    scene = Scene(objects=[tall, low], table_half=0.4)
    cam = look_at(eye=(0.0, -0.3, 0.6), target=(0.0, 0.0, 0.0))
    depth, labels = render(scene, cam)
    down = tuple(cam[:3, :3].T @ np.array([0.0, 0.0, -1.0]))
    gw = fg.detect_from_rgbd(depth, FX, FY, CX, CY, 1.0, mask=labels, approach_direction=down).transform(cam)
    on_low = [g for g in gw if g.object_id == 2]
    on_tall = [g for g in gw if g.object_id == 1]
    assert on_low and on_tall
    assert gw[0].object_id == 1, gw[0]
    for g in on_low:
        assert g.depth < PAD_WIDTH, g


def test_a_depth_shallower_than_the_pads_width_is_no_fallback():
    # Only 1.5 cm allowed on a tall box: straight down from the top face the pads would overlap 15 of 20 mm, so
    # the hand does not qualify (and no support plane limits it: the table is 8 cm below); the default depths
    # grasp it.
    box = Box(size=(0.04, 0.05, 0.08), center_xy=(0.0, 0.0), yaw=0.3, label=1)
    scene = Scene(objects=[box], table_half=0.4)
    cam = look_at(eye=(-0.25, -0.15, 0.6), target=(0.0, 0.0, 0.0))
    depth, labels = render(scene, cam)
    down = tuple(cam[:3, :3].T @ np.array([0.0, 0.0, -1.0]))
    opts = dict(mask=labels, object_id=1, approach_direction=down)
    shallow = fg.detect_from_rgbd(depth, FX, FY, CX, CY, 1.0, depths=[0.015], **opts).transform(cam)
    for g in shallow:
        # Any hand left at 1.5 cm has the box rising >= 5 mm above its seed between the fingers.
        _check_hand_clear_and_engaged(scene, g, box)
        vertical = g.rotation_matrix[:, 0] @ np.array([0.0, 0.0, -1.0]) > np.cos(np.radians(5))
        assert not (vertical and abs(g.translation[2] - 0.08) < 0.003), f"{g}: a 15 mm hand from the top face"
    assert len(fg.detect_from_rgbd(depth, FX, FY, CX, CY, 1.0, **opts)) > 0
