"""How far `Planner.plan(time_limit=...)` overruns its limit on hostile problems (issue 15).

Each case asks for more collision checking than the limit allows: a fine `resolution` on a long
motion (the straight-line check and the trajectory's dense re-check alone take seconds), a
five posts around the robot, a pose goal. Prints wall and CPU time per call, the overrun factor
(wall / time_limit) and the status; a solved plan is re-checked independently (its interpolated
trajectory sampled every 1 mrad and checked configuration by configuration).

    python benches/plan_deadline.py [--limits 0.02 0.1 0.5] [--repeat 3]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import ferrobot


def scenes():
    empty = ferrobot.CollisionWorld()
    posts = ferrobot.CollisionWorld()
    for i, (x, y) in enumerate([(0.5, 0.3), (0.5, -0.3), (0.0, 0.6), (0.0, -0.6), (-0.5, 0.0)]):
        posts.add_cylinder(f"post{i}", 0.05, 1.6, [x, y, 0.8, 1, 0, 0, 0])
    return {"empty": empty, "posts": posts}


def dense_ok(planner, result) -> bool:
    traj = result.interpolated(dt=0.002)
    q = traj.positions
    # Sample every 1 mrad of the largest joint step between interpolated points.
    pts = [q[0]]
    for a, b in zip(q[:-1], q[1:], strict=True):
        n = max(1, int(np.ceil(np.abs(b - a).max() / 1e-3)))
        pts.extend(a + (b - a) * (k / n) for k in range(1, n + 1))
    return not any(planner.in_collision(p) for p in pts)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--limits", type=float, nargs="+", default=[0.02, 0.1, 0.5])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    panda = ferrobot.robots.panda()
    q0 = panda.named_state("ready")
    far = q0.copy()
    far[:7] = [2.5, 1.5, -2.5, -0.5, 2.5, 3.5, -2.5]
    cases = [
        ("empty, far goal, resolution 1e-6", "empty", dict(goal_q=far, resolution=1e-6, coarse_factor=1.0)),
        ("posts, far goal, resolution 1e-6", "posts", dict(goal_q=far, resolution=1e-6, coarse_factor=1000.0)),
        (
            "posts, pose goal, resolution 1e-6",
            "posts",
            dict(goal_pose=[0.45, 0.0, 0.3, 0, 1, 0, 0], resolution=1e-6, coarse_factor=10.0),
        ),
        ("posts, far goal, resolution 1e-4", "posts", dict(goal_q=far, resolution=1e-4)),
    ]
    worlds = scenes()
    print(f"{'case':40s} {'limit s':>8s} {'wall s':>8s} {'cpu s':>8s} {'wall/limit':>10s}  status")
    for name, scene, kw in cases:
        planner = ferrobot.Planner(panda, worlds[scene])
        for limit in args.limits:
            for r in range(args.repeat):
                t0, c0 = time.perf_counter(), time.process_time()
                res = planner.plan(q0, time_limit=limit, seed=r, **kw)
                wall, cpu = time.perf_counter() - t0, time.process_time() - c0
                note = res.status
                if res.success:
                    note += " (dense re-check " + ("ok" if dense_ok(planner, res) else "COLLIDES") + ")"
                    if res.message:
                        note += ", " + res.message[:60]
                print(f"{name:40s} {limit:8.3f} {wall:8.3f} {cpu:8.3f} {wall / limit:10.1f}  {note}", flush=True)


if __name__ == "__main__":
    main()
