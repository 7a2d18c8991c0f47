"""Inverse kinematics only: one pose, a goal set, and a batch on all cores, on the bundled Panda.

python examples/ik.py
"""

import time

import numpy as np

import ferrobot

panda = ferrobot.robots.panda()
planner = ferrobot.Planner(panda)  # plans the SRDF arm group: panda_joint1..7

# One pose: [x, y, z, qw, qx, qy, qz] in the base frame, the hand pointing down.
goal = [0.5, 0.1, 0.3, 0.0, 1.0, 0.0, 0.0]
res = planner.ik(goal)
print(f"ik: success={res.success} q={np.round(res.q, 3)}")
print(f"    position error {res.position_error * 1e3:.3f} mm, rotation error {res.rotation_error:.4f} rad")
print(f"    check by FK: {np.round(ferrobot.transforms.matrix_to_pose(panda.fk(np.r_[res.q, 0.04])), 4)}")

# A goal set: any of several poses (e.g. grasps); the result says which one was reached.
goals = [[0.5, y, 0.3, 0.0, 1.0, 0.0, 0.0] for y in (-0.2, 0.0, 0.2)]
gs = planner.ik_goalset(goals)
print(f"goal set: reached goal {gs.goal_index}, success={gs.success}")

# Collision-free IK against a world of obstacles.
world = ferrobot.CollisionWorld()
world.add_box("table", [0.8, 1.2, 0.05], [0.5, 0.0, 0.1, 1, 0, 0, 0])
planner.update_world(world)
free = planner.ik([0.5, 0.0, 0.25, 0.0, 1.0, 0.0, 0.0], collision_free=True)
print(f"collision-free ik above a table: success={free.success}, in collision: {planner.in_collision(free.q)}")

# A batch of 1,000 reachable poses, solved in parallel with the GIL released.
rng = np.random.default_rng(0)
lo, hi = panda.lower_limits, panda.upper_limits
poses = panda.fk_batch(rng.uniform(lo, hi, size=(1000, panda.num_dof)))
t0 = time.perf_counter()
batch = planner.ik_batch(poses)
dt = time.perf_counter() - t0
print(f"batch: {np.mean(batch.success) * 100:.1f}% solved, {len(poses) / dt:,.0f} solves/s")
