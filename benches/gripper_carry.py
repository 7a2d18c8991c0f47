"""Issue 17: a grasped 0.5 kg box carried 0.5 m at 1 m/s, its drift relative to the hand, per bundled robot.

The robot starts at its home configuration (gripper open, pointing down) with a 0.5 kg box (50 mm across the
closing axis, 40 mm, 60 mm tall) between its fingers on a static stand. The gripper closes (40 N per finger)
and holds 0.5 s, the hand lifts 5 cm (0.5 s), then the hand is carried 0.5 m along the world y in a straight
line: cosine ramps of 0.2 s to 1 m/s and back, 0.3 s at 1 m/s; then 0.3 s held. The hand's path comes from
IK every 5 ms, run through the joint drives (first, slowly, to 0.25 m on one side, so that the carry spans
-0.25 to +0.25 m). Drift = largest distance of the box's centre, in the hand frame,
from where it was at the start of the carry (sampled every 5 ms), and where it is at the end.

    python benches/gripper_carry.py            # both bundled robots
"""

from __future__ import annotations

import argparse
import math

import numpy as np

import ferrobot

BOX = (0.05, 0.04, 0.06)  # closing, other, approach (m)
MASS = 0.5


def _cartesian(planner, hand_to_ee, start_hand, offsets, seed):
    """IK of the hand moved by each world offset (3,), seeded along the way."""
    out = []
    q = seed
    for d in offsets:
        pose = start_hand.copy()
        pose[:3, 3] += d
        r = planner.ik(pose @ hand_to_ee, q, num_seeds=4)
        if not r.success:
            raise RuntimeError(f"no IK along the carry at offset {np.round(d, 3)}")
        q = r.q
        out.append(q)
    return np.array(out)


def box_between_fingers(robot: str):
    """A bundled robot at its first named state with the gripper open and a ``BOX`` of ``MASS`` between the
    fingers, centred on the TCP (its ``BOX[0]`` side along the closing axis), on a fixed stand; stepped 24
    times. Returns ``(model, gripper, world, sim_robot, q, box_pose)``: ``q`` the robot's joint positions,
    ``box_pose`` the 4x4 pose the box was placed at (world frame)."""
    model = ferrobot.robots.bundled(robot)
    gripper = ferrobot.Gripper.from_model(model)
    world = ferrobot.World()
    sim = world.add_robot(model, [0, 0, 0, 1, 0, 0, 0])
    sim.use_gripper(gripper)
    q = sim.joint_positions
    q[model.dof_names.index(gripper.driver)] = gripper.open_position
    sim.set_joint_positions(q)
    sim.set_joint_position_targets(q)
    hand = model.fk(q, gripper.hand_link)
    # Box between the fingers: centred on the TCP, its 50 mm side along the closing axis.
    rot = hand[:3, :3] @ np.column_stack(
        [gripper.closing, np.cross(gripper.approach, gripper.closing), gripper.approach]
    )
    centre = hand[:3, :3] @ gripper.tcp + hand[:3, 3]
    pose = np.eye(4)
    pose[:3, :3], pose[:3, 3] = rot, centre
    quat = ferrobot.transforms.matrix_to_pose(pose)[3:]
    world.add_box("box", BOX, [*centre, *quat], mass=MASS, friction=0.9)
    # A static stand under the box (the hand points down in the home configurations).
    bottom = centre[2] - BOX[2] / 2
    world.add_box("stand", (0.03, 0.03, 0.1), [centre[0], centre[1], bottom - 0.05, 1, 0, 0, 0], fixed=True)
    world.step(24)
    return model, gripper, world, sim, q, pose


def carry(robot: str = "panda", speed: float = 1.0, distance: float = 0.5, force: float = 40.0) -> dict:
    """Runs the carry on a bundled robot; returns drift figures (m) and whether the box was held."""
    model, gripper, world, robot_, q, _ = box_between_fingers(robot)
    robot_.close_gripper(force=force)
    world.step(int(0.5 / world.dt))
    planner = ferrobot.Planner(model)
    arm = [model.dof_names.index(n) for n in planner.joint_names]
    hand_to_ee = np.linalg.inv(model.fk(q, gripper.hand_link)) @ model.fk(q, model.ee_link)
    qa = robot_.joint_positions[arm]
    start = robot_.get_link_pose(gripper.hand_link)
    start_base = start  # base at the world origin
    step = 0.005
    # Lift 5 cm in 0.5 s (cosine profile).
    t = np.arange(0, 0.5 + 1e-9, step)
    lift = _cartesian(
        planner, hand_to_ee, start_base, [np.array([0, 0, 0.05 * (1 - math.cos(math.pi * x / 0.5)) / 2]) for x in t], qa
    )
    robot_.execute_trajectory(lift, step, joint_names=planner.joint_names, settle_time=0.2)

    # Slowly (1 s) to the start of the carry, 0.25 m to the side.
    up = start_base.copy()
    up[2, 3] += 0.05
    t = np.arange(0, 1.0 + 1e-9, step)
    side = _cartesian(
        planner,
        hand_to_ee,
        up,
        [np.array([0, -distance / 4 * (1 - math.cos(math.pi * x / 1.0)), 0]) for x in t],
        lift[-1],
    )
    robot_.execute_trajectory(side, step, joint_names=planner.joint_names, settle_time=0.3)
    up[1, 3] -= distance / 2

    def rel():
        h = robot_.get_link_pose(gripper.hand_link)
        b = world.get_object_pose("box")
        return (np.linalg.inv(h) @ b)[:3, 3]

    r0 = rel()
    # Carry along +y: ramps of ramp s to `speed`, cruise for the rest of `distance`.
    ramp = 0.2
    ramp_d = speed * ramp / 2
    cruise = (distance - 2 * ramp_d) / speed
    total = 2 * ramp + cruise

    def s_of(x):
        if x < ramp:
            return speed * (x / 2 - ramp / (2 * math.pi) * math.sin(math.pi * x / ramp))
        if x < ramp + cruise:
            return ramp_d + speed * (x - ramp)
        y = x - ramp - cruise
        return ramp_d + speed * cruise + speed * (y / 2 + ramp / (2 * math.pi) * math.sin(math.pi * y / ramp))

    t = np.arange(0, total + 1e-9, step)
    path = _cartesian(planner, hand_to_ee, up, [np.array([0, s_of(x), 0]) for x in t], side[-1])
    worst = 0.0
    chunk = 4
    for k in range(0, len(path), chunk):
        robot_.execute_trajectory(path[k : k + chunk], step, joint_names=planner.joint_names)
        worst = max(worst, float(np.linalg.norm(rel() - r0)))
    robot_.execute_trajectory(path[-1:], step, joint_names=planner.joint_names, settle_time=0.3)
    final = float(np.linalg.norm(rel() - r0))
    hand_end = robot_.get_link_pose(gripper.hand_link)[:3, 3]
    return {
        "robot": robot,
        "gripper": gripper.name,
        "opening_mm": 1e3 * robot_.gripper_opening,
        "carried_m": float(hand_end[1] - up[1, 3]),
        "peak_speed_m_s": speed,
        "max_drift_mm": 1e3 * max(worst, final),
        "final_drift_mm": 1e3 * final,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--robots", default="panda,ur5e")
    args = ap.parse_args()
    for r in args.robots.split(","):
        res = carry(r)
        print(
            f"{res['robot']:<6} {res['gripper']:<13} opening {res['opening_mm']:.1f} mm, carried "
            f"{res['carried_m']:.3f} m at {res['peak_speed_m_s']} m/s: max drift {res['max_drift_mm']:.2f} mm, "
            f"final {res['final_drift_mm']:.2f} mm"
        )


if __name__ == "__main__":
    main()
