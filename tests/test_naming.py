"""One naming scheme across the Python API (issue 16): ``fixed`` instead of the ``static_`` keyword (deprecated,
with a warning), joint subsets by ``joint_names`` everywhere (``joint_indices`` deprecated with a warning; Isaac
Sim's spelling stays in ``ferrobot.compat.isaac.Articulation``), state read through properties (the ``get_*``
getters warn), the object properties of every ``World.add_*`` read in one place."""

from __future__ import annotations

import numpy as np
import pytest

import ferrobot
from ferrobot.errors import InvalidArgumentError, UnknownNameError

G = 9.81


def _fall(world: ferrobot.World, name: str, steps: int) -> float:
    z0 = world.get_object_pose(name)[2, 3]
    for _ in range(steps):
        world.step()
    return z0 - world.get_object_pose(name)[2, 3]


def test_fixed_replaces_static_underscore():
    w = ferrobot.World(dt=1 / 240, ground=False)
    w.add_box("free", [0.1, 0.1, 0.1], [0, 0, 5.0, 1, 0, 0, 0])
    w.add_box("fixed", [0.1, 0.1, 0.1], [1, 0, 5.0, 1, 0, 0, 0], fixed=True)
    with pytest.warns(DeprecationWarning, match="static_=.*deprecated: use fixed="):
        w.add_box("old", [0.1, 0.1, 0.1], [2, 0, 5.0, 1, 0, 0, 0], static_=True)
    n = 60
    t = n / 240
    # Free fall for 0.25 s: g t^2 / 2 = 0.3066 m (semi-implicit Euler steps fall g dt^2 n(n+1)/2).
    assert _fall(w, "free", 0) == 0.0
    w2 = ferrobot.World(dt=1 / 240, ground=False)
    w2.add_box("free", [0.1, 0.1, 0.1], [0, 0, 5.0, 1, 0, 0, 0])
    drop = _fall(w2, "free", n)
    assert drop == pytest.approx(G * t * t / 2, rel=0.03)
    assert _fall(w, "fixed", n) == 0.0
    assert _fall(w, "old", 1) == 0.0
    with pytest.raises(InvalidArgumentError, match="not both"), pytest.warns(DeprecationWarning):
        w.add_sphere("x", 0.05, fixed=True, static_=True)
    with pytest.raises(InvalidArgumentError, match="unknown object property 'static'"):
        w.add_sphere("y", 0.05, static=True)
    with pytest.raises(InvalidArgumentError, match="mass"):
        w.add_sphere("z", 0.05, mass=0.0)
    with pytest.raises(InvalidArgumentError, match="fixed: expected a bool"):
        w.add_sphere("z", 0.05, fixed="yes")
    with pytest.raises(InvalidArgumentError, match="friction: expected a number, got a bool"):
        w.add_sphere("z", 0.05, friction=True)
    # A fixed object's mass is not checked (it has none).
    w.add_capsule("c", 0.02, 0.1, [3, 0, 1, 1, 0, 0, 0], fixed=True, mass=0.0, color=(1.0, 0.0, 0.0))


def test_robot_joint_subsets_by_name_match_deprecated_indices():
    w = ferrobot.World()
    r = w.add_robot(ferrobot.robots.panda())
    names = r.dof_names
    pick = [names[5], names[1]]
    ix = [5, 1]
    r.set_joint_position_targets([0.3, -0.2], joint_names=pick)
    by_name = r.joint_position_targets
    with pytest.warns(DeprecationWarning, match=r"set_joint_position_targets\(joint_indices=...\) is deprecated"):
        r.set_joint_position_targets([0.0, 0.0], joint_indices=ix)
        r.set_joint_position_targets([0.3, -0.2], joint_indices=ix)
    np.testing.assert_array_equal(by_name, r.joint_position_targets)
    assert by_name[5] == 0.3 and by_name[1] == -0.2
    r.set_drive_gains([100.0], [10.0], joint_names=[names[0]])
    g = r.drive_gains
    assert (g.stiffness[0], g.damping[0]) == (100.0, 10.0)
    for call in (r.set_joint_velocity_targets, r.set_joint_efforts):
        with pytest.warns(DeprecationWarning, match="joint_indices=...\\) is deprecated: use joint_names="):
            call([0.0], joint_indices=[0])
    with pytest.warns(DeprecationWarning, match="set_drive_gains"):
        r.set_drive_gains([100.0], [10.0], joint_indices=[0])
    with pytest.warns(DeprecationWarning, match="execute_trajectory"):
        r.execute_trajectory([[0.0], [0.0]], 1 / 240, joint_indices=[0])
    with pytest.raises(InvalidArgumentError, match="not both"):
        r.set_joint_velocity_targets([0.0], joint_indices=[0], joint_names=[names[0]])
    with pytest.raises(UnknownNameError, match="nope"):
        r.set_joint_efforts([0.0], joint_names=["nope"])


def test_new_spellings_do_not_warn():
    import warnings

    w = ferrobot.World()
    r = w.add_robot(ferrobot.robots.panda())
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        r.set_joint_position_targets([0.1], joint_names=[r.dof_names[0]])
        _ = (r.joint_positions, r.joint_velocities, r.joint_position_targets, r.drive_gains, r.world_transform)
        _ = (r.applied_joint_efforts, r.measured_joint_efforts, r.gripper_positions, r.gripper_opening)
        rep = r.execute_trajectory([[0.0], [0.1]], 1 / 240, joint_names=[r.dof_names[0]])
        _ = (rep.max_error, rep.to_dict())


def test_getters_are_properties_and_old_getters_warn():
    w = ferrobot.World(dt=1 / 240)
    r = w.add_robot(ferrobot.robots.panda())
    q = np.array([0.1, -0.3, 0.2, -2.0, 0.1, 1.9, 0.7, 0.03])
    r.set_joint_positions(q)
    r.set_joint_position_targets(q)
    r.set_joint_efforts([1.5], joint_names=["panda_joint2"])
    # Hand values: what was set (the simulator stores float32), and the identity base.
    np.testing.assert_allclose(r.joint_positions, q, atol=1e-6)
    np.testing.assert_array_equal(r.joint_velocities, np.zeros(8))
    np.testing.assert_allclose(r.joint_position_targets, q, atol=1e-6)
    np.testing.assert_array_equal(r.applied_joint_efforts, [0, 1.5, 0, 0, 0, 0, 0, 0])
    np.testing.assert_array_equal(r.world_transform, np.eye(4))
    # The Panda's fingers: each finger at 0.03 m, so 0.06 m between the pads.
    assert r.gripper_opening == pytest.approx(0.06, abs=1e-6)
    for old, new in [
        ("get_joint_positions", "joint_positions"),
        ("get_joint_velocities", "joint_velocities"),
        ("get_joint_position_targets", "joint_position_targets"),
        ("get_applied_joint_efforts", "applied_joint_efforts"),
        ("get_measured_joint_efforts", "measured_joint_efforts"),
        ("get_gripper_positions", "gripper_positions"),
        ("get_world_transform", "world_transform"),
        ("get_gripper_opening", "gripper_opening"),
    ]:
        with pytest.warns(DeprecationWarning, match=rf"Robot.{old}\(\) is deprecated: read the property Robot.{new}"):
            got = getattr(r, old)()
        np.testing.assert_array_equal(got, getattr(r, new))
    with pytest.warns(DeprecationWarning, match="get_drive_gains"):
        k, d, f = r.get_drive_gains()
    g = r.drive_gains
    np.testing.assert_array_equal(k, g.stiffness)
    np.testing.assert_array_equal(d, g.damping)
    np.testing.assert_array_equal(f, g.max_force)


def test_isaac_articulation_keeps_indices_and_getters_without_warnings():
    import warnings

    from ferrobot.compat.isaac import Articulation

    w = ferrobot.World()
    r = w.add_robot(ferrobot.robots.panda())
    a = Articulation(r)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        a.set_joint_position_targets([0.25, -0.5], joint_indices=[2, 4])
        a.set_gains(kps=[50.0], kds=[5.0], joint_indices=[6])
        np.testing.assert_array_equal(a.get_joint_position_targets([2, 4]), [0.25, -0.5])
        np.testing.assert_array_equal(a.get_gains([6])[0], [50.0])
        before = a.get_joint_positions()
        a.set_joint_positions([0.5], joint_indices=[0])  # 0.5: exact in the simulator's float32
        assert a.get_joint_positions([0]).tolist() == [0.5]
        np.testing.assert_array_equal(a.get_joint_positions()[1:], before[1:])  # the others stay
        assert a.dof_names == r.dof_names  # everything else is the robot's
    assert r.joint_position_targets[2] == 0.25 and r.joint_position_targets[4] == -0.5
    assert r.drive_gains.stiffness[6] == 50.0 and r.drive_gains.damping[6] == 5.0
    with pytest.raises(UnknownNameError, match="out of range"):
        a.set_joint_efforts([0.0], joint_indices=[8])


def test_controllers_and_steppers_take_joint_names():
    from ferrobot.control import ControlStepper

    m = ferrobot.robots.panda()
    q = m.named_state("ready")
    target = m.fk(q)
    target[2, 3] -= 0.05
    by_name = ferrobot.ResolvedRateController(m, joint_names=m.dof_names[:6])
    with pytest.warns(DeprecationWarning, match="ResolvedRateController\\(joint_indices=...\\) is deprecated"):
        by_index = ferrobot.ResolvedRateController(m, joint_indices=list(range(6)))
    v = by_name.compute(q, target)
    np.testing.assert_array_equal(v, by_index.compute(q, target))
    assert v[6] == 0.0 and v[7] == 0.0 and np.abs(v[:6]).max() > 0  # joint 7 and the finger not used
    w = ferrobot.World()
    r = w.add_robot(m)
    s = ControlStepper(w, r, control_hz=60.0, arm_joint_names=m.dof_names[:7])
    assert s.arm == list(range(7)) and s.arm_names == m.dof_names[:7]
    with pytest.warns(DeprecationWarning, match="arm_joint_indices"):
        old = ControlStepper(w, r, control_hz=60.0, arm_joint_indices=list(range(7)))
    assert old.arm_names == s.arm_names
    with pytest.raises(UnknownNameError, match="nope"):
        ControlStepper(w, r, arm_joint_names=["nope"])


def test_setters_are_properties_and_old_methods_warn(bundled_panda):
    p = ferrobot.Planner(bundled_panda)
    q = bundled_panda.named_state("ready").copy()
    q[-1] = 0.02
    p.locked_positions = q
    assert p.locked_positions[-1] == 0.02
    q[-1] = 0.03
    with pytest.warns(DeprecationWarning, match="assign Planner.locked_positions"):
        p.set_locked_positions(q)
    assert p.locked_positions[-1] == 0.03
    w = ferrobot.World()
    r = w.add_robot(bundled_panda)
    r.command_latency = 0.01
    assert r.command_latency == 0.01
    with pytest.warns(DeprecationWarning, match="assign Robot.command_latency"):
        r.set_command_latency(0.02)
    assert r.command_latency == 0.02


def test_mesh_file_reads_the_shared_properties_before_its_shape(tmp_path):
    # A 0.1 m cube as an OBJ file (8 vertices, 12 triangles), written here.
    v = np.array([[x, y, z] for x in (-0.05, 0.05) for y in (-0.05, 0.05) for z in (-0.05, 0.05)])
    faces = [(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1)]
    faces += [(2, 3, 7), (2, 7, 6), (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3)]
    path = tmp_path / "cube.obj"
    path.write_text(
        "".join(f"v {a} {b} {c}\n" for a, b, c in v) + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in faces)
    )
    w = ferrobot.World()
    # `fixed` (read first) picks the default approximation: a static triangle mesh, which has no volume.
    with pytest.raises(InvalidArgumentError, match="density needs a solid"):
        w.add_mesh_file("a", path, fixed=True, density=500.0)
    with (
        pytest.warns(DeprecationWarning, match="static_"),
        pytest.raises(InvalidArgumentError, match="density needs a solid"),
    ):
        w.add_mesh_file("b", path, static_=True, density=500.0)
    # Dynamic: a convex decomposition; 1e-4 kg/m3 x 1e-3 m3 = 1e-7 kg is below the 1e-6 kg minimum.
    with pytest.raises(InvalidArgumentError, match="mass from density"):
        w.add_mesh_file("c", path, density=1e-4)
    with pytest.raises(InvalidArgumentError, match="mass or density"):
        w.add_mesh_file("d", path, mass=1.0, density=500.0)
    with pytest.raises(InvalidArgumentError, match="unknown object property 'colour'"):
        w.add_mesh_file("e", path, colour=(1, 0, 0))
    with pytest.raises(InvalidArgumentError, match="friction"):
        w.add_mesh_file("f", path, friction=-1.0)
    assert w.object_names == []
    w.add_mesh_file("g", path, [0, 0, 1, 1, 0, 0, 0], density=1000.0, friction=0.9, color=(0.0, 1.0, 0.0))
    w.add_mesh_file("h", path, [1, 0, 0.05, 1, 0, 0, 0], fixed=True)
    assert w.object_names == ["g", "h"]
