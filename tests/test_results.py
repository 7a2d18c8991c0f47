"""Typed result objects (issue 16): what were plain dicts (``PlanResult.times``, ``Planner.limits``,
``Planner.world_sync_stats``, ``Robot.execute`` / ``execute_trajectory``'s tracking report, a controller's
``last_step``, the robot's drive gains) are frozen classes with attributes and ``to_dict()``; dict-style access
still works for one release and warns. References: the Panda's limits from Franka's datasheet, tracking errors
recomputed with numpy from the report's own desired/actual arrays, hand-derived step counts."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import ferrobot
from ferrobot.pipeline import build_world, random_scene


def _dict_style_warns(obj, field, value):
    """Every dict-style access warns and gives the attribute's value."""
    same = (lambda a, b: np.array_equal(a, b)) if isinstance(value, np.ndarray) else (lambda a, b: a == b)
    with pytest.warns(DeprecationWarning, match="dict-style access to results is deprecated"):
        assert same(obj[field], value)
    with pytest.warns(DeprecationWarning):
        assert field in obj and "nope" not in obj
    with pytest.warns(DeprecationWarning):
        assert list(obj.keys()) == list(obj.to_dict())
    with pytest.warns(DeprecationWarning):
        assert same(dict(obj.items())[field], value)
    with pytest.warns(DeprecationWarning):
        assert obj.get("nope", 7) == 7 and same(obj.get(field), value)
    with pytest.warns(DeprecationWarning):
        assert list(obj) == list(obj.to_dict())
    with pytest.warns(DeprecationWarning), pytest.raises(KeyError, match="nope"):
        obj["nope"]
    with pytest.raises(AttributeError):
        obj.nope  # noqa: B018


def _no_warning(f):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return f()


def test_plan_times_and_limits(bundled_panda):
    planner = ferrobot.Planner(bundled_panda)
    q0 = bundled_panda.named_state("ready")[:7]
    goal = q0 + np.array([0.3, -0.2, 0.1, 0.2, 0.0, 0.1, 0.0])
    r = planner.plan(q0, goal_q=goal)
    assert r.success
    t = _no_warning(lambda: r.times)
    assert type(t).__name__ == "PlanTimes"
    d = t.to_dict()
    assert list(d) == ["ik", "planning", "simplify", "trajectory", "fit", "recheck", "total"]
    assert all(isinstance(v, float) and v >= 0 for v in d.values())
    assert t.ik == 0.0  # a configuration goal needs no IK
    # The stages run one after another inside the call.
    assert t.planning + t.simplify + t.trajectory <= t.total * (1 + 1e-9)
    # fit and recheck are parts of the trajectory stage.
    assert t.fit + t.recheck <= t.trajectory * (1 + 1e-9)
    _dict_style_warns(t, "total", t.total)
    assert "total=" in repr(t)

    lim = planner.limits
    assert type(lim).__name__ == "JointLimits"
    # Franka Emika Panda datasheet: joint 1 in [-2.8973, 2.8973] rad, 2.1750 rad/s; joint 4 in
    # [-3.0718, -0.0698] rad; joint 7 2.61 rad/s.
    assert lim.lower[0] == pytest.approx(-2.8973) and lim.upper[0] == pytest.approx(2.8973)
    assert lim.lower[3] == pytest.approx(-3.0718) and lim.upper[3] == pytest.approx(-0.0698)
    assert lim.velocity[0] == pytest.approx(2.175) and lim.velocity[6] == pytest.approx(2.61)
    assert lim.acceleration.shape == lim.jerk.shape == (7,)
    _dict_style_warns(lim, "velocity", lim.velocity)


def test_world_sync_stats_count_builds():
    sim, _, _ = build_world(random_scene(seed=3))
    planner = ferrobot.Planner(ferrobot.robots.panda())
    s0 = planner.world_sync_stats
    assert type(s0).__name__ == "WorldSyncStats"
    assert s0.to_dict() == {"full_builds": 0, "incremental": 0, "added": 0, "removed": 0, "moved": 0}
    planner.update_world(sim)
    planner.update_world(sim)
    s = planner.world_sync_stats
    n = len(sim.object_names) + 1  # the objects and the ground plane (a slab named "ground")
    # The first sync builds the world with every object; the second finds them in place (nothing moved).
    assert (s.full_builds, s.incremental) == (1, 1)
    assert s.added == n and s.removed == 0
    _dict_style_warns(s, "full_builds", 1)


def test_tracking_report_fields_match_numpy():
    w = ferrobot.World(dt=1 / 240)
    r = w.add_robot(ferrobot.robots.panda(), q=ferrobot.robots.panda().named_state("ready"))
    arm = r.dof_names[:7]
    q0 = r.joint_positions[:7]
    qs = q0 + np.linspace(0.0, 0.2, 11)[:, None]  # 11 rows every 0.01 s: 0.1 s
    rep = r.execute_trajectory(qs, 0.01, joint_names=arm, settle_time=0.05)
    assert type(rep).__name__ == "TrackingReport"
    # (0.1 s + 0.05 s settle) at 240 Hz = 36 physics steps.
    m = 36
    assert rep.times.shape == (m,) and rep.desired.shape == rep.actual.shape == (m, 7)
    np.testing.assert_allclose(rep.times, np.arange(1, m + 1) / 240, atol=1e-12)
    np.testing.assert_allclose(rep.desired[-1], qs[-1], atol=1e-12)
    err = np.abs(rep.desired - rep.actual)
    np.testing.assert_allclose(rep.max_error, err.max(axis=0), atol=1e-12)
    np.testing.assert_allclose(rep.rms_error, np.sqrt((err**2).mean(axis=0)), atol=1e-12)
    np.testing.assert_allclose(rep.final_error, err[-1], atol=1e-12)
    _dict_style_warns(rep, "max_error", rep.max_error)
    assert set(rep.to_dict()) == {"times", "desired", "actual", "max_error", "rms_error", "final_error"}


def test_controller_step_info():
    model = ferrobot.robots.panda()
    ctl = ferrobot.ReactiveController(model, None, ferrobot.SphereModel.automatic(model, total_budget=59))
    assert ctl.last_step is None
    q = model.named_state("ready")
    ctl.step(q, np.zeros_like(q), 0.01)
    info = ctl.last_step
    assert type(info).__name__ == "ControlStepInfo"
    # No target and no world: nan target errors, nothing to avoid, guidance idle.
    assert np.isnan(info.position_error) and np.isnan(info.rotation_error)
    assert info.world_clearance == np.inf and info.guidance == "idle" and info.guidance_plans == 0
    assert isinstance(info.limit_braked, bool) and 0 < info.velocity_scale <= 1
    _dict_style_warns(info, "guidance", "idle")


def test_drive_gains():
    w = ferrobot.World()
    r = w.add_robot(ferrobot.robots.panda())
    r.set_drive_gains([300.0, 400.0], [30.0, 40.0], [50.0, np.inf], joint_names=["panda_joint3", "panda_joint5"])
    g = r.drive_gains
    assert type(g).__name__ == "DriveGains"
    assert (g.stiffness[2], g.stiffness[4], g.damping[2], g.damping[4]) == (300.0, 400.0, 30.0, 40.0)
    assert g.max_force[2] == 50.0 and g.max_force[4] == np.inf
    _dict_style_warns(g, "stiffness", g.stiffness)


def _box_cloud():
    g = np.linspace(-0.02, 0.02, 30)
    u, v = np.meshgrid(g, g)
    top = np.stack([u.ravel(), v.ravel(), np.full(u.size, 0.48)], axis=1)
    side = np.stack([np.full(u.size, 0.02), u.ravel(), 0.5 + v.ravel()], axis=1)
    side2 = np.stack([np.full(u.size, -0.02), u.ravel(), 0.5 + v.ravel()], axis=1)
    return np.concatenate([top, side, side2])


@pytest.mark.parametrize(
    ("gripper", "hand"),
    [
        # Panda hand: 50 mm pads -> depths 0.8, 0.6, 0.4, 0.3 of them = 40, 30, 20, 15 mm.
        (
            ferrobot.Gripper.panda_hand,
            dict(
                depths=[0.04, 0.03, 0.02, 0.015],
                max_width=0.08,
                finger_depth=0.05,
                finger_width=0.01,
                height=0.02,
                palm_width=0.208,
                palm_height=0.063,
                palm_depth=0.092,
            ),
        ),
        # Robotiq 2F-85: 37.5 mm pads -> 30, 22.5, 15, 11.25 mm.
        (
            ferrobot.Gripper.robotiq_2f85,
            dict(
                depths=[0.03, 0.0225, 0.015, 0.01125],
                finger_depth=0.0375,
                finger_width=0.007,
                height=0.022,
                palm_width=0.09,
                palm_height=0.065,
                palm_depth=0.06,
            ),
        ),
    ],
)
def test_detect_with_gripper_uses_pad_scaled_depths(gripper, hand):
    import ferrobot.grasp as fg

    g = gripper()
    # The opening is the gripper's (the 2F-85's four-bar map gives 85 mm, its name).
    hand.setdefault("max_width", g.max_opening)
    assert hand["max_width"] == pytest.approx(0.085 if "robotiq" in g.name.lower() else 0.08, abs=1e-3)
    cloud = _box_cloud()
    kw = dict(support_plane=False, num_seeds=24, max_grasps=8)
    by_gripper = fg.detect(cloud, gripper=g, **kw)
    by_hand = fg.detect(cloud, options=ferrobot.DetectOptions(**hand), **kw)
    assert len(by_gripper) > 0
    # The same grasps; 0.8 x 0.05 is 0.04000000000000001 in floating point, so compare to 1e-12.
    np.testing.assert_allclose(by_gripper.grasp_group_array, by_hand.grasp_group_array, rtol=0, atol=1e-12)
    # Overrides still win over the gripper's geometry.
    only = fg.detect(cloud, gripper=g, depths=[hand["depths"][0]], **kw)
    np.testing.assert_allclose(
        only.grasp_group_array,
        fg.detect(cloud, options=ferrobot.DetectOptions(**hand), depths=[hand["depths"][0]], **kw).grasp_group_array,
        rtol=0,
        atol=1e-12,
    )
    with pytest.raises(ferrobot.errors.InvalidArgumentError, match="gripper: expected a ferrobot.Gripper"):
        fg.detect(cloud, gripper="panda")
