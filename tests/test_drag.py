"""Dragging a flat piece away from a bin wall with a fingertip on its top (``ferrobot.pipeline.drag``), executed in
the simulator by the clutter bench's floating Panda hand, on a bin floor of the walls' material (0.6).

References, independent of the planner: the piece's motion is read from the simulator; the hand's collision meshes
(pybullet_data's ``hand.obj`` and ``finger.obj`` at the simulated link poses, not the planner's boxes) are tested
against the walls' analytic boxes at every step; whether the piece can be grasped before and after is the grasp
detector's verdict on a fresh camera frame; the friction condition is derived by hand (Coulomb friction, averaged
coefficients).
"""

from __future__ import annotations

import sys
import tempfile
import types
from pathlib import Path

import numpy as np
import pytest
from _bin_hand import bench_frame, bench_grasps, hand_mesh_points, inside_walls

import ferrobot
from ferrobot.errors import InvalidArgumentError
from ferrobot.pipeline import clutter as clutter_mod
from ferrobot.pipeline import drag

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benches"))

SLAB = (0.085, 0.065, 0.022)  # a flat piece as the bins leave them against a wall (bins18: 8.5 x 6.5 x 2.2 cm)


def _world(x: float, y: float, yaw: float = 0.0):
    """The clutter bench's bin (floor of the bench's bin material) with the slab centred at (x, y), settled."""
    import clutter as bench

    spec = types.SimpleNamespace(bin=clutter_mod.BinSpec(center=bench.CENTER))
    w = ferrobot.World(dt=bench.DT)
    floor = bench.BIN_FLOOR_FRICTION
    w.add_box("table", [2, 2, bench.TABLE_TOP], [0, 0, bench.TABLE_TOP / 2, 1, 0, 0, 0], fixed=True, friction=floor)
    clutter_mod.add_bin(w, spec.bin, bench.TABLE_TOP)
    q = [np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)]
    w.add_box("slab", list(SLAB), [x, y, bench.TABLE_TOP + SLAB[2] / 2, *q], mass=0.2, friction=0.8)
    w.step(120)
    return bench, w, spec


@pytest.mark.parametrize("wall", ["+y", "-y"])
def test_drag_moves_a_slab_off_the_wall_until_it_can_be_grasped(wall):
    """A slab 2 mm from a long wall, its 8.5 cm side along it: no grasp (closing across its 6.5 cm side puts the
    20.8 cm housing across the wall), no push (no finger fits between slab and wall). The drag presses a
    fingertip on its top and pulls it away from the wall: the slab moves the planned way by about the planned
    distance, stays flat on the floor and in the bin, the hand never enters a wall, and in the new frame the
    detector finds grasps on it."""
    pybullet_data = pytest.importorskip("pybullet_data")
    sign = 1.0 if wall == "+y" else -1.0
    y = sign * (0.12 - 0.002 - SLAB[1] / 2)
    bench, w, spec = _world(0.0, y)
    frame, depth, cam_pose, ids = bench_frame(bench, w, {"slab"})
    state = types.SimpleNamespace(spec=spec, poses={})
    assert bench_grasps(bench, frame, depth, cam_pose, ids) == 0
    assert bench.plan_scene_push(state, w, frame, depth, cam_pose, ids) is None
    assert bench.drag_enabled(spec)
    plan = bench.plan_scene_drag(state, frame, depth, cam_pose, ids)
    assert plan is not None
    assert plan.direction @ np.array([0.0, -sign, 0.0]) > 0.99  # away from the wall
    assert 0.04 <= plan.distance <= 0.12
    before = w.get_object_pose("slab")
    mesh_dir = Path(pybullet_data.getDataPath()) / "franka_panda" / "meshes" / "collision"
    worst = [0]
    cache: dict = {}

    def watch(robot):
        worst[0] = max(worst[0], inside_walls(hand_mesh_points(robot, mesh_dir, cache), spec, bench.TABLE_TOP, 1e-3))

    with tempfile.TemporaryDirectory() as tmp:
        _, hand_model = bench.ge.hand_files(Path(tmp), coupled=True)
        rec = bench.execute_drag(state, w, hand_model, plan, ["slab"], ids, on_step=watch)
    after = state.poses["slab"]
    moved = after[:3, 3] - before[:3, 3]
    along = float(moved @ plan.direction)
    # The fingertip holds the slab (finger-slab 0.9 > slab-floor 0.7 averaged, 30 N press against 2 N weight).
    assert plan.distance - 0.01 <= along <= plan.distance + 0.01, (along, plan.distance)
    assert abs(float(moved @ np.cross([0.0, 0.0, 1.0], plan.direction))) < 0.01
    assert abs(moved[2]) < 0.003 and after[2, 2] > 0.99  # flat on the floor
    b = spec.bin
    assert abs(after[0, 3] - b.center[0]) < b.inner[0] / 2 and abs(after[1, 3] - b.center[1]) < b.inner[1] / 2
    assert worst[0] == 0  # no vertex of the simulated hand's meshes deeper than 1 mm in a wall at any step
    assert rec["kind"] == "drag" and rec["target"] == "slab"
    assert rec["target_moved"] == pytest.approx(np.linalg.norm(moved), abs=1e-9)
    # Where it lies now the housing fits: a fresh world, the slab at its new pose, gets grasps.
    yaw = float(np.arctan2(after[1, 0], after[0, 0]))
    bench2, w2, _ = _world(float(after[0, 3]), float(after[1, 3]), yaw)
    assert bench_grasps(bench2, *bench_frame(bench2, w2, {"slab"})) > 0


def test_no_drag_in_the_middle_of_the_bin():
    """In the middle the slab already has the most clearance a drag could give: nothing to gain."""
    pytest.importorskip("pybullet_data")
    bench, w, spec = _world(0.0, 0.0)
    frame, depth, cam_pose, ids = bench_frame(bench, w, {"slab"})
    state = types.SimpleNamespace(spec=spec, poses={})
    assert bench.plan_scene_drag(state, frame, depth, cam_pose, ids) is None


def test_drag_feasibility_is_coulomb_friction_with_averaged_coefficients():
    """Hand derivation: the fingertip transmits at most mu_fo N, the floor resists mu_of (N + m g), with
    mu_fo = (mu_f + mu_o) / 2 and mu_of = (mu_o + mu_floor) / 2."""
    # Bin floor 0.6, object 0.8, 0.2 kg, 30 N: 0.9 * 30 = 27 > 0.7 * 31.962 = 22.37.
    assert drag.drag_feasible(1.0, 0.8, 0.6, 0.2, 30.0)
    # The table's 1.0 under the bin: mu_fo = mu_of = 0.9, and 0.9 N < 0.9 (N + m g) for every N.
    for n in (1.0, 30.0, 900.0):
        assert not drag.drag_feasible(1.0, 0.8, 1.0, 0.2, n)
    # Object 1.0 on 0.6: ratio 1.25, so N must exceed m g / 0.25 = 4 m g (11.77 N for 0.3 kg).
    assert not drag.drag_feasible(1.0, 1.0, 0.6, 0.3, 11.5)
    assert drag.drag_feasible(1.0, 1.0, 0.6, 0.3, 12.0)
    for kw, name in (
        ({"mu_finger": -0.1}, "mu_finger"),
        ({"mu_object": 11.0}, "mu_object"),
        ({"mu_floor": float("nan")}, "mu_floor"),
        ({"mass": 0.0}, "mass"),
        ({"press_force": -1.0}, "press_force"),
    ):
        args = {"mu_finger": 1.0, "mu_object": 0.8, "mu_floor": 0.6, "mass": 0.2, "press_force": 30.0, **kw}
        with pytest.raises(InvalidArgumentError, match=name):
            drag.drag_feasible(**args)


def test_drag_planner_rejects_bad_input_naming_the_argument():
    pts = np.array([[0.0, 0.0, 0.41], [0.01, 0.0, 0.42]])
    lab = np.array([1, 1])
    g = ferrobot.Gripper.panda_hand()
    ok = dict(support_z=0.4, bounds=[-0.1, 0.1, -0.1, 0.1])
    for kw, name in (
        ({"bounds": [0.1, -0.1, -0.1, 0.1]}, "bounds"),
        ({"support_z": float("nan")}, "support_z"),
        ({"num_directions": 0}, "num_directions"),
        ({"distances": (0.5,)}, "distances"),
        ({"tilts": (float("nan"),)}, "tilts"),
        ({"press": 0.0}, "press"),
        ({"inset": 0.05}, "inset"),
        ({"flatness": -0.01}, "flatness"),
        ({"max_contacts": 0}, "max_contacts"),
        ({"max_contacts": float("nan")}, "max_contacts"),
        ({"num_directions": 2.5}, "num_directions"),
        ({"min_support": 0.0}, "min_support"),
        ({"margin": -0.001}, "margin"),
        ({"min_gain": 0.5}, "min_gain"),
    ):
        with pytest.raises(InvalidArgumentError, match=name):
            drag.plan_drag(pts, lab, 1, g, **{**ok, **kw})
    with pytest.raises(InvalidArgumentError, match="points"):
        drag.plan_drag(pts[:, :2], lab, 1, g, **ok)


def test_pybullet_agrees_the_drag_needs_the_bin_floor():
    """An independent judge of the drag's physics: PyBullet (coefficients multiplied) runs the same hand through
    the same planned drag, the press a constant force of the soft drive's size (``benches/drag_physics.py``). On
    the bin's floor (0.6) the slab follows the fingertip as in ferrobot; on a floor of the finger's friction
    (1.0: Coulomb says no drag, mu_o N < mu_o (N + m g)) it falls well short of the planned distance."""
    pytest.importorskip("pybullet")
    pytest.importorskip("pybullet_data")
    import drag_physics

    on_bin = drag_physics.drag_in_both(0.6, 0.8, 0.2)
    assert on_bin["planned"] - 0.01 <= on_bin["pybullet"] <= on_bin["planned"] + 0.01, on_bin
    assert on_bin["planned"] - 0.01 <= on_bin["ferrobot"] <= on_bin["planned"] + 0.01, on_bin
    on_table = drag_physics.drag_in_both(1.0, 0.8, 0.2)
    assert on_table["pybullet"] < on_table["planned"] - 0.02, on_table
