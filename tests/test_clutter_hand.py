"""The clutter bench's floating Panda hand with geared fingers (``grasp_eval.hand_files(coupled=True)``), as
the real Panda hand: the two fingers close symmetrically, so a box off the hand's axis ends centred between
them (hand derivation: equal finger positions put the box's two faces at the same distance from the axis),
held at its true width, in ferrobot's simulator and in the two replay judges (PyBullet, MuJoCo)."""

from __future__ import annotations

import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

import ferrobot

BENCHES = Path(__file__).resolve().parents[1] / "benches"
sys.path.insert(0, str(BENCHES))

pytest.importorskip("pybullet_data")
pytest.importorskip("scipy.spatial")

WIDTH, DEPTH, HEIGHT = 0.030, 0.040, 0.050
OFFSET = 0.008  # the box's centre from the hand's axis, along the closing axis (world x)


def _setup(tmp_path: Path):
    import clutter as bench
    import grasp_eval as ge
    from scipy.spatial import ConvexHull

    v = np.array(
        [[x, y, z] for x in (-WIDTH / 2, WIDTH / 2) for y in (-DEPTH / 2, DEPTH / 2) for z in (-HEIGHT / 2, HEIGHT / 2)]
    )
    f = ConvexHull(v).simplices
    obj = tmp_path / "box.obj"
    obj.write_text(
        "".join(f"v {a} {b} {c}\n" for a, b, c in v) + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in f)
    )
    pose = np.eye(4)
    pose[:3, 3] = [OFFSET, 0.0, bench.TABLE_TOP + HEIGHT / 2]
    # Top-down hand, its closing axis (hand y) along world x, fingertips 2 cm below the box's top.
    hand = np.eye(4)
    hand[:3, :3] = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
    hand[:3, 3] = [0.0, 0.0, bench.TABLE_TOP + HEIGHT - 0.02 + ge.TCP_OFFSET]
    base = hand.copy()
    base[:3, 3] -= ge.PREGRASP * hand[:3, 2]
    steps = bench.table_schedule(base, ge.OPEN)
    return bench, ge, obj, v, f, pose, base, steps


def _ferrobot(tmp_path, coupled):
    bench, ge, _obj, v, f, pose, base, steps = _setup(tmp_path)
    w = ferrobot.World(dt=bench.DT)
    w.add_box("table", [2, 2, bench.TABLE_TOP], [0, 0, bench.TABLE_TOP / 2, 1, 0, 0, 0], fixed=True, friction=1.0)
    w.add_mesh("box", v, f, ge.pose7(pose), approximation="convex_decomposition", mass=0.1, friction=1.0)
    _, model = ge.hand_files(tmp_path, coupled=coupled)
    z0 = {"box": pose[2, 3]}
    res, after, robot, opening = bench.run_hand(w, model, base, steps, ge.OPEN, ["box"], {"box": pose}, z0, "box")
    q = robot.joint_positions
    fingers = [q[3], q[3]] if coupled else [q[3], q[4]]
    return res["success"], opening, fingers


def _pybullet(tmp_path, coupled):
    bench, ge, obj, _v, _f, pose, base, steps = _setup(tmp_path)
    o = SimpleNamespace(mesh=str(obj), scale=(1.0, 1.0, 1.0), mass=0.1, friction=1.0)
    state = SimpleNamespace(objects={"box": o}, spec=SimpleNamespace(bin=None))
    urdf, _ = ge.hand_files(tmp_path, coupled=coupled)
    pb = bench.PyBulletClutterJudge(urdf, tmp_path, coupled=coupled)
    try:
        r = pb.run_pile(state, {"box": pose}, base, steps)
    finally:
        pb.close()
    return r["success"], r["opening"], r["fingers"]


def _mujoco(tmp_path, coupled):
    pytest.importorskip("mujoco")
    import mujoco_judge

    bench, _ge, obj, _v, _f, pose, base, steps = _setup(tmp_path)
    o = SimpleNamespace(mesh=str(obj), scale=(1.0, 1.0, 1.0), mass=0.1, friction=1.0)
    state = SimpleNamespace(objects={"box": o}, spec=SimpleNamespace(bin=None))
    r = mujoco_judge.MuJoCoClutterJudge(tmp_path, coupled=coupled).run_pile(
        state, {"box": pose}, base, steps, bench.part_files
    )
    return r["success"], r["opening"], r["fingers"]


# Largest opening beyond the box's width: ferrobot and MuJoCo touch the faces (contact error <= 1.5 mm);
# PyBullet's convex shapes keep a collision margin (4.2 mm in all on the box centred on the axis, 2.1 mm a
# finger), and there the first finger to touch the off-axis box also turns it a few degrees about the
# vertical before the second meets it (36.9 mm measured: 30 cos a + 40 sin a + 4.2 mm, a = 4 degrees).
JUDGES = {"ferrobot": (_ferrobot, 0.0015), "pybullet": (_pybullet, 0.008), "mujoco": (_mujoco, 0.0015)}


#: Known since the velocity-capped drive (drive18i): ferrobot's fingers now close at the URDF's 0.2 m/s, so the
#: first finger pushes the box (8 mm off the axis) alone for ~40 ms with its pad 3-5 cm up a 3 cm wide box on a
#: table of friction 1; quasi-statically a push at height h tips a box of width b when mu > b / (2 h) (0.375 here),
#: and the box is held pitched ~9 degrees (yaw ~2), 32.2 mm wide. MuJoCo (0.14 m/s) keeps it upright; whether
#: ferrobot's single-point pad manifold (BENCHMARKS, slip18h) or MuJoCo's soft contact is nearer the truth is open.
_TIPS = pytest.mark.xfail(
    strict=True,
    reason="known: with the 0.2 m/s drive the first finger tips the off-axis box ~9 degrees before the second "
    "clamps it (push 3-5 cm up a 3 cm box, mu 1 > b/2h); held 32.2 mm wide (drive18i)",
)


@pytest.mark.parametrize("judge", [pytest.param(j, marks=_TIPS) if j == "ferrobot" else j for j in JUDGES])
def test_coupled_hand_centres_the_box_between_its_fingers(tmp_path, judge):
    run, slack = JUDGES[judge]
    ok, opening, (q1, q2) = run(tmp_path, coupled=True)
    assert ok
    assert WIDTH - 0.0015 <= opening <= WIDTH + slack, opening
    # Equal fingers: the box's centre on the hand's axis (it started OFFSET = 8 mm off it).
    assert abs(q1 - q2) < 0.001, (q1, q2)
