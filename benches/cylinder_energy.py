"""Energy of a rigid cylinder released tilted on its bottom rim on the ground, nothing else touching it, in
ferrobot, MuJoCo and PyBullet (issue 18, BENCHMARKS.md "A cylinder rocking on its rim gains energy"):

    python benches/cylinder_energy.py [--seconds 5]

Prints, per simulator and case (radius, height, mass, tilt), the largest rise of the total mechanical energy
above its initial value (must be <= 0 up to contact compliance), the energy left above rest at the end and
the final tilt. Inertias are hand-derived (solid cylinder). ferrobot gains energy today (a known defect).
"""

import numpy as np
from scipy.spatial.transform import Rotation as R

import ferrobot

G = 9.81


def inertia_cyl(m, r, h):
    ixx = m * (3 * r * r + h * h) / 12
    return np.diag([ixx, ixx, 0.5 * m * r * r])


def energy(m, Ib, z, quat_wxyz, v, w):
    if np.ndim(quat_wxyz) == 2:
        rot = np.asarray(quat_wxyz)
    else:
        rot = R.from_quat([quat_wxyz[1], quat_wxyz[2], quat_wxyz[3], quat_wxyz[0]]).as_matrix()
    Iw = rot @ Ib @ rot.T
    return 0.5 * m * v @ v + 0.5 * w @ Iw @ w + m * G * z


def start_pose(r, h, tilt_deg, drop=0.0):
    # tilted about x; bottom rim lowest point at z = drop
    t = np.radians(tilt_deg)
    z = 0.5 * h * np.cos(t) + r * np.sin(t) + drop
    q = R.from_euler("x", t).as_quat()  # xyzw
    return np.array([0, 0, z]), np.array([q[3], q[0], q[1], q[2]])


def run_ferrobot(r, h, m, tilt, T=5.0, shape="cylinder", spin=0.0, **kw):
    w = ferrobot.World(**kw)
    p, q = start_pose(r, h, tilt)
    pose = [*p, *q]
    if shape == "cylinder":
        w.add_cylinder("c", r, h, pose, mass=m, friction=0.8)
        Ib = inertia_cyl(m, r, h)
    elif shape == "box":
        w.add_box("c", [2 * r, 2 * r, h], pose, mass=m, friction=0.8)
        Ib = m / 12 * np.diag([4 * r * r + h * h, 4 * r * r + h * h, 8 * r * r])
    else:
        w.add_sphere("c", r, [0, 0, r + 0.0, 1, 0, 0, 0], mass=m, friction=0.8)
        Ib = 0.4 * m * r * r * np.eye(3)
    if spin:
        w.set_object_velocity("c", [0.0, 0.0, 0.0], [0.0, 0.0, spin])
    n = int(round(T / w.dt))
    E = []
    tilts = []
    for _ in range(n):
        pz = w.get_object_pose("c")
        v, om = w.get_object_velocity("c")
        rot = pz[:3, :3]
        E.append(energy(m, Ib, pz[2, 3], rot, np.asarray(v), np.asarray(om)))
        tilts.append(np.degrees(np.arccos(np.clip(rot[2, 2], -1, 1))))
        w.step()
    return np.array(E), np.array(tilts)


def run_mujoco(r, h, m, tilt, T=5.0, dt=1 / 240):
    import mujoco

    p, q = start_pose(r, h, tilt)
    xml = f"""<mujoco><option timestep="{dt / 4}" cone="elliptic" integrator="implicitfast"/>
    <worldbody><geom type="plane" size="1 1 0.1" friction="0.8"/>
    <body name="c" pos="{p[0]} {p[1]} {p[2]}" quat="{q[0]} {q[1]} {q[2]} {q[3]}"><freejoint/>
    <geom type="cylinder" size="{r} {h / 2}" mass="{m}" friction="0.8"/></body></worldbody></mujoco>"""
    mm = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(mm)
    Ib = inertia_cyl(m, r, h)
    E, tilts = [], []
    for _ in range(int(round(T / dt))):
        qpos = d.qpos
        v = d.qvel[:3].copy()
        rot = R.from_quat([qpos[4], qpos[5], qpos[6], qpos[3]]).as_matrix()
        wl = d.qvel[3:6]  # body frame in mujoco free joint
        w = rot @ wl
        E.append(energy(m, Ib, qpos[2], qpos[3:7], v, w))
        tilts.append(np.degrees(np.arccos(np.clip(rot[2, 2], -1, 1))))
        for _ in range(4):
            mujoco.mj_step(mm, d)
    return np.array(E), np.array(tilts)


def run_pybullet(r, h, m, tilt, T=5.0, dt=1 / 240):
    import pybullet as pb

    c = pb.connect(pb.DIRECT)
    pb.setGravity(0, 0, -G, physicsClientId=c)
    pb.setTimeStep(dt, physicsClientId=c)
    plane = pb.createCollisionShape(pb.GEOM_PLANE, physicsClientId=c)
    pid = pb.createMultiBody(0, plane, physicsClientId=c)
    pb.changeDynamics(pid, -1, lateralFriction=0.8, physicsClientId=c)
    cs = pb.createCollisionShape(pb.GEOM_CYLINDER, radius=r, height=h, physicsClientId=c)
    p, q = start_pose(r, h, tilt)
    b = pb.createMultiBody(m, cs, basePosition=p.tolist(), baseOrientation=[q[1], q[2], q[3], q[0]], physicsClientId=c)
    pb.changeDynamics(b, -1, lateralFriction=0.8, physicsClientId=c)
    Ib = inertia_cyl(m, r, h)
    E, tilts = [], []
    for _ in range(int(round(T / dt))):
        pos, orn = pb.getBasePositionAndOrientation(b, physicsClientId=c)
        v, w = pb.getBaseVelocity(b, physicsClientId=c)
        qw = [orn[3], orn[0], orn[1], orn[2]]
        E.append(energy(m, Ib, pos[2], qw, np.array(v), np.array(w)))
        rot = R.from_quat(orn).as_matrix()
        tilts.append(np.degrees(np.arccos(np.clip(rot[2, 2], -1, 1))))
        pb.stepSimulation(physicsClientId=c)
    pb.disconnect(c)
    return np.array(E), np.array(tilts)


def main() -> None:
    import argparse

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seconds", type=float, default=5.0)
    a = ap.parse_args()
    for r, h, m in [(0.0215, 0.106, 0.1), (0.04, 0.05, 0.3), (0.015, 0.15, 0.05)]:
        rest = m * G * h / 2
        for tilt in (1.0, 3.0, 6.0):
            for name, fn in [("ferrobot", run_ferrobot), ("mujoco", run_mujoco), ("pybullet", run_pybullet)]:
                e, t = fn(r, h, m, tilt, T=a.seconds)
                print(
                    f"r {r * 1e3:.1f} mm h {h * 1e3:.0f} mm m {m:.2f} kg tilt {tilt:.0f} deg {name:9s}: "
                    f"E0 {1e3 * (e[0] - rest):.3f} mJ above rest, max rise {1e3 * (e.max() - e[0]):+.3f} mJ, "
                    f"end {1e3 * (e[-1] - rest):+.3f} mJ above rest, tilt {t[-1]:.2f} deg"
                )


if __name__ == "__main__":
    main()
