"""USD robots: the bundled and shared robots written with ``RobotModel.to_usd`` and read back with
``RobotModel.from_usd`` (FK to 1e-9, the same simulation), the files checked with usd-core directly, and a
hand-built UsdPhysics articulation in centimetres read against a hand derivation."""

from __future__ import annotations

import math

import numpy as np
import pytest

pxr = pytest.importorskip("pxr")
from pxr import Gf, Usd, UsdGeom, UsdPhysics  # noqa: E402

import ferrobot  # noqa: E402
from conftest import PANDA_URDF, UR5_URDF, random_configurations  # noqa: E402
from ferrobot.usd import read_usd  # noqa: E402


def robots():
    return {
        "bundled_panda": ferrobot.robots.panda(),
        "panda": ferrobot.RobotModel.from_urdf(PANDA_URDF),
        "ur5": ferrobot.RobotModel.from_urdf(UR5_URDF),
    }


@pytest.mark.parametrize("name", ["bundled_panda", "panda", "ur5"])
def test_round_trip_fk_equal(name, tmp_path):
    model = robots()[name]
    path = model.to_usd(tmp_path / f"{name}.usda")
    back = ferrobot.RobotModel.from_usd(path, ee_link=model.ee_link)
    assert back.dof_names == model.dof_names
    assert sorted(back.link_names) == sorted(model.link_names)
    assert dict(back.mimic_joints) == dict(model.mimic_joints)
    lo, hi = model.lower_limits, model.upper_limits
    assert back.lower_limits == pytest.approx(lo, rel=1e-6, abs=1e-6)
    assert back.upper_limits == pytest.approx(hi, rel=1e-6, abs=1e-6)
    assert back.effort_limits == pytest.approx(model.effort_limits, rel=1e-6)
    assert back.velocity_limits == pytest.approx(model.velocity_limits, rel=1e-6)
    order = [back.link_names.index(n) for n in model.link_names]
    for q in random_configurations(model, 50, seed=1):
        assert np.abs(back.fk_all(q)[order] - model.fk_all(q)).max() < 1e-9
    for link in model.link_names:
        a, b = model.inertial(link), back.inertial(link)
        assert b.mass == pytest.approx(a.mass, rel=1e-6)
        if a.mass > 0:
            Ia = a.origin[:3, :3] @ a.inertia @ a.origin[:3, :3].T
            Ib = b.origin[:3, :3] @ b.inertia @ b.origin[:3, :3].T
            assert Ib == pytest.approx(Ia, abs=1e-6 * max(1e-9, np.abs(Ia).max()) + 1e-12)
            assert b.origin[:3, 3] == pytest.approx(a.origin[:3, 3], abs=1e-6)
        assert len(back.collision_geometry(link)) == len(model.collision_geometry(link))
        assert len(back.visual_geometry(link)) == len(model.visual_geometry(link))

    # the file, read with usd-core alone: one joint prim per URDF joint (plus the world fixture), limits in degrees
    stage = Usd.Stage.Open(str(path))
    joints = {p.GetName(): p for p in stage.Traverse() if p.IsA(UsdPhysics.Joint)}
    assert len(joints) == len(model.joint_names) + 1
    for jn in model.dof_names:
        info = model.joint_info(jn)
        p = joints[jn]
        if info.type == "revolute":
            j = UsdPhysics.RevoluteJoint(p)
            lims = sorted([j.GetLowerLimitAttr().Get(), j.GetUpperLimitAttr().Get()])
            assert lims == pytest.approx(sorted([math.degrees(info.lower), math.degrees(info.upper)]), rel=1e-6)
    assert stage.GetDefaultPrim().HasAPI(UsdPhysics.ArticulationRootAPI)


def test_simulation_of_the_usd_robot_equals_the_urdf_robot(tmp_path):
    model = ferrobot.robots.panda()
    back = ferrobot.RobotModel.from_usd(
        model.to_usd(tmp_path / "panda.usda"), srdf=ferrobot.robots.panda_srdf(), ee_link=model.ee_link
    )
    finals = []
    for m in (model, back):
        w = ferrobot.World(dt=1 / 240)
        r = w.add_robot(m, name="panda", gravity_compensation=False)
        r.set_joint_positions(model.named_state("ready"))
        target = model.named_state("ready") + np.r_[0.3, -0.2, 0.2, 0.3, -0.2, 0.2, 0.3, 0.0]
        r.set_joint_position_targets(target)
        w.step(240)
        finals.append(r.joint_positions)
    # the same motion, to the float32 precision of the stored masses and inertias (the SRDF, which USD does
    # not carry, gives both the same allowed finger contacts)
    assert finals[1] == pytest.approx(finals[0], abs=1e-9)
    assert np.abs(finals[0] - model.named_state("ready")).max() > 0.1  # it moved


def test_hand_built_usd_in_centimetres(tmp_path):
    """Two links in a stage in centimetres; the elbow's joint frame set on both sides, turning about Y;
    limits in degrees; an angular drive with stiffness per degree; a capsule along X; mass properties."""
    path = tmp_path / "arm.usda"
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageMetersPerUnit(stage, 0.01)
    root = UsdGeom.Xform.Define(stage, "/arm")
    stage.SetDefaultPrim(root.GetPrim())
    UsdPhysics.ArticulationRootAPI.Apply(root.GetPrim())
    base = UsdGeom.Xform.Define(stage, "/arm/base")
    UsdPhysics.RigidBodyAPI.Apply(base.GetPrim())
    upper = UsdGeom.Xform.Define(stage, "/arm/upper")
    upper.AddTranslateOp().Set(Gf.Vec3d(0, 0, 50))  # 0.5 m up
    UsdPhysics.RigidBodyAPI.Apply(upper.GetPrim())
    ma = UsdPhysics.MassAPI.Apply(upper.GetPrim())
    ma.CreateMassAttr(2.0)
    ma.CreateCenterOfMassAttr(Gf.Vec3f(10, 0, 0))  # cm
    ma.CreateDiagonalInertiaAttr(Gf.Vec3f(100, 200, 300))  # kg cm^2
    cap = UsdGeom.Capsule.Define(stage, "/arm/upper/shape")
    cap.CreateRadiusAttr(3.0)
    cap.CreateHeightAttr(20.0)
    cap.CreateAxisAttr("X")
    cap.AddTranslateOp().Set(Gf.Vec3d(10, 0, 0))
    UsdPhysics.CollisionAPI.Apply(cap.GetPrim())
    fix = UsdPhysics.FixedJoint.Define(stage, "/arm/joints/fix")
    fix.CreateBody1Rel().SetTargets(["/arm/base"])
    j = UsdPhysics.RevoluteJoint.Define(stage, "/arm/joints/elbow")
    j.CreateBody0Rel().SetTargets(["/arm/base"])
    j.CreateBody1Rel().SetTargets(["/arm/upper"])
    j.CreateLocalPos0Attr(Gf.Vec3f(0, 0, 50))
    j.CreateLocalPos1Attr(Gf.Vec3f(0, 0, 0))
    j.CreateAxisAttr("Y")
    j.CreateLowerLimitAttr(-90.0)
    j.CreateUpperLimitAttr(45.0)
    d = UsdPhysics.DriveAPI.Apply(j.GetPrim(), "angular")
    d.CreateStiffnessAttr(2.0)  # N·m per degree
    d.CreateDampingAttr(0.5)
    d.CreateMaxForceAttr(30.0)
    stage.GetRootLayer().Save()

    r = read_usd(path)
    m = r.model
    assert m.dof_names == ["elbow"]
    assert m.lower_limits == pytest.approx([-math.pi / 2]) and m.upper_limits == pytest.approx([math.pi / 4])
    assert m.effort_limits == pytest.approx([30.0])
    assert r.drives["elbow"]["stiffness"] == pytest.approx(2.0 * 180 / math.pi)
    assert r.drives["elbow"]["damping"] == pytest.approx(0.5 * 180 / math.pi)
    # FK by hand: the upper link turns about y at 0.5 m height; its point 0.2 m along x goes to
    # (0.2 cos a, 0, 0.5 - 0.2 sin a)
    a = 0.4
    T = m.fk([a], "upper")
    p = T[:3, :3] @ [0.2, 0, 0] + T[:3, 3]
    assert p == pytest.approx([0.2 * math.cos(a), 0, 0.5 - 0.2 * math.sin(a)], abs=1e-9)
    inert = m.inertial("upper")
    assert inert.mass == pytest.approx(2.0)
    assert inert.origin[:3, 3] == pytest.approx([0.1, 0, 0])
    inertia = inert.origin[:3, :3] @ inert.inertia @ inert.origin[:3, :3].T
    assert np.diag(inertia) == pytest.approx([0.01, 0.02, 0.03])
    (g,) = m.collision_geometry("upper")
    assert g["type"] == "capsule" and g["radius"] == pytest.approx(0.03) and g["length"] == pytest.approx(0.2)
    # its axis is the link's x, its centre 0.1 m along x
    assert np.abs(g["origin"][:3, 2]) == pytest.approx([1, 0, 0], abs=1e-9)
    assert g["origin"][:3, 3] == pytest.approx([0.1, 0, 0])


def test_bad_usd_paths(tmp_path):
    with pytest.raises(ferrobot.errors.InvalidArgumentError, match="no USD file"):
        read_usd(tmp_path / "missing.usda")
    stage = Usd.Stage.CreateNew(str(tmp_path / "empty.usda"))
    UsdGeom.Xform.Define(stage, "/nothing")
    stage.GetRootLayer().Save()
    with pytest.raises(ferrobot.errors.InvalidArgumentError, match="no UsdPhysics joints"):
        read_usd(tmp_path / "empty.usda")
