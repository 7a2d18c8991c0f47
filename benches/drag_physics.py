"""The fingertip drag's physics in two simulators: ferrobot (Rapier, friction coefficients averaged) and PyBullet
(coefficients multiplied), on the same slab, bin and planned drag (``ferrobot.pipeline.drag``), for bin floors of
the walls' material (0.6) and of the table's (1.0).

    python benches/drag_physics.py [--floors 0.6 1.0] [--object-friction 0.7 1.0] [--mass 0.2]

The slab (8.5 x 6.5 x 2.2 cm) lies 2 mm from the bin's +y wall; the drag is planned on ferrobot's camera frame as
the clutter bench plans it and run by the bench's floating hand (``clutter.execute_drag``: press with a soft drive,
about 30 N, drag 1.5 s). PyBullet runs the same hand URDF from the same base pose through the same slide targets,
the approach slide's motor capped at the soft drive's force at the planned overlap (a constant press of the same
size), the lateral slides stiff. Printed: how far the slab moved along the drag in each.

Coulomb's law (``drag.drag_feasible``): the fingertip moves the slab when mu_fo N > mu_of (N + m g). Averaged, floor
0.6: mu_fo = (1 + mu_o) / 2 > mu_of = (mu_o + 0.6) / 2, a drag; floor 1.0: mu_fo = mu_of, none. Multiplied
(PyBullet), floor 0.6: mu_o > 0.6 mu_o, a drag; floor 1.0: mu_o = mu_o, none.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import types
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import clutter as bench  # noqa: E402

import ferrobot  # noqa: E402

ge = bench.ge
SLAB = (0.085, 0.065, 0.022)


def slab_world(floor: float, mu_o: float, mass: float, y: float, spec) -> ferrobot.World:
    """The bench's bin on a floor of friction ``floor`` with the slab at (0, y), settled."""
    w = ferrobot.World(dt=bench.DT)
    w.add_box("table", [2, 2, bench.TABLE_TOP], [0, 0, bench.TABLE_TOP / 2, 1, 0, 0, 0], fixed=True, friction=floor)
    bench.clutter.add_bin(w, spec.bin, bench.TABLE_TOP)
    w.add_box("slab", list(SLAB), [0.0, y, bench.TABLE_TOP + SLAB[2] / 2, 1, 0, 0, 0], mass=mass, friction=mu_o)
    w.step(120)
    return w


def drag_in_both(floor: float, mu_o: float, mass: float) -> dict:
    """Plans the drag of the slab against the +y wall (on a frame of the 0.6 floor's world: the plan is geometry)
    and runs it in ferrobot and in PyBullet on a floor of friction ``floor``; returns the planned distance, the
    press force (N) and each simulator's displacement along the drag (m)."""
    import pybullet as p

    spec = types.SimpleNamespace(bin=bench.clutter.BinSpec(center=bench.CENTER))
    y = 0.12 - 0.002 - SLAB[1] / 2
    w = slab_world(0.6, mu_o, mass, y, spec)
    cam_pose = bench.camera_pose()
    frame = ferrobot.Camera(w, ge.WIDTH, ge.HEIGHT, fx=ge.F, cx=ge.CX, cy=ge.CY, pose=cam_pose).render(rgb=False)
    depth = np.where(np.isfinite(frame.depth), frame.depth, 0.0)
    ids = {i: n for i, n in w.segmentation_labels.items() if n == "slab"}
    state = types.SimpleNamespace(spec=spec, poses={})
    plan = bench.plan_scene_drag(state, frame, depth, cam_pose, ids)
    if plan is None:
        raise RuntimeError("no drag planned for the slab against the +y wall")
    w = slab_world(floor, mu_o, mass, y, spec)
    ids = {i: n for i, n in w.segmentation_labels.items() if n == "slab"}
    b0 = w.get_object_pose("slab")[:3, 3].copy()
    out = {"planned": plan.distance}
    with tempfile.TemporaryDirectory() as tmp:
        urdf, hand_model = ge.hand_files(Path(tmp), coupled=True)
        bench.execute_drag(state, w, hand_model, plan, ["slab"], ids)
        out["ferrobot"] = float((state.poses["slab"][:3, 3] - b0) @ plan.direction)
        shift = (ge.TCP_OFFSET - ge.PANDA_HAND.tcp[2]) * plan.pre[:3, 2]
        base = plan.pre.copy()
        base[:3, 3] -= shift
        rot = base[:3, :3]
        c = p.connect(p.DIRECT)
        try:
            p.setGravity(0, 0, -9.81, physicsClientId=c)
            p.setTimeStep(bench.DT, physicsClientId=c)
            box = p.createCollisionShape(p.GEOM_BOX, halfExtents=[1, 1, bench.TABLE_TOP / 2], physicsClientId=c)
            tid = p.createMultiBody(0, box, -1, [0, 0, bench.TABLE_TOP / 2], physicsClientId=c)
            p.changeDynamics(tid, -1, lateralFriction=floor, physicsClientId=c)
            for _, size, pose in spec.bin.walls(bench.TABLE_TOP):
                shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=[s / 2 for s in size], physicsClientId=c)
                bid = p.createMultiBody(0, shape, -1, pose[:3], physicsClientId=c)
                p.changeDynamics(bid, -1, lateralFriction=0.6, physicsClientId=c)
            shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=[s / 2 for s in SLAB], physicsClientId=c)
            sid = p.createMultiBody(mass, shape, -1, [0.0, y, bench.TABLE_TOP + SLAB[2] / 2], physicsClientId=c)
            p.changeDynamics(sid, -1, lateralFriction=mu_o, physicsClientId=c)
            for _ in range(120):
                p.stepSimulation(physicsClientId=c)
            s0 = np.array(p.getBasePositionAndOrientation(sid, physicsClientId=c)[0])
            hand = p.loadURDF(urdf, list(base[:3, 3]), ge.xyzw(base), useFixedBase=True, physicsClientId=c)
            for j in (3, 4):
                p.changeDynamics(hand, j, lateralFriction=1.0, physicsClientId=c)
            q_start = np.array([0.0, 0.0, 0.05])
            q_pressed = q_start + rot.T @ (plan.pressed[:3, 3] - plan.start[:3, 3])
            q_end = q_start + rot.T @ (plan.end[:3, 3] - plan.start[:3, 3])
            # The soft drive's force at the planned overlap (the fingertips stop at the top, clearance above it).
            press = bench.DRAG_STIFFNESS * plan.press
            out["press_force"] = press
            legs = ((np.zeros(3), q_start, 0.5), (q_start, q_pressed, 0.5), (q_pressed, q_end, bench.DRAG_S))
            for leg, (qa, qb, sec) in enumerate(legs):
                for q in ge.smooth(qa, qb, sec):
                    forces = [ge.MOVE_FORCE, ge.MOVE_FORCE, press if leg >= 1 else ge.MOVE_FORCE]
                    p.setJointMotorControlArray(
                        hand, [0, 1, 2], p.POSITION_CONTROL, targetPositions=list(q), forces=forces, physicsClientId=c
                    )
                    p.setJointMotorControlArray(
                        hand,
                        [3, 4],
                        p.POSITION_CONTROL,
                        targetPositions=[0, 0],
                        forces=[ge.FINGER_FORCE] * 2,
                        physicsClientId=c,
                    )
                    p.stepSimulation(physicsClientId=c)
            s1 = np.array(p.getBasePositionAndOrientation(sid, physicsClientId=c)[0])
            out["pybullet"] = float((s1 - s0) @ plan.direction)
        finally:
            p.disconnect(c)
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--floors", type=float, nargs="+", default=[0.6, 1.0])
    ap.add_argument("--object-friction", type=float, nargs="+", default=[0.7, 1.0])
    ap.add_argument("--mass", type=float, default=0.2)
    args = ap.parse_args()
    for floor in args.floors:
        for mu in args.object_friction:
            r = drag_in_both(floor, mu, args.mass)
            feasible = bench.drag_mod.drag_feasible(1.0, mu, floor, args.mass, r["press_force"])
            print(
                f"floor {floor}, object friction {mu}, {args.mass} kg, press {r['press_force']:.0f} N: planned "
                f"{r['planned'] * 100:.1f} cm; moved ferrobot {r['ferrobot'] * 100:.1f} cm, PyBullet "
                f"{r['pybullet'] * 100:.1f} cm; Coulomb (averaged) says {'drag' if feasible else 'no drag'}",
                flush=True,
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
