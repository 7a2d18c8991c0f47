"""Plans are free at every configuration, not only at the planner's own samples (issue 23, item 5).

Two plans of `benches/scene_classes.py --worlds 6 --problems 20` (cage world 0 problem 10, clutter world 4
problem 14) used to return trajectories that grazed an obstacle (by 33 and 4 micrometres) between the
configurations the planner had checked 5 mrad apart: the bench's re-check, sampling the same trajectory at
other times, found them. The planner now certifies every path edge and trajectory piece continuously
(`ferrobot_collision::certify`). The judge here is a separate CollisionChecker sampling the results far more
densely than the planner's resolution and at several time steps.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import ferrobot

BENCHES = Path(__file__).resolve().parents[1] / "benches"
sys.path.insert(0, str(BENCHES))
import scene_classes  # noqa: E402  (benches/scene_classes.py)

RESOLUTION = 0.005


@pytest.fixture(scope="module")
def panda():
    shared = scene_classes.SHARED
    model = ferrobot.RobotModel.from_urdf(shared / "robots/panda/panda.urdf", srdf=shared / "robots/panda/panda.srdf")
    spheres = ferrobot.SphereModel.from_spherized_urdf(model, shared / "robots/panda/panda_spherized.urdf")
    return model, spheres


def _dense(path: np.ndarray, step: float) -> np.ndarray:
    out = [path[:1]]
    for a, b in zip(path[:-1], path[1:], strict=True):
        n = max(1, int(np.ceil(np.abs(b - a).max() / step)))
        out.append(a + (b - a) * (np.arange(1, n + 1)[:, None] / n))
    return np.concatenate(out)


@pytest.mark.parametrize(("cname", "world_index", "problem"), [("cage", 0, 10), ("clutter", 4, 14)])
def test_bench_plans_that_grazed_are_free_everywhere(panda, cname, world_index, problem):
    model, spheres = panda
    planner = ferrobot.Planner(model, spheres=spheres)
    judge = ferrobot.CollisionChecker(model, spheres=spheres)
    idx = [planner.dof_names.index(n) for n in planner.joint_names]
    lo, hi = np.asarray(planner.limits.lower), np.asarray(planner.limits.upper)
    # The bench's world and problem, drawn exactly as benches/scene_classes.py draws them.
    rng = np.random.default_rng(1000 * world_index + len(cname))
    world = ferrobot.CollisionWorld()
    scene_classes.CLASSES[cname](world, rng)
    planner.update_world(world)
    judge.update_world(world)
    full = np.tile(planner.locked_positions, (100_000, 1))
    full[:, idx] = rng.uniform(lo, hi, (100_000, len(idx)))
    free = full[~judge.in_collision_batch(full)][:, idx]
    start, goal = free[2 * problem], free[2 * problem + 1]

    def clean(configs: np.ndarray) -> bool:
        qs = np.tile(planner.locked_positions, (len(configs), 1))
        qs[:, idx] = configs
        return not judge.in_collision_batch(qs).any()

    for trajectory in (False, True):
        r = planner.plan(start, goal_q=goal, seed=problem, trajectory=trajectory)
        assert r.success, r.message
        # The path at the bench's 5 mrad and 50 times finer.
        assert clean(_dense(r.path, RESOLUTION))
        assert clean(_dense(r.path, RESOLUTION / 50))
    vmax = planner.limits.velocity.max()
    # The bench's time step (0.8 x 5 mrad at the fastest joint's limit) and others.
    for f in (0.8, 0.53, 0.31, 0.07):
        traj = r.interpolated(dt=f * RESOLUTION / vmax).positions
        assert clean(traj), f"trajectory sampled at {f} x 5 mrad / vmax collides"
