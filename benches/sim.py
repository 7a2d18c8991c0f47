"""Simulation speed: Panda steps/s, camera render time, a pick-and-place episode.

    python benches/sim.py [--repeats 7] [--json FILE]

Prints medians over the repeats. Targets (2-core machine): a 640x480 depth +
segmentation frame of a table scene in <= 20 ms; a whole pick-and-place
episode (grasp, lift, carry, place, release, retreat; about 4 s simulated at
240 Hz) in < 1 s wall time. Trajectories are computed before the timing (the
planner is not part of this benchmark).
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

import numpy as np

import ferrobot

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from _sim_helpers import PANDA_Q0, ik, pose_at, straight_line  # noqa: E402

TABLE_TOP = 0.4
TCP = "panda_hand_tcp"


def median_time(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def table_scene(model, q):
    w = ferrobot.World()
    r = w.add_robot(model, name="panda", q=q)
    r.set_joint_position_targets(q)
    w.add_box("table", [0.8, 1.2, TABLE_TOP], [0.6, 0, TABLE_TOP / 2, 1, 0, 0, 0], static_=True)
    w.add_box("box", [0.05, 0.05, 0.05], [0.5, 0, TABLE_TOP + 0.025, 1, 0, 0, 0], mass=0.5, friction=1.0)
    w.add_cylinder("can", 0.03, 0.12, [0.6, 0.25, TABLE_TOP + 0.06, 1, 0, 0, 0], mass=0.3)
    w.add_sphere("ball", 0.04, [0.7, -0.25, TABLE_TOP + 0.04, 1, 0, 0, 0], mass=0.2)
    return w, r


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    model = ferrobot.robots.panda()
    out = {}

    # 1. Panda alone holding a pose (no contacts).
    n = 2400
    w = ferrobot.World()
    r = w.add_robot(model, q=PANDA_Q0)
    r.set_joint_position_targets(PANDA_Q0)
    t = median_time(lambda: w.step(n), args.repeats)
    out["panda_steps_per_s"] = n / t
    print(f"Panda alone (8 DOF, 4 solver iterations): {n / t:,.0f} steps/s ({1e6 * t / n:.1f} us/step)")

    # 2. Table scene: Panda, static table, three objects resting on it.
    w, r = table_scene(model, PANDA_Q0)
    w.step(240)
    t = median_time(lambda: w.step(n), args.repeats)
    out["table_scene_steps_per_s"] = n / t
    print(f"Table scene (Panda + table + 3 objects): {n / t:,.0f} steps/s ({1e6 * t / n:.1f} us/step)")

    # 3. Rendering 640x480 from a camera looking at the table.
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

    # 4. A pick-and-place episode on the table.
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
        arm = list(range(7))
        r.execute_trajectory(legs[0], dt, joint_indices=arm, settle_time=0.1)
        r.close_gripper(force=40.0)
        w.step(60)
        r.execute_trajectory(legs[1], dt, joint_indices=arm)
        r.execute_trajectory(legs[2], dt, joint_indices=arm)
        r.execute_trajectory(legs[3], dt, joint_indices=arm, settle_time=0.1)
        r.open_gripper()
        w.step(60)
        r.execute_trajectory(legs[4], dt, joint_indices=arm)
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
    if args.json:
        args.json.write_text(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
