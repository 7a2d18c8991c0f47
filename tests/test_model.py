"""Robot model loading: joints, limits, mimic, SRDF, geometry and mesh paths."""

from __future__ import annotations

import math
import shutil

import numpy as np
import pytest

import ferrobot
from conftest import SHARED
from ferrobot import RobotModel

# A small robot whose FK is easy to write by hand: a continuous joint about z at
# height 0.5, then an arm of length 0.3 along x, then two prismatic fingers along
# y, the second a mimic of the first with multiplier -2 and offset 0.01.
TOY = """<?xml version="1.0"?>
<robot name="toy">
  <link name="base"/>
  <link name="arm">
    <collision><origin xyz="0.15 0 0"/><geometry><box size="0.3 0.05 0.05"/></geometry></collision>
    <visual><geometry><cylinder radius="0.02" length="0.3"/></geometry>
      <material name="red"><color rgba="1 0 0 1"/></material></visual>
  </link>
  <link name="tip"><collision><geometry><sphere radius="0.02"/></geometry></collision></link>
  <link name="finger_a"><collision><geometry><capsule radius="0.01" length="0.04"/></geometry></collision></link>
  <link name="finger_b"/>
  <joint name="yaw" type="continuous">
    <parent link="base"/><child link="arm"/>
    <origin xyz="0 0 0.5"/><axis xyz="0 0 1"/>
  </joint>
  <joint name="arm_tip" type="fixed">
    <parent link="arm"/><child link="tip"/><origin xyz="0.3 0 0"/>
  </joint>
  <joint name="fa" type="prismatic">
    <parent link="tip"/><child link="finger_a"/><axis xyz="0 1 0"/>
    <limit lower="0" upper="0.04" effort="20"/>
  </joint>
  <joint name="fb" type="prismatic">
    <parent link="tip"/><child link="finger_b"/><axis xyz="0 1 0"/>
    <limit lower="-0.1" upper="0.1" effort="20" velocity="0.2"/>
    <mimic joint="fa" multiplier="-2" offset="0.01"/>
  </joint>
</robot>
"""


@pytest.fixture(scope="module")
def toy():
    return RobotModel.from_urdf_string(TOY)


def test_toy_structure_and_documented_defaults(toy):
    assert toy.dof_names == ["yaw", "fa"]  # fixed and mimic joints are not DOFs
    assert toy.num_dof == 2
    assert toy.link_names == ["base", "arm", "tip", "finger_a", "finger_b"]
    assert toy.base_link == "base"
    assert toy.ee_link == "tip"  # the chain branches into the fingers at tip
    assert toy.lower_limits[0] == -math.inf and toy.upper_limits[0] == math.inf
    assert toy.velocity_limits[0] == math.inf  # continuous joint without <limit>
    assert toy.velocity_limits[1] == math.inf  # <limit> without velocity
    assert toy.effort_limits[1] == 20.0
    assert dict(toy.mimic_joints) == {"fb": ("fa", -2.0, 0.01)}


def test_toy_fk_by_hand_including_mimic(toy):
    for yaw, fa in [(0.0, 0.0), (0.7, 0.03), (-2.5, 0.01)]:
        q = np.array([yaw, fa])
        c, s = math.cos(yaw), math.sin(yaw)
        tip = np.array([0.3 * c, 0.3 * s, 0.5])
        y_axis = np.array([-s, c, 0.0])
        poses = dict(zip(toy.link_names, toy.fk_all(q), strict=True))
        assert np.allclose(poses["tip"][:3, 3], tip, atol=1e-12)
        assert np.allclose(poses["finger_a"][:3, 3], tip + fa * y_axis, atol=1e-12)
        assert np.allclose(poses["finger_b"][:3, 3], tip + (-2 * fa + 0.01) * y_axis, atol=1e-12)
        assert np.allclose(toy.fk(q, link="finger_b"), poses["finger_b"], atol=1e-12)
        rz = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
        assert np.allclose(poses["finger_b"][:3, :3], rz, atol=1e-12)
        jac = toy.jacobian(q, link="finger_b")
        assert np.allclose(jac[:3, 1], -2 * y_axis, atol=1e-12)  # mimic gain on the driver
        assert np.allclose(jac[3:, 1], 0.0)


def test_toy_geometry(toy):
    (box,) = toy.collision_geometry("arm")
    assert box["type"] == "box" and box["size"] == [0.3, 0.05, 0.05]
    assert np.allclose(box["origin"][:3, 3], [0.15, 0, 0])
    (vis,) = toy.visual_geometry("arm")
    assert vis["type"] == "cylinder" and vis["rgba"] == [1.0, 0.0, 0.0, 1.0]
    (cap,) = toy.collision_geometry("finger_a")
    assert cap["type"] == "capsule" and cap["radius"] == 0.01 and cap["length"] == 0.04
    assert toy.collision_geometry("finger_b") == []


def test_base_and_ee_overrides(toy):
    m = RobotModel.from_urdf_string(TOY, ee_link="finger_a")
    assert m.ee_link == "finger_a"
    assert m.group_dof_names == ["yaw", "fa"]
    q = np.array([0.3, 0.02])
    assert np.allclose(m.fk(q), toy.fk(q, link="finger_a"))
    with pytest.raises(ferrobot.errors.InvalidArgumentError, match="moved by joint 'yaw'"):
        RobotModel.from_urdf_string(TOY, base_link="arm")


def test_mbm_panda_semantics(mbm_panda):
    m = mbm_panda
    assert m.dof_names == [f"panda_joint{i}" for i in range(1, 8)]
    assert m.ee_link == "panda_hand"
    assert m.group_names[:2] == ["panda_arm", "hand"]
    assert m.group_joint_names("panda_arm")[:7] == m.dof_names
    ready = m.named_state("ready")
    assert np.allclose(ready, [0, -0.785, 0, -2.356, 0, 1.571, 0.785])
    pairs = m.disabled_collision_pairs
    assert ("panda_link0", "panda_link1", "Adjacent") in pairs
    assert len(pairs) > 20
    # meshes are resolved through package:// against the URDF's folder and loaded
    (g,) = m.collision_geometry("panda_link3")
    assert g["type"] == "mesh" and g["path"].endswith("meshes/collision/link3.obj")
    assert g["vertices"].shape[1] == 3 and g["faces"].max() < len(g["vertices"])
    with pytest.raises(ferrobot.errors.UnknownNameError, match="state"):
        m.named_state("nope")


def test_group_selects_chain_tip_and_dofs(ur5):
    m = RobotModel.from_urdf(SHARED / "robots/ur5/ur5.urdf", srdf=SHARED / "robots/ur5/ur5.srdf", group="manipulator")
    assert m.group_name == "manipulator"
    assert m.group_dof_names == ur5.dof_names[:6]
    assert m.ee_link == "ee_link"  # the tip of the group's SRDF chain (base_link -> ee_link)
    assert np.allclose(m.named_state("home"), ur5.named_state("home"))


def test_bundled_panda_matches_motionbenchmaker_panda(bundled_panda, mbm_panda):
    b, m = bundled_panda, mbm_panda
    assert b.dof_names == m.dof_names + ["panda_finger_joint1"]
    assert dict(b.mimic_joints)["panda_finger_joint2"] == ("panda_finger_joint1", 1.0, 0.0)
    assert b.ee_link == "panda_hand"
    rng = np.random.default_rng(7)
    lo, hi = b.lower_limits, b.upper_limits
    qs = rng.uniform(lo, hi, size=(1000, b.num_dof))
    ours = b.fk_batch(qs)
    ref = m.fk_batch(qs[:, :7], link="panda_hand")
    assert np.abs(ours[:, :3] - ref[:, :3]).max() < 1e-6
    # rotation angle between the two orientations
    dots = np.abs(np.sum(ours[:, 3:] * ref[:, 3:], axis=1))
    assert np.arccos(np.clip(dots, -1, 1)).max() * 2 < 1e-6
    # Franka's published limits, not the wider ones of the benchmark file
    assert np.allclose(b.upper_limits[:7], [2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973])
    assert np.allclose(b.velocity_limits[:7], [2.175] * 4 + [2.61] * 3)
    for link in b.link_names:
        for g in b.collision_geometry(link):
            assert g["type"] in {"box", "sphere", "cylinder", "capsule"}


def test_bundled_panda_named_states(bundled_panda):
    b = bundled_panda
    assert ("panda_arm", "ready") in b.named_states
    q = b.named_state("open", group="hand")
    assert q[-1] == pytest.approx(0.04)


def _mesh_package(tmp_path, urdf_mesh_uri: str):
    """A package folder with an OBJ mesh and a URDF that references it."""
    pkg = tmp_path / "src" / "my_robot"
    (pkg / "meshes").mkdir(parents=True)
    (pkg / "urdf").mkdir()
    shutil.copy(SHARED / "robots/panda/meshes/collision/link0.obj", pkg / "meshes" / "base.obj")
    urdf = pkg / "urdf" / "robot.urdf"
    urdf.write_text(
        f"""<robot name="r"><link name="a"><collision><geometry>
        <mesh filename="{urdf_mesh_uri}" scale="2 2 2"/></geometry></collision></link></robot>"""
    )
    return pkg, urdf


def test_package_uri_resolves_through_urdf_parents(tmp_path):
    pkg, urdf = _mesh_package(tmp_path, "package://my_robot/meshes/base.obj")
    m = RobotModel.from_urdf(urdf)
    (g,) = m.collision_geometry("a")
    assert g["path"] == str(pkg / "meshes" / "base.obj")
    assert g["scale"] == [2.0, 2.0, 2.0]


def test_package_uri_resolves_through_package_dirs_and_ros_package_path(tmp_path, monkeypatch):
    pkg, urdf = _mesh_package(tmp_path, "package://my_robot/meshes/base.obj")
    text = urdf.read_text()
    with pytest.raises(ferrobot.errors.MeshError, match="package_dirs"):
        RobotModel.from_urdf_string(text)
    m = RobotModel.from_urdf_string(text, package_dirs=[tmp_path / "src"])
    assert m.collision_geometry("a")[0]["path"] == str(pkg / "meshes" / "base.obj")
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path / "src"))
    assert RobotModel.from_urdf_string(text).collision_geometry("a")[0]["type"] == "mesh"


def test_relative_mesh_path(tmp_path):
    pkg, urdf = _mesh_package(tmp_path, "../meshes/base.obj")
    assert RobotModel.from_urdf(urdf).collision_geometry("a")[0]["vertices"].shape[0] > 0


def test_dae_and_stl_meshes_of_ur5(ur5):
    kinds = {
        g["path"].rsplit(".", 1)[-1].lower()
        for ln in ur5.link_names
        for g in ur5.visual_geometry(ln)
        if g["type"] == "mesh"
    }
    assert {"dae", "stl"} <= kinds


def test_fk_accepts_lists_and_returns_float64(mbm_panda):
    out = mbm_panda.fk([0, 0, 0, -1, 0, 1, 0])
    assert out.dtype == np.float64 and out.shape == (4, 4)
    assert mbm_panda.fk_all(np.zeros(7)).shape == (len(mbm_panda.link_names), 4, 4)
    # non-contiguous input is read correctly
    qs = np.zeros((10, 14))
    assert np.allclose(mbm_panda.fk_batch(qs[:, ::2]), mbm_panda.fk_batch(np.zeros((10, 7))))
