"""Sliding an object along a bin wall (``ferrobot.pipeline.slide``), executed in the simulator by the clutter
bench's floating Panda hand.

References, independent of the planner: the box's motion is read from the simulator; the hand's collision meshes
(pybullet_data's ``hand.obj`` and ``finger.obj``, the meshes the simulator collides, not the planner's boxes) are
placed at the simulated link poses at every step and tested against the walls' analytic boxes; the geometry of the
open-floor case is checked by hand (no wall within 3 cm: nothing to slide along).
"""

from __future__ import annotations

import sys
import tempfile
import types
from pathlib import Path

import numpy as np
import pytest
from _bin_hand import hand_mesh_points, inside_walls

import ferrobot
from ferrobot.errors import InvalidArgumentError
from ferrobot.pipeline import clutter as clutter_mod
from ferrobot.pipeline import slide

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benches"))

BOX = (0.065, 0.065, 0.022)  # a flat piece as the bins leave them (bins18c: 6.5 x 6.5 x 2.2 cm plates)


def _scene(x: float, y: float):
    """The clutter bench's bin with one flat box centred at (x, y), settled, and its camera frame."""
    import clutter as bench

    spec = types.SimpleNamespace(bin=clutter_mod.BinSpec(center=bench.CENTER))
    w = ferrobot.World(dt=bench.DT)
    w.add_box("table", [2, 2, bench.TABLE_TOP], [0, 0, bench.TABLE_TOP / 2, 1, 0, 0, 0], fixed=True, friction=1.0)
    clutter_mod.add_bin(w, spec.bin, bench.TABLE_TOP)
    w.add_box("box", list(BOX), [x, y, bench.TABLE_TOP + BOX[2] / 2, 1, 0, 0, 0], mass=0.2, friction=0.8)
    w.step(120)
    cam_pose = bench.camera_pose()
    g = bench.ge
    frame = ferrobot.Camera(w, g.WIDTH, g.HEIGHT, fx=g.F, cx=g.CX, cy=g.CY, pose=cam_pose).render(rgb=False)
    depth = np.where(np.isfinite(frame.depth), frame.depth, 0.0)
    ids = {i: n for i, n in w.segmentation_labels.items() if n == "box"}
    state = types.SimpleNamespace(spec=spec, poses={})
    return bench, w, state, frame, depth, cam_pose, ids


def _run_slide(bench, w, state, plan, ids, mesh_dir):
    """The bench's slide execution, watching the simulated hand's meshes against the walls at every step."""
    worst = [0]
    cache: dict = {}

    def watch(robot):
        pts = hand_mesh_points(robot, mesh_dir, cache)
        worst[0] = max(worst[0], inside_walls(pts, state.spec, bench.TABLE_TOP, 0.001))

    with tempfile.TemporaryDirectory() as tmp:
        _, hand_model = bench.ge.hand_files(Path(tmp))
        rec = bench.execute_slide(state, w, hand_model, plan, ["box"], ids, on_step=watch)
    return rec, worst[0]


@pytest.mark.parametrize("x", [-0.06, 0.06])
def test_slide_moves_a_flat_box_along_the_wall_in_the_simulator(x):
    """A flat box 2 mm from the -y wall, 5.75 cm from the nearer end wall: no push exists (no finger fits
    between box and wall, pushing from inside drives it into the wall); the slide presses it against the
    wall and moves it along the wall towards the middle (where there is room for the housing), and the box
    follows: it moves the planned way, stays on the floor and in the bin, and the hand never enters a wall."""
    pybullet_data = pytest.importorskip("pybullet_data")
    y = -0.12 + 0.002 + BOX[1] / 2
    bench, w, state, frame, depth, cam_pose, ids = _scene(x, y)
    assert bench.plan_scene_push(state, w, frame, depth, cam_pose, ids) is None
    plan = bench.plan_scene_slide(state, frame, depth, cam_pose, ids)
    assert plan is not None
    assert plan.normal @ np.array([0.0, 1.0, 0.0]) > 0.99  # the -y wall
    assert plan.direction @ np.array([-np.sign(x), 0.0, 0.0]) > 0.99  # towards the middle of the wall
    assert 0.04 <= plan.distance <= 0.12
    before = w.get_object_pose("box")
    mesh_dir = Path(pybullet_data.getDataPath()) / "franka_panda" / "meshes" / "collision"
    rec, inside = _run_slide(bench, w, state, plan, ids, mesh_dir)
    after = state.poses["box"]
    moved = after[:3, 3] - before[:3, 3]
    along = float(moved @ plan.direction)
    # The fingers drag the box by friction (fingers 1.0, box 0.8, wall 0.6: the wall lets it slide); it lags
    # while the press builds up and slides on a little after the hand stops: within [d/2, d + 3 cm].
    assert 0.5 * plan.distance <= along <= plan.distance + 0.03, (along, plan.distance)
    # Not into the wall; it may turn a little and come off the wall (the wall's friction acts on one side).
    assert -0.003 <= float(moved @ plan.normal) <= 0.03
    assert abs(moved[2]) < 0.003 and after[2, 2] > 0.99  # on the floor, flat
    b = state.spec.bin
    assert abs(after[0, 3] - b.center[0]) < b.inner[0] / 2 and abs(after[1, 3] - b.center[1]) < b.inner[1] / 2
    assert inside == 0  # no vertex of the simulated hand's meshes deeper than 1 mm in a wall at any step
    assert rec["kind"] == "slide" and rec["target"] == "box"
    assert rec["target_moved"] == pytest.approx(np.linalg.norm(moved), abs=1e-9)


def test_no_slide_without_a_wall():
    """In the middle of the bin the box has no wall within 3 cm: there is nothing to slide along."""
    pytest.importorskip("pybullet_data")
    bench, w, state, frame, depth, cam_pose, ids = _scene(0.0, 0.0)
    assert bench.plan_scene_slide(state, frame, depth, cam_pose, ids) is None


def test_slide_planner_rejects_bad_input_naming_the_argument():
    pts = np.array([[0.0, 0.0, 0.41], [0.01, 0.0, 0.42]])
    lab = np.array([1, 1])
    g = ferrobot.Gripper.panda_hand()
    ok = dict(support_z=0.4, bounds=[-0.1, 0.1, -0.1, 0.1])
    for kw, name in (
        ({"bounds": [0.1, -0.1, -0.1, 0.1]}, "bounds"),
        ({"support_z": float("nan")}, "support_z"),
        ({"num_directions": 2}, "num_directions"),
        ({"wall_gap": 0.0}, "wall_gap"),
        ({"distances": (0.5,)}, "distances"),
        ({"press": 0.05}, "press"),
        ({"reach": 0.03}, "reach"),
        ({"tilts": (float("nan"),)}, "tilts"),
        ({"leans": (2.0,)}, "leans"),
        ({"tip_heights": (0.0,)}, "tip_heights"),
        ({"margin": -0.001}, "margin"),
        ({"min_gain": 0.5}, "min_gain"),
    ):
        with pytest.raises(InvalidArgumentError, match=name):
            slide.plan_slide(pts, lab, 1, g, **{**ok, **kw})
    with pytest.raises(InvalidArgumentError, match="points"):
        slide.plan_slide(pts[:, :2], lab, 1, g, **ok)
