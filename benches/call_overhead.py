"""Per-call cost of ``Planner.plan`` and ``ferrobot.grasp.detect`` from Python, with keyword options, for two
builds of ferrobot compared A/B, interleaved (issue 16: options as pyclasses must not make calls slower).

Each round runs one child process per build (``PYTHONPATH`` set to the build's ``python`` directory, so the
build's own ``_core`` extension is imported) and alternates which build goes first; each child reports CPU
time per call (best of 5 batches):

* ``plan (early exit)``: a goal outside the joint limits, so the call is option parsing, argument
  conversion and the limit check (the binding's share of a call);
* ``plan (easy)``: the direct connection of ``benches/plan_call.py``'s scene (a realistic cheap plan);
* ``detect (tiny)``: ``detect`` on a 3-point cloud with 4 keyword options (options and conversion only);
* ``detect (cloud)``: a 4,800-point box cloud with the same options.

Issue 16 deliverable 5 (joint names, properties, typed results) adds, each spelled as the build's own
internal callers spell it (the "before" build: ``joint_indices=`` and getters; "after": ``joint_names=`` and
properties):

* ``robot: 2-joint targets``: ``Robot.set_joint_position_targets`` for 2 DOFs;
* ``robot: read q``: ``Robot.get_joint_positions()`` / ``Robot.joint_positions``;
* ``robot: execute 1 step``: ``Robot.execute_trajectory`` of 2 rows one physics step apart (7 arm joints),
  reading ``max_error`` from its report (a dict / a ``TrackingReport``);
* ``plan times: read total``: ``PlanResult.times`` and its total (a dict / a ``PlanTimes``);
* ``stepper: 1 control step``: ``ferrobot.control.ControlStepper.step`` at 60 Hz (4 physics steps).

    python benches/call_overhead.py /work/main/python /work/wt/arch16/python [--rounds 6]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys

CHILD = r"""
import json, time
import numpy as np
import ferrobot
import ferrobot.grasp as fg

def per_call(f, n, batches=5):
    best = float("inf")
    for _ in range(batches):
        t = time.process_time()
        for i in range(n):
            f(i)
        best = min(best, time.process_time() - t)
    return best / n * 1e6

m = ferrobot.robots.panda()
w = ferrobot.CollisionWorld()
w.add_box("table", [0.8, 1.2, 0.05], [0.55, 0.0, 0.0, 1, 0, 0, 0])
w.add_cylinder("post", 0.04, 0.5, [0.5, -0.05, 0.25, 1, 0, 0, 0])
p = ferrobot.Planner(m, w)
q0 = m.named_state("ready")[:7]
goal = p.ik([0.45, 0.25, 0.30, 0.0, 1.0, 0.0, 0.0], collision_free=True).q
bad = q0.copy(); bad[0] = 10.0
g = np.linspace(-0.02, 0.02, 40); u, v = np.meshgrid(g, g)
top = np.stack([u.ravel(), v.ravel(), np.full(u.size, 0.48)], axis=1)
side = np.stack([np.full(u.size, 0.02), u.ravel(), 0.5 + v.ravel()], axis=1)
side2 = np.stack([np.full(u.size, -0.02), u.ravel(), 0.5 + v.ravel()], axis=1)
cloud = np.concatenate([top, side, side2])
tiny = cloud[:3]
kw = dict(support_plane=False, num_seeds=32, max_grasps=5, voxel_size=0.005)
out = {
    "plan (early exit)": per_call(lambda s: p.plan(q0, goal_q=bad, seed=s, time_limit=1.0, resolution=0.005), 400),
    "plan (easy)": per_call(lambda s: p.plan(q0, goal_q=goal, seed=s, time_limit=1.0), 40),
    "detect (tiny)": per_call(lambda s: fg.detect(tiny, **kw), 400),
    "detect (cloud)": per_call(lambda s: fg.detect(cloud, **kw), 10),
}
assert not p.plan(q0, goal_q=bad).success

from ferrobot.control import ControlStepper
world = ferrobot.World(dt=1 / 240)
robot = world.add_robot(m, q=m.named_state("ready"))
new = hasattr(ferrobot.Robot, "joint_positions")  # the "after" build's spellings
names2, ix2 = [robot.dof_names[5], robot.dof_names[1]], [5, 1]
arm_names, arm_ix = robot.dof_names[:7], list(range(7))
t2 = np.array([0.1, -0.2])
q_now = m.named_state("ready")[:7]
rows = np.stack([q_now, q_now])
r_ok = p.plan(q0, goal_q=goal)
if new:
    targets = lambda s: robot.set_joint_position_targets(t2, joint_names=names2)
    read_q = lambda s: robot.joint_positions
    execute = lambda s: robot.execute_trajectory(rows, 1 / 240, joint_names=arm_names).max_error
    times = lambda s: r_ok.times.total
    stepper = ControlStepper(world, robot, control_hz=60.0, arm_joint_names=arm_names)
else:
    targets = lambda s: robot.set_joint_position_targets(t2, joint_indices=ix2)
    read_q = lambda s: robot.get_joint_positions()
    execute = lambda s: robot.execute_trajectory(rows, 1 / 240, joint_indices=arm_ix)["max_error"]
    times = lambda s: r_ok.times["total"]
    stepper = ControlStepper(world, robot, control_hz=60.0, arm_joint_indices=arm_ix)
action = np.r_[q_now, 0.0]
out["robot: 2-joint targets"] = per_call(targets, 2000)
out["robot: read q"] = per_call(read_q, 2000)
out["robot: execute 1 step"] = per_call(execute, 300)
out["plan times: read total"] = per_call(times, 2000)
out["stepper: 1 control step"] = per_call(lambda s: stepper.step(action), 100)
print(json.dumps(out))
"""


def run(path: str) -> dict[str, float]:
    env = dict(os.environ, PYTHONPATH=path)
    proc = subprocess.run([sys.executable, "-c", CHILD], env=env, capture_output=True, text=True, check=True)
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("before", help="python/ directory of the 'before' build")
    ap.add_argument("after", help="python/ directory of the 'after' build")
    ap.add_argument("--rounds", type=int, default=6)
    a = ap.parse_args()
    res: dict[str, list[dict[str, float]]] = {"before": [], "after": []}
    for r in range(a.rounds):
        order = [("before", a.before), ("after", a.after)]
        if r % 2:
            order.reverse()
        for label, path in order:
            res[label].append(run(path))
    print(f"load average: {os.getloadavg()}")
    keys = list(res["before"][0])
    print(
        f"{'us per call (CPU), median of rounds':40s} {'before':>10s} {'after':>10s} {'after/before':>13s}"
        f"  {'before min-max':>16s} {'after min-max':>16s}"
    )
    for k in keys:
        bs, fs = [x[k] for x in res["before"]], [x[k] for x in res["after"]]
        b, f = statistics.median(bs), statistics.median(fs)
        print(
            f"{k:40s} {b:10.2f} {f:10.2f} {f / b:13.3f}  {min(bs):7.2f}-{max(bs):<8.2f} {min(fs):7.2f}-{max(fs):<8.2f}"
        )


if __name__ == "__main__":
    main()
