"""Reactive controller: an arm pinned at the velocity filter's hold asks for guidance and gets round it.

The scene is episode 3 of ``python benches/reactive.py --robot ur5 --ur5-spheres spherized`` (seed 0): the UR5 of
``../shared/robots/ur5`` with its spherized URDF (spheres that do not cover the links), three obstacles crossing.
Without ``stall_filtered`` (the controller of main) the arm ends this episode 15 cm from the target with a self link
pair held at the filter's 2 mm hold (``self_hold``), the attractor pressing the links together and the arm moving
along the hold (joints at 0.3-0.5 rad/s) without getting closer, so the stall watch (joints at rest) never fired: no
plan, no progress. With ``stall_filtered`` (the default) motion
the filter shapes is not evasion, the watch fires, and global guidance plans around (checked with the fixed
world-avoidance reach, ``collision_horizon 0``: with the default closing-speed reach the arm gets round this episode
locally, which the last run checks, contacts judged).

References independent of the controller: contacts are judged by coal on the URDF's own collision meshes (convex
hulls; ``benches/coal_judge.py``), and the end-effector error by ``RobotModel.fk`` (checked against Pinocchio
elsewhere).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import ferrobot

SHARED = Path(__file__).resolve().parent.parent.parent / "shared"
Q0 = [
    -0.19677275683397683,
    0.19248926742278022,
    -0.1402784110066743,
    -0.107587933266309,
    0.09265249408186499,
    0.10122447807794116,
]
QG = [
    0.02343439851613749,
    -0.8612145096887579,
    -0.499211415850117,
    -0.5256245783137401,
    0.7061711231511582,
    -0.07409750422060069,
]
OBSTACLES = [
    (
        "sphere",
        0.05572604108249281,
        [-0.2521738009545366, 0.527539509474112, 1.342849604624564],
        [0.18626934091226027, 0.09803847089120991, 0.07091202937332848],
    ),
    (
        "box",
        0.05771653242397788,
        [0.11111242553751544, 0.5105385183615684, 1.7204958543033086],
        [-0.25827699216299094, -0.05104671993402074, -0.06244946216631087],
    ),
    (
        "box",
        0.050412432937573304,
        [0.2172096037257723, -0.06021616499319715, 1.4246991046149111],
        [-0.20921056729186294, 0.3374784599636841, 0.10950941173187265],
    ),
]


def rot_err(a, b):
    r = a[:3, :3].T @ b[:3, :3]
    return float(np.arccos(np.clip((np.trace(r) - 1) / 2, -1, 1)))


@pytest.mark.skipif(not (SHARED / "robots/ur5/ur5.urdf").exists(), reason="../shared/robots/ur5 not available")
def test_an_arm_held_at_the_filter_stalls_and_guidance_gets_it_round():
    pytest.importorskip("coal")
    pytest.importorskip("trimesh")
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "benches"))
    from coal_judge import CoalJudge
    from reactive import load_robot

    model, spheres, _, (urdf, mesh_dir) = load_robot("ur5", 3.15, "spherized")
    coal = CoalJudge(model, urdf, mesh_dir)
    pairs = ferrobot.ReactiveController(model, None, spheres, self_collision_samples=0).self_link_pairs
    target = model.fk(np.array(QG))
    dt = 0.01

    def run(cfg, judge):
        world = ferrobot.CollisionWorld()
        for i, (kind, size, p0, _) in enumerate(OBSTACLES):
            if kind == "sphere":
                world.add_sphere(f"obs{i}", size, [*p0, 1, 0, 0, 0])
            else:
                world.add_box(f"obs{i}", [2 * size] * 3, [*p0, 1, 0, 0, 0])
        ctl = ferrobot.ReactiveController(model, world, spheres, config=cfg)
        ctl.set_target(target)
        q, qd = np.array(Q0), np.zeros(6)
        reached, held, self_min, world_min = False, 0, np.inf, np.inf
        for k in range(600):
            t = k * dt
            for i, (_, _, p0, v) in enumerate(OBSTACLES):
                ctl.set_obstacle_pose(f"obs{i}", [*(np.array(p0) + np.array(v) * t), 1, 0, 0, 0], v)
            q, qd, _ = ctl.step(q, qd, dt)
            held += ctl.last_step.filter_active
            T = model.fk(q)
            reached |= bool(np.linalg.norm(T[:3, 3] - target[:3, 3]) < 0.01 and rot_err(T, target) < 0.05)
            if judge:
                obs = [(kind, size, np.array(p0) + np.array(v) * (t + dt)) for kind, size, p0, v in OBSTACLES]
                world_min = min(world_min, coal.obstacle_distance(q, obs)[0])
                self_min = min(self_min, min(coal.pair_distances(q, pairs).values()))
        return reached, ctl.last_step.guidance_plans, held, self_min, world_min

    # Before: held at the hold (the filter active in most steps), never stalled, never planned, not reached. The
    # counterfactual is main's controller at the time: no stall watch on filtered or unforced motion, and the fixed
    # world-avoidance reach (with the closing-speed reach alone this arm already gets round locally).
    before = {"stall_filtered": 0, "stall_unforced": 0, "collision_horizon": 0.0}
    reached, plans, held, _, _ = run(before, judge=False)
    assert not reached and plans == 0 and held > 100, (reached, plans, held)
    # The stall watch on filtered motion (the fixed reach kept, so the arm is pinned as before): the watch fires, a
    # plan is followed, the target is reached.
    reached, plans, held, _, _ = run({"collision_horizon": 0.0}, judge=False)
    assert reached and plans >= 1, (reached, plans, held)
    # The defaults (the closing-speed reach too): the target is reached (here without a plan) and no link touches
    # anything.
    reached, plans, held, self_min, world_min = run(None, judge=True)
    assert reached, (reached, plans, held)
    assert self_min > 0.0 and world_min > 0.0, (self_min, world_min)
