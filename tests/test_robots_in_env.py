"""Every robot the environment's packages ship (PyPI `pybullet`'s pybullet_data, PyPI
`example-robot-data`), loaded as a new user would (issue 17, deliverable 7), held to
independent references: FK and Jacobians against Pinocchio to 1e-9, automatic spheres against
the collision meshes' vertices (read with trimesh), SRDF named states free of self-collision,
100% IK on poses from FK of random configurations (checked with Pinocchio's FK), and random
plans whose trajectories are re-checked at 2 mrad."""

from __future__ import annotations

import functools
import tempfile
import warnings
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
import robots_in_env as env
import trimesh

import ferrobot

ROBOTS = env.available()
# The automatic sphere model takes seconds of CPU per robot the first time (the bench times it:
# BENCHMARKS.md); it is cached in memory and on disk (README, collision section), so each robot
# is spherized once per run (and not at all on a machine that keeps ~/.cache).
SPHERED = ROBOTS
# No robot is expected to fail its plans. (UR3 was, while the exact stage used convex hulls
# only: the hulls of base_link and upper_arm_link touch with the upper arm pointing down while
# the meshes are 22.7 mm apart, which split shoulder_lift's range into three components; the
# exact stage now re-decides hull contacts on the meshes where a hull is too coarse.)
PLAN_XFAIL: dict[str, str] = {}
pytestmark = pytest.mark.skipif(not ROBOTS, reason="pybullet / example-robot-data not installed")
TOL = 1e-9


@functools.cache
def setup(name: str):
    model = env.load(name)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # the always-in-contact report
        planner = ferrobot.Planner(model)
    checker = ferrobot.CollisionChecker(model, spheres=planner.sphere_model)
    return model, planner, checker


@functools.cache
def pinocchio_of(name: str):
    model = env.load(name)
    pm = pin.buildModelFromUrdf(str(env.urdf_path(name)), mimic=True)
    dof = {n: i for i, n in enumerate(model.dof_names)}
    mimic = dict(model.mimic_joints)

    def to_pin(q):
        out = np.zeros(pm.nq)
        for jid in range(1, pm.njoints):
            name_, idx, nq = pm.names[jid], pm.idx_qs[jid], pm.nqs[jid]
            if nq == 0:
                continue
            if name_ in dof:
                v = q[dof[name_]]
            elif name_ in mimic:
                driver, mult, off = mimic[name_]
                v = mult * q[dof[driver]] + off
            else:
                raise AssertionError(f"{name}: pinocchio joint {name_} unknown to ferrobot")
            if nq == 2:  # continuous joint: (cos, sin)
                out[idx : idx + 2] = [np.cos(v), np.sin(v)]
            else:
                out[idx] = v
        return out

    cols = np.array([pm.idx_vs[pm.getJointId(n)] for n in model.dof_names])
    return pm, to_pin, cols


def random_q(model, n, seed):
    rng = np.random.default_rng(seed)
    lo = np.where(np.isfinite(model.lower_limits), model.lower_limits, -np.pi)
    hi = np.where(np.isfinite(model.upper_limits), model.upper_limits, np.pi)
    return rng.uniform(lo, hi, size=(n, model.num_dof))


@pytest.mark.parametrize("name", ROBOTS)
def test_fk_and_jacobians_match_pinocchio(name):
    model = env.load(name)
    pm, to_pin, cols = pinocchio_of(name)
    data = pm.createData()
    frames = {ln: pm.getFrameId(ln, pin.BODY) for ln in model.link_names}
    assert all(f < pm.nframes for f in frames.values())
    worst_fk = worst_j = 0.0
    for i, q in enumerate(random_q(model, 20, seed=1)):
        qp = to_pin(q)
        pin.computeJointJacobians(pm, data, qp)
        pin.framesForwardKinematics(pm, data, qp)
        ours = model.fk_all(q)
        for k, ln in enumerate(model.link_names):
            worst_fk = max(worst_fk, np.abs(ours[k] - data.oMf[frames[ln]].homogeneous).max())
            if i < 3 or ln == model.ee_link:
                ref = pin.getFrameJacobian(pm, data, frames[ln], pin.LOCAL_WORLD_ALIGNED)[:, cols]
                worst_j = max(worst_j, np.abs(model.jacobian(q, link=ln) - ref).max())
    assert worst_fk < TOL and worst_j < TOL, (worst_fk, worst_j)


def _mesh_vertices(geom) -> np.ndarray:
    """A mesh collision element's vertices in the link frame, read from its file by trimesh."""
    mesh = trimesh.load(geom["path"], force="mesh", process=False)
    v = np.asarray(mesh.vertices, dtype=float) * np.asarray(geom["scale"])
    return v @ geom["origin"][:3, :3].T + geom["origin"][:3, 3]


@pytest.mark.parametrize("name", SPHERED)
def test_automatic_spheres_hold_every_mesh_vertex(name):
    model, planner, _ = setup(name)
    spheres = planner.sphere_model
    tolerance = 1e-3  # SphereModel.automatic's default coverage tolerance
    for link in model.link_names:
        for g in model.collision_geometry(link):
            if g["type"] != "mesh":
                continue
            v = _mesh_vertices(g)
            s = np.asarray(spheres.spheres(link))
            assert len(s), f"{name}: {link} has a mesh but no sphere"
            gap = np.linalg.norm(v[:, None, :] - s[None, :, :3], axis=2) - s[None, :, 3]
            worst = gap.min(axis=1).max()
            assert worst <= tolerance + 1e-6, f"{name}: {link} vertex {worst * 1e3:.2f} mm outside"


@pytest.mark.parametrize("name", SPHERED)
def test_named_states_are_free(name):
    model, _, checker = setup(name)
    for group, state in model.named_states:
        q = model.named_state(state, group)
        assert not checker.in_collision(q), f"{name}: {group}/{state}: {checker.explain(q)}"


@functools.cache
def ik_planner(name: str) -> ferrobot.Planner:
    """A planner whose sphere model is one bounding sphere per link (from trimesh / the
    primitive's size): IK without collision avoidance does not read the spheres, and this
    skips the automatic model's seconds of build time."""
    model = env.load(name)
    lines = ["collision_spheres:"]
    for link in model.link_names:
        pts = []
        for g in model.collision_geometry(link):
            if g["type"] == "mesh":
                pts.append(_mesh_vertices(g))
            else:
                pts.append(g["origin"][:3, 3][None, :])
        if pts:
            p = np.concatenate(pts)
            c = (p.min(axis=0) + p.max(axis=0)) / 2
            r = float(np.linalg.norm(p - c, axis=1).max()) + 1e-3
            x, y, z = (float(v) for v in c)
            lines.append(f"  {link}:\n    - center: [{x!r}, {y!r}, {z!r}]\n      radius: {r!r}")
    yml = _tmp / f"{name}.yml"
    yml.write_text("\n".join(lines) + "\n")
    spheres = ferrobot.SphereModel.load(model, yml)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        return ferrobot.Planner(model, spheres=spheres)


_tmp = Path(tempfile.mkdtemp(prefix="ferrobot-robots-"))


@pytest.mark.parametrize("name", ROBOTS)
def test_ik_solves_every_reachable_pose(name):
    model, planner = env.load(name), ik_planner(name)
    pm, to_pin, _ = pinocchio_of(name)
    data = pm.createData()
    fid = pm.getFrameId(planner.ee_link, pin.BODY)
    qs = random_q(model, 20, seed=2)
    poses = np.array([model.fk(q, link=planner.ee_link) for q in qs])
    result = planner.ik_batch(poses, seed=0)
    assert np.all(result.success), f"{name}: {np.count_nonzero(result.success)}/20"
    full = np.tile(model.neutral_configuration(), (len(qs), 1))
    idx = [model.dof_names.index(n) for n in planner.joint_names]
    full[:, idx] = result.q
    for q, pose in zip(full, poses, strict=True):
        pin.framesForwardKinematics(pm, data, to_pin(q))
        got = data.oMf[fid]
        assert np.linalg.norm(got.translation - pose[:3, 3]) <= 1e-3 + 1e-9
        rot = np.linalg.norm(pin.log3(got.rotation.T @ pose[:3, :3]))
        assert rot <= 0.01 + 1e-9


@pytest.mark.parametrize(
    "name",
    [
        pytest.param(r, marks=pytest.mark.xfail(reason=PLAN_XFAIL[r], strict=True)) if r in PLAN_XFAIL else r
        for r in SPHERED
    ],
)
def test_random_plans_are_clean_at_2_mrad(name):
    model, planner, checker = setup(name)
    idx = [model.dof_names.index(n) for n in planner.joint_names]
    rng = np.random.default_rng(3)
    base = model.neutral_configuration()
    lo, hi = planner.limits.lower, planner.limits.upper
    lo = np.where(np.isfinite(lo), lo, -np.pi)
    hi = np.where(np.isfinite(hi), hi, np.pi)

    def free_q():
        for _ in range(2000):
            q = rng.uniform(lo, hi)
            if not planner.in_collision(q):
                return q
        raise AssertionError(f"{name}: no free configuration in 2000 uniform samples")

    solved = 0
    for _ in range(20):
        start, goal = free_q(), free_q()
        # A generous wall-clock limit: this checks paths, not speed (benches/robots.py times plans),
        # and CI machines are shared.
        result = planner.plan(start, goal_q=goal, seed=solved, time_limit=10.0)
        assert result.success, f"{name}: {result.status}: {result.message}"
        solved += 1
        path = result.interpolated(dt=0.01).positions
        full = np.tile(base, (len(path), 1))
        full[:, idx] = path
        for a, b in zip(full[:-1], full[1:], strict=True):
            assert checker.motion_valid(a, b, resolution=0.002), f"{name}: {checker.explain(b)}"


@pytest.mark.parametrize("name", [r for r in ("erd_ur3", "erd_ur10") if r in ROBOTS])
def test_self_collision_matches_the_meshes(name):
    """The exact stage against coal's mesh-mesh distance on the same link pairs (tests/mesh_truth.py:
    Pinocchio's geometry loader and FK, triangle meshes, no hulls): every random configuration whose
    meshes touch is reported (conservative), and none whose meshes are more than 5 mm apart is (with
    convex hulls alone, 14-20% of these robots' configurations were flagged while their meshes were
    2-23 mm apart: BENCHMARKS.md)."""
    from mesh_truth import MeshTruth

    model, _, checker = setup(name)
    truth = MeshTruth(name, model, checker)
    qs = random_q(model, 100, seed=11)  # about 10% (UR10) to 30% (UR3) touch
    ours = checker.in_collision_batch(qs)
    for q, flagged in zip(qs, ours, strict=True):
        gap, pair = truth.min_distance(q)
        if gap <= 0.0:
            assert flagged, f"{name}: meshes of {pair} touch (coal) at {q}, ferrobot: free"
        elif gap > 5e-3:
            assert not flagged, f"{name}: meshes {gap * 1e3:.1f} mm apart at {q}: {checker.explain(q)}"
    assert 0.05 < ours.mean() < 0.5  # both verdicts occur in the sample


def test_pybullet_panda_self_collision_matches_pybullet():
    """pybullet's Panda has no SRDF: closed fingers touch (0.26 mm by their meshes' hulls) and
    were reported in every configuration. Now the pair is disabled as touching at its stop and
    the arm's verdicts agree with PyBullet's own `getClosestPoints` on the same URDF (meshes as
    convex hulls): every configuration PyBullet finds a checked pair more than 1 mm deep in is
    reported, and most of the rest are free."""
    pybullet = pytest.importorskip("pybullet")
    name = "pb_franka_panda"
    if name not in ROBOTS:
        pytest.skip("pybullet_data not installed")
    model, planner, checker = setup(name)
    reasons = {frozenset((a, b)): r for a, b, r in checker.allowed_collision_pairs}
    assert reasons[frozenset(("panda_leftfinger", "panda_rightfinger"))] == "Stop (automatic)"
    assert frozenset(("panda_link5", "panda_hand")) not in reasons  # an arm folding is kept
    cid = pybullet.connect(pybullet.DIRECT)
    try:
        body = pybullet.loadURDF(str(env.urdf_path(name)), useFixedBase=True, physicsClientId=cid)
        info = [
            pybullet.getJointInfo(body, j, physicsClientId=cid)
            for j in range(pybullet.getNumJoints(body, physicsClientId=cid))
        ]
        joint = {i[1].decode(): i[0] for i in info}
        link = {i[12].decode(): i[0] for i in info}
        link[pybullet.getBodyInfo(body, physicsClientId=cid)[0].decode()] = -1
        names = [n for n in model.link_names if n in link and model.collision_geometry(n)]
        pairs = [(a, b) for i, a in enumerate(names) for b in names[i + 1 :] if frozenset((a, b)) not in reasons]
        base = model.neutral_configuration()
        idx = [model.dof_names.index(n) for n in planner.joint_names]
        qs = random_q(model, 150, seed=5)
        free = 0
        for q in qs:
            full = base.copy()
            full[idx] = q[idx]
            for n, v in zip(model.dof_names, full, strict=True):
                pybullet.resetJointState(body, joint[n], v, physicsClientId=cid)
            deepest = min(
                (
                    c[8]
                    for a, b in pairs
                    for c in pybullet.getClosestPoints(body, body, 0.0, link[a], link[b], physicsClientId=cid)
                ),
                default=1.0,
            )
            ours = checker.in_collision(full)
            if deepest < -1e-3:
                assert ours, f"PyBullet: {-deepest * 1e3:.1f} mm deep at {full}, ferrobot: free"
            free += not ours
    finally:
        pybullet.disconnect(cid)
    assert free >= 0.4 * len(qs), f"{free}/{len(qs)} free"
