"""Pick-and-place end to end, written out step by step with the public API (what `ferrobot demo` runs).

    python examples/pick_and_place.py [--seed 0]

The simulated Panda stands before a table; a camera renders RGB-D; grasps are detected on the target,
moved camera -> world -> robot base, filtered by collision-free IK; the planner's world is synced from the
simulation (ignoring the target and the table where the fingers must touch them); each motion is planned
and executed by the joint drives.
"""

import argparse

import numpy as np

import ferrobot
from ferrobot.pipeline import TABLE_TOP, build_world, random_scene

ap = argparse.ArgumentParser()
ap.add_argument("--seed", type=int, default=3)
args = ap.parse_args()

spec = random_scene(args.seed)
world, robot, camera = build_world(spec)  # ferrobot.World, its Robot (Isaac-Sim-like API), a Camera
base = robot.world_transform
planner = ferrobot.Planner(robot.model)
arm = [robot.dof_names.index(n) for n in planner.joint_names]


def sync(ignore=()):
    # cuRobo's update_world(get_obstacles_from_stage(ignore_substring=...)), in one call.
    planner.update_world(world, ignore=["pedestal", *ignore], base_pose=base)


def move_to(q_goal, ignore=()):
    sync(ignore)
    result = planner.plan(robot.joint_positions[arm], goal_q=q_goal, velocity_scale=0.5, acceleration_scale=0.5)
    assert result.success, result.message
    report = robot.execute(result)  # joints matched by name, sampled at the world's time step
    world.step(24)
    print(
        f"  {result.status}: {result.duration:.2f} s trajectory, max tracking error {report['max_error'].max():.4f} rad"
    )


# 1. Perceive: RGB-D + segmentation from the camera, back-projected and moved to the world frame.
frame = camera.render()
target_id = next(i for i, n in world.segmentation_labels.items() if n == spec.target)
k = camera.intrinsic_matrix
depth = np.where(np.isfinite(frame.depth), frame.depth, 0.0)
points, pixels = ferrobot.grasp.backproject(depth, k[0, 0], k[1, 1], k[0, 2], k[1, 2], scale=1.0)
cam_pose = camera.world_transform
points = ferrobot.grasp.transform_points(points, cam_pose)
labels = frame.segmentation[pixels[:, 0], pixels[:, 1]]
keep = points[:, 2] > TABLE_TOP - 0.02  # workspace: the table and what is on it

# 2. Grasps on the target, approaching from above (normals face the camera: the viewpoint), then
#    Panda hand poses in the robot base frame.
grasps = ferrobot.grasp.detect(
    points[keep],
    seed_mask=labels[keep] == target_id,
    viewpoint=tuple(cam_pose[:3, 3]),
    approach_direction=(0, 0, -1),
    approach_tilts=(0.0,),
)
print(f"{len(grasps)} grasps on '{spec.target}', best score {grasps.scores[0]:.3f}")
hand_poses = grasps.to_hand(ferrobot.Gripper.panda_hand())  # panda_hand poses in the world
hands = np.einsum("ij,njk->nik", ferrobot.transforms.world_to_base(np.eye(4), base), hand_poses)
pregrasps = hands.copy()
pregrasps[:, :3, 3] -= 0.08 * hands[:, :3, 2]  # 8 cm back along the approach (the hand's z)

# 3. Collision-free IK for every pre-grasp at once; then the grasp pose near it (target and table ignored).
sync()
ik_pre = planner.ik_batch(pregrasps, collision_free=True, num_seeds=64)
sync([spec.target, "table"])
for i in np.flatnonzero(ik_pre.success):
    ik_grasp = planner.ik(hands[i], ik_pre.q[i], collision_free=True)
    if ik_grasp.success:
        break
else:
    raise SystemExit("no reachable grasp")
print(f"grasp {i}: score {grasps.scores[i]:.3f}, width {grasps.widths[i] * 1e3:.0f} mm")

# 4. Pick: pre-grasp, approach, close, attach the target to the planner's robot, lift.
print("pre-grasp")
move_to(ik_pre.q[i])
print("approach")
move_to(ik_grasp.q, ignore=[spec.target, "table"])
robot.close_gripper(force=40.0)
world.step(72)
sync()
planner.attach_world_object(spec.target, robot.joint_positions[arm])
lift = hands[i].copy()
lift[2, 3] += 0.12
print("lift")
move_to(planner.ik(lift, ik_grasp.q).q, ignore=["table"])

# 5. Place: same hand orientation over the place location, lower, open, detach, retreat.
obj = world.get_object_pose(spec.target)  # the simulation knows where it is; a robot would re-perceive
shift = ferrobot.transforms.world_to_base(np.eye(4), base)[:3, :3] @ np.r_[np.subtract(spec.place_xy, obj[:2, 3]), 0]
place = hands[i].copy()
place[:3, 3] += shift + [0, 0, 0.008]
above = place.copy()
above[2, 3] += 0.12
sync()
q_above = planner.ik(above, robot.joint_positions[arm], collision_free=True).q
print("transport")
move_to(q_above)
print("lower")
move_to(planner.ik(place, q_above).q, ignore=["table"])
robot.open_gripper()
world.step(72)
planner.detach(spec.target)
print("retreat")
move_to(q_above, ignore=[spec.target, "table"])

err = np.hypot(*(world.get_object_pose(spec.target)[:2, 3] - spec.place_xy))
print(f"'{spec.target}' rests {err * 1e3:.1f} mm from the place location ({world.time:.1f} s simulated)")
