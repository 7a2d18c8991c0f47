"""Planning around obstacles loaded from a MoveIt planning scene (a MotionBenchMaker problem).

    python examples/plan_moveit_scene.py [problem folder] [index]

Defaults to ../shared/bench/mbm/bookshelf_small_panda, problem 1: the spherized Panda of
MotionBenchMaker, its scene, start and goal, then a collision-free, time-parametrised trajectory.
"""

import sys
from pathlib import Path

import numpy as np
import yaml

import ferrobot

root = Path(__file__).resolve().parents[1]
folder = Path(sys.argv[1]) if len(sys.argv) > 1 else root.parent / "shared/bench/mbm/bookshelf_small_panda"
index = int(sys.argv[2]) if len(sys.argv) > 2 else 1
robots = root.parent / "shared/robots/panda"

model = ferrobot.RobotModel.from_urdf(robots / "panda.urdf", srdf=robots / "panda.srdf", ee_link="panda_hand")
spheres = ferrobot.SphereModel.from_spherized_urdf(model, robots / "panda_spherized.urdf")
world = ferrobot.CollisionWorld.from_moveit_scene(folder / f"scene{index:04d}.yaml")
request = yaml.safe_load((folder / f"request{index:04d}.yaml").read_text())
start_state = request["start_state"]["joint_state"]
start = dict(zip(start_state["name"], start_state["position"], strict=True))
goal = {c["joint_name"]: c["position"] for c in request["goal_constraints"][0]["joint_constraints"]}

planner = ferrobot.Planner(model, world, spheres)
names = planner.joint_names
result = planner.plan([start[n] for n in names], goal_q=[goal[n] for n in names])
print(f"{folder.name} #{index}: {len(world.names)} obstacles -> {result.status}")
print(f"  path: {len(result.path)} waypoints, {result.path_length:.2f} rad; trajectory {result.duration:.2f} s")
print("  stage times (us): " + ", ".join(f"{k} {v * 1e6:.0f}" for k, v in result.times.to_dict().items()))
traj = result.interpolated(0.01)
print(f"  sampled every 10 ms: positions {traj.positions.shape}, max |qd| {np.abs(traj.velocities).max():.2f} rad/s")
checker = ferrobot.CollisionChecker(model, world, spheres)
print(f"  every sample collision-free: {not checker.in_collision_batch(traj.positions).any()}")
