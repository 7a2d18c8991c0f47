"""Batch IK large enough to be seeded from the nearest-pose library (issue 23): every solution checked
by Pinocchio's forward kinematics, the joint limits and, when asked, an independent collision checker."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
from scipy.spatial.transform import Rotation

import ferrobot
from conftest import PANDA_URDF, random_configurations


def pin_pose(pm, data, q, frame):
    pin.framesForwardKinematics(pm, data, np.asarray(q, dtype=float))
    m = data.oMf[pm.getFrameId(frame)]
    return m.translation.copy(), m.rotation.copy()


def full(planner, q_active):
    out = planner.locked_positions.copy()
    idx = [planner.dof_names.index(n) for n in planner.joint_names]
    out[idx] = q_active
    return out


def test_batch_ik_solutions_hold_against_pinocchio():
    model = ferrobot.RobotModel.from_urdf(PANDA_URDF)
    planner = ferrobot.Planner(model, spheres=None)
    pm = pin.buildModelFromUrdf(str(PANDA_URDF))
    data = pm.createData()
    assert pm.nq == model.num_dof
    qs = random_configurations(model, 300, seed=11)
    poses = model.fk_batch(qs)
    b = planner.ik_batch(poses)
    assert b.success.all()
    lo, hi = planner.limits.lower, planner.limits.upper
    ee = model.link_names[-1] if "panda_hand" not in model.link_names else "panda_hand"
    # ferrobot's default IK link is its FK default (the end effector): find it by matching FK once.
    t0, r0 = pin_pose(pm, data, qs[0], ee)
    if np.linalg.norm(t0 - poses[0, :3]) > 1e-9:
        ee = next(n for n in model.link_names if np.allclose(pin_pose(pm, data, qs[0], n)[0], poses[0, :3]))
    for q, pose in zip(b.q, poses, strict=True):
        assert np.all(q >= lo) and np.all(q <= hi)
        t, r = pin_pose(pm, data, full(planner, q), ee)
        assert np.linalg.norm(t - pose[:3]) <= 1e-3
        want = Rotation.from_quat(np.r_[pose[4:], pose[3]])
        assert (want * Rotation.from_matrix(r).inv()).magnitude() <= 0.01
    # Deterministic: the library and the random restarts come from the options' seed.
    again = planner.ik_batch(poses)
    np.testing.assert_array_equal(again.q, b.q)


def test_collision_free_batch_ik_is_free_by_an_independent_checker():
    model = ferrobot.robots.panda()
    world = ferrobot.CollisionWorld()
    world.add_box("table", [0.8, 1.2, 0.05], [0.55, 0.0, 0.0, 1, 0, 0, 0])
    world.add_cylinder("post", 0.04, 0.5, [0.5, -0.05, 0.25, 1, 0, 0, 0])
    planner = ferrobot.Planner(model, world)
    checker = ferrobot.CollisionChecker(model, world)
    qs = [q for q in random_configurations(model, 400, seed=5) if not checker.in_collision(q)][:120]
    assert len(qs) >= 64
    b = planner.ik_batch(model.fk_batch(np.array(qs)), collision_free=True)
    assert b.success.mean() >= 0.95
    for q, ok in zip(b.q, b.success, strict=True):
        if ok:
            assert not checker.in_collision(full(planner, q))
