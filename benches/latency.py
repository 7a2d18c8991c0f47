"""Tracking error of a planned motion under command latency, uncompensated vs compensated.

The bundled Panda (gravity compensation on, default drives, dt = 1/240 s)
tracks a planned motion (RRT-Connect + time scaling, 7 arm joints) whose
position and velocity commands go through the simulated robot's own command
latency (``Robot.command_latency``: a command issued at world time t takes
effect at the first step starting at or after t + delay, applied inside
``World.step``). Modes:

* ``none``: the trajectory sample at t is issued at t (uncompensated);
* ``linear``: the command stream is extrapolated by the robot's latency
  (``ferrobot.LinearPredictor(robot.command_latency)``; velocity feed-forward by
  finite differences);
* ``lookahead``: the plan is known, so the sample at t + robot.command_latency is
  issued at t.

Tracking error is |q(t) - plan(t)| over the arm joints, during the motion and a
0.3 s settle. Run: ``python benches/latency.py [--delays 0.02 0.05 0.1] [--json FILE]``.
"""

from __future__ import annotations

import argparse
import json
import platform
import time

import numpy as np

import ferrobot
from ferrobot import _core
from ferrobot.scenarios import _planned_motion


def run(delay: float, mode: str, dt: float = 1 / 240) -> dict:
    model = ferrobot.robots.panda()
    world = ferrobot.World(dt=dt)
    robot = world.add_robot(model, name="panda")
    q0 = model.named_state("ready")
    robot.set_joint_positions(q0)
    robot.set_joint_position_targets(q0)
    positions, velocities, idx = _planned_motion(model, q0, dt)
    k = len(idx)
    names = [robot.dof_names[i] for i in idx]
    robot.command_latency = delay
    latency = robot.command_latency
    pred = _core.LinearPredictor(latency)
    prev_p = None
    n = len(positions) + int(0.3 / dt)
    errs = []
    for s in range(n):
        t = s * dt
        if mode == "lookahead":
            p = _core.trajectory_sample(positions, dt, t + latency)
            v = _core.trajectory_sample(velocities, dt, t + latency)
        else:
            p = _core.trajectory_sample(positions, dt, t)
            v = _core.trajectory_sample(velocities, dt, t)
            if mode == "linear":
                raw = p
                p = pred.update(t, raw)
                v = np.zeros(k) if prev_p is None else (raw - prev_p) / dt
                prev_p = raw
        robot.set_joint_position_targets(p, joint_names=names)
        robot.set_joint_velocity_targets(v, joint_names=names)
        world.step(1)
        want = _core.trajectory_sample(positions, dt, t + dt)
        errs.append(np.abs(robot.joint_positions[idx] - want))
    e = np.array(errs)
    return {
        "delay_ms": delay * 1e3,
        "mode": mode,
        "max_error_rad": float(e.max()),
        "rms_error_rad": float(np.sqrt(np.mean(e**2))),
        "final_error_rad": float(e[-1].max()),
        "motion_s": len(positions) * dt,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--delays", type=float, nargs="+", default=[0.02, 0.05, 0.1], help="latencies (s)")
    ap.add_argument("--json", default=None, help="write the results to this file")
    args = ap.parse_args()
    t0 = time.perf_counter()
    rows = [run(0.0, "none")]
    for d in args.delays:
        for mode in ("none", "linear", "lookahead"):
            rows.append(run(d, mode))
    print(f"{'delay':>8} {'mode':>10} {'max err (mrad)':>15} {'rms err (mrad)':>15}")
    for r in rows:
        print(
            f"{r['delay_ms']:>6.0f}ms {r['mode']:>10} "
            f"{r['max_error_rad'] * 1e3:>15.2f} {r['rms_error_rad'] * 1e3:>15.2f}"
        )
    print(f"motion {rows[0]['motion_s']:.2f} s; total {time.perf_counter() - t0:.1f} s on {platform.machine()}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=2)


if __name__ == "__main__":
    main()
