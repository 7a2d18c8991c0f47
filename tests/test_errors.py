"""Every error path raises a ferrobot.errors exception that names the problem."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import PANDA_URDF
from ferrobot import RobotModel
from ferrobot import errors as E

LINK = '<link name="{}"/>'


def robot(*body: str) -> str:
    return '<?xml version="1.0"?>\n<robot name="r">\n' + "\n".join(body) + "\n</robot>\n"


def joint(name, parent, child, kind="revolute", extra='<limit lower="-1" upper="1" effort="1" velocity="1"/>'):
    return f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>{extra}</joint>'


def test_hierarchy():
    assert issubclass(E.UrdfError, E.ModelError) and issubclass(E.ModelError, E.FerrobotError)
    assert issubclass(E.MeshError, E.UrdfError)
    assert issubclass(E.ShapeError, ValueError) and issubclass(E.NonFiniteError, ValueError)
    assert issubclass(E.UnknownNameError, LookupError)


def test_malformed_xml_names_file_and_line(tmp_path):
    p = tmp_path / "bad.urdf"
    p.write_text(robot(LINK.format("a"), '<link name="b">', "</robot2>"))
    with pytest.raises(E.UrdfError, match=r"bad\.urdf:\d+: malformed XML"):
        RobotModel.from_urdf(p)


def test_missing_file():
    with pytest.raises(E.UrdfError, match="cannot read"):
        RobotModel.from_urdf("/nonexistent/robot.urdf")


def test_not_a_robot():
    with pytest.raises(E.UrdfError, match="root element is <sdf>"):
        RobotModel.from_urdf_string("<sdf/>")


def test_unknown_joint_type_names_joint_and_line():
    text = robot(LINK.format("a"), LINK.format("b"), joint("j", "a", "b", kind="hinge"))
    with pytest.raises(E.UrdfError, match=r"<string>:5: joint 'j' has unknown type 'hinge'"):
        RobotModel.from_urdf_string(text)


def test_unsupported_joint_type():
    text = robot(LINK.format("a"), LINK.format("b"), joint("j", "a", "b", kind="floating", extra=""))
    with pytest.raises(E.UrdfError, match="'floating', which is not supported"):
        RobotModel.from_urdf_string(text)


def test_revolute_without_limit():
    text = robot(LINK.format("a"), LINK.format("b"), joint("j", "a", "b", extra=""))
    with pytest.raises(E.UrdfError, match="revolute joint 'j' has no <limit>"):
        RobotModel.from_urdf_string(text)


def test_kinematic_loop_two_parents():
    text = robot(*(LINK.format(n) for n in "abc"), joint("j1", "a", "b"), joint("j2", "a", "c"), joint("j3", "b", "c"))
    with pytest.raises(E.UrdfError, match="kinematic loop: link 'c' is the child of both joint 'j2' and joint 'j3'"):
        RobotModel.from_urdf_string(text)


def test_kinematic_cycle_without_root():
    text = robot(LINK.format("a"), LINK.format("b"), joint("j1", "a", "b"), joint("j2", "b", "a"))
    with pytest.raises(E.UrdfError, match="kinematic loop"):
        RobotModel.from_urdf_string(text)


def test_two_roots():
    text = robot(*(LINK.format(n) for n in "abc"), joint("j1", "a", "b"))
    with pytest.raises(E.UrdfError, match=r"2 root links \(a, c\)"):
        RobotModel.from_urdf_string(text)


def test_joint_to_undefined_link():
    text = robot(LINK.format("a"), joint("j1", "a", "ghost"))
    with pytest.raises(E.UrdfError, match="child link 'ghost', which is not defined"):
        RobotModel.from_urdf_string(text)


def test_mimic_of_unknown_joint():
    text = robot(
        LINK.format("a"),
        LINK.format("b"),
        joint("j1", "a", "b", extra='<limit lower="0" upper="1" effort="1" velocity="1"/><mimic joint="nope"/>'),
    )
    with pytest.raises(E.UrdfError, match="mimics joint 'nope', which is not defined"):
        RobotModel.from_urdf_string(text)


def test_negative_size_and_lower_above_upper():
    text = robot('<link name="a"><collision><geometry><sphere radius="-1"/></geometry></collision></link>')
    with pytest.raises(E.UrdfError, match="sphere radius must be positive"):
        RobotModel.from_urdf_string(text)
    text = robot(
        LINK.format("a"),
        LINK.format("b"),
        joint("j", "a", "b", extra='<limit lower="1" upper="-1" effort="1" velocity="1"/>'),
    )
    with pytest.raises(E.UrdfError, match="lower limit 1 is above upper limit -1"):
        RobotModel.from_urdf_string(text)


def test_missing_mesh_lists_candidates(tmp_path):
    p = tmp_path / "r.urdf"
    p.write_text(
        robot(
            '<link name="a"><collision><geometry><mesh filename="package://pkg/m.stl"/></geometry></collision></link>'
        )
    )
    with pytest.raises(E.MeshError, match=r"link 'a': mesh 'package://pkg/m.stl': file not found \(tried"):
        RobotModel.from_urdf(p)


def test_unreadable_mesh(tmp_path):
    (tmp_path / "m.stl").write_text("this is not a mesh")
    p = tmp_path / "r.urdf"
    p.write_text(robot('<link name="a"><collision><geometry><mesh filename="m.stl"/></geometry></collision></link>'))
    with pytest.raises(E.MeshError, match="cannot load"):
        RobotModel.from_urdf(p)


def test_srdf_errors(tmp_path):
    bad = tmp_path / "bad.srdf"
    bad.write_text('<robot name="panda">\n<group name="g"><joint name="nope"/></group>\n</robot>')
    with pytest.raises(E.SrdfError, match=r"bad\.srdf:2: group 'g' names joint 'nope'"):
        RobotModel.from_urdf(PANDA_URDF, srdf=bad, strict=True)
    with pytest.raises(E.SrdfError, match="malformed XML"):
        RobotModel.from_urdf(PANDA_URDF, srdf="<robot><group></robot>")
    with pytest.raises(E.UnknownNameError, match="unknown group 'arm'"):
        RobotModel.from_urdf(PANDA_URDF, srdf=PANDA_URDF.with_suffix(".srdf"), group="arm")


def test_unknown_names(mbm_panda):
    q = np.zeros(7)
    with pytest.raises(E.UnknownNameError, match="unknown link 'hand'; known: panda_link0"):
        mbm_panda.fk(q, link="hand")
    with pytest.raises(E.UnknownNameError, match="unknown link"):
        RobotModel.from_urdf(PANDA_URDF, ee_link="nope")
    with pytest.raises(E.UnknownNameError, match="unknown joint 'x'"):
        mbm_panda.joint_info("x")


@pytest.mark.parametrize(
    "bad, exc, msg",
    [
        (np.zeros(6), E.ShapeError, r"q: expected shape \(7,\), got \(6,\)"),
        (np.zeros((1, 7)), E.ShapeError, r"expected shape \(7,\), got \(1, 7\)"),
        (np.array([0, 0, np.nan, 0, 0, 0, 0]), E.NonFiniteError, r"NaN at index \[2\]"),
        (np.array([0, 0, 0, np.inf, 0, 0, 0]), E.NonFiniteError, r"inf at index \[3\]"),
        ("seven", E.InvalidArgumentError, "expected an array of numbers"),
    ],
)
def test_bad_configuration(mbm_panda, bad, exc, msg):
    for call in (mbm_panda.fk, mbm_panda.jacobian, mbm_panda.fk_all):
        with pytest.raises(exc, match=msg):
            call(bad)


def test_bad_batch(mbm_panda):
    with pytest.raises(E.ShapeError, match=r"expected shape \(N, 7\), got \(7,\)"):
        mbm_panda.fk_batch(np.zeros(7))
    with pytest.raises(E.ShapeError, match=r"got \(3, 6\)"):
        mbm_panda.fk_batch(np.zeros((3, 6)))
    qs = np.zeros((100, 7))
    qs[42, 5] = np.nan
    with pytest.raises(E.NonFiniteError, match=r"index \[42, 5\]"):
        mbm_panda.fk_batch(qs)
    assert mbm_panda.fk_batch(np.zeros((0, 7))).shape == (0, 7)
