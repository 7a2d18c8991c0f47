"""Option classes (issue 16): ``PlanOptions``, ``IkOptions`` and ``DetectOptions`` are typed objects whose
defaults are the Rust ``Default`` and whose checks are the crates' ``validate``; every field is also a keyword
of the calls that take them (``**overrides``), so the old keyword calls keep working and give the same
results as the option object."""

from __future__ import annotations

import math

import numpy as np
import pytest

import ferrobot
import ferrobot.grasp as fg
from ferrobot import DetectOptions, IkOptions, Planner, PlanOptions
from ferrobot.errors import InvalidArgumentError


@pytest.fixture(scope="module")
def planner(bundled_panda):
    return Planner(bundled_panda)


def test_defaults_are_the_documented_ones():
    # The documented defaults (README / crate docs), written out here independently of the Rust `Default`.
    p = PlanOptions()
    assert (p.time_limit, p.max_samples, p.resolution, p.range, p.seed) == (1.0, 100_000, 0.005, 1.0, 0)
    assert (p.velocity_scale, p.acceleration_scale, p.simplify, p.trajectory) == (1.0, 1.0, True, True)
    assert (p.goal_solutions, p.coarse_factor, p.refinements) == (4, 4.0, 4)
    k = IkOptions()
    assert (k.position_tolerance, k.rotation_tolerance, k.num_seeds, k.max_iterations) == (1e-3, 0.01, 200, 60)
    assert (k.collision_free, k.seed) == (False, 0)
    d = DetectOptions()
    assert d.voxel_size == 0.005 and d.num_seeds == 128 and d.depths == [0.04, 0.03, 0.02]
    assert d.approach_tilts == [0.0, -0.4, 0.4] and d.viewpoint == [0.0, 0.0, 0.0]
    assert d.approach_direction == [0.0, 0.0, 1.0] and math.isclose(d.nms_rotation, math.pi / 6)
    assert (d.max_width, d.palm_width, d.seed, d.support_plane) == (0.08, 0.208, 0, True)
    # ferrobot.grasp.OPTIONS is derived from the one source of defaults.
    assert fg.OPTIONS == DetectOptions().to_dict()


def test_overrides_setters_replace_and_equality():
    p = PlanOptions(time_limit=2.5, seed=7, simplify=False)
    assert (p.time_limit, p.seed, p.simplify) == (2.5, 7, False)
    q = p.replace(seed=8)
    assert q.seed == 8 and p.seed == 7 and q.time_limit == 2.5
    q.seed = 7
    assert q == p and q != PlanOptions()
    d = DetectOptions(depths=np.array([0.03, 0.02]), viewpoint=(0.0, 0.0, 0.5))
    assert d.depths == [0.03, 0.02] and d.viewpoint == [0.0, 0.0, 0.5]
    assert "time_limit=2.5" in repr(p)


@pytest.mark.parametrize(
    ("cls", "kw", "match"),
    [
        (PlanOptions, {"time_limit": 0.0}, "time_limit"),
        (PlanOptions, {"time_limit": float("nan")}, "time_limit"),
        (PlanOptions, {"resolution": 2.0}, "resolution"),
        (PlanOptions, {"resolution": 0.5, "coarse_factor": 4.0}, r"resolution \* coarse_factor"),
        (PlanOptions, {"velocity_scale": 1.5}, "velocity_scale"),
        (PlanOptions, {"max_samples": 0}, "max_samples"),
        (PlanOptions, {"max_samples": -1}, "PlanOptions.max_samples: expected int"),
        (PlanOptions, {"seed": 1.5}, "PlanOptions.seed: expected int"),
        (PlanOptions, {"max_samples": True}, "expected int, got a bool"),
        (PlanOptions, {"timelimit": 1.0}, "unknown plan option 'timelimit'"),
        (IkOptions, {"position_tolerance": -1.0}, "position_tolerance"),
        (IkOptions, {"num_seeds": 0}, "num_seeds"),
        (DetectOptions, {"voxel_size": 0.0}, "voxel_size must be positive"),
        (DetectOptions, {"depths": [0.06]}, "depth 0.06"),
        (DetectOptions, {"depths": []}, "must not be empty"),
        (DetectOptions, {"approach_direction": [0, 0, 0]}, "approach_direction"),
        (DetectOptions, {"viewpoint": [0, 0]}, "DetectOptions.viewpoint: expected 3 floats"),
        (DetectOptions, {"voxel": 0.01}, "unknown grasp option 'voxel'"),
    ],
)
def test_out_of_range_and_unknown_raise_naming_the_option(cls, kw, match):
    with pytest.raises(InvalidArgumentError, match=match):
        cls(**kw)
    # The same check on set: the object keeps its valid value.
    name, value = next(iter(kw.items()))
    if len(kw) == 1 and name in cls().to_dict():
        obj = cls()
        before = getattr(obj, name)
        with pytest.raises(InvalidArgumentError):
            setattr(obj, name, value)
        assert getattr(obj, name) == before


def test_plan_keywords_and_options_object_agree(bundled_panda, planner):
    q0 = bundled_panda.named_state("ready")[:7]
    goal = q0 + np.array([0.4, -0.3, 0.2, -0.2, 0.3, 0.2, -0.4])
    by_kw = planner.plan(q0, goal_q=goal, seed=3, time_limit=2.0, resolution=0.01, velocity_scale=0.5)
    opts = PlanOptions(seed=3, time_limit=2.0, resolution=0.01, velocity_scale=0.5)
    by_obj = planner.plan(q0, goal_q=goal, options=opts)
    mixed = planner.plan(
        q0, goal_q=goal, options=PlanOptions(seed=3, time_limit=2.0), resolution=0.01, velocity_scale=0.5
    )
    assert by_kw.success and by_obj.success and mixed.success
    np.testing.assert_array_equal(by_kw.path, by_obj.path)
    np.testing.assert_array_equal(by_kw.path, mixed.path)
    assert by_kw.duration == by_obj.duration == mixed.duration
    # Half the velocity limit: the same path takes longer than at full speed.
    full = planner.plan(q0, goal_q=goal, options=opts.replace(velocity_scale=1.0))
    np.testing.assert_array_equal(full.path, by_obj.path)
    assert full.duration < by_obj.duration
    with pytest.raises(InvalidArgumentError, match="unknown plan option 'sed'"):
        planner.plan(q0, goal_q=goal, sed=3)
    with pytest.raises(InvalidArgumentError, match="velocity_scale"):
        planner.plan(q0, goal_q=goal, options=opts, velocity_scale=0.0)


def test_ik_keywords_and_options_object_agree(bundled_panda, planner):
    q = bundled_panda.named_state("ready")
    target = bundled_panda.fk(q)
    a = planner.ik(target, num_seeds=8, seed=4, collision_free=True)
    b = planner.ik(target, options=IkOptions(num_seeds=8, seed=4, collision_free=True))
    c = planner.ik(target, options=IkOptions(num_seeds=8, collision_free=True), seed=4)
    assert a.success and b.success
    np.testing.assert_array_equal(a.q, b.q)
    np.testing.assert_array_equal(a.q, c.q)
    # The solution is an independent check: FK of it reaches the target within the tolerance.
    got = bundled_panda.fk(np.concatenate([b.q, q[7:]]))
    assert np.linalg.norm(got[:3, 3] - target[:3, 3]) <= 1e-3
    poses = np.stack([target, target])
    x = planner.ik_batch(poses, num_seeds=4, seed=1)
    y = planner.ik_batch(poses, options=IkOptions(num_seeds=4, seed=1))
    np.testing.assert_array_equal(x.q, y.q)
    with pytest.raises(InvalidArgumentError, match="unknown IK option 'tolerance'"):
        planner.ik_goalset(target[None], tolerance=1e-3)


def _box_cloud(n: int = 40) -> np.ndarray:
    """Points on the top and sides of a 4 cm cube centred 0.5 m in front of the camera (+z)."""
    g = np.linspace(-0.02, 0.02, n)
    u, v = np.meshgrid(g, g)
    top = np.stack([u.ravel(), v.ravel(), np.full(u.size, 0.48)], axis=1)
    side = np.stack([np.full(u.size, 0.02), u.ravel(), 0.5 + v.ravel()], axis=1)
    side2 = np.stack([np.full(u.size, -0.02), u.ravel(), 0.5 + v.ravel()], axis=1)
    return np.concatenate([top, side, side2])


def test_detect_keywords_options_object_and_deprecated_rng_seed_agree():
    pts = _box_cloud()
    kw = dict(support_plane=False, num_seeds=32, seed=3, max_grasps=5)
    a = fg.detect(pts, **kw)
    b = fg.detect(pts, options=DetectOptions(**kw))
    c = fg.detect(pts, options=DetectOptions(support_plane=False), num_seeds=32, seed=3, max_grasps=5)
    assert len(a) > 0
    np.testing.assert_array_equal(a.to_array(np.float64), b.to_array(np.float64))
    np.testing.assert_array_equal(a.to_array(np.float64), c.to_array(np.float64))
    old_kw = dict(kw)
    old_kw["rng_seed"] = old_kw.pop("seed")
    with pytest.warns(DeprecationWarning, match="'rng_seed' is deprecated: use 'seed'"):
        d = fg.detect(pts, **old_kw)
    np.testing.assert_array_equal(a.to_array(np.float64), d.to_array(np.float64))
    # Every grasp is no wider than the gripper opening given (an independent bound on the output).
    narrow = fg.detect(pts, options=DetectOptions(**kw), max_width=0.06)
    assert np.all(narrow.widths <= 0.06 + 1e-12)


def test_option_classes_are_exported():
    assert ferrobot.PlanOptions is PlanOptions and fg.DetectOptions is DetectOptions
