"""The simplifier's options on ``PlanOptions`` (issue 23): ``min_gain``, ``max_shortcuts`` and
``max_shortcut_failures`` have documented ranges, raise ``InvalidArgumentError`` naming the field when out of
range (on construction, on set and as ``plan`` keywords), and change the result as documented. The reference
for the effect is geometry computed here: the same seed gives the same RRT-Connect path; the vertex reduction
and every kept shortcut replace a part of the path by a straight line, so by the triangle inequality no
simplified path is longer than the raw one, and shortcuts on top of the reduction shorten it further. Every
path is judged free by a separate CollisionChecker sampled at 1 mrad."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import ferrobot
from ferrobot import PlanOptions
from ferrobot.errors import InvalidArgumentError

BENCHES = Path(__file__).resolve().parents[1] / "benches"
sys.path.insert(0, str(BENCHES))
import scene_classes  # noqa: E402  (benches/scene_classes.py)


def test_defaults_and_documented_ranges():
    p = PlanOptions()
    assert (p.min_gain, p.max_shortcuts, p.max_shortcut_failures) == (0.01, 40, 10)
    for kw in ({"min_gain": 0.0}, {"min_gain": 0.5}, {"max_shortcuts": 0}, {"max_shortcuts": 100_000}):
        PlanOptions(**kw)
    PlanOptions(max_shortcut_failures=1)
    PlanOptions(max_shortcut_failures=100_000)


@pytest.mark.parametrize(
    ("kw", "name"),
    [
        ({"min_gain": -0.01}, "min_gain"),
        ({"min_gain": 0.51}, "min_gain"),
        ({"min_gain": float("nan")}, "min_gain"),
        ({"max_shortcuts": 100_001}, "max_shortcuts"),
        ({"max_shortcut_failures": 0}, "max_shortcut_failures"),
        ({"max_shortcut_failures": 100_001}, "max_shortcut_failures"),
    ],
)
def test_out_of_range_raises_naming_the_field(kw, name):
    with pytest.raises(InvalidArgumentError, match=name):
        PlanOptions(**kw)
    p = PlanOptions()
    with pytest.raises(InvalidArgumentError, match=name):
        setattr(p, *next(iter(kw.items())))
    assert p == PlanOptions()  # a refused value is not kept
    with pytest.raises(InvalidArgumentError, match=name):
        PlanOptions().replace(**kw)


def test_shortcut_options_shorten_as_documented(bundled_panda):
    shared = scene_classes.SHARED
    model = ferrobot.RobotModel.from_urdf(shared / "robots/panda/panda.urdf", srdf=shared / "robots/panda/panda.srdf")
    spheres = ferrobot.SphereModel.from_spherized_urdf(model, shared / "robots/panda/panda_spherized.urdf")
    planner = ferrobot.Planner(model, spheres=spheres)
    judge = ferrobot.CollisionChecker(model, spheres=spheres)
    idx = [planner.dof_names.index(n) for n in planner.joint_names]
    lo, hi = np.asarray(planner.limits.lower), np.asarray(planner.limits.upper)
    rng = np.random.default_rng(7)
    world = ferrobot.CollisionWorld()
    scene_classes.cage(world, rng)
    planner.update_world(world)
    judge.update_world(world)
    full = np.tile(planner.locked_positions, (4000, 1))
    full[:, idx] = rng.uniform(lo, hi, (4000, len(idx)))
    free = full[~judge.in_collision_batch(full)][:, idx]

    def length(path):
        return float(np.linalg.norm(np.diff(path, axis=0), axis=1).sum())

    def clean(path):
        qs = [path[:1]]
        for a, b in zip(path[:-1], path[1:], strict=True):
            n = max(1, int(np.ceil(np.abs(b - a).max() / 1e-3)))
            qs.append(a + (b - a) * (np.arange(1, n + 1)[:, None] / n))
        qs = np.concatenate(qs)
        full = np.tile(planner.locked_positions, (len(qs), 1))
        full[:, idx] = qs
        return not judge.in_collision_batch(full).any()

    bent, sums = 0, {"raw": 0.0, "reduced": 0.0, "default": 0.0, "gain0": 0.0, "gain_half": 0.0}
    for p in range(0, len(free) - 1, 2):
        start, goal = free[p], free[p + 1]
        raw = planner.plan(start, goal_q=goal, seed=p, trajectory=False, simplify=False)
        if not raw.success or len(raw.path) < 4:
            continue  # straight or nearly straight: nothing to shortcut
        bent += 1
        runs = {
            "raw": raw,
            "reduced": planner.plan(start, goal_q=goal, seed=p, trajectory=False, max_shortcuts=0),
            "default": planner.plan(start, goal_q=goal, seed=p, trajectory=False),
            "gain0": planner.plan(start, goal_q=goal, seed=p, trajectory=False, min_gain=0.0),
            "gain_half": planner.plan(start, goal_q=goal, seed=p, trajectory=False, options=PlanOptions(min_gain=0.5)),
        }
        for key, r in runs.items():
            assert r.success, (p, key)
            path = np.asarray(r.path)
            assert clean(path), (p, key)
            assert np.allclose(path[0], start) and np.allclose(path[-1], goal)
            sums[key] += length(path)
        # The triangle inequality, problem by problem (same seed, same RRT-Connect path).
        assert length(np.asarray(runs["reduced"].path)) <= length(np.asarray(raw.path)) + 1e-9
        assert length(np.asarray(runs["default"].path)) <= length(np.asarray(runs["reduced"].path)) + 1e-9
        if bent == 8:
            break
    assert bent >= 5, f"only {bent} problems needed shortcuts"
    # Shortcuts shorten the vertex-only reduction; a larger min_gain gives up some of them.
    assert sums["default"] < sums["reduced"] <= sums["raw"]
    assert sums["default"] < sums["gain_half"]
    # min_gain 0 checks every candidate: no longer than the default within the randomness of the shortcuts drawn.
    assert sums["gain0"] <= 1.02 * sums["default"]
    assert sums["gain_half"] <= sums["reduced"] + 1e-9
