"""Moving pieces off bin walls and out of corners with a fingertip on their top (``ferrobot.pipeline.drag``): when
the press tips a piece instead of dragging it, and pieces freed from corners, executed in the simulator by the
clutter bench's floating Panda hand on a bin floor of the walls' material (0.6).

References, independent of the planner: whether a piece tips is read from the simulator (hand-built drags, not the
planner's) and compared with the hand derivation of ``drag.tipping_line`` (moments about the piece's leading bottom
edge); where a freed piece ends is read from the simulator and judged against the hand's housing (the 20.8 x 6.3 cm
``palm_*`` box centred on the piece must fit inside the bin's inner walls) and by the grasp detector on a fresh camera
frame; the simulated hand's collision meshes (pybullet_data's, not the planner's boxes) are tested against the walls'
analytic boxes at every step; the planned hand poses are tested against the camera's cloud with the gripper
description's boxes.
"""

from __future__ import annotations

import math
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
from ferrobot.pipeline.push import hand_rotation

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benches"))

PLATE = (0.065, 0.065, 0.02)
TUBE = (0.015, 0.12)  # radius, length: a tube lying on the floor, its axis along x
INNER_X, INNER_Y = 0.15, 0.12  # half the bench bin's inner size


def _bench():
    import clutter as bench

    return bench


def _world(pieces):
    """The clutter bench's bin (floor of its material) holding ``pieces`` [(name, kind, dims, xy)], settled."""
    bench = _bench()
    spec = types.SimpleNamespace(bin=clutter_mod.BinSpec(center=bench.CENTER))
    w = ferrobot.World(dt=bench.DT)
    floor = bench.BIN_FLOOR_FRICTION
    w.add_box("table", [2, 2, bench.TABLE_TOP], [0, 0, bench.TABLE_TOP / 2, 1, 0, 0, 0], fixed=True, friction=floor)
    clutter_mod.add_bin(w, spec.bin, bench.TABLE_TOP)
    for name, kind, dims, (x, y) in pieces:
        if kind == "box":
            w.add_box(name, list(dims), [x, y, bench.TABLE_TOP + dims[2] / 2, 1, 0, 0, 0], mass=0.2, friction=0.8)
        else:  # a tube lying along x ("cyl") or y ("cylY"): the cylinder's axis (z) turned onto it
            c45 = math.cos(math.pi / 4)
            q = [c45, 0.0, c45, 0.0] if kind == "cyl" else [c45, c45, 0.0, 0.0]
            w.add_cylinder(name, dims[0], dims[1], [x, y, bench.TABLE_TOP + dims[0], *q], mass=0.2, friction=0.8)
    w.step(120)
    return bench, w, spec


def _hand_plan(bench, x: float, top: float, tilt: float, dist: float = 0.06) -> drag.DragPlan:
    """A drag along +x built by hand (not planned): the closed fingertips' centre at (x, 0) on a top ``top`` high,
    the closing axis across the drag, the hand's top leaning ``tilt`` towards +x; the poses as ``plan_drag`` makes."""
    g = bench.ge.PANDA_HAND
    up, d = np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0])
    a = -math.cos(tilt) * up - math.sin(tilt) * d
    c = np.cross(up, d)
    c = c - (c @ a) * a
    c /= np.linalg.norm(c)
    rot = hand_rotation(g, a, c)
    clearance, press = 0.005, 0.015
    tip = np.array([x, 0.0, bench.TABLE_TOP + top + clearance])
    start = np.eye(4)
    start[:3, :3] = rot
    start[:3, 3] = tip - rot @ np.asarray(g.tcp)
    pre, pressed, end = start.copy(), start.copy(), start.copy()
    pre[:3, 3] -= 0.05 * a
    pressed[:3, 3] += (clearance + press) / math.cos(tilt) * a
    end[:3, 3] = pressed[:3, 3] + dist * d
    return drag.DragPlan(1, pre, start, pressed, end, d, dist, press, tip, top, tilt, 0.0, 0.0)


def _execute(bench, w, spec, plan, names, ids, mesh_dir=None):
    """The bench's drag; returns the state, the pieces' largest tilt (deg) and rise (m) over the run and how many
    hand-mesh vertices were ever deeper than 1 mm in a wall."""
    state = types.SimpleNamespace(spec=spec, poses={})
    before = {n: w.get_object_pose(n) for n in names}
    worst = {"tilt": 0.0, "rise": 0.0, "inside": 0}
    cache: dict = {}

    def watch(robot):
        for n in names:
            t = w.get_object_pose(n)
            worst["tilt"] = max(
                worst["tilt"], math.degrees(math.acos(min(1.0, abs(float(before[n][:3, 2] @ t[:3, 2])))))
            )
            worst["rise"] = max(worst["rise"], float(t[2, 3] - before[n][2, 3]))
        if mesh_dir is not None:
            pts = hand_mesh_points(robot, mesh_dir, cache)
            worst["inside"] = max(worst["inside"], inside_walls(pts, spec, bench.TABLE_TOP, 1e-3))

    with tempfile.TemporaryDirectory() as tmp:
        _, hand_model = bench.ge.hand_files(Path(tmp), coupled=True)
        bench.execute_drag(state, w, hand_model, plan, names, ids, on_step=watch)
    return state, before, worst


@pytest.mark.parametrize(
    "x, tilt, tips",
    [
        # Leaning 0.4 rad, the fingertips' leading edge meets the top alone. Pressed 2.25 cm behind the plate's
        # leading edge (mu h = 0.7 x 2 cm = 1.4 cm, mu the averaged plate-floor 0.8 / 0.6): no press tips it.
        (0.0, 0.4, False),
        # The same edge at the plate's leading edge (e_p = 0): it stays down only for N < m g (e_g - mu h) / (mu h)
        # = 2.6 N; the drag presses with about 30 N: it tips up onto its leading edge.
        (0.0225, 0.4, True),
        # Upright, the same place: the flat fingertips can press with their trailing edge, 2 cm behind the
        # plate's edge, beyond mu h: it stays down.
        (0.0225, 0.0, False),
    ],
)
def test_a_press_tips_a_plate_exactly_where_the_tipping_line_says(x, tilt, tips):
    """A 6.5 cm plate in the middle of the bin, dragged 6 cm along +x by hand-built drags (the planner's poses,
    placed by hand): whether it tips is the simulator's verdict; the derivation's (``drag.tipping_line``, with the
    planner's choice of the fingertips' edge: the leading one when leaning, the trailing one upright) agrees."""
    pytest.importorskip("pybullet_data")
    bench, w, spec = _world([("plate", "box", PLATE, (0.0, 0.0))])
    ids = {i: n for i, n in w.segmentation_labels.items() if n == "plate"}
    plan = _hand_plan(bench, x, PLATE[2], tilt)
    half_d = bench.ge.PANDA_HAND.fingers.height / 2  # closing across the drag: the fingers' height along it
    edge = x + (half_d if tilt > 0 else -half_d)
    mu = 0.5 * (0.8 + bench.BIN_FLOOR_FRICTION)
    predicted = edge > drag.tipping_line(PLATE[0] / 2, PLATE[2], mu)
    assert predicted == tips
    state, before, worst = _execute(bench, w, spec, plan, ["plate"], ids)
    moved = state.poses["plate"][:3, 3] - before["plate"][:3, 3]
    if tips:
        assert worst["tilt"] > 45.0 and worst["rise"] > 0.01, worst  # stood up on its edge
    else:
        assert worst["tilt"] < 5.0 and worst["rise"] < 0.003, worst
        assert abs(float(moved[0]) - plan.distance) < 0.01, moved  # dragged the planned way


def test_tipping_line_is_the_moment_balance_about_the_leading_edge():
    """Hand derivation: with the press at e_p and the centre at e_g behind the leading bottom edge, the piece stays
    down while mu (N + m g) h <= N e_p + m g e_g. Behind the line (e_p, e_g >= mu h) that holds for every N; in front
    of it, it fails for N above m g (e_g - mu h) / (mu h - e_p)."""
    lead, h, mu, m, g = 0.0325, 0.02, 0.7, 0.2, 9.81
    line = drag.tipping_line(lead, h, mu)
    assert line == pytest.approx(lead - 0.014)
    e_g = lead  # the centre, at the footprint's middle
    for x in (line - 0.01, line - 0.001):
        e_p = lead - x
        for n in (0.1, 1.0, 10.0, 100.0, 1000.0):
            assert mu * (n + m * g) * h <= n * e_p + m * g * e_g
    e_p = lead - (line + 0.005)
    n_max = m * g * (e_g - mu * h) / (mu * h - e_p)
    assert mu * (0.99 * n_max + m * g) * h <= 0.99 * n_max * e_p + m * g * e_g
    assert mu * (1.01 * n_max + m * g) * h > 1.01 * n_max * e_p + m * g * e_g
    with pytest.raises(InvalidArgumentError, match="tip_friction"):
        drag.plan_drag(
            np.array([[0.0, 0.0, 0.41]]),
            np.array([1]),
            1,
            ferrobot.Gripper.panda_hand(),
            0.4,
            [-0.1, 0.1, -0.1, 0.1],
            tip_friction=-0.1,
        )


def _hand_boxes_hit(points: np.ndarray, pose: np.ndarray, gripper) -> int:
    """How many ``points`` (world) lie inside the gripper description's closed fingers or housing at the hand-link
    ``pose`` (the description's boxes: approach along the link's z to the TCP, closing along its y)."""
    f = gripper.fingers
    tz = float(np.asarray(gripper.tcp)[2])
    local = (points - pose[:3, 3]) @ pose[:3, :3]
    fingers = (np.abs(local[:, 0]) <= f.height / 2) & (np.abs(local[:, 1]) <= f.thickness)
    fingers &= (local[:, 2] >= tz - f.depth) & (local[:, 2] <= tz)
    palm = (np.abs(local[:, 0]) <= f.palm_height / 2) & (np.abs(local[:, 1]) <= f.palm_width / 2)
    palm &= (local[:, 2] >= tz - f.depth - f.palm_depth) & (local[:, 2] <= tz - f.depth)
    return int((fingers | palm).sum())


def _housing_fits(x: float, y: float, gripper) -> bool:
    """Whether the hand's housing (palm_width x palm_height), centred on (x, y) with its long side along one of the
    bin's axes, lies inside the bin's inner walls: where a grasp of a low piece can stand."""
    f = gripper.fingers
    a, b = f.palm_width / 2, f.palm_height / 2
    return (abs(x) + a <= INNER_X and abs(y) + b <= INNER_Y) or (abs(x) + b <= INNER_X and abs(y) + a <= INNER_Y)


SLAB = (0.085, 0.065, 0.022)  # 8.5 x 6.5 x 2.2 cm (bins18g's slab)


def _piece(name, shape: str, x: float, y: float):
    """``_world``'s piece: "slab" (long side along x) or "slabT" (along y)."""
    return (name, "box", SLAB if shape == "slab" else (SLAB[1], SLAB[0], SLAB[2]), (x, y))


def _half_extents(shape: str) -> tuple[float, float]:
    return (SLAB[0] / 2, SLAB[1] / 2) if shape == "slab" else (SLAB[1] / 2, SLAB[0] / 2)


@pytest.mark.parametrize(
    "shape, corner, gap",
    [
        # flat slabs 3 cm from both walls: an upright drag over the whole top (main's 12 contacts nearest the centre
        # found none)
        ("slab", (-1, -1), 0.03),
    ],
)
def test_a_piece_in_a_corner_is_dragged_to_where_a_grasp_fits(shape, corner, gap):
    """A piece ``gap`` from both walls of a corner: no grasp (the 20.8 cm housing meets a wall on every closing axis),
    no push. The drag presses a fingertip on it and pulls it out of the corner: it ends where the housing fits centred
    on it (>= 10.4 cm from both walls across the housing, >= 3.15 cm from the other two), flat on the
    floor, in the bin; the detector finds grasps on it in a fresh frame; the simulated hand never enters a wall; no
    planned hand pose holds a point of the cloud but the piece's."""
    pybullet_data = pytest.importorskip("pybullet_data")
    sx, sy = corner
    hx, hy = _half_extents(shape)
    x, y = sx * (INNER_X - gap - hx), sy * (INNER_Y - gap - hy)
    bench, w, spec = _world([_piece("piece", shape, x, y)])
    frame, depth, cam_pose, ids = bench_frame(bench, w, {"piece"})
    state = types.SimpleNamespace(spec=spec, poses={})
    gripper = bench.ge.PANDA_HAND
    assert not _housing_fits(x, y, gripper)
    assert bench_grasps(bench, frame, depth, cam_pose, ids) == 0
    assert bench.plan_scene_push(state, w, frame, depth, cam_pose, ids) is None
    plan = bench.plan_scene_drag(state, frame, depth, cam_pose, ids)
    assert plan is not None
    assert plan.direction[0] * sx < -0.3 or plan.direction[1] * sy < -0.3  # out of the corner
    # The plan against the cloud: the hand above the start, at the start and dragging (resting on the top) holds
    # no observed point but the piece's (walls, floor).
    pts, labels, _, _, _ = bench.scene_observation(state, frame, depth, cam_pose, ids)
    others = pts[labels != plan.target]
    rest = plan.start.copy()
    rest[2, 3] -= 0.004
    poses = [plan.pre, plan.start]
    for s in np.linspace(0.0, plan.distance, 9):
        p = rest.copy()
        p[:3, 3] += s * plan.direction
        poses.append(p)
    assert all(_hand_boxes_hit(others, p, gripper) == 0 for p in poses)
    mesh_dir = Path(pybullet_data.getDataPath()) / "franka_panda" / "meshes" / "collision"
    state, before, worst = _execute(bench, w, spec, plan, ["piece"], ids, mesh_dir)
    after = state.poses["piece"]
    assert worst["inside"] == 0
    assert abs(after[2, 3] - before["piece"][2, 3]) < 0.003 and abs(after[:3, 2] @ before["piece"][:3, 2]) > 0.99
    assert abs(after[0, 3]) < INNER_X and abs(after[1, 3]) < INNER_Y
    assert _housing_fits(float(after[0, 3]), float(after[1, 3]), gripper), after[:3, 3]
    # A fresh world with the piece where it ended: the detector finds grasps on it.
    from ferrobot.transforms import matrix_to_pose

    bench2, w2, _ = _world([])
    p7 = [float(v) for v in matrix_to_pose(after)]
    dims = SLAB if shape == "slab" else (SLAB[1], SLAB[0], SLAB[2])
    w2.add_box("piece", list(dims), p7, mass=0.2, friction=0.8)
    w2.step(120)
    assert bench_grasps(bench2, *bench_frame(bench2, w2, {"piece"})) > 0


@pytest.mark.parametrize("dims", [PLATE])
def test_no_drag_tips_a_flat_plate_out_of_a_corner(dims):
    """A 6.5 cm plate 3 mm from both walls of the (+x, +y) corner: the only fingertip placements whose housing clears
    both walls lean about 0.5 rad over a wall and press at the plate's leading edge along the drag, in front of the
    tipping line, where the drag stands the plate on its edge (the test above); so no drag is planned. Ignoring the
    friction (``tip_friction`` 0: the fingertips' footprint only has to lie on the plate along the drag) finds none
    either: those placements overhang its edge. (A 6.5 x 8.5 cm slab there still gets the stand-up drag: the wall
    hides a third of its top, its observed centre lies in front of the line; BENCHMARKS.md, wall18i.)"""
    pytest.importorskip("pybullet_data")
    x, y = INNER_X - 0.003 - dims[0] / 2, INNER_Y - 0.003 - dims[1] / 2
    bench, w, spec = _world([("plate", "box", dims, (x, y))])
    frame, depth, cam_pose, ids = bench_frame(bench, w, {"plate"})
    state = types.SimpleNamespace(spec=spec, poses={})
    assert bench_grasps(bench, frame, depth, cam_pose, ids) == 0
    assert bench.plan_scene_drag(state, frame, depth, cam_pose, ids) is None
    pts, labels, bounds, hm, view = bench.scene_observation(state, frame, depth, cam_pose, ids)
    (label,) = ids
    g = bench.ge.PANDA_HAND
    kw = dict(heightmap=hm, view=view, tilts=bench.DRAG_TILTS)
    assert drag.plan_drag(pts, labels, label, g, bench.TABLE_TOP, bounds, tip_friction=0.0, **kw) is None


@pytest.mark.parametrize("block_xy, in_the_way", [((-0.055, 0.0), True), ((0.06, 0.0), False)])
def test_a_drag_out_of_a_corner_never_moves_a_piece_over_a_neighbour(block_xy, in_the_way):
    """The slab of the test above, 3 cm from both walls of the (-x, -y) corner, with a 5 x 5 x 6.3 cm block standing
    where the free drag leaves it (in the way) or 6 cm to the side of the bin's middle. In the way: no drag (every
    direction that gains room runs the slab's footprint into the block's cells). Beside: the drag of the free case,
    executed, moves the block less than 5 mm and leaves the slab flat on the floor (not on the block), both in the
    bin, the hand out of the walls."""
    pybullet_data = pytest.importorskip("pybullet_data")
    hx, hy = SLAB[0] / 2, SLAB[1] / 2
    x, y = -(INNER_X - 0.03 - hx), -(INNER_Y - 0.03 - hy)
    bench, w, spec = _world([_piece("piece", "slab", x, y), ("block", "box", (0.05, 0.05, 0.063), block_xy)])
    frame, depth, cam_pose, ids = bench_frame(bench, w, {"piece", "block"})
    state = types.SimpleNamespace(spec=spec, poses={})
    plan = bench.plan_scene_drag(state, frame, depth, cam_pose, {k: v for k, v in ids.items() if v == "piece"})
    if in_the_way:
        assert plan is None
        return
    assert plan is not None
    mesh_dir = Path(pybullet_data.getDataPath()) / "franka_panda" / "meshes" / "collision"
    block_before = w.get_object_pose("block")
    state, before, worst = _execute(bench, w, spec, plan, ["piece", "block"], ids, mesh_dir)
    after = state.poses["piece"]
    assert worst["inside"] == 0
    assert np.linalg.norm(state.poses["block"][:3, 3] - block_before[:3, 3]) < 0.005
    assert abs(after[2, 3] - before["piece"][2, 3]) < 0.003 and abs(after[:3, 2] @ before["piece"][:3, 2]) > 0.99
    assert float((after[:3, 3] - before["piece"][:3, 3]) @ plan.direction) > 0.5 * plan.distance
    for n in ("piece", "block"):
        p = state.poses[n][:3, 3]
        assert abs(p[0]) < INNER_X and abs(p[1]) < INNER_Y
