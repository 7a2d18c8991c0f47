"""``Planner.exact_clearance``: each world object's exact distance to the robot's links (parry), judged against
an independent reference: the links' primitives sampled densely on their surfaces (from the model's collision
geometry and forward kinematics, numpy only) and the analytic distance from those points to a box."""

from __future__ import annotations

import numpy as np
import pytest

import ferrobot
from ferrobot import errors


def _surface_points(g: dict, n: int = 4000) -> np.ndarray:
    """Points on the surface of a box / cylinder / capsule / sphere collision shape (shape frame)."""
    rng = np.random.default_rng(1)
    t = g["type"]
    if t == "box":
        h = np.asarray(g["size"], dtype=float) / 2
        u = rng.uniform(-1, 1, size=(n, 3))
        ax = np.argmax(np.abs(u), axis=1)
        u[np.arange(n), ax] = np.sign(u[np.arange(n), ax])
        return u * h
    if t == "sphere":
        u = rng.normal(size=(n, 3))
        return g["radius"] * u / np.linalg.norm(u, axis=1)[:, None]
    r, length = g["radius"], g["length"]
    a = rng.uniform(0, 2 * np.pi, n)
    z = rng.uniform(-length / 2, length / 2, n)
    side = np.c_[r * np.cos(a), r * np.sin(a), z]
    if t == "cylinder":
        rr = r * np.sqrt(rng.uniform(0, 1, n))
        caps = np.c_[rr * np.cos(a), rr * np.sin(a), np.where(rng.uniform(size=n) < 0.5, -length / 2, length / 2)]
        return np.vstack([side, caps])
    u = rng.normal(size=(n, 3))
    u = r * u / np.linalg.norm(u, axis=1)[:, None]
    return np.vstack([side, u + [0, 0, length / 2], u - [0, 0, length / 2]])


def _robot_points(model: ferrobot.RobotModel, q: np.ndarray) -> dict[str, np.ndarray]:
    out = {}
    for link in model.link_names:
        pts = []
        for g in model.collision_geometry(link):
            if g["type"] == "mesh":
                pytest.skip("reference samples primitives only")
            p = _surface_points(g)
            m = model.fk(q, link) @ g["origin"]
            pts.append(p @ m[:3, :3].T + m[:3, 3])
        if pts:
            out[link] = np.vstack(pts)
    return out


def _box_distance(points: np.ndarray, centre, half) -> np.ndarray:
    """Distance from points to an axis-aligned solid box (0 inside)."""
    d = np.abs(points - np.asarray(centre)) - np.asarray(half)
    return np.linalg.norm(np.maximum(d, 0.0), axis=1)


@pytest.fixture(scope="module")
def panda():
    return ferrobot.robots.panda()


def test_exact_clearance_matches_sampled_surfaces(panda):
    q = panda.named_state("ready")
    hand = panda.fk(q, "panda_hand")[:3, 3]
    pts = _robot_points(panda, q)
    all_pts = np.vstack(list(pts.values()))
    rng = np.random.default_rng(0)
    for trial in range(6):
        half = rng.uniform(0.02, 0.08, 3)
        # A box beside the hand, 1-30 mm from the nearest sampled robot point along a random horizontal line.
        direction = np.r_[rng.normal(size=2), 0.0]
        direction /= np.linalg.norm(direction)
        centre = hand + direction * 0.3
        for _ in range(60):  # bisect the offset so that the sampled clearance is the wanted gap
            d = _box_distance(all_pts, centre, half).min()
            want = [0.001, 0.003, 0.01, 0.03, 0.005, 0.02][trial]
            centre = centre - direction * (d - want)
        w = ferrobot.CollisionWorld()
        w.add_box("b", 2 * half, [*centre, 1, 0, 0, 0])
        planner = ferrobot.Planner(panda, w)
        got = planner.exact_clearance(q)
        assert set(got) == {"b"}
        ref = _box_distance(all_pts, centre, half)
        ref_link = min(pts, key=lambda k: _box_distance(pts[k], centre, half).min())
        # Samples lie on the surfaces: the true distance is at most the sampled one, and within the sampling
        # spacing (~2 mm on these shapes) of it; parry computes in single precision.
        assert got["b"].distance <= ref.min() + 2e-5
        assert got["b"].distance >= ref.min() - 2.5e-3
        assert got["b"].closest[1] == "b"
        if ref.min() < 0.02:
            assert (
                got["b"].closest[0] == ref_link
                or abs(_box_distance(pts[got["b"].closest[0]], centre, half).min() - ref.min()) < 2.5e-3
            )


def test_overlap_is_zero_meshes_and_errors(panda):
    q = panda.named_state("ready")
    hand = panda.fk(q, "panda_hand")[:3, 3]
    w = ferrobot.CollisionWorld()
    w.add_box("inside", [0.05, 0.05, 0.05], [*hand, 1, 0, 0, 0])
    far = hand + [0.0, 0.0, 0.6]
    w.add_box("far", [0.1, 0.1, 0.1], [*far, 1, 0, 0, 0])
    # The same box as a closed triangle mesh: the same distance.
    v = np.array([[x, y, z] for x in (-0.05, 0.05) for y in (-0.05, 0.05) for z in (-0.05, 0.05)])
    f = np.array(
        [[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1], [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4],
         [1, 5, 7], [1, 7, 3]]
    )  # fmt: skip
    w.add_mesh("far_mesh", v, f, [*far, 1, 0, 0, 0])
    planner = ferrobot.Planner(panda, w)
    got = planner.exact_clearance(q)
    assert got["inside"].distance == 0.0
    assert got["far"].distance > 0.3
    assert got["far_mesh"].distance == pytest.approx(got["far"].distance, abs=1e-4)
    # Only the named objects; other layouts of q give the same answer.
    only = planner.exact_clearance(np.asfortranarray(q[None, :])[0], objects=["far"])
    assert set(only) == {"far"} and only["far"].distance == pytest.approx(got["far"].distance, abs=1e-9)
    with pytest.raises(errors.UnknownNameError, match="objects"):
        planner.exact_clearance(q, objects=["nope"])
    with pytest.raises(errors.ShapeError):
        planner.exact_clearance(q[:3])
    w.add_pointcloud("cloud", np.zeros((3, 3)) + far, 0.01)
    with pytest.raises(errors.InvalidArgumentError, match="cloud"):
        ferrobot.Planner(panda, w).exact_clearance(q)
