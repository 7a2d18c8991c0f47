"""Typed result objects (issue 16): what were plain dicts (``PlanResult.times``, ``Planner.limits``,
``Planner.world_sync_stats``, ``Robot.execute`` / ``execute_trajectory``'s tracking report, a controller's
``last_step``, the robot's drive gains) are frozen classes with attributes and ``to_dict()``; dict-style access
still works for one release and warns. Also the render frame, the collision and distance reports, inertials, joint
descriptions, lighting, the guidance plan and the camera's pose properties. References: the Panda's limits from
Franka's datasheet, tracking errors recomputed with numpy from the report's own desired/actual arrays, hand-derived
step counts and distances, a plane's depth by hand, the URDF read with ElementTree."""

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
        # Panda hand: 50 mm fingers -> depths 0.8, 0.6, 0.4 of them = 40, 30, 20 mm.
        (
            ferrobot.Gripper.panda_hand,
            dict(
                depths=[0.04, 0.03, 0.02],
                max_width=0.08,
                finger_depth=0.05,
                finger_width=0.01,
                height=0.02,
                palm_width=0.208,
                palm_height=0.063,
                palm_depth=0.092,
            ),
        ),
        # Robotiq 2F-85: 37.5 mm fingers -> 30, 22.5, 15 mm.
        (
            ferrobot.Gripper.robotiq_2f85,
            dict(
                depths=[0.03, 0.0225, 0.015],
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


# --- Issue 16 deliverable 5, the last dict results: render frames, collision reports, distances, inertials,
# joint descriptions, lighting, and the camera's properties.


def _look_down(height):
    """A camera pose (OpenCV frame: x right, y down, z forward) `height` m above the origin, looking down."""
    pose = np.diag([1.0, -1.0, -1.0, 1.0])
    pose[2, 3] = height
    return pose


def test_render_frame_attributes_and_a_plane_by_hand():
    w = ferrobot.World(ground=False)
    # A slab whose top face is the plane z = 0; the camera 0.8 m above it looks straight down.
    w.add_box("slab", [10.0, 10.0, 0.1], [0, 0, -0.05, 1, 0, 0, 0], fixed=True, color=[0.2, 0.6, 0.2])
    cam = ferrobot.Camera(w, 64, 48, 60.0, pose=_look_down(0.8))
    f = _no_warning(lambda: cam.render())
    assert type(f).__name__ == "RenderFrame"
    assert f.depth.shape == (48, 64) and f.depth.dtype == np.float32
    assert f.segmentation.shape == (48, 64) and f.segmentation.dtype == np.int32
    assert f.rgb.shape == (48, 64, 3) and f.rgb.dtype == np.uint8
    # A plane perpendicular to the optical axis is at the same depth (along the axis) in every pixel.
    np.testing.assert_allclose(f.depth, 0.8, atol=1e-5)
    slab = [k for k, v in w.segmentation_labels.items() if v == "slab"][0]
    assert np.all(f.segmentation == slab)
    # Green-dominant pixels: the slab's colour under the default grey lighting.
    assert np.all(f.rgb[..., 1] > f.rgb[..., 0])
    d = f.to_dict()
    assert list(d) == ["depth", "segmentation", "rgb"]
    for k in d:
        np.testing.assert_array_equal(d[k], getattr(f, k))
    _dict_style_warns(f, "depth", f.depth)
    no_rgb = cam.render(rgb=False)
    assert no_rgb.rgb is None
    np.testing.assert_array_equal(no_rgb.depth, f.depth)


def test_camera_pose_properties_and_deprecated_getters():
    w = ferrobot.World(ground=False)
    pose = _look_down(0.8)
    cam = ferrobot.Camera(w, 32, 24, 30.0, pose=pose)
    # Fixed to the world, the mount is the world frame: the local pose is the world pose.
    np.testing.assert_allclose(_no_warning(lambda: cam.world_transform), pose, atol=1e-12)
    np.testing.assert_allclose(_no_warning(lambda: cam.local_pose), pose, atol=1e-12)
    moved = _look_down(1.5)
    moved[:3, 3] = [0.1, -0.2, 1.5]
    cam.local_pose = moved
    np.testing.assert_allclose(cam.world_transform, moved, atol=1e-12)
    with pytest.warns(DeprecationWarning, match=r"Camera.get_world_transform\(\) is deprecated: read the property"):
        np.testing.assert_allclose(cam.get_world_transform(), moved, atol=1e-12)
    with pytest.warns(DeprecationWarning, match=r"Camera.get_local_pose\(\) is deprecated"):
        np.testing.assert_allclose(cam.get_local_pose(), moved, atol=1e-12)
    with pytest.warns(DeprecationWarning, match="assign Camera.local_pose"):
        cam.set_local_pose(pose)
    np.testing.assert_allclose(cam.local_pose, pose, atol=1e-12)
    with pytest.raises(ferrobot.errors.ShapeError, match="pose: expected a 4x4 matrix"):
        cam.local_pose = [1.0, 2.0]


# A one-joint robot with one 0.1 m sphere 0.5 m out along its arm: distances are written by hand.
_ARM = """<robot name="arm">
  <link name="base"/>
  <link name="arm"><collision><origin xyz="0.5 0 0"/><geometry><sphere radius="0.1"/></geometry></collision></link>
  <joint name="yaw" type="revolute"><parent link="base"/><child link="arm"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
</robot>"""


def test_collision_distance_and_contacts_by_hand(tmp_path):
    path = tmp_path / "arm.urdf"
    path.write_text(_ARM)
    model = ferrobot.RobotModel.from_urdf_string(_ARM)
    world = ferrobot.CollisionWorld()
    world.add_sphere("ball", 0.2, [1.0, 0.0, 0.0, 1, 0, 0, 0])
    checker = ferrobot.CollisionChecker(model, world, ferrobot.SphereModel.from_spherized_urdf(model, path))
    yaw = 0.7
    d = _no_warning(lambda: checker.distance([yaw]))
    assert type(d).__name__ == "CollisionDistance"
    centre = 0.5 * np.array([np.cos(yaw), np.sin(yaw), 0.0])
    expected = np.linalg.norm(centre - [1, 0, 0]) - 0.3
    assert d.distance == pytest.approx(expected, abs=1e-12) and d.world_distance == pytest.approx(expected, abs=1e-12)
    assert d.closest == ("arm", "ball") and d.gradient.shape == (1,)
    _dict_style_warns(d, "closest", ("arm", "ball"))
    # Ball moved to x = 0.65: at yaw 0 the arm's sphere (centre 0.5, r 0.1) overlaps it (r 0.2) by
    # (0.1 + 0.2) - 0.15 = 0.15 m.
    world.set_pose("ball", [0.65, 0.0, 0.0, 1, 0, 0, 0])
    checker.update_world(world)
    (c,) = _no_warning(lambda: checker.contacts([0.0]))
    assert type(c).__name__ == "Contact"
    assert (c.body, c.other, c.self_collision) == ("arm", "ball", False)
    assert c.depth == pytest.approx(0.15, abs=1e-12)
    _dict_style_warns(c, "depth", c.depth)


def test_self_collision_analysis_and_sphere_fit_report():
    model = ferrobot.robots.panda()
    spheres = ferrobot.SphereModel.automatic(model, total_budget=59)
    rep = _no_warning(lambda: spheres.report)
    assert all(type(r).__name__ == "SphereFit" for r in rep)
    # The report's counts are the spheres the model holds per link.
    for r in rep:
        assert r.spheres == len(spheres.spheres(r.link))
        assert 0.0 <= r.coverage <= 1.0 and 0.0 <= r.mean_protrusion <= r.max_protrusion
    assert sum(r.spheres for r in rep) == 59
    _dict_style_warns(rep[0], "link", rep[0].link)
    checker = ferrobot.CollisionChecker(model, spheres=spheres)
    a = _no_warning(lambda: checker.analyze_self_collisions(samples=50, seed=1))
    assert type(a).__name__ == "SelfCollisionAnalysis" and a.samples == 50
    # Never and always are excluded afterwards: they are now among the allowed pairs.
    excluded = {r for *_, r in checker.allowed_collision_pairs}
    assert (a.never > 0) == any("never" in r.lower() for r in excluded)
    _dict_style_warns(a, "samples", 50)


def test_sphere_distances_and_exact_clearance_by_hand():
    model = ferrobot.robots.panda()
    ball_c, ball_r = np.array([0.5, 0.3, 0.5]), 0.06
    world = ferrobot.CollisionWorld()
    world.add_sphere("ball", ball_r, [*ball_c, 1, 0, 0, 0])
    ctl = ferrobot.ReactiveController(model, world, ferrobot.SphereModel.automatic(model, total_budget=59))
    q = model.named_state("ready")
    s = _no_warning(lambda: ctl.sphere_distances(q, reach=10.0))
    assert type(s).__name__ == "SphereDistances"
    assert s.distance.shape == s.radii.shape == (59,) and s.centers.shape == s.direction.shape == (59, 3)
    # Sphere to ball, by hand from the reported centres and radii; the direction points away from the ball.
    np.testing.assert_allclose(s.distance, np.linalg.norm(s.centers - ball_c, axis=1) - ball_r - s.radii, atol=1e-9)
    away = (s.centers - ball_c) / np.linalg.norm(s.centers - ball_c, axis=1)[:, None]
    np.testing.assert_allclose(s.direction, away, atol=1e-9)
    _dict_style_warns(s, "radii", s.radii)
    c = _no_warning(lambda: ctl.exact_clearance(q))
    assert type(c).__name__ == "Clearance"
    assert c.closest is not None and c.closest[1] == "ball" and c.closest[0] in model.link_names
    # Exact geometry is inside the spheres up to their protrusion, so it is no nearer than the nearest sphere.
    assert 0.0 < s.distance.min() <= c.distance
    _dict_style_warns(c, "distance", c.distance)
    sc = ctl.exact_self_clearance(q)
    assert type(sc).__name__ == "Clearance" and sc.distance > 0.0


def _urdf_origin(el):
    from scipy.spatial.transform import Rotation

    o = el.find("origin")
    xyz = [float(v) for v in (o.get("xyz", "0 0 0") if o is not None else "0 0 0").split()]
    rpy = [float(v) for v in (o.get("rpy", "0 0 0") if o is not None else "0 0 0").split()]
    T = np.eye(4)
    T[:3, :3] = Rotation.from_euler("xyz", rpy).as_matrix()  # URDF rpy: fixed axes x, y, z
    T[:3, 3] = xyz
    return T


def test_inertials_and_joint_info_match_the_urdf_read_with_elementtree():
    import xml.etree.ElementTree as ET

    from conftest import PANDA_URDF

    root = ET.parse(PANDA_URDF).getroot()
    model = ferrobot.RobotModel.from_urdf(PANDA_URDF)
    w = ferrobot.World(ground=False)
    robot = w.add_robot(model)
    for link in root.findall("link"):
        el = link.find("inertial")
        if el is None:
            continue
        name = link.get("name")
        mass = float(el.find("mass").get("value"))
        a = {k: float(v) for k, v in el.find("inertia").attrib.items()}
        inertia = np.array(
            [[a["ixx"], a["ixy"], a["ixz"]], [a["ixy"], a["iyy"], a["iyz"]], [a["ixz"], a["iyz"], a["izz"]]]
        )
        origin = _urdf_origin(el)
        i = _no_warning(lambda name=name: model.inertial(name))
        assert type(i).__name__ == "Inertial"
        assert i.mass == pytest.approx(mass, rel=1e-12)
        np.testing.assert_allclose(i.origin, origin, atol=1e-9)
        np.testing.assert_allclose(i.inertia, inertia, atol=1e-12)
        li = _no_warning(lambda name=name: robot.get_link_inertial(name))
        assert type(li).__name__ == "LinkInertial"
        assert li.mass == pytest.approx(mass, rel=1e-6)
        np.testing.assert_allclose(li.com, origin[:3, 3], atol=1e-6)
        R = origin[:3, :3]
        np.testing.assert_allclose(li.inertia, R @ inertia @ R.T, atol=1e-6)
    _dict_style_warns(i, "mass", i.mass)
    _dict_style_warns(li, "com", li.com)
    checked = 0
    for j in root.findall("joint"):
        info = _no_warning(lambda j=j: model.joint_info(j.get("name")))
        assert type(info).__name__ == "JointInfo"
        assert (info.name, info.type) == (j.get("name"), j.get("type"))
        assert (info.parent, info.child) == (j.find("parent").get("link"), j.find("child").get("link"))
        np.testing.assert_allclose(info.origin, _urdf_origin(j), atol=1e-9)
        lim = j.find("limit")
        if j.get("type") != "fixed":
            axis = [float(v) for v in j.find("axis").get("xyz").split()]
            np.testing.assert_allclose(info.axis, axis, atol=1e-12)
        if lim is not None and j.get("type") == "revolute":
            assert (info.lower, info.upper) == (float(lim.get("lower")), float(lim.get("upper")))
            assert (info.velocity, info.effort) == (float(lim.get("velocity")), float(lim.get("effort")))
            checked += 1
        mimic = j.find("mimic")
        assert (info.mimic is None) == (mimic is None)
    assert checked == 7
    _dict_style_warns(info, "type", info.type)


def test_lighting_reads_back_what_was_set():
    w = ferrobot.World(ground=False)
    w.set_lighting(ambient=[0.1, 0.2, 0.3], headlight=0.4, lights=[([0.0, 0.0, -1.0], [1.0, 0.9, 0.8], 2.5)])
    lt = _no_warning(lambda: w.lighting)
    assert type(lt).__name__ == "Lighting"
    assert lt.ambient == pytest.approx([0.1, 0.2, 0.3]) and lt.headlight == pytest.approx(0.4)
    ((direction, color, intensity),) = lt.lights
    np.testing.assert_allclose(color, [1.0, 0.9, 0.8])
    assert intensity == pytest.approx(2.5)
    # Stored as given or normalised: either way a unit vector along -z.
    np.testing.assert_allclose(np.asarray(direction) / np.linalg.norm(direction), [0.0, 0.0, -1.0])
    _dict_style_warns(lt, "headlight", lt.headlight)


def test_guidance_last_plan_after_a_stall():
    model = ferrobot.robots.panda()
    ctl = ferrobot.ReactiveController(
        model, None, ferrobot.SphereModel.automatic(model, total_budget=59), config={"guidance_blocking": 1}
    )
    q = model.named_state("ready")
    goal = q.copy()
    goal[0] += 1.0
    goal[3] += 0.5
    ctl.set_target(model.fk(goal))
    # The measured state never moves (nothing integrates the commands): the controller stalls and plans.
    for _ in range(1000):
        ctl.step(q, np.zeros(model.num_dof), 0.01)
        if ctl.guidance_last_plan is not None:
            break
    p = _no_warning(lambda: ctl.guidance_last_plan)
    assert type(p).__name__ == "GuidancePlan"
    # An empty world: the planner connects start and IK goal directly; the controller follows those waypoints.
    assert p.status == "solved" and p.waypoints >= 2 and p.waypoints == ctl.waypoints_remaining
    assert ctl.last_step.guidance == "guided" and ctl.last_step.guidance_plans == 1
    assert 0.0 < p.seconds < 60.0
    _dict_style_warns(p, "status", "solved")


# --- sim-to-real and fault-injection reads (issue 16, last debts) ---


def test_friction_fit_recovers_the_law_it_was_fed():
    v = np.linspace(-1.0, 1.0, 41)  # 0.0 and |v| <= 1e-3 are skipped: 40 equations
    e = 0.3 * np.sign(v) + 0.05 * v
    fit = _no_warning(lambda: ferrobot._core.identify_friction(v, e, 1e-3))
    assert type(fit).__name__ == "FrictionFit"
    assert fit.coulomb == pytest.approx(0.3, abs=1e-9) and fit.viscous == pytest.approx(0.05, abs=1e-9)
    assert fit.rms_residual == pytest.approx(0.0, abs=1e-9) and fit.equations == 40
    assert fit.condition >= 1.0
    # The wrapper keeps its own dataclass, filled from the attributes.
    f = _no_warning(lambda: ferrobot.calibration.identify_friction(v, e))
    assert (f.coulomb, f.equations) == (pytest.approx(0.3, abs=1e-9), 40)
    _dict_style_warns(fit, "viscous", fit.viscous)


def test_payload_and_link_mass_fits(bundled_panda):
    core = ferrobot._core
    g = np.array([0.0, 0.0, -9.81])
    rng = np.random.default_rng(3)
    lo, hi = bundled_panda.lower_limits, bundled_panda.upper_limits
    qs = rng.uniform(lo, hi, size=(12, bundled_panda.num_dof))
    m, com = 0.8, np.array([0.01, -0.02, 0.05])
    theta = np.array([m, *(m * com)])  # the regressor's parameters: [m, m cx, m cy, m cz]
    base = np.array([core.gravity_torques(bundled_panda, q, g) for q in qs])
    link = "panda_link7"
    e = base + np.array([core.payload_regressor(bundled_panda, q, link, g) @ theta for q in qs])
    p = _no_warning(lambda: core.identify_payload(bundled_panda, link, qs, e, g))
    assert type(p).__name__ == "PayloadFit"
    assert p.mass == pytest.approx(m, rel=1e-6)
    np.testing.assert_allclose(p.com, com, atol=1e-6)
    assert p.rms_residual == pytest.approx(0.0, abs=1e-6) and p.equations > 0
    _dict_style_warns(p, "mass", p.mass)
    # Efforts that are exactly the model's gravity torques: no mass is missing anywhere.
    fit = _no_warning(lambda: ferrobot.calibration.identify_link_masses(bundled_panda, ["panda_link5", link], qs, base))
    assert type(fit).__name__ == "LinkMassFit"
    np.testing.assert_allclose(fit.offsets, [0.0, 0.0], atol=1e-6)
    _dict_style_warns(fit, "offsets", fit.offsets)


def test_arbiter_conflict_names_winner_and_loser():
    arb = ferrobot._core.Arbiter(2, 0.1, 1e-9)
    arb.add_source("teleop", 1)
    arb.add_source("policy", 0)
    arb.command("policy", 0.0, [0], [0.5])
    arb.command("teleop", 0.0, [0], [0.2])
    arb.resolve(0.01)
    (c,) = _no_warning(lambda: arb.conflicts)
    assert type(c).__name__ == "ArbiterConflict"
    assert (c.joint, c.winner, c.losers) == (0, "teleop", ["policy"]) and 0.0 <= c.t <= 0.01
    _dict_style_warns(c, "winner", "teleop")


def test_stream_guard_step_holds_then_rate_limits():
    g = ferrobot.StreamGuard(0.05, [1.0])
    first = _no_warning(lambda: g.update(0.0, [0.0], [0.0]))
    assert type(first).__name__ == "StreamGuardStep"
    assert first.step == 0.0 and not first.holding and not first.catching_up
    assert g.update(0.2, None, [0.0]).holding  # nothing for 0.2 s > timeout 0.05 s
    out = g.update(0.21, [1.0], [0.0])  # resumes at most 1 rad/s * 0.01 s
    assert out.command[0] == pytest.approx(0.01) and out.catching_up and out.step == pytest.approx(0.01)
    _dict_style_warns(out, "step", out.step)


def test_depth_noise_params_are_what_was_given():
    given = {
        "sigma0": 0.002,
        "sigma2": 0.003,
        "z0": 0.5,
        "dropout": 0.1,
        "edge_threshold": 0.04,
        "edge_dropout": 0.3,
        "missing_value": 0.0,
    }
    p = _no_warning(lambda: ferrobot._core.DepthNoise(**given, seed=1).params())
    assert type(p).__name__ == "DepthNoiseParams"
    assert p.to_dict() == given and p.z0 == 0.5
    _dict_style_warns(p, "sigma2", 0.003)


def test_urdf_check_report_points_at_the_line(tmp_path):
    inertia = '<inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/>'
    link = '<link name="{n}"><inertial><mass value="1"/>' + inertia + "</inertial></link>\n"
    text = (
        '<robot name="two">\n'
        + link.format(n="a")
        + link.format(n="b")
        + '<joint name="j" type="revolute"><parent link="a"/><child link="b"/>\n'
        + '<axis xyz="0 0 0"/>\n'
        + '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>\n</robot>\n'
    )
    path = tmp_path / "two.urdf"
    path.write_text(text)
    rep = _no_warning(lambda: ferrobot._core.urdf_check(str(path), skip_coverage=True))
    assert type(rep).__name__ == "UrdfCheckReport"
    assert rep.robot == "two" and str(path) in rep.source and "a" in rep.tree and "b" in rep.tree
    (f,) = [f for f in rep.findings if f.code == "zero-axis"]
    assert type(f).__name__ == "UrdfFinding"
    assert f.line == 5 and f.severity == "error" and f.element == "j" and f.message
    _dict_style_warns(f, "line", 5)
    _dict_style_warns(rep, "robot", "two")


def test_loaded_mesh_of_a_cube(tmp_path):
    s = 0.1  # an axis-aligned cube of side s: 8 vertices, 12 triangles, volume s**3
    v = [(x, y, z) for x in (0, s) for y in (0, s) for z in (0, s)]
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    lines = [f"v {x} {y} {z}" for x, y, z in v] + [f"f {a + 1} {b + 1} {c + 1} {d + 1}" for a, b, c, d in quads]
    path = tmp_path / "cube.obj"
    path.write_text("\n".join(lines) + "\n")
    mesh = _no_warning(lambda: ferrobot.load_mesh(path, 2.0))
    assert type(mesh).__name__ == "LoadedMesh"
    assert mesh.vertices.shape == (8, 3) and mesh.faces.shape == (12, 3) and mesh.closed
    np.testing.assert_allclose(np.sort(np.unique(mesh.vertices)), [0.0, 2 * s], atol=1e-12)
    assert mesh.volume == pytest.approx((2 * s) ** 3, rel=0.02) and len(mesh.parts) >= 1
    _dict_style_warns(mesh, "volume", mesh.volume)
