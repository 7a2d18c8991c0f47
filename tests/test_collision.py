"""Collision worlds, sphere models and checks: MotionBenchMaker scenes, analytic
distances, finite-difference gradients, batch/scalar agreement and errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

import ferrobot
from conftest import PANDA_SRDF, PANDA_URDF, SHARED
from ferrobot import CollisionChecker, CollisionWorld, RobotModel, SphereModel
from ferrobot import errors as E

MBM = SHARED / "bench" / "mbm"
SPHERIZED = SHARED / "robots" / "panda" / "panda_spherized.urdf"

# A one-joint robot with one sphere on a 0.5 m arm: distances are easy to write by hand.
ARM = """<robot name="arm">
  <link name="base"/>
  <link name="arm"><collision><origin xyz="0.5 0 0"/><geometry><sphere radius="0.1"/></geometry></collision></link>
  <joint name="yaw" type="revolute"><parent link="base"/><child link="arm"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
</robot>"""


@pytest.fixture(scope="module")
def panda():
    return RobotModel.from_urdf(PANDA_URDF, srdf=PANDA_SRDF)


@pytest.fixture(scope="module")
def panda_spheres(panda):
    return SphereModel.from_spherized_urdf(panda, SPHERIZED)


def problems():
    for scene_dir in sorted(MBM.iterdir()):
        for scene in sorted(scene_dir.glob("scene*.yaml")):
            yield scene_dir.name, scene, scene_dir / scene.name.replace("scene", "request")


def joint_values(names, positions, wanted):
    lookup = dict(zip(names, positions, strict=True))
    return np.array([lookup[n] for n in wanted])


def test_every_motionbenchmaker_problem_parses_and_start_goal_validity(panda, panda_spheres):
    checker = CollisionChecker(panda, spheres=panda_spheres)
    report = {}
    for scene_name, scene, request in problems():
        world = CollisionWorld.from_moveit_scene(scene)
        assert len(world) > 0
        req = yaml.safe_load(request.read_text())
        js = req["start_state"]["joint_state"]
        start = joint_values(js["name"], js["position"], panda.dof_names)
        goal = {c["joint_name"]: c["position"] for c in req["goal_constraints"][0]["joint_constraints"]}
        goal = np.array([goal[n] for n in panda.dof_names])
        checker.update_world(world)
        valid = not checker.in_collision(start) and not checker.in_collision(goal)
        report.setdefault(scene_name, []).append(valid)
    assert sorted(report) == ["bookshelf_small_panda", "table_pick_panda"]
    for scene_name, flags in report.items():
        assert len(flags) == 100
        # Most problems are valid; a few starts or goals touch the scene under the spherized model.
        assert sum(flags) >= 80, (scene_name, sum(flags))


def test_moveit_scene_contents():
    world = CollisionWorld.from_moveit_scene(MBM / "table_pick_panda" / "scene0001.yaml")
    assert "Can1" in world and "Cube" in world
    assert world.kinds("Can1") == ["cylinder"]
    # no object pose in the file: the object frame is the world frame, the primitive pose places it
    assert np.allclose(world.get_pose("Cube"), np.eye(4))
    centre = np.array([-0.04815510236526688, 0.9893543728427527, 0.3484669621486253])
    yaw = 2 * np.arctan2(0.2514099244310241, 0.9678807002402656)  # (x, y, z, w) in the file
    along_x = np.array([np.cos(yaw), np.sin(yaw), 0.0])
    probes = [centre, centre + [0, 0, 0.2], centre + 0.2 * along_x, centre + 0.2 * np.array([1.0, 0, 0])]
    d = world.signed_distance(probes)
    # the cube is 0.25 m: -0.125 at its centre, 0.075 at 0.2 m above or along its own x axis
    assert np.allclose(d[:3], [-0.125, 0.075, 0.075])
    assert d[3] < 0.075  # along world x the rotated cube's corner is closer


def test_analytic_distances_and_gradient_against_finite_differences():
    model = RobotModel.from_urdf_string(ARM)
    spheres = SphereModel.from_spherized_urdf(model, _write(ARM))
    world = CollisionWorld()
    world.add_sphere("ball", 0.2, [1.0, 0.0, 0.0, 1, 0, 0, 0])
    checker = CollisionChecker(model, world, spheres)
    for yaw in [0.0, 0.3, -1.0, 2.0]:
        q = np.array([yaw])
        centre = 0.5 * np.array([np.cos(yaw), np.sin(yaw), 0.0])
        expected = np.linalg.norm(centre - [1, 0, 0]) - 0.3
        d = checker.distance(q)
        assert d.distance == pytest.approx(expected, abs=1e-12)
        assert d.closest == ("arm", "ball")
        h = 1e-6
        fd = (checker.distance(q + h).distance - checker.distance(q - h).distance) / (2 * h)
        assert d.gradient[0] == pytest.approx(fd, abs=1e-6)
        assert checker.in_collision(q) == (expected < 0)
    # margin: free at 0.25 m clearance, colliding with a 0.26 m margin
    q = np.array([np.arccos((1 + 0.25 - 0.55**2) / (2 * 0.5))])  # centre 0.55 m from the ball centre
    assert checker.distance(q).distance == pytest.approx(0.25, abs=1e-9)
    assert not checker.in_collision(q)
    checker.margin = 0.26
    assert checker.in_collision(q)
    assert "arm hits ball" in checker.explain(q)


def _write(text: str) -> Path:
    import tempfile

    p = Path(tempfile.mkdtemp()) / "robot.urdf"
    p.write_text(text)
    return p


def test_batch_equals_scalar_and_motion_matches_dense_checks(panda, panda_spheres):
    world = CollisionWorld.from_moveit_scene(MBM / "bookshelf_small_panda" / "scene0007.yaml")
    checker = CollisionChecker(panda, world, panda_spheres)
    rng = np.random.default_rng(1)
    qs = rng.uniform(panda.lower_limits, panda.upper_limits, size=(1001, 7))
    batch = checker.in_collision_batch(qs)
    assert batch.dtype == np.bool_ and batch.shape == (1001,)
    assert list(batch) == [checker.in_collision(q) for q in qs]
    assert 0 < batch.sum() < len(qs)
    for a, b in zip(qs[:50], qs[50:100], strict=True):
        b = a + np.clip(b - a, -0.3, 0.3)
        steps = int(np.ceil(np.abs(b - a).max() / 0.005))
        dense = [a + (b - a) * k / steps for k in range(steps + 1)]
        assert checker.motion_valid(a, b, 0.005) == (not checker.in_collision_batch(np.array(dense)).any())


def test_contacts_explain_self_collision(panda, panda_spheres):
    checker = CollisionChecker(panda, spheres=panda_spheres)
    folded = np.array([0, 0, 0, -3.0, 0, 0.5, 0])  # elbow fully bent: the hand comes back onto link1
    assert checker.in_collision(folded)
    contacts = checker.contacts(folded)
    hand = [c for c in contacts if {c.body, c.other} == {"panda_link1", "panda_hand"}]
    assert len(hand) == 1 and hand[0].self_collision
    # Independent reference: the deepest overlap of the two links' spheres placed with fk_all.
    poses = dict(zip(panda.link_names, panda.fk_all(folded), strict=True))

    def placed(link):
        s = panda_spheres.spheres(link)
        return (poses[link][:3, :3] @ s[:, :3].T).T + poses[link][:3, 3], s[:, 3]

    (ca, ra), (cb, rb) = placed("panda_link1"), placed("panda_hand")
    gaps = np.linalg.norm(ca[:, None] - cb[None], axis=2) - ra[:, None] - rb[None]
    assert hand[0].depth == pytest.approx(-gaps.min(), abs=1e-9)
    assert "panda_link1 hits robot link panda_hand" in checker.explain(folded)
    assert checker.explain(panda.named_state("ready")) == "collision-free"


def test_attach_and_detach(panda, panda_spheres):
    world = CollisionWorld()
    world.add_box("table", [0.3, 0.3, 0.05], [0.3, 0, 0.1, 1, 0, 0, 0])
    checker = CollisionChecker(panda, world, panda_spheres)
    q = panda.named_state("ready")
    assert not checker.in_collision(q)
    hand_z = panda.fk(q, "panda_hand")[2, 3]
    # a long rod held in the hand reaching down through the table
    checker.attach(
        "rod",
        "panda_hand",
        ("cylinder", 0.02, 2 * (hand_z - 0.1)),
        [0, 0, 0.1, 1, 0, 0, 0],
        touch_links=["panda_leftfinger", "panda_rightfinger"],
    )
    assert checker.attached == ["rod"]
    assert checker.in_collision(q)
    assert "attached:rod hits table" in checker.explain(q)
    checker.detach("rod", q)
    assert "rod" in checker.world and checker.attached == []
    with pytest.raises(E.UnknownNameError):
        checker.detach("rod")


def test_bad_input(panda, panda_spheres):
    world = CollisionWorld()
    with pytest.raises(E.InvalidArgumentError, match="box size must be positive"):
        world.add_box("b", [1, -1, 1])
    with pytest.raises(E.NonFiniteError):
        world.add_sphere("s", 0.1, [np.nan, 0, 0, 1, 0, 0, 0])
    with pytest.raises(E.InvalidArgumentError, match="quaternion"):
        world.add_sphere("s", 0.1, [0, 0, 0, 2, 0, 0, 0])
    with pytest.raises(E.ShapeError, match="4x4 matrix or a 7-vector"):
        world.add_sphere("s", 0.1, [0, 0, 0])
    world.add_sphere("s", 0.1)
    with pytest.raises(E.DuplicateNameError, match="exists already"):
        world.add_sphere("s", 0.1)
    with pytest.raises(E.UnknownNameError, match="unknown world object 'x'"):
        world.remove("x")
    scene = _write("").parent / "scene.yaml"
    scene.write_text(
        "world:\n  collision_objects:\n    - id: c\n      primitives:\n        - type: cone\n"
        "          dimensions: [1, 1]\n"
    )
    with pytest.raises(E.FileFormatError, match="unknown or unsupported primitive type 'cone'"):
        CollisionWorld.from_moveit_scene(scene)
    checker = CollisionChecker(panda, world, panda_spheres)
    with pytest.raises(E.UnknownNameError, match="unknown link 'nope'"):
        checker.attach("x", "nope", ("sphere", 0.1))
    with pytest.raises(E.InvalidArgumentError, match="shape: expected"):
        checker.attach("x", "panda_hand", ("cylinder", 0.1))
    with pytest.raises(E.InvalidArgumentError, match="unknown shape type 'cone'"):
        checker.attach("x", "panda_hand", ("cone", 0.1, 0.2))
    with pytest.raises(E.InvalidArgumentError, match="whose links differ"):
        CollisionChecker(ferrobot.robots.panda(), spheres=panda_spheres)
    with pytest.raises(E.NonFiniteError):
        checker.in_collision([0, 0, 0, np.nan, 0, 0, 0])
    with pytest.raises(E.ShapeError):
        checker.in_collision_batch(np.zeros((3, 6)))
    with pytest.raises(E.InvalidArgumentError, match="resolution"):
        checker.motion_valid(np.zeros(7), np.ones(7), 0.0)
    assert isinstance(ferrobot.CollisionChecker, type)
