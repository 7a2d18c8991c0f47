"""One naming scheme across the Python API (issue 16): ``fixed`` instead of the ``static_`` keyword (deprecated,
with a warning), joint subsets by ``joint_names`` as on the Planner (``joint_indices`` stays, Isaac Sim's
spelling), the object properties of every ``World.add_*`` read in one place."""

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


def test_robot_joint_subsets_by_name_match_indices():
    w = ferrobot.World()
    r = w.add_robot(ferrobot.robots.panda())
    names = r.dof_names
    pick = [names[5], names[1]]
    ix = [5, 1]
    r.set_joint_position_targets([0.3, -0.2], joint_names=pick)
    by_name = r.get_joint_position_targets()
    r.set_joint_position_targets([0.0, 0.0], joint_indices=ix)
    r.set_joint_position_targets([0.3, -0.2], joint_indices=ix)
    np.testing.assert_array_equal(by_name, r.get_joint_position_targets())
    assert by_name[5] == 0.3 and by_name[1] == -0.2
    r.set_drive_gains([100.0], [10.0], joint_names=[names[0]])
    k, d, _ = r.get_drive_gains()
    assert (k[0], d[0]) == (100.0, 10.0)
    with pytest.raises(InvalidArgumentError, match="not both"):
        r.set_joint_velocity_targets([0.0], joint_indices=[0], joint_names=[names[0]])
    with pytest.raises(UnknownNameError, match="nope"):
        r.set_joint_efforts([0.0], joint_names=["nope"])


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
