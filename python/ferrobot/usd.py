"""USD robots (``pip install "ferrobot[usd]"``, PyPI ``usd-core``): read UsdPhysics articulations into a
:class:`ferrobot.RobotModel`, and write a model as USD.

Reading (:func:`read_usd`, ``RobotModel.from_usd``): the joints are the prims of the UsdPhysics joint types
(revolute, prismatic, fixed; a joint with an empty ``body0`` fixes the robot to the world) between rigid
bodies; the root link is the body no joint moves. Each link's frame has its body's orientation and its joint's
origin (``localPos1``, zero in the files :func:`write_usd` writes, where link frames are the bodies' frames);
the joint axis is expressed in it through ``localRot1``. Taken over:

* poses from the prims' transforms (double precision), scaled by the stage's ``metersPerUnit``;
* joint axis (``X`` / ``Y`` / ``Z`` of the joint frame), limits (degrees for revolute joints; both infinite:
  a continuous joint), ``physxJoint:maxJointVelocity`` (deg/s or m/s) as the velocity limit,
  ``physxJoint:jointFriction`` and ``ferrobot:damping`` as URDF friction and damping;
* drives (``UsdPhysics.DriveAPI`` angular / linear): ``maxForce`` as the effort limit; stiffness and damping
  (per degree for angular drives, converted to per radian) in :attr:`UsdRobot.drives`, for
  ``Robot.set_drive_gains``;
* mimic couplings (``PhysxMimicJointAPI``: ``q + gearing q_ref + offset = 0``, offset in radians or metres,
  so multiplier ``-gearing``, offset ``-offset``);
* collision geometry (prims with ``UsdPhysics.CollisionAPI``: Cube, Sphere, Cylinder, Capsule along z, Mesh)
  and visual geometry (the other Gprims, with ``displayColor``); meshes go through temporary OBJ files;
* masses, centres of mass and inertias (``UsdPhysics.MassAPI``; principal axes and diagonal inertia).

USD stores joint frames, limits, mesh points and mass properties in single precision (float32): a model read
from USD agrees with its source to about 1e-7 in those; link poses come from the double-precision transforms.
"""

from __future__ import annotations

import math
import os
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from . import _core
from .errors import InvalidArgumentError

__all__ = ["UsdRobot", "read_usd", "write_usd"]

_AXES = {"X": np.array([1.0, 0, 0]), "Y": np.array([0, 1.0, 0]), "Z": np.array([0, 0, 1.0])}


def _pxr():
    try:
        from pxr import Gf, Sdf, Usd, UsdGeom, UsdPhysics
    except ImportError as e:
        raise ImportError('USD support needs usd-core: pip install "ferrobot[usd]"') from e
    return Gf, Sdf, Usd, UsdGeom, UsdPhysics


# --------------------------------------------------------------------------- small maths


def _m4(gf_matrix) -> np.ndarray:
    """A Gf.Matrix4d (row vectors, translation in the last row) as a column-vector 4x4."""
    return np.array(gf_matrix, dtype=np.float64).T


def _gf4(m: np.ndarray):
    Gf = _pxr()[0]
    return Gf.Matrix4d(*np.asarray(m, dtype=np.float64).T.ravel().tolist())


def _quat_to_R(w, x, y, z) -> np.ndarray:
    n = math.sqrt(w * w + x * x + y * y + z * z)
    if n == 0.0:  # an unauthored quaternion attribute reads as zeros: no rotation
        return np.eye(3)
    w, x, y, z = w / n, x / n, y / n, z / n
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def _R_to_quat(R) -> tuple[float, float, float, float]:
    from .transforms import matrix_to_quat

    return tuple(float(v) for v in matrix_to_quat(np.asarray(R)))


def _rpy(R) -> tuple[float, float, float]:
    """URDF roll-pitch-yaw (R = Rz(yaw) Ry(pitch) Rx(roll))."""
    pitch = math.atan2(-R[2, 0], math.hypot(R[0, 0], R[1, 0]))
    if abs(R[2, 0]) < 1 - 1e-12:
        roll = math.atan2(R[2, 1], R[2, 2])
        yaw = math.atan2(R[1, 0], R[0, 0])
    else:
        roll = 0.0
        yaw = math.atan2(-R[0, 1], R[1, 1])
    return roll, pitch, yaw


def _n(v) -> str:
    """A number as URDF text, exactly (shortest round-trip repr)."""
    return repr(float(v))


def _origin_xml(T) -> str:
    r = " ".join(_n(v) for v in _rpy(T[:3, :3]))
    x = " ".join(_n(v) for v in T[:3, 3])
    return f'<origin xyz="{x}" rpy="{r}"/>'


def _frame(pos, rot) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = [float(v) for v in pos]
    T[:3, :3] = _quat_to_R(rot.GetReal(), *[float(v) for v in rot.GetImaginary()])
    return T


# --------------------------------------------------------------------------- reading


@dataclass
class UsdRobot:
    """What :func:`read_usd` found: the model, the URDF it was built from, and the drives per joint name
    (``stiffness`` N·m/rad or N/m, ``damping`` N·m·s/rad or N·s/m, ``max_force``)."""

    model: object
    urdf: str
    drives: dict[str, dict[str, float]] = field(default_factory=dict)


def _attr(prim, name, default=None):
    a = prim.GetAttribute(name)
    if not a or not a.HasAuthoredValue():
        return default
    return a.Get()


def read_usd(path, *, root: str | None = None, srdf=None, base_link=None, ee_link=None, group=None) -> UsdRobot:
    """Reads the articulation in the USD file ``path`` (under the prim ``root`` when given)."""
    Gf, Sdf, Usd, UsdGeom, UsdPhysics = _pxr()
    path = Path(path)
    if not path.is_file():
        raise InvalidArgumentError(f"path: no USD file at {path}")
    stage = Usd.Stage.Open(str(path))
    if stage is None:
        raise InvalidArgumentError(f"path: {path} is not a USD file usd-core can open")
    mpu = UsdGeom.GetStageMetersPerUnit(stage) or 1.0
    top = stage.GetPrimAtPath(root) if root else stage.GetPseudoRoot()
    if not top:
        raise InvalidArgumentError(f"root: no prim {root} in {path}")
    tc = Usd.TimeCode.Default()
    xcache = UsdGeom.XformCache(tc)

    def world(prim) -> np.ndarray:
        T = _m4(xcache.GetLocalToWorldTransform(prim))
        T[:3, 3] *= mpu
        # strip scale from the rotation block
        for c in range(3):
            n = np.linalg.norm(T[:3, c])
            if n > 0:
                T[:3, c] /= n
        return T

    joints = [p for p in Usd.PrimRange(top) if p.IsA(UsdPhysics.Joint)]
    if not joints:
        raise InvalidArgumentError(f"{path}: no UsdPhysics joints found")
    parsed = []
    for jp in joints:
        j = UsdPhysics.Joint(jp)
        b0 = j.GetBody0Rel().GetTargets()
        b1 = j.GetBody1Rel().GetTargets()
        if not b1:
            raise InvalidArgumentError(f"joint {jp.GetPath()}: has no body1")
        if _attr(jp, "physics:excludeFromArticulation", False):
            continue
        parsed.append((jp, str(b0[0]) if b0 else None, str(b1[0])))
    children = {b1 for _, _, b1 in parsed if True}
    moved = {b1 for jp, b0, b1 in parsed if b0 is not None}
    bodies = {b for _, b0, b1 in parsed for b in (b0, b1) if b is not None}
    roots = sorted(bodies - moved)
    if len(roots) != 1:
        raise InvalidArgumentError(f"{path}: expected one root body (not moved by any joint), found {roots}")
    root_body = roots[0]
    del children

    name_of = {b: stage.GetPrimAtPath(b).GetName() for b in bodies}
    if len(set(name_of.values())) != len(name_of):
        name_of = {b: b.strip("/").replace("/", "_") for b in bodies}
    link_frame = {root_body: world(stage.GetPrimAtPath(root_body))}  # world pose of each URDF link frame
    by_parent: dict[str, list] = {}
    for jp, b0, b1 in parsed:
        if b0 is not None:
            by_parent.setdefault(b0, []).append((jp, b1))
    joint_xml, drives, order = [], {}, [root_body]
    stack = [root_body]
    while stack:
        b0 = stack.pop()
        for jp, b1 in by_parent.get(b0, []):
            j = UsdPhysics.Joint(jp)
            rot1 = j.GetLocalRot1Attr().Get() or Gf.Quatf(1)
            R1 = _frame((0, 0, 0), rot1)[:3, :3]  # the joint frame's axes in the child body frame
            T1 = world(stage.GetPrimAtPath(b1)) @ _frame(
                np.asarray(j.GetLocalPos1Attr().Get() or (0, 0, 0)) * mpu, Gf.Quatf(1)
            )
            link_frame[b1] = T1
            origin = np.linalg.inv(link_frame[b0]) @ T1
            name = jp.GetName()
            if jp.IsA(UsdPhysics.RevoluteJoint) or jp.IsA(UsdPhysics.PrismaticJoint):
                revolute = jp.IsA(UsdPhysics.RevoluteJoint)
                rj = UsdPhysics.RevoluteJoint(jp) if revolute else UsdPhysics.PrismaticJoint(jp)
                axis = R1 @ _AXES[str(rj.GetAxisAttr().Get() or "X")]
                lo = rj.GetLowerLimitAttr().Get()
                hi = rj.GetUpperLimitAttr().Get()
                lo = -math.inf if lo is None else float(lo)
                hi = math.inf if hi is None else float(hi)
                unit = math.pi / 180 if revolute else mpu
                kind = "revolute" if revolute else "prismatic"
                if revolute and math.isinf(lo) and math.isinf(hi):
                    kind = "continuous"
                drive_name = "angular" if revolute else "linear"
                d = UsdPhysics.DriveAPI.Get(jp, drive_name)
                effort = math.inf
                if jp.HasAPI(UsdPhysics.DriveAPI, drive_name):
                    mf = d.GetMaxForceAttr().Get()
                    effort = math.inf if mf is None else float(mf)
                    per = 180 / math.pi if revolute else 1 / mpu
                    drives[name] = {
                        "stiffness": float(d.GetStiffnessAttr().Get() or 0.0) * per,
                        "damping": float(d.GetDampingAttr().Get() or 0.0) * per,
                        "max_force": effort,
                    }
                vel = _attr(jp, "physxJoint:maxJointVelocity")
                vel = math.inf if vel is None else float(vel) * unit
                lim = []
                if kind != "continuous":
                    lim += [f'lower="{_n(lo * unit)}"', f'upper="{_n(hi * unit)}"']
                if math.isfinite(effort):
                    lim.append(f'effort="{_n(effort)}"')
                if math.isfinite(vel):
                    lim.append(f'velocity="{_n(vel)}"')
                extra = f'<axis xyz="{_n(axis[0])} {_n(axis[1])} {_n(axis[2])}"/>'
                if lim:
                    extra += f"<limit {' '.join(lim)}/>"
                damping = float(_attr(jp, "ferrobot:damping", 0.0))
                friction = float(_attr(jp, "physxJoint:jointFriction", 0.0))
                if damping or friction:
                    extra += f'<dynamics damping="{_n(damping)}" friction="{_n(friction)}"/>'
                for ax in ("rotX", "rotY", "rotZ", "transX", "transY", "transZ"):
                    ref = jp.GetRelationship(f"physxMimicJoint:{ax}:referenceJoint")
                    if ref and ref.GetTargets():
                        refname = stage.GetPrimAtPath(ref.GetTargets()[0]).GetName()
                        gearing = float(_attr(jp, f"physxMimicJoint:{ax}:gearing", 1.0))
                        offset = float(_attr(jp, f"physxMimicJoint:{ax}:offset", 0.0))
                        extra += (
                            f'<mimic joint={quoteattr(refname)} multiplier="{_n(-gearing)}" offset="{_n(-offset)}"/>'
                        )
            elif jp.IsA(UsdPhysics.FixedJoint):
                kind, extra = "fixed", ""
            else:
                raise InvalidArgumentError(
                    f"joint {jp.GetPath()}: type {jp.GetTypeName()} not supported (revolute, prismatic, fixed)"
                )
            joint_xml.append(
                f'<joint name={quoteattr(name)} type="{kind}"><parent link={quoteattr(name_of[b0])}/>'
                f"<child link={quoteattr(name_of[b1])}/>{_origin_xml(origin)}{extra}</joint>"
            )
            order.append(b1)
            stack.append(b1)
    missing = bodies - set(order)
    if missing:
        raise InvalidArgumentError(f"{path}: bodies {sorted(missing)} are not connected to the root {root_body}")

    tmp = tempfile.mkdtemp(prefix="ferrobot-usd-")
    counter = [0]

    def geom_xml(gp, T_link, tag):
        W = world(gp)
        M = _m4(xcache.GetLocalToWorldTransform(gp))
        scale = np.array([np.linalg.norm(M[:3, c]) for c in range(3)]) * mpu
        G = np.linalg.inv(T_link) @ W  # the geometry's frame in the link frame
        if gp.IsA(UsdGeom.Cube):
            size = float(UsdGeom.Cube(gp).GetSizeAttr().Get()) * scale
            shape = f'<box size="{_n(size[0])} {_n(size[1])} {_n(size[2])}"/>'
        elif gp.IsA(UsdGeom.Sphere):
            shape = f'<sphere radius="{_n(float(UsdGeom.Sphere(gp).GetRadiusAttr().Get()) * scale[0])}"/>'
        elif gp.IsA(UsdGeom.Cylinder) or gp.IsA(UsdGeom.Capsule):
            g = UsdGeom.Cylinder(gp) if gp.IsA(UsdGeom.Cylinder) else UsdGeom.Capsule(gp)
            ax = str(g.GetAxisAttr().Get() or "Z")
            if ax != "Z":  # turn the shape's axis onto z
                turn = {
                    "X": np.array([[0, 0, 1], [0, 1, 0], [-1, 0, 0]]),
                    "Y": np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]]),
                }
                G[:3, :3] = G[:3, :3] @ turn[ax].T
            r = float(g.GetRadiusAttr().Get()) * scale[0]
            h = float(g.GetHeightAttr().Get()) * scale[2 if ax == "Z" else 0]
            tagname = "cylinder" if gp.IsA(UsdGeom.Cylinder) else "capsule"
            shape = f'<{tagname} radius="{_n(r)}" length="{_n(h)}"/>'
        elif gp.IsA(UsdGeom.Mesh):
            m = UsdGeom.Mesh(gp)
            pts = np.asarray(m.GetPointsAttr().Get(), dtype=np.float64) * scale
            counts = np.asarray(m.GetFaceVertexCountsAttr().Get(), dtype=np.int64)
            idx = np.asarray(m.GetFaceVertexIndicesAttr().Get(), dtype=np.int64)
            tris, k = [], 0
            for c in counts:  # fan triangulation of polygons
                for i in range(1, c - 1):
                    tris.append((idx[k], idx[k + i], idx[k + i + 1]))
                k += c
            counter[0] += 1
            f = os.path.join(tmp, f"m{counter[0]}.obj")
            with open(f, "w") as out:
                out.writelines(f"v {_n(p[0])} {_n(p[1])} {_n(p[2])}\n" for p in pts)
                out.writelines(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in tris)
            shape = f"<mesh filename={quoteattr(f)}/>"
        else:
            return ""
        color = ""
        if tag == "visual":
            dc = UsdGeom.Gprim(gp).GetDisplayColorAttr().Get()
            if dc is not None and len(dc):
                c = dc[0]
                color = f'<material name=""><color rgba="{c[0]} {c[1]} {c[2]} 1"/></material>'
        return f"<{tag}>{_origin_xml(G)}<geometry>{shape}</geometry>{color}</{tag}>"

    link_xml = []
    body_set = set(bodies)
    for b in order:
        prim = stage.GetPrimAtPath(b)
        T_link = link_frame[b]
        parts = []
        it = iter(Usd.PrimRange(prim))
        for gp in it:
            if gp != prim and str(gp.GetPath()) in body_set:
                it.PruneChildren()
                continue
            if not gp.IsA(UsdGeom.Gprim):
                continue
            collision = gp.HasAPI(UsdPhysics.CollisionAPI)
            if not collision and UsdGeom.Imageable(gp).ComputePurpose() == UsdGeom.Tokens.guide:
                continue
            tag = "collision" if collision else "visual"
            parts.append(geom_xml(gp, T_link, tag))
        if prim.HasAPI(UsdPhysics.MassAPI):
            ma = UsdPhysics.MassAPI(prim)
            mass = float(ma.GetMassAttr().Get() or 0.0)
            com = np.asarray(ma.GetCenterOfMassAttr().Get() or (0, 0, 0), dtype=np.float64) * mpu
            diag = np.asarray(ma.GetDiagonalInertiaAttr().Get() or (0, 0, 0), dtype=np.float64) * mpu * mpu
            pa = ma.GetPrincipalAxesAttr().Get() or Gf.Quatf(1)
            if mass > 0:
                Rb = _quat_to_R(pa.GetReal(), *[float(v) for v in pa.GetImaginary()])
                I_body = Rb @ np.diag(diag) @ Rb.T
                T_bl = np.linalg.inv(T_link) @ world(prim)  # body frame in the link frame
                inertia = T_bl[:3, :3] @ I_body @ T_bl[:3, :3].T
                c = (T_bl @ np.r_[com, 1.0])[:3]
                parts.append(
                    f'<inertial><origin xyz="{_n(c[0])} {_n(c[1])} {_n(c[2])}" rpy="0 0 0"/><mass value="{_n(mass)}"/>'
                    f'<inertia ixx="{_n(inertia[0, 0])}" ixy="{_n(inertia[0, 1])}" ixz="{_n(inertia[0, 2])}" '
                    f'iyy="{_n(inertia[1, 1])}" iyz="{_n(inertia[1, 2])}" izz="{_n(inertia[2, 2])}"/></inertial>'
                )
        link_xml.append(f"<link name={quoteattr(name_of[b])}>{''.join(parts)}</link>")
    robot_name = top.GetName() if root else (stage.GetDefaultPrim().GetName() if stage.GetDefaultPrim() else "robot")
    urdf = f"<robot name={quoteattr(robot_name or 'robot')}>{''.join(link_xml)}{''.join(joint_xml)}</robot>"
    try:
        kwargs = {
            k: v for k, v in (("srdf", srdf), ("base_link", base_link), ("ee_link", ee_link), ("group", group)) if v
        }
        model = _core.RobotModel.from_urdf_string(urdf, **kwargs)
    finally:
        for f in os.listdir(tmp):
            os.unlink(os.path.join(tmp, f))
        os.rmdir(tmp)
    return UsdRobot(model, urdf, drives)


# --------------------------------------------------------------------------- writing


def _safe(name: str) -> str:
    out = "".join(c if c.isalnum() or c == "_" else "_" for c in name)
    return out if out and not out[0].isdigit() else "_" + out


def write_usd(model, path, *, drive_stiffness=None, drive_damping=None) -> Path:
    """Writes ``model`` as a UsdPhysics articulation (``.usda`` text or ``.usd`` / ``.usdc`` binary).

    Links become rigid bodies (``Xform`` prims posed at the zero configuration, with ``MassAPI``), their
    collision geometry ``CollisionAPI`` prims, their visual geometry plain Gprims under ``visuals``; joints
    become ``PhysicsRevoluteJoint`` / ``PhysicsPrismaticJoint`` / ``PhysicsFixedJoint`` with limits, a
    ``DriveAPI`` (``maxForce`` = effort limit; ``drive_stiffness`` / ``drive_damping`` dicts per joint name in
    SI units, per radian), mimic joints a ``PhysxMimicJointAPI``. The base link is fixed to the world.
    """
    Gf, Sdf, Usd, UsdGeom, UsdPhysics = _pxr()
    path = Path(path)
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    root = UsdGeom.Xform.Define(stage, "/" + _safe(model.name or "robot"))
    stage.SetDefaultPrim(root.GetPrim())
    UsdPhysics.ArticulationRootAPI.Apply(root.GetPrim())
    rp = str(root.GetPath())
    # link poses at joint value zero (mimic joints included), from the joint origins
    infos = [model.joint_info(j) for j in model.joint_names]
    pose = {model.base_link: np.eye(4)}
    pending = list(infos)
    while pending:
        rest = []
        for j in pending:
            if j.parent in pose:
                pose[j.child] = pose[j.parent] @ np.asarray(j.origin)
            else:
                rest.append(j)
        if len(rest) == len(pending):
            break
        pending = rest
    link_path = {}
    for link in model.link_names:
        if link not in pose:
            continue
        p = f"{rp}/{_safe(link)}"
        link_path[link] = p
        x = UsdGeom.Xform.Define(stage, p)
        x.AddTransformOp(UsdGeom.XformOp.PrecisionDouble).Set(_gf4(pose[link]))
        prim = x.GetPrim()
        UsdPhysics.RigidBodyAPI.Apply(prim)
        inert = model.inertial(link)
        if inert.mass > 0:
            ma = UsdPhysics.MassAPI.Apply(prim)
            ma.CreateMassAttr(float(inert.mass))
            o = np.asarray(inert.origin)
            inertia = o[:3, :3] @ np.asarray(inert.inertia) @ o[:3, :3].T
            w, V = np.linalg.eigh(inertia)
            if np.linalg.det(V) < 0:
                V[:, 0] = -V[:, 0]
            q = _R_to_quat(V)
            ma.CreateCenterOfMassAttr(Gf.Vec3f(*o[:3, 3].tolist()))
            ma.CreateDiagonalInertiaAttr(Gf.Vec3f(*w.tolist()))
            ma.CreatePrincipalAxesAttr(Gf.Quatf(q[0], q[1], q[2], q[3]))
        for kind, geoms in (("collisions", model.collision_geometry(link)), ("visuals", model.visual_geometry(link))):
            for i, g in enumerate(geoms):
                gp = f"{p}/{kind}_{i}"
                T = np.asarray(g["origin"])
                t = g["type"]
                if t == "box":
                    s = UsdGeom.Cube.Define(stage, gp)
                    s.CreateSizeAttr(1.0)
                    xf = s
                elif t == "sphere":
                    xf = UsdGeom.Sphere.Define(stage, gp)
                    xf.CreateRadiusAttr(float(g["radius"]))
                elif t in ("cylinder", "capsule"):
                    xf = (UsdGeom.Cylinder if t == "cylinder" else UsdGeom.Capsule).Define(stage, gp)
                    xf.CreateRadiusAttr(float(g["radius"]))
                    xf.CreateHeightAttr(float(g["length"]))
                    xf.CreateAxisAttr("Z")
                else:
                    xf = UsdGeom.Mesh.Define(stage, gp)
                    v = np.asarray(g["vertices"], dtype=np.float64) * np.asarray(g["scale"], dtype=np.float64)
                    f = np.asarray(g["faces"], dtype=np.int64)
                    xf.CreatePointsAttr([Gf.Vec3f(*r) for r in v.tolist()])
                    xf.CreateFaceVertexCountsAttr([3] * len(f))
                    xf.CreateFaceVertexIndicesAttr(f.ravel().tolist())
                xf.AddTransformOp(UsdGeom.XformOp.PrecisionDouble).Set(_gf4(T))
                if t == "box":
                    xf.AddScaleOp(UsdGeom.XformOp.PrecisionDouble).Set(Gf.Vec3d(*[float(v) for v in g["size"]]))
                if kind == "collisions":
                    UsdPhysics.CollisionAPI.Apply(xf.GetPrim())
                    UsdGeom.Imageable(xf).CreatePurposeAttr(UsdGeom.Tokens.guide)
                elif g.get("rgba") is not None:
                    xf.CreateDisplayColorAttr([Gf.Vec3f(*[float(c) for c in g["rgba"][:3]])])
    fix = UsdPhysics.FixedJoint.Define(stage, f"{rp}/joints/root_joint")
    fix.CreateBody1Rel().SetTargets([link_path[model.base_link]])
    names = {j.name: _safe(j.name) for j in infos}
    for j in infos:
        jp = f"{rp}/joints/{names[j.name]}"
        o = np.asarray(j.origin)
        q0 = _R_to_quat(o[:3, :3])
        kind = j.type
        if kind in ("revolute", "continuous", "prismatic"):
            axis = np.asarray(j.axis, dtype=np.float64)
            k = int(np.argmax(np.abs(axis)))
            if abs(abs(axis[k]) - 1.0) > 1e-12:
                raise InvalidArgumentError(
                    f"joint '{j.name}': axis {axis.tolist()} is not a coordinate axis; USD joints turn about X, Y or Z"
                )
            sign = float(np.sign(axis[k]))
            revolute = kind != "prismatic"
            J = (UsdPhysics.RevoluteJoint if revolute else UsdPhysics.PrismaticJoint).Define(stage, jp)
            J.CreateAxisAttr("XYZ"[k])
            unit = 180 / math.pi if revolute else 1.0
            lo, hi = j.lower * unit, j.upper * unit
            if math.isfinite(lo) or math.isfinite(hi):
                J.CreateLowerLimitAttr(float(lo))
                J.CreateUpperLimitAttr(float(hi))
            drive = UsdPhysics.DriveAPI.Apply(J.GetPrim(), "angular" if revolute else "linear")
            drive.CreateTypeAttr("force")
            per = math.pi / 180 if revolute else 1.0
            drive.CreateStiffnessAttr(float((drive_stiffness or {}).get(j.name, 0.0)) * per)
            drive.CreateDampingAttr(float((drive_damping or {}).get(j.name, 0.0)) * per)
            if math.isfinite(j.effort):
                drive.CreateMaxForceAttr(float(j.effort))
            prim = J.GetPrim()
            if math.isfinite(j.velocity):
                prim.CreateAttribute("physxJoint:maxJointVelocity", Sdf.ValueTypeNames.Float).Set(j.velocity * unit)
            if j.friction:
                prim.CreateAttribute("physxJoint:jointFriction", Sdf.ValueTypeNames.Float).Set(j.friction)
            if j.damping:
                prim.CreateAttribute("ferrobot:damping", Sdf.ValueTypeNames.Double).Set(j.damping)
            # a negative axis: both joint frames turned by pi about another axis (exact in float), so the joint
            # moves along -axis of the child body and its coordinate is the URDF one
            flip = {0: Gf.Quatf(0, 0, 1, 0), 1: Gf.Quatf(0, 0, 0, 1), 2: Gf.Quatf(0, 1, 0, 0)}[k]
            rot1 = flip if sign < 0 else Gf.Quatf(1)
            if j.mimic:
                ref, mult, off = j.mimic
                ax = ("rot" if revolute else "trans") + "XYZ"[k]
                prim.AddAppliedSchema(f"PhysxMimicJointAPI:{ax}")
                prim.CreateRelationship(f"physxMimicJoint:{ax}:referenceJoint").SetTargets(
                    [Sdf.Path(f"{rp}/joints/{names[ref]}")]
                )
                prim.CreateAttribute(f"physxMimicJoint:{ax}:gearing", Sdf.ValueTypeNames.Float).Set(-mult)
                prim.CreateAttribute(f"physxMimicJoint:{ax}:offset", Sdf.ValueTypeNames.Float).Set(-off)
        elif kind == "fixed":
            J = UsdPhysics.FixedJoint.Define(stage, jp)
            rot1 = Gf.Quatf(1)
        else:
            raise InvalidArgumentError(f"joint '{j.name}': type {kind} cannot be written to USD")
        J.CreateBody0Rel().SetTargets([link_path[j.parent]])
        J.CreateBody1Rel().SetTargets([link_path[j.child]])
        J.CreateLocalPos0Attr(Gf.Vec3f(*o[:3, 3].tolist()))
        J.CreateLocalRot0Attr(Gf.Quatf(*q0) * rot1)
        J.CreateLocalPos1Attr(Gf.Vec3f(0, 0, 0))
        J.CreateLocalRot1Attr(rot1)
    stage.GetRootLayer().Save()
    return path
