"""Replays one recorded attempt of ``benches/clutter.py`` step by step, in ferrobot's simulator and (optionally)
in the PyBullet and MuJoCo judges, from the poses the objects had settled to, logging the fingers and the
target object in the hand's frame: the tool behind the "slipped out" diagnosis in BENCHMARKS.md.

    python benches/clutter_replay.py RUN.json SCENE ATTEMPT [--objects DIR] [--coupled] [--pybullet] [--mujoco]
                                     [--every K] [--world KEY=JSON ...] [--iters N] [--force F] [--quiet]
                                     [--close-speed V]

``RUN.json`` is a ``clutter.py --json`` file, ``SCENE`` and ``ATTEMPT`` indices into its ``scene_records``
and their ``attempts``; ``--objects`` the folder the run drew from (default: pybullet_data's). The world is
rebuilt from the recorded settled poses without a new settle (so ferrobot's outcome may differ from the
recorded one: the pile's contacts start afresh), the hand runs the recorded schedule. ``--world`` passes a
``ferrobot.World`` keyword (e.g. ``contact_frequency=200``), ``--iters`` the hand's solver iterations,
``--force`` the squeeze per finger (N), ``--close-speed`` a finger speed (m/s) at which ferrobot's finger
target is ramped shut instead of being set closed at once (without it the drive closes at ~0.6 m/s). Every
``K`` steps from the end of the approach: each finger's position (mm), the target's origin in the hand frame (mm;
PyBullet reports the centre of mass instead), its rise (cm), its angular speed (rad/s, with its components in the
hand frame when above 2 rad/s: y is the closing axis) and how far the other objects moved.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import clutter as cb  # noqa: E402
import grasp_eval as ge  # noqa: E402

from ferrobot.pipeline import clutter  # noqa: E402
from ferrobot.transforms import pose_to_matrix  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("json", type=Path)
    ap.add_argument("scene", type=int)
    ap.add_argument("attempt", type=int)
    ap.add_argument("--objects", type=Path, default=None)
    ap.add_argument("--coupled", action="store_true", help="geared fingers (the bench's default hand)")
    ap.add_argument("--pybullet", action="store_true")
    ap.add_argument("--mujoco", action="store_true")
    ap.add_argument("--every", type=int, default=12)
    ap.add_argument("--world", action="append", default=[], metavar="KEY=JSON")
    ap.add_argument("--iters", type=int, default=None)
    ap.add_argument("--force", type=float, default=ge.FINGER_FORCE)
    ap.add_argument("--quiet", action="store_true", help="results only")
    ap.add_argument(
        "--close-speed",
        type=float,
        default=None,
        help="ferrobot: ramp the finger target at this speed (m/s per finger) instead of closing at once",
    )
    a = ap.parse_args()
    data = json.loads(a.json.read_text())
    sc = data["scene_records"][a.scene]
    rec = sc["attempts"][a.attempt]
    if "hand_base" not in rec:
        raise SystemExit(f"attempt {a.attempt} of scene {a.scene} has no grasp ({rec.get('ferrobot')})")
    files = clutter.find_object_files(a.objects) if a.objects else None
    spec = clutter.random_clutter(
        sc["seed"], data["objects_per_scene"], files, bin=data["bin"], table_top=cb.TABLE_TOP, center=cb.CENTER
    )
    st = cb.State(spec)
    names = list(rec["settled"])
    st.objects = {n: st.objects[n] for n in names}
    st.poses = {n: pose_to_matrix(rec["settled"][n]) for n in names}
    overrides = {}
    for kv in a.world:
        key, _, value = kv.partition("=")
        overrides[key] = json.loads(value)
    world_cls = cb.ferrobot.World
    cb.ferrobot.World = lambda dt=cb.DT, **kw: world_cls(dt=dt, **{**kw, **overrides})
    try:
        w = st.build()
    finally:
        cb.ferrobot.World = world_cls
    settled = {n: w.get_object_pose(n) for n in names}
    base = np.asarray(rec["hand_base"])
    finger = rec["grasp"]["preshape_opening"] / 2
    sched = cb.table_schedule(base, finger) if spec.bin is None else cb.bin_schedule(base, finger)
    steps = [(t, (a.force if f > 0 else 0.0)) for t, f in sched]
    target = rec["target"]
    o = st.objects[target]
    g = rec["grasp"]
    print(
        f"target {target}: mass {o.mass:.3f} kg, friction {o.friction:.2f}; grasp width {g['width'] * 1e3:.1f} mm, "
        f"depth {g['depth'] * 1e3:.1f} mm, approach {np.round(g['approach'], 2).tolist()}; recorded: ferrobot "
        f"{rec['ferrobot']['stage']}, pybullet {rec.get('pybullet', {}).get('success')}"
    )
    n_app = int(round(ge.APPROACH_S / cb.DT))

    def logged(k: int) -> bool:
        return not a.quiet and k >= n_app - 1 and (k - n_app + 1) % a.every == 0

    with tempfile.TemporaryDirectory() as tmp:
        urdf, hand_model = ge.hand_files(Path(tmp), coupled=a.coupled)
        nf = 1 if a.coupled else 2
        z0 = {n: settled[n][2, 3] for n in names}
        q_start = np.r_[0.0, 0.0, 0.0, [finger] * nf]
        robot = w.add_robot(hand_model, ge.pose7(base), name="hand", q=q_start)
        if a.iters is not None:
            robot.set_solver_iterations(a.iters)
        slide, fingers = robot.dof_names[:3], robot.dof_names[3:]
        robot.set_drive_gains(stiffness=[2.0e4] * 3, damping=[1.0e3] * 3, joint_names=slide)
        robot.set_gripper(fingers, [ge.OPEN] * nf, [0.0] * nf)
        robot.set_joint_position_targets(q_start)
        closing = False
        ramp = finger
        for k, (tgt, force) in enumerate(steps):
            robot.set_joint_position_targets(tgt[:3], joint_names=slide)
            if force > 0 and a.close_speed is not None and ramp > 0.0:
                ramp = max(ramp - a.close_speed * cb.DT, 0.0)
                robot.set_gripper_driver(ramp, force=force * (3 - nf))
            elif force > 0 and not closing:
                robot.close_gripper(force=force * (3 - nf))
                closing = True
            elif force == 0:
                robot.set_joint_position_targets(tgt[3 : 3 + nf], joint_names=fingers)
            w.step(1)
            if logged(k):
                q = robot.joint_positions
                q1, q2 = (q[3], q[3]) if a.coupled else (q[3], q[4])
                hand = robot.get_link_pose("panda_hand")
                pose = w.get_object_pose(target)
                rel = np.linalg.inv(hand) @ pose
                ang = np.asarray(w.get_object_velocity(target)[1])
                others = max(
                    (np.linalg.norm(w.get_object_pose(n)[:3, 3] - settled[n][:3, 3]) for n in names if n != target),
                    default=0.0,
                )
                print(
                    f"  ferrobot step {k:4d} t={k * cb.DT:5.2f} s fingers {q1 * 1e3:6.2f} {q2 * 1e3:6.2f} mm, "
                    f"target in hand {np.round(rel[:3, 3] * 1e3, 1).tolist()} mm, rise "
                    f"{(pose[2, 3] - z0[target]) * 100:5.1f} cm, |w| {np.linalg.norm(ang):5.2f}, others moved "
                    f"{others * 100:4.1f} cm"
                    + (f", w in hand {np.round(hand[:3, :3].T @ ang, 2).tolist()}" if np.linalg.norm(ang) > 2.0 else "")
                )
        q = robot.joint_positions
        opening = 2.0 * q[3] if a.coupled else q[3] + q[4]
        lifted = [n for n in names if w.get_object_pose(n)[2, 3] - z0[n] >= ge.MIN_RISE]
        ok = bool(lifted) and opening > ge.MIN_OPENING
        print(f"RESULT ferrobot {'ok' if ok else 'fail'}: lifted {lifted}, opening {opening * 1e3:.1f} mm")
        if a.pybullet:
            pb = cb.PyBulletClutterJudge(urdf, Path(tmp), coupled=a.coupled)
            p, c = pb.p, pb.cid

            def on_step(k, hand, ids):
                if not logged(k):
                    return
                q1, q2 = (p.getJointState(hand, j, physicsClientId=c)[0] for j in (3, 4))
                ls = p.getLinkState(hand, 2, computeForwardKinematics=True, physicsClientId=c)
                pos, _ = p.getBasePositionAndOrientation(ids[target], physicsClientId=c)
                ang = p.getBaseVelocity(ids[target], physicsClientId=c)[1]
                r = np.array(p.getMatrixFromQuaternion(ls[5])).reshape(3, 3)
                rel = r.T @ (np.asarray(pos) - np.asarray(ls[4]))
                print(
                    f"  pybullet step {k:4d} fingers {q1 * 1e3:6.2f} {q2 * 1e3:6.2f} mm, target (centre of mass) "
                    f"in hand {np.round(rel * 1e3, 1).tolist()} mm, |w| {np.linalg.norm(ang):5.2f}"
                )

            try:
                r = pb.run_pile(st, settled, base, steps, on_step=on_step)
            finally:
                pb.close()
            print(
                f"RESULT pybullet {'ok' if r['success'] else 'fail'}: lifted {r['lifted']}, "
                f"opening {r['opening'] * 1e3:.1f} mm"
            )
        if a.mujoco:
            import mujoco_judge

            mj = mujoco_judge.MuJoCoClutterJudge(Path(tmp), coupled=a.coupled)
            r = mj.run_pile(st, settled, base, steps, cb.part_files, log_every=0 if a.quiet else a.every)
            print(
                f"RESULT mujoco {'ok' if r['success'] else 'fail'}: lifted {r['lifted']}, "
                f"opening {r['opening'] * 1e3:.1f} mm"
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
