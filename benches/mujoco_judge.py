"""A third judge for the clutter bench's grasps: MuJoCo replays an attempt (the same convex parts, poses,
hand meshes, base pose and per-step joint targets as ferrobot and the PyBullet judge) and applies the
same success test.

Used by ``benches/clutter.py --mujoco`` and to replay recorded attempts. The model, per attempt:

- the table as a box (friction 1), every object in play as a free body whose geoms are its convex parts
  (``clutter.part_files``; MuJoCo takes each mesh's convex hull, and the parts are convex), the object's
  mass split over the parts by volume, its friction on every part, with ``priority`` 1 so a contact
  with the hand uses the object's coefficient (PyBullet multiplies it by the fingers' 1.0: the same);
- the floating Panda hand of ``grasp_eval``: pybullet_data's hand and finger collision meshes on three
  slides along the base pose's axes (PD: 2e4 N/m, 1e3 N s/m, 500 N, as the other judges) and two finger
  slides (target-tracking at 1e5 N/m, limited to ``FINGER_FORCE`` N each: a constant squeeze once the
  fingers meet the object), gravity-compensated as in ferrobot; ``coupled``: an equality keeps the two
  finger joints equal (the real Panda's gearing, ``grasp_eval.hand_files(coupled=True)``);
- contacts without margin, stiff (``solref`` 4 ms, critically damped) and elliptic friction cones,
  4 substeps of the 240 Hz schedule (implicit-fast integrator, Newton solver).
"""

from __future__ import annotations

from pathlib import Path

import grasp_eval as ge
import numpy as np

SUBSTEPS = 4
SLIDE_KP, SLIDE_KD = 2.0e4, 1.0e3
FINGER_KP = 1.0e5
FINGER_KD = 1.0e2


def _quat(t: np.ndarray) -> str:
    w, x, y, z = ge.quat_wxyz(t[:3, :3])
    return f"{w:.12g} {x:.12g} {y:.12g} {z:.12g}"


def _vec(v) -> str:
    return " ".join(f"{float(x):.12g}" for x in v)


def _part_volume(path: str) -> float:
    v, f = [], []
    for line in Path(path).read_text().splitlines():
        if line.startswith("v "):
            v.append([float(x) for x in line.split()[1:4]])
        elif line.startswith("f "):
            f.append([int(x.split("/")[0]) - 1 for x in line.split()[1:4]])
    v, f = np.asarray(v), np.asarray(f)
    o = v.mean(axis=0)
    tri = v[f]
    return float(abs(np.einsum("ij,ij->i", tri[:, 0] - o, np.cross(tri[:, 1] - o, tri[:, 2] - o)).sum() / 6.0))


class MuJoCoClutterJudge:
    """Replays an attempt on the whole pile in MuJoCo (see the module's doc)."""

    def __init__(self, tmp: Path, coupled: bool = False):
        import mujoco
        import pybullet_data

        self.mj = mujoco
        self.tmp = tmp
        self.coupled = coupled
        self.parts: dict = {}
        self.mesh_dir = Path(pybullet_data.getDataPath()) / "franka_panda" / "meshes" / "collision"

    def _xml(self, state, poses: dict, base: np.ndarray, q0: np.ndarray, part_files) -> str:
        dt = ge.DT / SUBSTEPS
        assets = [
            f'<mesh name="hand" file="{self.mesh_dir / "hand.obj"}"/>',
            f'<mesh name="finger" file="{self.mesh_dir / "finger.obj"}"/>',
        ]
        bodies = []
        half = ge.TABLE_SIZE / 2
        top = ge.TABLE_TOP
        world = [f'<geom type="box" size="{half} {half} {top / 2}" pos="0 0 {top / 2}" friction="1 0.005 0.0001"/>']
        if state.spec.bin is not None:
            for _, size, pose in state.spec.bin.walls(top):
                world.append(
                    f'<geom type="box" size="{_vec(np.asarray(size) / 2)}" pos="{_vec(pose[:3])}" '
                    f'friction="0.6 0.005 0.0001"/>'
                )
        for name, pose in poses.items():
            o = state.objects[name]
            files, _com = part_files(o, self.tmp, self.parts)
            vols = np.array([max(_part_volume(f), 1e-12) for f in files])
            geoms = []
            for k, (f, vol) in enumerate(zip(files, vols, strict=True)):
                mname = f"{name}_p{k}"
                assets.append(f'<mesh name="{mname}" file="{f}"/>')
                geoms.append(
                    f'<geom type="mesh" mesh="{mname}" mass="{o.mass * vol / vols.sum():.9g}" '
                    f'friction="{o.friction} 0.005 0.0001" priority="1"/>'
                )
            bodies.append(
                f'<body name="{name}" pos="{_vec(pose[:3, 3])}" quat="{_quat(pose)}"><freejoint/>'
                + "".join(geoms)
                + "</body>"
            )
        finger_force = ge.FINGER_FORCE
        hand = f"""
<body name="hand_root" pos="{_vec(base[:3, 3])}" quat="{_quat(base)}">
  <body name="slide_x" gravcomp="1"><inertial pos="0 0 0" mass="0.01" diaginertia="1e-5 1e-5 1e-5"/>
    <joint name="hand_x" type="slide" axis="1 0 0" range="-0.5 0.5"/>
    <body name="slide_y" gravcomp="1"><inertial pos="0 0 0" mass="0.01" diaginertia="1e-5 1e-5 1e-5"/>
      <joint name="hand_y" type="slide" axis="0 1 0" range="-0.5 0.5"/>
      <body name="panda_hand" gravcomp="1">
        <inertial pos="0 0 0.04" mass="0.81" diaginertia="0.003 0.003 0.002"/>
        <joint name="hand_z" type="slide" axis="0 0 1" range="-0.5 0.5"/>
        <geom type="mesh" mesh="hand" friction="1 0.005 0.0001"/>
        <body name="panda_leftfinger" pos="0 0 0.0584" gravcomp="1">
          <inertial pos="0 0.01 0.02" mass="0.1" diaginertia="2e-5 2e-5 1e-5"/>
          <joint name="f1" type="slide" axis="0 1 0" range="0 0.04" limited="true"/>
          <geom type="mesh" mesh="finger" friction="1 0.005 0.0001"/>
        </body>
        <body name="panda_rightfinger" pos="0 0 0.0584" gravcomp="1">
          <inertial pos="0 -0.01 0.02" mass="0.1" diaginertia="2e-5 2e-5 1e-5"/>
          <joint name="f2" type="slide" axis="0 -1 0" range="0 0.04" limited="true"/>
          <geom type="mesh" mesh="finger" euler="0 0 3.14159265359" friction="1 0.005 0.0001"/>
        </body>
      </body>
    </body>
  </body>
</body>"""
        equality = '<equality><joint joint1="f2" joint2="f1" polycoef="0 1 0 0 0"/></equality>' if self.coupled else ""
        acts = "".join(
            f'<position joint="{j}" kp="{SLIDE_KP}" kv="{SLIDE_KD}" forcerange="-{ge.MOVE_FORCE} {ge.MOVE_FORCE}" '
            f'forcelimited="true" ctrlrange="-0.5 0.5"/>'
            for j in ("hand_x", "hand_y", "hand_z")
        ) + "".join(
            f'<position joint="{j}" kp="{FINGER_KP}" kv="{FINGER_KD}" forcerange="-{finger_force} {finger_force}" '
            f'forcelimited="true" ctrlrange="-0.01 0.05"/>'
            for j in ("f1", "f2")
        )
        return f"""<mujoco model="clutter_judge">
<compiler angle="radian"/>
<option timestep="{dt}" integrator="implicitfast" cone="elliptic" solver="Newton" iterations="50"/>
<default><geom solref="0.004 1" solimp="0.95 0.99 0.001" margin="0" condim="3"/></default>
<asset>{"".join(assets)}</asset>
<worldbody>{"".join(world)}{"".join(bodies)}{hand}</worldbody>
<contact><exclude body1="panda_leftfinger" body2="panda_rightfinger"/>
  <exclude body1="panda_hand" body2="panda_leftfinger"/>
  <exclude body1="panda_hand" body2="panda_rightfinger"/></contact>
{equality}
<actuator>{acts}</actuator>
</mujoco>"""

    def run_pile(self, state, poses: dict, base: np.ndarray, steps, part_files, log_every: int = 0) -> dict:
        """Replays ``steps`` (per 240 Hz step: targets [x, y, z, finger1, finger2] and the squeeze force, 0
        before the close) with the objects at ``poses``; returns success, lifted, opening (as the other
        judges)."""
        mj = self.mj
        q0 = np.asarray(steps[0][0], dtype=float)
        xml = self._xml(state, poses, base, q0, part_files)
        model = mj.MjModel.from_xml_string(xml)
        data = mj.MjData(model)
        jf1, jf2 = model.joint("f1").qposadr[0], model.joint("f2").qposadr[0]
        data.qpos[jf1] = data.qpos[jf2] = q0[3]
        data.ctrl[:] = [0, 0, 0, q0[3], q0[4]]
        mj.mj_forward(model, data)
        # The settled poses come from ferrobot: let MuJoCo's contacts take them up before the hand moves
        # (the PyBullet judge steps 60 times alike).
        hand_free = data.ctrl.copy()
        for _ in range(60 * SUBSTEPS):
            data.ctrl[:] = hand_free
            mj.mj_step(model, data)
        names = list(poses)
        adr = {n: model.joint(model.body(n).jntadr[0]).qposadr[0] for n in names}
        z0 = {n: float(data.qpos[adr[n] + 2]) for n in names}
        for k, (target, force) in enumerate(steps):
            t = np.asarray(target, dtype=float)
            if force > 0:
                data.ctrl[:] = [t[0], t[1], t[2], 0.0, 0.0]
            else:
                data.ctrl[:] = t
            for _ in range(SUBSTEPS):
                mj.mj_step(model, data)
            if log_every and k % log_every == 0:
                print(
                    f"  MJ step {k:4d} fingers {data.qpos[jf1] * 1000:6.2f} {data.qpos[jf2] * 1000:6.2f} mm "
                    + " ".join(f"{n} dz {(data.qpos[adr[n] + 2] - z0[n]) * 100:5.1f} cm" for n in names)
                )
        opening = float(data.qpos[jf1] + data.qpos[jf2])
        lifted = [n for n in names if data.qpos[adr[n] + 2] - z0[n] >= ge.MIN_RISE]
        return {
            "success": bool(lifted) and opening > ge.MIN_OPENING,
            "lifted": lifted,
            "opening": opening,
            "fingers": [float(data.qpos[jf1]), float(data.qpos[jf2])],
        }
