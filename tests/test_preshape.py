"""Pre-shaped approaches: the fingers open to the grasp's width plus a margin (not fully open) before the
approach, through the gripper description's opening map, and the planner checks the approach with them there;
and the push primitive for objects without a grasp (``ferrobot.pipeline.push``), executed in the simulator.

References: the Panda hand's fingers are two prismatic joints sliding in opposite directions along the
closing axis, so the opening is twice the driver's position (hand derivation); the Robotiq 2F-85's opening
is measured from the model's forward kinematics (the inner fingers stay parallel in its four-bar linkage, so
the gap between the pads changes as the distance between the inner-finger links along the closing axis,
anchored at the datasheet's 85 mm stroke when fully open).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import ferrobot
from ferrobot.errors import InvalidArgumentError
from ferrobot.pipeline import PickPlace, PickPlaceConfig, random_scene
from ferrobot.pipeline import clutter as clutter_mod

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benches"))


def _end_of(result, stage: str) -> np.ndarray:
    """The simulated robot's joint positions at the end of ``stage`` (full DOF vector)."""
    arrays = result.episode.recorder.arrays()
    rows = np.flatnonzero(arrays["stage"] == stage)
    assert len(rows), stage
    return arrays["positions"][rows[-1]]


def _stage(result, name: str):
    return next(s for s in result.stages if s.name == name)


def test_panda_approaches_with_the_fingers_at_the_grasp_width_plus_margin():
    pp = PickPlace(PickPlaceConfig(preshape_margin=0.01), robot="panda")
    result = pp.run(random_scene(seed=3))
    assert result.success, result.reason
    width = _stage(result, "select").detail["width"]
    opening = min(0.08, width + 0.01)
    assert _stage(result, "pregrasp").detail["preshape_opening_mm"] == pytest.approx(1e3 * opening)
    assert width + 0.01 < 0.08  # the pre-shape is narrower than fully open here
    # Hand derivation: each Panda finger joint moves half the opening.
    names = list(result.episode.robot.dof_names)
    for stage in ("pregrasp", "approach"):
        q = _end_of(result, stage)
        assert q[names.index("panda_finger_joint1")] == pytest.approx(opening / 2, abs=1e-3), stage
    # The planner checked the approach with the fingers there (its locked driver position).
    # (After the episode the gripper is open again for the retreat.)
    assert pp.planner.locked_positions[pp.planner.dof_names.index("panda_finger_joint1")] == pytest.approx(0.04)


def test_2f85_approaches_with_the_pads_at_the_grasp_width_plus_margin():
    pp = PickPlace(PickPlaceConfig(preshape_margin=0.01), robot="ur5e")
    result = pp.run(random_scene(seed=3))
    assert result.success, result.reason
    g, model = pp.gripper, pp.model
    width = _stage(result, "select").detail["width"]
    opening = min(g.max_opening, width + 0.01)
    assert width + 0.01 < g.max_opening

    def pad_gap(driver: float) -> float:
        q = model.neutral_configuration()
        q[list(model.dof_names).index(g.driver)] = driver
        base = model.fk(q, g.hand_link)
        left = np.linalg.inv(base) @ model.fk(q, "left_inner_finger")
        right = np.linalg.inv(base) @ model.fk(q, "right_inner_finger")
        return abs(float(np.dot(left[:3, 3] - right[:3, 3], g.closing)))

    # Opening from the forward kinematics, anchored at the datasheet's 85 mm when fully open.
    def fk_opening(driver: float) -> float:
        return 0.085 - (pad_gap(g.open_position) - pad_gap(driver))

    names = list(result.episode.robot.dof_names)
    q = _end_of(result, "approach")
    assert fk_opening(q[names.index(g.driver)]) == pytest.approx(opening, abs=2e-3)


def test_preshape_margin_none_approaches_fully_open_and_bad_margins_raise():
    pp = PickPlace(PickPlaceConfig(preshape_margin=None), robot="panda")
    result = pp.run(random_scene(seed=3))
    assert result.success, result.reason
    names = list(result.episode.robot.dof_names)
    assert _end_of(result, "approach")[names.index("panda_finger_joint1")] == pytest.approx(0.04, abs=1e-3)
    for bad in (-0.001, 0.06, float("nan"), "1cm"):
        with pytest.raises(InvalidArgumentError, match="preshape_margin"):
            PickPlace(PickPlaceConfig(preshape_margin=bad))


def test_clutter_bench_preshape_through_the_panda_width_map():
    import clutter as bench

    # Each of the floating hand's finger joints moves half the opening (hand derivation, as above).
    assert bench.preshape_finger(0.030, 0.01) == pytest.approx(0.020)
    assert bench.preshape_finger(0.075, 0.01) == pytest.approx(0.040)  # at most fully open
    assert bench.preshape_finger(0.030, None) == pytest.approx(0.040)  # no pre-shape: fully open
    steps = bench.bin_schedule(np.eye(4), 0.02)
    n = int(round(bench.ge.APPROACH_S / bench.DT))
    assert all(t[3] == t[4] == 0.02 and f == 0.0 for t, f in steps[:n])
    assert all(t[3] == t[4] == 0.0 for t, f in steps[n:])
    steps = bench.table_schedule(np.eye(4), 0.015)
    assert all(t[3] == t[4] == 0.015 for t, f in steps[:n]) and all(t[3] == 0.0 for t, f in steps[n:])
    assert ferrobot.Gripper.panda_hand().max_opening == pytest.approx(0.08)


def _box_near_wall_scene(gap: float):
    """The clutter bench's bin with one 5 x 5 x 4 cm box ``gap`` (m) from the -y wall, settled, and its frame."""
    import types

    import clutter as bench

    spec = types.SimpleNamespace(bin=clutter_mod.BinSpec(center=bench.CENTER))
    w = ferrobot.World(dt=bench.DT)
    w.add_box("table", [2.0, 2.0, bench.TABLE_TOP], [0, 0, bench.TABLE_TOP / 2, 1, 0, 0, 0], fixed=True, friction=1.0)
    clutter_mod.add_bin(w, spec.bin, bench.TABLE_TOP)
    y0 = -spec.bin.inner[1] / 2 + gap + 0.025
    w.add_box("box", [0.05, 0.05, 0.04], [0.0, y0, bench.TABLE_TOP + 0.02, 1, 0, 0, 0], mass=0.2, friction=0.8)
    w.step(120)
    cam_pose = bench.camera_pose()
    cam = ferrobot.Camera(
        w, bench.ge.WIDTH, bench.ge.HEIGHT, fx=bench.ge.F, cx=bench.ge.CX, cy=bench.ge.CY, pose=cam_pose
    )
    frame = cam.render(rgb=False)
    depth = np.where(np.isfinite(frame.depth), frame.depth, 0.0)
    ids = {i: n for i, n in w.segmentation_labels.items() if n == "box"}
    state = types.SimpleNamespace(spec=spec, poses={})
    return bench, w, state, frame, depth, cam_pose, ids, y0


def test_push_moves_a_box_away_from_a_bin_wall_in_the_simulator(tmp_path):
    pytest.importorskip("pybullet_data")
    bench, w, state, frame, depth, cam_pose, ids, y0 = _box_near_wall_scene(gap=0.06)
    plan = bench.plan_scene_push(state, w, frame, depth, cam_pose, ids)
    assert plan is not None
    # Away from the -y wall (the only free side that moves the box off a wall: +y), 4-10 cm.
    assert plan.direction[1] > 0.9 and 0.04 <= plan.distance <= 0.10
    # The fingertips start between the wall (y = -0.12) and the box's -y face (y0 - 0.025).
    assert -0.12 + 0.01 < plan.tip_start[1] < y0 - 0.025
    before = w.get_object_pose("box")
    _, hand_model = bench.ge.hand_files(tmp_path)
    rec = bench.execute_push(state, w, hand_model, plan, ["box"], {}, ids)
    after = state.poses["box"]
    moved = after[:3, 3] - before[:3, 3]
    # Hand-checked: the closed fingers start the gap travel - distance (margin 4 mm + clearance 5 mm, plus the
    # lean over the box's top when tilted) short of the box's face and travel the distance beyond it, so the
    # box moves the distance, give or take: the simulated finger meshes (pybullet_data's) reach up to ~5 mm
    # beyond the description's boxes (earlier contact), the box slides on while the hand decelerates, and
    # finger compliance and contact slip lose some: within [d - 1 cm, d + 1.5 cm].
    along = float(moved @ plan.direction)
    assert plan.travel - plan.distance >= 0.009 - 1e-9
    assert plan.distance - 0.01 <= along <= plan.distance + 0.015, (along, plan.distance)
    assert abs(float(moved @ np.array([-plan.direction[1], plan.direction[0], 0.0]))) < 0.015
    assert abs(moved[2]) < 0.003  # still on the floor, upright
    assert rec["target"] == "box" and rec["target_moved"] == pytest.approx(np.linalg.norm(moved), abs=1e-9)


def test_no_push_when_the_box_touches_the_wall():
    pytest.importorskip("pybullet_data")
    bench, w, state, frame, depth, cam_pose, ids, y0 = _box_near_wall_scene(gap=0.002)
    plan = bench.plan_scene_push(state, w, frame, depth, cam_pose, ids)
    # No finger fits in the 2 mm between the box and the wall: no push starts there, none goes into the wall.
    if plan is not None:
        assert plan.tip_start[1] > y0 - 0.025 and plan.direction[1] > -0.5


def test_push_planner_rejects_bad_input_naming_the_argument():
    from ferrobot.pipeline import push

    pts = np.array([[0.0, 0.0, 0.41], [0.01, 0.0, 0.42]])
    lab = np.array([1, 1])
    g = ferrobot.Gripper.panda_hand()
    ok = dict(support_z=0.4, bounds=[-0.1, 0.1, -0.1, 0.1])
    for kw, name in (
        ({"bounds": [0.1, -0.1, -0.1, 0.1]}, "bounds"),
        ({"bounds": [0.0, float("nan"), 0.0, 0.1]}, "bounds"),
        ({"support_z": float("inf")}, "support_z"),
        ({"num_directions": 0}, "num_directions"),
        ({"distances": (0.5,)}, "distances"),
        ({"tilts": (float("nan"),)}, "tilts"),
        ({"tip_heights": (0.0,)}, "tip_heights"),
        ({"margin": -0.001}, "margin"),
    ):
        with pytest.raises(InvalidArgumentError, match=name):
            push.plan_push(pts, lab, 1, g, **{**ok, **kw})
    with pytest.raises(InvalidArgumentError, match="points"):
        push.plan_push(pts[:, :2], lab, 1, g, **ok)
