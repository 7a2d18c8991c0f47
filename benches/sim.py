"""Simulation speed against MuJoCo, PD tracking of a planned motion, camera frame time.

    python benches/sim.py [--repeats 7] [--steps 2400] [--json FILE]

Needs the ``bench`` extra (``pip install -e ".[bench]"``: MuJoCo from PyPI).

Steps per second for (a) the bundled Panda alone holding a pose and (b) the
Panda (arm + hand, 8 DOF plus the mimic finger) with 5 objects resting on a
static table, at 240 Hz with 4 solver iterations, in ferrobot and, in the same
run and interleaved with it, in MuJoCo on the same scene written as MJCF by
``benches/mjcf_scene.py`` from the same ``RobotModel`` (link masses, inertias,
collision primitives, joint limits, mimic coupling, allowed-collision pairs)
and the same object list. Rapier puts resting bodies to sleep, so MuJoCo runs
with sleeping enabled for the ratio (and with its defaults, everything awake,
as a second figure); the robot never sleeps in either. Both simulators: dt 1/240 s, gravity -9.81, robot
links gravity-compensated, PD drives kp 1e4 / kd 1e2 clamped to the URDF
efforts, the same friction coefficients. Target: ferrobot at least as fast as
MuJoCo (ratio >= 1.0). Medians over the repeats, wall time and CPU time
(``time.process_time``, all threads: the load-independent figure on a shared
machine).

Also: PD tracking error of a trajectory planned by ``ferrobot.Planner`` and
executed by ``Robot.execute_trajectory``; a 640x480 depth + segmentation frame
of the table scene (target <= 20 ms on 2 cores); a pick-and-place episode
(target < 1 s wall). Trajectories are computed before the timing.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

import ferrobot

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent))
from _sim_helpers import PANDA_Q0, ik, pose_at, straight_line  # noqa: E402
from mjcf_scene import Obj, Settings, build_ferrobot, build_mujoco  # noqa: E402

TABLE_TOP = 0.4
TCP = "panda_hand_tcp"


def median_time(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def timed(fn) -> tuple[float, float]:
    """(wall, CPU) seconds of one call."""
    c0, t0 = time.process_time(), time.perf_counter()
    fn()
    return time.perf_counter() - t0, time.process_time() - c0


def table_objects() -> list[Obj]:
    """A static table and 5 objects resting on it (box, can, ball, lying bar, block)."""
    t = TABLE_TOP
    c = float(np.cos(np.pi / 4))
    return [
        Obj("table", "box", (0.8, 1.2, t), (0.6, 0, t / 2, 1, 0, 0, 0), friction=0.8, static=True),
        Obj("box", "box", (0.05, 0.05, 0.05), (0.5, 0, t + 0.025, 1, 0, 0, 0), mass=0.5, friction=1.0),
        Obj("can", "cylinder", (0.03, 0.12), (0.6, 0.25, t + 0.06, 1, 0, 0, 0), mass=0.3),
        Obj("ball", "sphere", (0.04,), (0.7, -0.25, t + 0.04, 1, 0, 0, 0), mass=0.2),
        Obj("bar", "capsule", (0.02, 0.1), (0.75, 0.1, t + 0.02, c, 0, c, 0), mass=0.2),
        Obj("block", "box", (0.1, 0.06, 0.04), (0.45, -0.3, t + 0.02, 1, 0, 0, 0), mass=0.4, friction=0.8),
    ]


def table_scene(model, q):
    w, r = build_ferrobot(model, Settings(objects=table_objects()), q)
    return w, r


def compare_with_mujoco(model, settings: Settings, q: np.ndarray, steps: int, repeats: int) -> dict:
    """Steps/s of ferrobot and MuJoCo on one scene, interleaved repeat by repeat,
    the robot holding ``q``. MuJoCo twice: with sleeping enabled (as Rapier, which
    puts resting bodies to sleep; the robot never sleeps in either) and with its
    defaults (everything awake). ``ratio`` is against the former, the same work."""
    import mujoco

    w, r = build_ferrobot(model, settings, q)
    m, d, _ = build_mujoco(model, settings, q)
    ms, ds, _ = build_mujoco(model, settings, q)
    ms.opt.enableflags |= mujoco.mjtEnableBit.mjENBL_SLEEP
    w.step(240)  # settle (1 s), untimed
    mujoco.mj_step(m, d, nstep=240)
    mujoco.mj_step(ms, ds, nstep=240)
    runs: dict[str, list] = {"ferrobot": [], "mujoco": [], "mujoco_default": []}
    for _ in range(repeats):
        runs["ferrobot"].append(timed(lambda: w.step(steps)))
        runs["mujoco"].append(timed(lambda: mujoco.mj_step(ms, ds, nstep=steps)))
        runs["mujoco_default"].append(timed(lambda: mujoco.mj_step(m, d, nstep=steps)))
    out = {}
    for key, rs in runs.items():
        out[f"{key}_steps_per_s"] = steps / statistics.median(t for t, _ in rs)
        out[f"{key}_cpu_steps_per_s"] = steps / statistics.median(c for _, c in rs)
    out["ratio"] = out["ferrobot_steps_per_s"] / out["mujoco_steps_per_s"]
    out["ratio_cpu"] = out["ferrobot_cpu_steps_per_s"] / out["mujoco_cpu_steps_per_s"]
    out["ratio_mujoco_default"] = out["ferrobot_steps_per_s"] / out["mujoco_default_steps_per_s"]
    out["ratio_cpu_mujoco_default"] = out["ferrobot_cpu_steps_per_s"] / out["mujoco_default_cpu_steps_per_s"]
    # What each simulated: joint error to the held pose, object drift since the start.
    qm = np.array([ds.joint(n).qpos[0] for n in model.dof_names])
    out["ferrobot_joint_error_rad"] = float(np.abs(r.joint_positions - q)[:7].max())
    out["mujoco_joint_error_rad"] = float(np.abs(qm - q)[:7].max())
    dyn = [o for o in settings.objects if not o.static]
    if dyn:
        out["ferrobot_object_drift_m"] = max(
            float(np.linalg.norm(w.get_object_pose(o.name)[:3, 3] - o.pose[:3])) for o in dyn
        )
        out["mujoco_object_drift_m"] = max(float(np.linalg.norm(ds.body(o.name).xpos - o.pose[:3])) for o in dyn)
        out["mujoco_default_object_drift_m"] = max(float(np.linalg.norm(d.body(o.name).xpos - o.pose[:3])) for o in dyn)
        out["mujoco_default_contacts"] = int(d.ncon)
    out["simulated_s"] = w.time
    return out


def planned_tracking(model) -> dict:
    """PD tracking of a collision-free plan (Planner on the bundled Panda) executed at 240 Hz."""
    planner = ferrobot.Planner(model)
    start = PANDA_Q0[:7]
    goal = np.array([1.2, 0.3, -0.4, -1.6, 0.3, 1.9, 0.2])
    plan = planner.plan(start, goal_q=goal, seed=0)
    if not plan:
        raise RuntimeError(f"planning failed: {plan.status} {plan.message}")
    traj = plan.interpolated(dt=0.01)
    w = ferrobot.World()
    r = w.add_robot(model, q=PANDA_Q0)
    r.set_joint_position_targets(PANDA_Q0)
    rep = r.execute_trajectory(traj.positions, 0.01, velocities=traj.velocities, joint_names=model.dof_names[:7])
    err = np.asarray(rep.desired) - np.asarray(rep.actual)
    return {
        "duration_s": float(plan.duration),
        "samples": len(traj),
        "max_error_rad": float(np.abs(err).max()),
        "rms_error_rad": float(np.sqrt(np.mean(err**2))),
        "final_error_rad": float(np.abs(rep.final_error).max()),
        "peak_speed_rad_s": float(np.abs(traj.velocities).max()),
    }


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--steps", type=int, default=2400, help="steps per timed run (default 10 s simulated)")
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    import mujoco

    model = ferrobot.robots.panda()
    s = Settings()
    load = os.getloadavg()
    out: dict = {
        "settings": {
            "dt": s.dt,
            "gravity": s.gravity,
            "solver_iterations": s.solver_iterations,
            "drive_stiffness": s.stiffness,
            "drive_damping": s.damping,
            "gravity_compensation": s.gravity_compensation,
            "steps_per_run": args.steps,
            "repeats": args.repeats,
            "mujoco_version": mujoco.__version__,
            "mujoco_integrator": "implicitfast",
            "mujoco_solver": "Newton (default), pyramidal cones (default)",
            "mujoco_sleep": "enabled for 'mujoco_*' figures (Rapier sleeps resting bodies), off for 'mujoco_default_*'",
            "ferrobot_substeps": (
                "base step 1 substep; dynamic objects solver_iterations (4); the robot 4 + 4 while it touches "
                "something or nears a joint limit, 4 while it moves, 1 while it holds still"
            ),
            "ferrobot_rapier": "vendored rapier3d 0.36.1 with the patches in vendor/rapier3d/FERROBOT.md",
            "load_average_start": load,
            "cpus": os.cpu_count(),
        }
    }
    print(
        f"Settings: dt = 1/{round(1 / s.dt)} s, gravity {s.gravity} m/s^2, {s.solver_iterations} solver iterations "
        f"(ferrobot: substeps per body: objects {s.solver_iterations}, the robot {s.solver_iterations}+4 while it "
        f"touches something or nears a limit, {s.solver_iterations} while it moves, 1 while it holds still; "
        f"MuJoCo: iterations={s.solver_iterations}, Newton, implicitfast), "
        f"drives kp {s.stiffness:g} kd {s.damping:g} clamped to URDF efforts, robot gravity-compensated; "
        f"MuJoCo {mujoco.__version__}; load average {load[0]:.2f} on {os.cpu_count()} CPUs"
    )

    # Steps/s against MuJoCo: Panda alone, then Panda + 5 objects on a table, the
    # hand holding 15 cm above the box (the robot touches nothing).
    q_hold = np.r_[ik(model, PANDA_Q0, pose_at([0.5, 0.0, TABLE_TOP + 0.15]), TCP)[:7], 0.04]
    for key, label, objects in (
        ("panda_alone", "Panda alone (8 DOF + mimic, no contacts)", []),
        ("table_scene", "Panda + table + 5 resting objects", table_objects()),
    ):
        res = compare_with_mujoco(model, Settings(objects=objects), q_hold, args.steps, args.repeats)
        out[key] = res
        print(
            f"{label}: ferrobot {res['ferrobot_steps_per_s']:,.0f} steps/s "
            f"({res['ferrobot_cpu_steps_per_s']:,.0f} per CPU s); MuJoCo with sleeping (as Rapier) "
            f"{res['mujoco_steps_per_s']:,.0f} ({res['mujoco_cpu_steps_per_s']:,.0f}): ratio {res['ratio']:.2f} wall, "
            f"{res['ratio_cpu']:.2f} CPU (target >= 1.0); MuJoCo defaults {res['mujoco_default_steps_per_s']:,.0f} "
            f"({res['mujoco_default_cpu_steps_per_s']:,.0f}): ratio {res['ratio_cpu_mujoco_default']:.2f} CPU"
        )
        drift = ""
        if "ferrobot_object_drift_m" in res:
            drift = (
                f", largest object drift {1e3 * res['ferrobot_object_drift_m']:.2f} mm vs "
                f"{1e3 * res['mujoco_object_drift_m']:.2f} mm (MuJoCo defaults "
                f"{1e3 * res['mujoco_default_object_drift_m']:.2f} mm, {res['mujoco_default_contacts']} contacts)"
            )
        print(
            f"  after {res['simulated_s']:.0f} s simulated: joint error {res['ferrobot_joint_error_rad']:.1e} rad "
            f"vs MuJoCo {res['mujoco_joint_error_rad']:.1e} rad{drift}"
        )

    # PD tracking of a planned trajectory.
    tr = planned_tracking(model)
    out["planned_tracking"] = tr
    print(
        f"PD tracking of a planned motion ({tr['duration_s']:.2f} s, peak {tr['peak_speed_rad_s']:.2f} rad/s, "
        f"kp 1e4 kd 1e2 with velocity feed-forward): max {1e3 * tr['max_error_rad']:.2f} mrad, "
        f"RMS {1e3 * tr['rms_error_rad']:.2f} mrad, final {1e3 * tr['final_error_rad']:.3f} mrad"
    )

    w, r = table_scene(model, q_hold)
    w.step(240)
    # Camera: rendering 640x480 from a camera looking at the table.
    pose = ferrobot.look_at([1.4, 0.0, 1.2], [0.55, 0.0, TABLE_TOP])
    cam = ferrobot.Camera(w, 640, 480, 525.0, 525.0, 319.5, 239.5, pose)
    for rgb in (False, True):
        cam.render(rgb=rgb)
        frames = max(args.repeats, 20)
        c0 = time.process_time()
        t = median_time(lambda rgb=rgb: cam.render(rgb=rgb), frames)
        cpu = (time.process_time() - c0) / frames
        key = "render_depth_seg_rgb_ms" if rgb else "render_depth_seg_ms"
        out[key] = 1e3 * t
        out[key.replace("_ms", "_cpu_ms")] = 1e3 * cpu
        what = "depth + segmentation + RGB" if rgb else "depth + segmentation"
        print(
            f"Render 640x480 {what}: {1e3 * t:.2f} ms wall (median), "
            f"{1e3 * cpu:.2f} ms CPU per frame (mean, all threads)"
        )

    # A pick-and-place episode on the table.
    dt = 1 / 240
    above = np.array([0.5, 0.0, TABLE_TOP + 0.15])
    grasp = np.array([0.5, 0.0, TABLE_TOP + 0.025])
    place_above = np.array([0.45, 0.35, TABLE_TOP + 0.15])
    place = np.array([0.45, 0.35, TABLE_TOP + 0.026])
    q_above = ik(model, PANDA_Q0, pose_at(above), TCP)
    legs = []
    q = q_above[:7]
    for a, b in [(above, grasp), (grasp, above), (above, place_above), (place_above, place), (place, place_above)]:
        leg = straight_line(model, np.r_[q, 0.04], a, b, TCP, peak_speed=0.5, dt=dt)
        legs.append(leg)
        q = leg[-1]

    def episode():
        w, r = table_scene(model, np.r_[q_above[:7], 0.04])
        arm = r.dof_names[:7]
        r.execute_trajectory(legs[0], dt, joint_names=arm, settle_time=0.1)
        r.close_gripper(force=40.0)
        w.step(60)
        r.execute_trajectory(legs[1], dt, joint_names=arm)
        r.execute_trajectory(legs[2], dt, joint_names=arm)
        r.execute_trajectory(legs[3], dt, joint_names=arm, settle_time=0.1)
        r.open_gripper()
        w.step(60)
        r.execute_trajectory(legs[4], dt, joint_names=arm)
        return w

    w = episode()
    placed = w.get_object_pose("box")[:3, 3]
    err = np.linalg.norm(placed[:2] - place[:2])
    t = median_time(episode, args.repeats)
    out["episode_wall_s"] = t
    out["episode_sim_s"] = w.time
    out["episode_place_error_m"] = float(err)
    print(
        f"Pick-and-place episode: {w.time:.2f} s simulated ({w.num_steps} steps) in {t * 1e3:.0f} ms wall "
        f"({w.time / t:.1f}x real time); box placed {1e3 * err:.1f} mm from the goal"
    )
    out["load_average_end"] = os.getloadavg()
    if args.json:
        args.json.write_text(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
