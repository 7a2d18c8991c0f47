"""One scene description, built twice: as a ferrobot ``World`` and as MJCF for MuJoCo.

The robot part of the MJCF is generated from a ``ferrobot.RobotModel`` (links,
joints, inertials, collision primitives, mimic joints, allowed-collision
pairs), so both simulators see the same masses, inertias and geometry. Used by
``benches/sim.py``; not part of the package.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from xml.sax.saxutils import quoteattr

import numpy as np

import ferrobot


@dataclass
class Obj:
    """A rigid object: kind "box" (full size), "sphere", "cylinder" or "capsule" (radius, length along z)."""

    name: str
    kind: str
    dims: tuple[float, ...]
    pose: tuple[float, ...]  # x, y, z, qw, qx, qy, qz
    mass: float = 1.0
    friction: float = 0.5
    static: bool = False


@dataclass
class Settings:
    """Everything both simulators are given."""

    dt: float = 1 / 240
    gravity: float = -9.81
    solver_iterations: int = 4
    ground_friction: float = 0.8
    robot_friction: float = 1.0
    gravity_compensation: bool = True
    # Drive gains per DOF (defaults of ferrobot's drives); force limits are the URDF efforts.
    stiffness: float = 1.0e4
    damping: float = 1.0e2
    objects: list[Obj] = field(default_factory=list)


def _f(v) -> str:
    return " ".join(f"{float(x):.9g}" for x in np.ravel(v))


def _quat(r: np.ndarray) -> np.ndarray:
    """(w, x, y, z) of a rotation matrix."""
    w = np.sqrt(max(0.0, 1.0 + r[0, 0] + r[1, 1] + r[2, 2])) / 2
    x = np.sqrt(max(0.0, 1.0 + r[0, 0] - r[1, 1] - r[2, 2])) / 2
    y = np.sqrt(max(0.0, 1.0 - r[0, 0] + r[1, 1] - r[2, 2])) / 2
    z = np.sqrt(max(0.0, 1.0 - r[0, 0] - r[1, 1] + r[2, 2])) / 2
    x = np.copysign(x, r[2, 1] - r[1, 2])
    y = np.copysign(y, r[0, 2] - r[2, 0])
    z = np.copysign(z, r[1, 0] - r[0, 1])
    q = np.array([w, x, y, z])
    return q / np.linalg.norm(q)


def _pose_attrs(t: np.ndarray) -> str:
    return f'pos="{_f(t[:3, 3])}" quat="{_f(_quat(t[:3, :3]))}"'


def _geom_xml(g: dict, name: str, friction: float) -> str:
    kind = g["type"]
    if kind == "box":
        size = _f(np.asarray(g["size"]) / 2)
        mj = "box"
    elif kind == "sphere":
        size, mj = _f([g["radius"]]), "sphere"
    elif kind in ("cylinder", "capsule"):
        # URDF cylinders and ferrobot capsules lie along z, as MuJoCo's.
        size, mj = _f([g["radius"], g["length"] / 2]), kind
    else:
        raise ValueError(f"collision geometry '{kind}' of {name}: only primitives are written to MJCF")
    pose = _pose_attrs(g["origin"])
    return f'<geom name={quoteattr(name)} type="{mj}" size="{size}" {pose} friction="{friction:.9g}"/>'


def robot_mjcf(model: ferrobot.RobotModel, s: Settings, prefix: str = "") -> tuple[str, str, str]:
    """(body tree, actuators, contact excludes + equalities) of ``model`` with its base at the world origin."""
    joints = {model.joint_info(j).child: model.joint_info(j) for j in model.joint_names}
    children: dict[str, list[str]] = {}
    for child, j in joints.items():
        children.setdefault(j.parent, []).append(child)
    dofs = model.dof_names
    effort = dict(zip(dofs, model.effort_limits, strict=True))
    gravcomp = ' gravcomp="1"' if s.gravity_compensation else ""

    def body(link: str, depth: int) -> str:
        pad = "  " * depth
        j = joints.get(link)
        origin = _pose_attrs(j.origin) if j is not None else 'pos="0 0 0"'
        out = [f'{pad}<body name="{prefix}{link}" {origin}{gravcomp}>']
        if j is not None and j.type in ("revolute", "continuous", "prismatic"):
            kind = "slide" if j.type == "prismatic" else "hinge"
            lim = ""
            if j.type != "continuous" and (j.mimic is None):
                lim = f' limited="true" range="{j.lower:.9g} {j.upper:.9g}"'
            out.append(
                f'{pad}  <joint name="{prefix}{j.name}" type="{kind}" axis="{_f(j.axis)}"{lim} '
                f'damping="{j.damping:.9g}" frictionloss="{j.friction:.9g}"/>'
            )
        inert = model.inertial(link)
        if inert.mass > 0:
            # fullinertia is in the body frame: rotate the URDF inertial frame's tensor into it.
            rot = inert.origin[:3, :3]
            i = rot @ inert.inertia @ rot.T
            full = _f([i[0, 0], i[1, 1], i[2, 2], i[0, 1], i[0, 2], i[1, 2]])
            com = _f(inert.origin[:3, 3])
            out.append(f'{pad}  <inertial pos="{com}" mass="{inert.mass:.9g}" fullinertia="{full}"/>')
        for k, g in enumerate(model.collision_geometry(link)):
            out.append(pad + "  " + _geom_xml(g, f"{prefix}{link}_{k}", s.robot_friction))
        for c in children.get(link, []):
            out.append(body(c, depth + 1))
        out.append(f"{pad}</body>")
        return "\n".join(out)

    tree = body(model.base_link, 2)
    acts = []
    for d in dofs:
        e = effort[d]
        limit = f' forcelimited="true" forcerange="{-e:.9g} {e:.9g}"' if e > 0 else ""
        gains = f'kp="{s.stiffness:.9g}" kv="{s.damping:.9g}"'
        acts.append(f'    <position name="{prefix}{d}_drive" joint="{prefix}{d}" {gains}{limit}/>')
    extra = ["  <contact>"]
    # Parent-child pairs are filtered by MuJoCo itself; the rest of the allowed-collision matrix here.
    for a, b, _ in model.disabled_collision_pairs:
        extra.append(f'    <exclude body1="{prefix}{a}" body2="{prefix}{b}"/>')
    extra.append("  </contact>\n  <equality>")
    for j, (driver, mult, off) in model.mimic_joints:
        poly = f"{off:.9g} {mult:.9g} 0 0 0"
        extra.append(f'    <joint joint1="{prefix}{j}" joint2="{prefix}{driver}" polycoef="{poly}"/>')
    extra.append("  </equality>")
    return tree, "\n".join(acts), "\n".join(extra)


def _obj_geom(o: Obj) -> str:
    if o.kind == "box":
        return f'type="box" size="{_f(np.asarray(o.dims) / 2)}"'
    if o.kind == "sphere":
        return f'type="sphere" size="{_f(o.dims[:1])}"'
    if o.kind in ("cylinder", "capsule"):
        return f'type="{o.kind}" size="{_f([o.dims[0], o.dims[1] / 2])}"'
    raise ValueError(o.kind)


def scene_mjcf(model: ferrobot.RobotModel | None, s: Settings, q0: np.ndarray | None = None) -> str:
    """The whole scene as an MJCF document (ground plane, objects, robot)."""
    world = [f'    <geom name="ground" type="plane" size="0 0 1" friction="{s.ground_friction:.9g}"/>']
    for o in s.objects:
        p = o.pose
        geom = f'<geom name="{o.name}" {_obj_geom(o)} friction="{o.friction:.9g}"'
        if o.static:
            world.append(f'    {geom} pos="{_f(p[:3])}" quat="{_f(p[3:])}"/>')
        else:
            world.append(
                f'    <body name="{o.name}" pos="{_f(p[:3])}" quat="{_f(p[3:])}">\n'
                f'      <freejoint name="{o.name}"/>\n      {geom} mass="{o.mass:.9g}"/>\n    </body>'
            )
    tree, acts, extra = ("", "", "") if model is None else robot_mjcf(model, s)
    return f"""<mujoco model="ferrobot_bench">
  <compiler angle="radian" autolimits="true"/>
  <option timestep="{s.dt:.12g}" gravity="0 0 {s.gravity:.9g}" iterations="{s.solver_iterations}"
          integrator="implicitfast"/>
  <worldbody>
{chr(10).join(world)}
{tree}
  </worldbody>
  <actuator>
{acts}
  </actuator>
{extra}
</mujoco>
"""


def build_ferrobot(model: ferrobot.RobotModel | None, s: Settings, q0: np.ndarray | None = None):
    """The same scene as a ferrobot World; returns (world, robot or None)."""
    w = ferrobot.World(
        dt=s.dt, gravity=[0, 0, s.gravity], solver_iterations=s.solver_iterations, ground_friction=s.ground_friction
    )
    r = None
    if model is not None:
        r = w.add_robot(
            model, name="panda", q=q0, gravity_compensation=s.gravity_compensation, friction=s.robot_friction
        )
        n = r.num_dof
        r.set_drive_gains([s.stiffness] * n, [s.damping] * n)
        if q0 is not None:
            r.set_joint_position_targets(q0)
    for o in s.objects:
        kw = dict(mass=o.mass, friction=o.friction, fixed=o.static)
        if o.kind == "box":
            w.add_box(o.name, o.dims, list(o.pose), **kw)
        elif o.kind == "sphere":
            w.add_sphere(o.name, o.dims[0], list(o.pose), **kw)
        elif o.kind == "cylinder":
            w.add_cylinder(o.name, o.dims[0], o.dims[1], list(o.pose), **kw)
        elif o.kind == "capsule":
            w.add_capsule(o.name, o.dims[0], o.dims[1], list(o.pose), **kw)
        else:
            raise ValueError(o.kind)
    return w, r


def build_mujoco(model: ferrobot.RobotModel | None, s: Settings, q0: np.ndarray | None = None):
    """(MjModel, MjData, xml) of the scene with the robot at ``q0`` and its targets at ``q0``."""
    import mujoco

    xml = scene_mjcf(model, s, q0)
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    if model is not None and q0 is not None:
        for name, v in zip(model.dof_names, q0, strict=True):
            d.joint(name).qpos[0] = v
            d.actuator(f"{name}_drive").ctrl[0] = v
        for j, (driver, mult, off) in model.mimic_joints:
            d.joint(j).qpos[0] = mult * q0[model.dof_names.index(driver)] + off
    mujoco.mj_forward(m, d)
    return m, d, xml
