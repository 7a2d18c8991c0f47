"""Issue 17: the gripper description, the bundled UR5e + Robotiq 2F-85, grippers in simulation.

References: a hand derivation of the UR5e's standard DH product (numpy), the pads' inner faces computed from
the URDF's own numbers (read with ElementTree) and the model's FK of the pad links, and the sphere/exact
collision checker for start configurations."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest

import ferrobot
from ferrobot.errors import InvalidArgumentError

UR5E_DH = {  # Universal Robots' published UR5e DH parameters
    "d": [0.1625, 0.0, 0.0, 0.1333, 0.0997, 0.0996],
    "a": [0.0, -0.425, -0.3922, 0.0, 0.0, 0.0],
    "alpha": [np.pi / 2, 0.0, 0.0, np.pi / 2, -np.pi / 2, 0.0],
}


def dh_fk(q):
    """Standard DH: T = prod Rz(q_i) Tz(d_i) Tx(a_i) Rx(alpha_i)."""
    t = np.eye(4)
    for qi, d, a, al in zip(q, UR5E_DH["d"], UR5E_DH["a"], UR5E_DH["alpha"], strict=True):
        c, s, ca, sa = np.cos(qi), np.sin(qi), np.cos(al), np.sin(al)
        t = t @ np.array([[c, -s * ca, s * sa, a * c], [s, c * ca, -c * sa, a * s], [0, sa, ca, d], [0, 0, 0, 1]])
    return t


@pytest.fixture(scope="module")
def ur5e():
    return ferrobot.robots.ur5e()


def test_ur5e_tool0_matches_the_dh_derivation(ur5e):
    rng = np.random.default_rng(0)
    lo, hi = ur5e.lower_limits, ur5e.upper_limits
    worst = 0.0
    for _ in range(200):
        q = rng.uniform(lo, hi)
        worst = max(worst, np.abs(ur5e.fk(q, "tool0") - dh_fk(q[:6])).max())
    assert worst < 1e-9  # the URDF writes pi/2 with 10 digits
    # The published zero pose: flange at (a2 + a3, -(d4 + d6), d1 - d5).
    np.testing.assert_allclose(ur5e.fk(np.zeros(7), "tool0")[:3, 3], [-0.8172, -0.2329, 0.0628], atol=1e-9)


def test_ur5e_limits_and_structure(ur5e):
    assert ur5e.dof_names[:6] == [
        "shoulder_pan_joint",
        "shoulder_lift_joint",
        "elbow_joint",
        "wrist_1_joint",
        "wrist_2_joint",
        "wrist_3_joint",
    ]
    np.testing.assert_allclose(ur5e.upper_limits[:6], [2 * np.pi, 2 * np.pi, np.pi, 2 * np.pi, 2 * np.pi, 2 * np.pi])
    mimics = dict(ur5e.mimic_joints)
    assert len(mimics) == 5 and all(m[0] == "finger_joint" for m in mimics.values())
    checker = ferrobot.CollisionChecker(ur5e)
    for group, name in ur5e.named_states:
        assert not checker.in_collision(ur5e.named_state(name, group=group)), name


def _pad_faces(urdf: str, link: str):
    """(centre, half size) of the pad box (the second collision box) of ``link``, read from the URDF text."""
    root = ET.fromstring(urdf)
    el = next(e for e in root.findall("link") if e.get("name") == link)
    boxes = [c for c in el.findall("collision") if c.find("geometry/box") is not None]
    pad = boxes[-1]
    centre = np.array([float(v) for v in pad.find("origin").get("xyz").split()])
    half = np.array([float(v) for v in pad.find("geometry/box").get("size").split()]) / 2
    return centre, half


def test_2f85_opening_map_matches_fk_of_the_pads(ur5e):
    """The four-bar map against the pads' inner faces from FK (both fingers, in the gripper frame)."""
    g = ferrobot.Gripper.robotiq_2f85()
    assert g.opening_map_kind == "four_bar" and len(g.followers) == 5
    urdf = ferrobot.robots.ur5e_urdf()
    cl, hl = _pad_faces(urdf, "left_inner_finger")
    cr, hr = _pad_faces(urdf, "right_inner_finger")
    q = ur5e.named_state("home")
    for x in np.linspace(0.0, 0.8, 17):
        q[6] = x
        base = ur5e.fk(q, "robotiq_85_base_link")
        inv = np.linalg.inv(base)
        left = inv @ ur5e.fk(q, "left_inner_finger")
        right = inv @ ur5e.fk(q, "right_inner_finger")
        # The pads stay parallel to the gripper frame (the inner finger joints mimic -1).
        np.testing.assert_allclose(left[:3, :3], np.eye(3), atol=1e-12)
        np.testing.assert_allclose(right[:3, :3], np.eye(3), atol=1e-12)
        inner_left = (left[:3, :3] @ cl + left[:3, 3])[1] - hl[1]
        inner_right = (right[:3, :3] @ cr + right[:3, 3])[1] + hr[1]
        assert abs((inner_left - inner_right) - g.opening(x)) < 1e-9, x
    assert abs(g.max_opening - 0.085) < 2e-4  # the published 85 mm stroke
    for w in (0.01, 0.04, 0.08):
        assert abs(g.opening(g.driver_position(w)) - w) < 1e-12
    with pytest.raises(InvalidArgumentError, match="outside"):
        g.driver_position(0.1)


def test_panda_hand_opening_matches_fk():
    panda = ferrobot.robots.panda()
    g = ferrobot.Gripper.from_model(panda)
    assert g.name == "panda_hand" and g.opening_map_kind == "linear"
    q = panda.named_state("ready")
    for x in (0.0, 0.02, 0.04):
        q[7] = x
        d = np.linalg.inv(panda.fk(q, "panda_hand")) @ panda.fk(q, "panda_leftfinger")
        e = np.linalg.inv(panda.fk(q, "panda_hand")) @ panda.fk(q, "panda_rightfinger")
        # The finger frames separate by 2q along the closing axis (y) as the opening does.
        assert abs((d[1, 3] - e[1, 3]) - g.opening(x)) < 1e-12


def test_auto_built_gripper_from_srdf_end_effector(ur5e):
    """A gripper built from the SRDF end effector of a URDF the library does not know by name."""
    urdf = ferrobot.robots.ur5e_urdf().replace('"finger_joint"', '"my_driver"')
    srdf = ferrobot.robots.ur5e_srdf().replace('"finger_joint"', '"my_driver"')
    model = ferrobot.RobotModel.from_urdf_string(urdf, srdf=srdf)
    g = ferrobot.Gripper.from_model(model)
    ref = ferrobot.Gripper.robotiq_2f85()
    assert g.driver == "my_driver" and sorted(g.followers) == sorted(ref.followers)
    assert g.opening_map_kind == "table"
    for x in np.linspace(0.0, 0.8, 9):
        assert abs(g.opening(x) - ref.opening(x)) < 1e-9
    assert abs(abs(g.closing[1]) - 1.0) < 1e-9  # either sign: the fingers are symmetric
    np.testing.assert_allclose(g.approach, [0, 0, 1], atol=1e-9)


def test_to_hand_generalises_to_panda_hand():
    rng = np.random.default_rng(3)
    rows = np.zeros((5, 17))
    rows[:, 0], rows[:, 1], rows[:, 3] = 0.5, 0.04, 0.02
    for i in range(5):
        q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        rows[i, 4:13] = (q * np.sign(np.linalg.det(q))).ravel()
    rows[:, 13:16] = rng.normal(size=(5, 3))
    gg = ferrobot.grasp.GraspGroup(rows)
    with pytest.warns(DeprecationWarning):
        old = gg.to_panda_hand()
    np.testing.assert_allclose(gg.to_hand(ferrobot.Gripper.panda_hand()), old, atol=1e-12)
    # Any gripper: its TCP lands on the fingertip centre, its approach on the grasp's x.
    g = ferrobot.Gripper.robotiq_2f85()
    hands = gg.to_hand(g)
    for h, row in zip(hands, rows, strict=True):
        r = row[4:13].reshape(3, 3)
        tip = row[13:16] + row[3] * r[:, 0]
        np.testing.assert_allclose(h[:3, :3] @ g.tcp + h[:3, 3], tip, atol=1e-12)
        np.testing.assert_allclose(h[:3, :3] @ g.approach, r[:, 0], atol=1e-12)
        np.testing.assert_allclose(h[:3, :3] @ g.closing, r[:, 1], atol=1e-12)


def test_detection_options_follow_the_gripper():
    opts = ferrobot.Gripper.robotiq_2f85().detection_options()
    assert isinstance(opts, ferrobot.GripperDetection)
    assert abs(opts.max_width - 0.085) < 2e-4 and opts.finger_depth == 0.0375
    assert ferrobot.Gripper.panda_hand().detection_options().max_width == 0.08
    # The detector takes these as DetectOptions fields of the same names.
    fields = set(ferrobot.DetectOptions().to_dict())
    assert set(opts.to_dict()) <= fields
    with pytest.warns(DeprecationWarning, match="GripperDetection"):
        assert opts["max_width"] == opts.max_width


def test_finger_geometry_is_typed_and_round_trips():
    """``Gripper.fingers`` is a FingerGeometry; a gripper built from another's fingers (object or dict)
    has the same geometry; bad finger dicts name the key."""
    hand = ferrobot.Gripper.panda_hand()
    f = hand.fingers
    assert isinstance(f, ferrobot.FingerGeometry)
    assert set(f.to_dict()) == {"depth", "thickness", "height", "palm_width", "palm_height", "palm_depth"}
    assert all(v > 0 for v in f.to_dict().values())
    args = dict(
        name="copy",
        hand_link=hand.hand_link,
        tcp=list(hand.tcp),
        approach=list(hand.approach),
        closing=list(hand.closing),
        driver=hand.driver,
        followers=hand.followers,
        open_position=hand.open_position,
        closed_position=hand.closed_position,
        opening_map=("linear", 2.0, 0.0),
    )
    for fingers in (f, f.to_dict()):
        g = ferrobot.Gripper(**args, fingers=fingers)
        assert g.fingers.to_dict() == f.to_dict()
    bad = f.to_dict() | {"span": 0.1}
    with pytest.raises(ferrobot.errors.InvalidArgumentError, match="span"):
        ferrobot.Gripper(**args, fingers=bad)
    missing = {k: v for k, v in f.to_dict().items() if k != "depth"}
    with pytest.raises(ferrobot.errors.InvalidArgumentError, match="depth"):
        ferrobot.Gripper(**args, fingers=missing)
    with pytest.raises(ferrobot.errors.InvalidArgumentError, match="fingers"):
        ferrobot.Gripper(**args, fingers=[0.05] * 6)


def test_add_robot_starts_free_of_self_collision():
    panda = ferrobot.robots.panda()
    checker = ferrobot.CollisionChecker(panda)
    assert checker.in_collision(np.zeros(8)), "the reference: the Panda's zero pose is in self-collision"
    ur5e = ferrobot.robots.ur5e()
    for model, check in ((panda, checker), (ur5e, ferrobot.CollisionChecker(ur5e))):
        world = ferrobot.World()
        robot = world.add_robot(model, [0, 0, 0, 1, 0, 0, 0])
        q = robot.joint_positions
        assert not check.in_collision(q)
        first_group, first = model.named_states[0]
        np.testing.assert_allclose(q, model.named_state(first, group=first_group))


def test_passive_max_force_zero_is_accepted():
    world = ferrobot.World()
    robot = world.add_robot(ferrobot.robots.ur5e(), [0, 0, 0, 1, 0, 0, 0])
    n = robot.num_dof if hasattr(robot, "num_dof") else len(robot.dof_names)
    robot.set_drive_gains(np.zeros(n), np.zeros(n), max_force=np.zeros(n))
    with pytest.raises(InvalidArgumentError):
        robot.set_drive_gains(np.zeros(n), np.zeros(n), max_force=-np.ones(n))


def test_grasped_box_carried_at_1_m_s_stays_in_the_hand():
    """0.5 kg box, 0.5 m at 1 m/s (benches/gripper_carry.py; both robots' figures in BENCHMARKS.md)."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benches"))
    import gripper_carry

    res = gripper_carry.carry("ur5e")
    assert abs(res["carried_m"] - 0.5) < 0.01
    assert 0.045 < res["opening_mm"] / 1e3 < 0.052  # closed on the 50 mm box
    assert res["max_drift_mm"] < 5.0, res


def test_pick_place_on_the_ur5e_with_its_2f85():
    """The whole workflow on the second bundled robot (100 episodes: BENCHMARKS.md, `ferrobot demo --robot ur5e`)."""
    from ferrobot.pipeline import PickPlace, random_scene

    pp = PickPlace(robot="ur5e")
    assert pp.gripper.name == "robotiq_2f85" and pp.hand_link == "robotiq_85_base_link"
    result = pp.run(random_scene(3))
    assert result.success, (result.failed_stage, result.reason)
    grasp = next(s for s in result.stages if s.name == "grasp")
    assert 0.005 < grasp.detail["opening_mm"] / 1e3 < 0.085
    with pytest.raises(InvalidArgumentError, match="gripper"):
        PickPlace(robot="ur5e", gripper="no_such_gripper")
