"""Top-1 grasp success in simulation, judged by ferrobot's physics and replayed in PyBullet.

    python benches/grasp_eval.py [--objects PATH] [--n N] [--split all|dev|heldout] [--json FILE] [--seed S]
                                 [--no-pybullet] [--camera-approach] [--option KEY=JSON ...]

PATH is a folder searched (recursively) for object URDFs (the first collision mesh of the first link,
with its scale, origin, mass and lateral friction) or bare meshes (OBJ, STL; 0.1 kg, friction 1).
Default: PyPI ``pybullet``'s ``pybullet_data/random_urdfs`` (1,000 meshes) and ``objects/``; ``--n``
objects are drawn from them at random (``--seed``), or all with ``--n 0``. ``--split`` keeps the
development or the held-out half by a fixed rule (the last number in the file name even or odd),
before drawing. A URDF with several ``<collision>`` meshes is a multi-part object (each mesh one
convex part, e.g. ``benches/heldout_objects.py``): ferrobot simulates it with
``approximation="convex_decomposition"`` of the parts' hulls, PyBullet with the exact parts.

Per object, in a fresh ``ferrobot.World`` (240 Hz):

- the object is the **convex hull** of its mesh (the same hull in both simulators), re-centred on its
  centroid; an object whose middle bounding-box extent exceeds 6.5 cm is **scaled down** so it does
  (the Panda hand opens 8 cm), and the JSON counts the scaled objects; it is dropped with a random yaw
  onto a 60 x 60 cm table (top at z = 0.4 m) and settles for 1 s;
- one 640 x 480 camera (fx = fy = 525) 0.6 m away, looking down at 50 degrees, renders depth and
  segmentation; ``detect_from_rgbd`` runs with default options, the object's mask and, as the
  preferred approach direction, the world's -z in the camera frame (``--camera-approach``: the
  camera's view, the detector's default); the top grasp is taken (no grasp: failure in both judges);
  the Panda hand pose comes from ``hand_poses`` (the gripper's ``to_hand``) with the TCP at the
  fingertips of the simulated finger meshes (0.112 m);
- a **floating Panda hand** executes it: the Panda hand and finger collision meshes of
  ``pybullet_data/franka_panda`` on three prismatic joints along the hand's own axes (a URDF written
  here, loaded as a ferrobot robot whose base is placed at the pre-grasp pose; joint drives move it),
  so the hand is a driven body with real contacts; fingers are two independent prismatic joints.
  Sequence: pre-grasp 5 cm back along the approach, approach (0.5 s), close with 20 N per finger
  (0.5 s), lift 10 cm (1 s), hold 2 s; the slides are stiff PD drives (2e4 N/m, 1e3 N s/m, 500 N);
- success: the object rose at least 8 cm with the hand and the fingers did not close on nothing
  (opening > 2 mm), i.e. the object is still between the fingers.

The **PyBullet judge** replays the same object hull at the pose it settled to in ferrobot, the same
hand URDF at the same base pose and the same joint targets every step (position control, same force
limits, friction 1 everywhere), and applies the same success test.

Prints detection time per frame (median wall and CPU time of this process, all threads) with the
machine load, and the success rate under each judge; ``--json`` writes them with per-object records.
"""

from __future__ import annotations

import argparse
import json
import os
import random
import statistics
import sys
import tempfile
import time
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.spatial import ConvexHull

import ferrobot
import ferrobot.grasp as fg

DT = 1.0 / 240.0
TABLE_TOP = 0.4
TABLE_SIZE = 2.0
WIDTH, HEIGHT, F = 640, 480, 525.0
CX, CY = (WIDTH - 1) / 2, (HEIGHT - 1) / 2
MAX_MIDDLE_EXTENT = 0.065
PREGRASP = 0.05
LIFT = 0.10
FINGER_FORCE = 20.0
MOVE_FORCE = 500.0
OPEN = 0.04
SETTLE_S, APPROACH_S, CLOSE_S, LIFT_S, HOLD_S = 1.0, 0.5, 0.5, 1.0, 2.0
MIN_RISE = 0.08
MIN_OPENING = 0.002
# fingertip centre of pybullet_data's Panda finger meshes: joint at 0.0584 m + 0.0538 m finger
TCP_OFFSET = 0.0584 + 0.0538
PANDA_HAND = ferrobot.Gripper.panda_hand()


def hand_poses(grasps) -> np.ndarray:
    """(N, 4, 4) poses of the simulated hand's ``panda_hand`` frame for ``grasps``: the Panda gripper's hand
    pose (``to_hand``), moved back along its approach so that the fingertips of pybullet_data's finger
    meshes (``TCP_OFFSET`` from the hand frame, not the gripper's 0.1034 m TCP) are on the grasp."""
    hands = grasps.to_hand(PANDA_HAND)
    hands[:, :3, 3] -= (TCP_OFFSET - PANDA_HAND.tcp[2]) * hands[:, :3, 2]
    return hands


HAND_URDF = """<?xml version="1.0"?>
<robot name="floating_panda_hand">
  <link name="hand_root">
    <inertial><mass value="0.01"/><inertia ixx="1e-5" iyy="1e-5" izz="1e-5" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <link name="slide_x">
    <inertial><mass value="0.01"/><inertia ixx="1e-5" iyy="1e-5" izz="1e-5" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <link name="slide_y">
    <inertial><mass value="0.01"/><inertia ixx="1e-5" iyy="1e-5" izz="1e-5" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <joint name="hand_x" type="prismatic">
    <parent link="hand_root"/><child link="slide_x"/><axis xyz="1 0 0"/>
    <limit lower="-0.5" upper="0.5" effort="{move_force}" velocity="1.0"/>
  </joint>
  <joint name="hand_y" type="prismatic">
    <parent link="slide_x"/><child link="slide_y"/><axis xyz="0 1 0"/>
    <limit lower="-0.5" upper="0.5" effort="{move_force}" velocity="1.0"/>
  </joint>
  <joint name="hand_z" type="prismatic">
    <parent link="slide_y"/><child link="panda_hand"/><axis xyz="0 0 1"/>
    <limit lower="-0.5" upper="0.5" effort="{move_force}" velocity="1.0"/>
  </joint>
  <link name="panda_hand">
    <contact><lateral_friction value="1.0"/></contact>
    <inertial><origin xyz="0 0 0.04"/><mass value="0.81"/>
      <inertia ixx="0.003" iyy="0.003" izz="0.002" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><geometry><mesh filename="{mesh_dir}/hand.obj"/></geometry></collision>
  </link>
  <link name="panda_leftfinger">
    <contact><lateral_friction value="1.0"/></contact>
    <inertial><origin xyz="0 0.01 0.02"/><mass value="0.1"/>
      <inertia ixx="2e-5" iyy="2e-5" izz="1e-5" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><geometry><mesh filename="{mesh_dir}/finger.obj"/></geometry></collision>
  </link>
  <link name="panda_rightfinger">
    <contact><lateral_friction value="1.0"/></contact>
    <inertial><origin xyz="0 -0.01 0.02"/><mass value="0.1"/>
      <inertia ixx="2e-5" iyy="2e-5" izz="1e-5" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin rpy="0 0 3.14159265359"/>
      <geometry><mesh filename="{mesh_dir}/finger.obj"/></geometry></collision>
  </link>
  <joint name="panda_finger_joint1" type="prismatic">
    <parent link="panda_hand"/><child link="panda_leftfinger"/><origin xyz="0 0 0.0584"/><axis xyz="0 1 0"/>
    <limit lower="0.0" upper="0.04" effort="{finger_force}" velocity="0.2"/>
  </joint>
  <joint name="panda_finger_joint2" type="prismatic">
    <parent link="panda_hand"/><child link="panda_rightfinger"/><origin xyz="0 0 0.0584"/><axis xyz="0 -1 0"/>
    <limit lower="0.0" upper="0.04" effort="{finger_force}" velocity="0.2"/>
  </joint>
</robot>
"""


# ---------------------------------------------------------------- objects


@dataclass
class ObjectSpec:
    """An object to grasp: hull points (m, centred on the hull's centroid) and physical properties."""

    name: str
    source: str
    points: np.ndarray
    faces: np.ndarray
    mass: float
    friction: float
    scale_factor: float = 1.0
    extents: list = field(default_factory=list)
    # convex parts (same frame as ``points``) of a multi-part object; empty: the hull is the object
    parts: list = field(default_factory=list)


def read_obj(path: Path) -> np.ndarray:
    """Vertices of an OBJ file (every ``v`` line, all groups)."""
    out = []
    with open(path, errors="replace") as f:
        for line in f:
            if line.startswith("v "):
                out.append([float(x) for x in line.split()[1:4]])
    return np.array(out, dtype=np.float64).reshape(-1, 3)


def read_stl(path: Path) -> np.ndarray:
    """Vertices of a binary or ASCII STL file."""
    data = path.read_bytes()
    if len(data) >= 84:
        n = int(np.frombuffer(data[80:84], dtype="<u4")[0])
        if 84 + 50 * n == len(data):
            rec = np.frombuffer(data[84:], dtype=np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")]))
            return rec["v"].reshape(-1, 3).astype(np.float64)
    text = data.decode(errors="replace").split()
    out = [[float(text[i + 1]), float(text[i + 2]), float(text[i + 3])] for i, t in enumerate(text) if t == "vertex"]
    return np.array(out, dtype=np.float64).reshape(-1, 3)


def read_mesh(path: Path) -> np.ndarray:
    suffix = path.suffix.lower()
    if suffix == ".obj":
        return read_obj(path)
    if suffix == ".stl":
        return read_stl(path)
    raise ValueError(f"{path}: unsupported mesh format (OBJ or STL)")


def rpy_matrix(rpy) -> np.ndarray:
    r, p, y = rpy
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return rz @ ry @ rx


def read_urdf(path: Path) -> tuple[list[np.ndarray], float, float]:
    """Vertices (m, link frame) of each collision mesh of a single-object URDF's first link (one array
    per ``<collision>``: several make a multi-part object), its mass and lateral friction."""
    root = ET.parse(path).getroot()
    link = root.find("link")
    if link is None:
        raise ValueError(f"{path}: no <link>")
    parts = []
    for col in link.findall("collision"):
        mesh = col.find("geometry/mesh")
        if mesh is None:
            continue
        fname = mesh.get("filename", "").replace("package://", "")
        verts = read_mesh((path.parent / fname).resolve())
        scale = np.array([float(s) for s in mesh.get("scale", "1 1 1").split()])
        verts = verts * scale
        origin = col.find("origin")
        if origin is not None:
            xyz = np.array([float(s) for s in origin.get("xyz", "0 0 0").split()])
            rpy = np.array([float(s) for s in origin.get("rpy", "0 0 0").split()])
            verts = verts @ rpy_matrix(rpy).T + xyz
        parts.append(verts)
    if not parts:
        raise ValueError(f"{path}: the first link has no collision mesh")
    m = link.find("inertial/mass")
    mass = float(m.get("value")) if m is not None else 0.1
    fr = link.find("contact/lateral_friction")
    friction = float(fr.get("value")) if fr is not None else 1.0
    return parts, (mass if mass > 0 else 0.1), friction


def hull_centroid(points: np.ndarray, hull: ConvexHull) -> np.ndarray:
    """Volume centroid of a convex hull (sum of tetrahedra from an interior point)."""
    o = points[hull.vertices].mean(axis=0)
    tri = points[hull.simplices]
    vol = np.abs(np.einsum("ij,ij->i", tri[:, 0] - o, np.cross(tri[:, 1] - o, tri[:, 2] - o))) / 6.0
    cent = (tri.sum(axis=1) + o) / 4.0
    return (cent * vol[:, None]).sum(axis=0) / vol.sum()


def make_spec(path: Path) -> ObjectSpec:
    if path.suffix.lower() == ".urdf":
        parts, mass, friction = read_urdf(path)
    else:
        parts, mass, friction = [read_mesh(path)], 0.1, 1.0
    if len(parts) > 1:
        return make_parts_spec(path, parts, mass, friction)
    verts = parts[0]
    verts = verts[np.all(np.isfinite(verts), axis=1)]
    hull = ConvexHull(verts)
    pts = verts[hull.vertices]
    ext = np.sort(pts.max(axis=0) - pts.min(axis=0))
    s = min(1.0, MAX_MIDDLE_EXTENT / ext[1])
    pts = pts * s
    hull = ConvexHull(pts)
    pts = pts - hull_centroid(pts, hull)
    return ObjectSpec(
        name=path.stem,
        source=str(path),
        points=pts,
        faces=hull.simplices.astype(np.int64),
        mass=mass,
        friction=friction,
        scale_factor=s,
        extents=(ext * s).round(4).tolist(),
    )


def make_parts_spec(path: Path, parts: list[np.ndarray], mass: float, friction: float) -> ObjectSpec:
    """A multi-part object (one convex part per OBJ group; parts must not overlap): scaled as a whole
    like a hull, centred on the union's volume centroid."""
    allv = np.concatenate(parts)
    ext = np.sort(allv.max(axis=0) - allv.min(axis=0))
    s = min(1.0, MAX_MIDDLE_EXTENT / ext[1])
    hulls = [ConvexHull(p * s) for p in parts]
    vols = np.array([h.volume for h in hulls])
    cents = np.array([hull_centroid(p * s, h) for p, h in zip(parts, hulls, strict=True)])
    com = (cents * vols[:, None]).sum(axis=0) / vols.sum()
    out_parts = [p[h.vertices] * s - com for p, h in zip(parts, hulls, strict=True)]
    faces, base = [], 0
    for h in hulls:
        remap = {int(v): i for i, v in enumerate(h.vertices)}
        faces.append(np.vectorize(remap.get)(h.simplices) + base)
        base += len(h.vertices)
    return ObjectSpec(
        name=path.stem,
        source=str(path),
        points=np.concatenate(out_parts),
        faces=np.concatenate(faces).astype(np.int64),
        mass=mass,
        friction=friction,
        scale_factor=s,
        extents=(ext * s).round(4).tolist(),
        parts=out_parts,
    )


def default_object_paths() -> list[Path]:
    import pybullet_data

    root = Path(pybullet_data.getDataPath())
    return find_objects(root / "random_urdfs") + find_objects(root / "objects")


def find_objects(folder: Path) -> list[Path]:
    """URDFs, else bare OBJ/STL meshes not referenced by a URDF in the same folder."""
    folder = Path(folder)
    if not folder.is_dir():
        raise SystemExit(f"--objects: {folder} is not a folder")
    urdfs = sorted(folder.rglob("*.urdf"))
    covered = {u.parent for u in urdfs}
    meshes = sorted(p for p in folder.rglob("*") if p.suffix.lower() in (".obj", ".stl") and p.parent not in covered)
    return urdfs + meshes


# ---------------------------------------------------------------- geometry helpers


def quat_wxyz(r: np.ndarray) -> np.ndarray:
    """(w, x, y, z) of a rotation matrix."""
    t = np.trace(r)
    if t > 0:
        s = np.sqrt(t + 1.0) * 2
        q = [0.25 * s, (r[2, 1] - r[1, 2]) / s, (r[0, 2] - r[2, 0]) / s, (r[1, 0] - r[0, 1]) / s]
    else:
        i = int(np.argmax(np.diag(r)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = np.sqrt(1.0 + r[i, i] - r[j, j] - r[k, k]) * 2
        q = [0.0] * 4
        q[0] = (r[k, j] - r[j, k]) / s
        q[1 + i] = 0.25 * s
        q[1 + j] = (r[j, i] + r[i, j]) / s
        q[1 + k] = (r[k, i] + r[i, k]) / s
    q = np.array(q)
    return q / np.linalg.norm(q)


def pose7(t: np.ndarray) -> list[float]:
    return list(t[:3, 3]) + list(quat_wxyz(t[:3, :3]))


def xyzw(t: np.ndarray) -> list[float]:
    w, x, y, z = quat_wxyz(t[:3, :3])
    return [x, y, z, w]


def yaw_pose(yaw: float, p) -> np.ndarray:
    t = np.eye(4)
    c, s = np.cos(yaw), np.sin(yaw)
    t[:2, :2] = [[c, -s], [s, c]]
    t[:3, 3] = p
    return t


def smooth(a: np.ndarray, b: np.ndarray, seconds: float) -> np.ndarray:
    """Joint positions (N, k) from a to b with a quintic time law, one row per step."""
    n = max(2, int(round(seconds / DT)) + 1)
    s = np.linspace(0.0, 1.0, n)[1:]
    s = 10 * s**3 - 15 * s**4 + 6 * s**5
    return a + s[:, None] * (b - a)


def hand_schedule(base: np.ndarray) -> list[tuple[np.ndarray, float]]:
    """Per-step targets [x, y, z, finger1, finger2] for approach, close, lift and hold.

    The joints slide along the hand's own axes (the base frame), so a world displacement d is
    R^T d in joint coordinates.
    """
    rot = base[:3, :3]
    q0 = np.zeros(3)
    q_grasp = np.array([0.0, 0.0, PREGRASP])
    q_lift = q_grasp + rot.T @ np.array([0.0, 0.0, LIFT])
    steps: list[tuple[np.ndarray, float]] = []
    for q in smooth(q0, q_grasp, APPROACH_S):
        steps.append((np.r_[q, OPEN, OPEN], 0.0))
    for _ in range(int(round(CLOSE_S / DT))):
        steps.append((np.r_[q_grasp, 0.0, 0.0], FINGER_FORCE))
    for q in smooth(q_grasp, q_lift, LIFT_S):
        steps.append((np.r_[q, 0.0, 0.0], FINGER_FORCE))
    for _ in range(int(round(HOLD_S / DT))):
        steps.append((np.r_[q_lift, 0.0, 0.0], FINGER_FORCE))
    return steps


# ---------------------------------------------------------------- ferrobot judge


class Scene:
    """A table, one object and a camera in a ferrobot world."""

    def __init__(self, spec: ObjectSpec, rng: random.Random):
        self.world = w = ferrobot.World(dt=DT)
        w.add_box(
            "table", [TABLE_SIZE, TABLE_SIZE, TABLE_TOP], [0, 0, TABLE_TOP / 2, 1, 0, 0, 0], fixed=True, friction=1.0
        )
        yaw = rng.uniform(-np.pi, np.pi)
        drop = yaw_pose(yaw, [0.0, 0.0, 0.0])
        lowest = (spec.points @ drop[:3, :3].T)[:, 2].min()
        drop[2, 3] = TABLE_TOP - lowest + 0.005
        w.add_mesh(
            "object",
            spec.points,
            spec.faces,
            pose7(drop),
            approximation="convex_decomposition" if spec.parts else "convex_hull",
            mass=spec.mass,
            friction=spec.friction,
        )
        w.step(int(round(SETTLE_S / DT)))
        self.settled = w.get_object_pose("object")
        self.object_id = next(k for k, v in w.segmentation_labels.items() if v == "object")
        target = self.settled[:3, 3]
        eye = target + 0.6 * np.array([np.cos(np.radians(50)), 0.0, np.sin(np.radians(50))])
        self.cam_pose = np.asarray(ferrobot.look_at(eye, target))
        self.camera = ferrobot.Camera(w, WIDTH, HEIGHT, fx=F, cx=CX, cy=CY, pose=self.cam_pose)

    def detect(self, **options):
        frame = self.camera.render(rgb=False)
        depth = np.where(np.isfinite(frame.depth), frame.depth, 0.0)
        t0, c0 = time.perf_counter(), time.process_time()
        gg = fg.detect_from_rgbd(
            depth, F, F, CX, CY, scale=1.0, mask=frame.segmentation, object_id=self.object_id, **options
        )
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        return gg, wall, cpu


def outcome(obj_z0: float, obj_z: float, opening: float) -> bool:
    return bool(obj_z - obj_z0 >= MIN_RISE and opening > MIN_OPENING)


def judge_ferrobot(scene: Scene, hand_model, base: np.ndarray, steps) -> dict:
    w = scene.world
    robot = w.add_robot(hand_model, pose7(base), name="hand", q=np.array([0, 0, 0, OPEN, OPEN]))
    names = robot.dof_names
    slide, fingers = names[:3], names[3:]
    robot.set_drive_gains(stiffness=[2.0e4, 2.0e4, 2.0e4], damping=[1.0e3, 1.0e3, 1.0e3], joint_names=slide)
    robot.set_gripper(["panda_finger_joint1", "panda_finger_joint2"], [OPEN, OPEN], [0.0, 0.0])
    robot.set_joint_position_targets(np.array([0, 0, 0, OPEN, OPEN]))
    p0 = w.get_object_pose("object")[:3, 3]
    z0 = p0[2]
    closing = False
    k_close = -1
    diag = {}
    for k, (target, force) in enumerate(steps):
        robot.set_joint_position_targets(target[:3], joint_names=slide)
        if force > 0 and not closing:
            q = robot.joint_positions
            diag["approach_error"] = float(PREGRASP - q[2])
            diag["pushed"] = float(np.linalg.norm(w.get_object_pose("object")[:3, 3] - p0))
            robot.close_gripper(force=force)
            closing = True
            k_close = k
        if closing and k == k_close + int(CLOSE_S / DT) - 1:
            q = robot.joint_positions
            diag["closed_opening"] = float(q[3] + q[4])
        elif force == 0:
            robot.set_joint_position_targets(target[3:], joint_names=fingers)
        w.step(1)
    q = robot.joint_positions
    z = w.get_object_pose("object")[2, 3]
    return {"success": outcome(z0, z, q[3] + q[4]), "rise": z - z0, "opening": q[3] + q[4], **diag}


# ---------------------------------------------------------------- pybullet judge


class PyBulletJudge:
    """Replays a hand schedule on the same object hull in PyBullet."""

    def __init__(self, hand_urdf: str):
        import pybullet

        self.p = pybullet
        self.hand_urdf = hand_urdf
        self.tmp = str(Path(hand_urdf).parent)
        self.cid = pybullet.connect(pybullet.DIRECT)

    def close(self):
        self.p.disconnect(self.cid)

    def run(self, spec: ObjectSpec, obj_pose: np.ndarray, base: np.ndarray, steps) -> dict:
        p, c = self.p, self.cid
        p.resetSimulation(physicsClientId=c)
        p.setGravity(0, 0, -9.81, physicsClientId=c)
        p.setTimeStep(DT, physicsClientId=c)
        table = p.createCollisionShape(
            p.GEOM_BOX, halfExtents=[TABLE_SIZE / 2, TABLE_SIZE / 2, TABLE_TOP / 2], physicsClientId=c
        )
        tid = p.createMultiBody(0, table, basePosition=[0, 0, TABLE_TOP / 2], physicsClientId=c)
        p.changeDynamics(tid, -1, lateralFriction=1.0, physicsClientId=c)
        if spec.parts:
            # the exact convex parts: an OBJ with one object per part loads as a compound of hulls
            obj = Path(self.tmp) / "parts.obj"
            lines = []
            for k, part in enumerate(spec.parts):
                lines.append(f"o part{k}")
                lines += [f"v {x:.7f} {y:.7f} {z:.7f}" for x, y, z in part]
                hull = ConvexHull(part)
                first = sum(len(q) for q in spec.parts[:k]) + 1
                lines += ["f " + " ".join(str(first + int(v)) for v in tri) for tri in hull.simplices]
            obj.write_text("\n".join(lines) + "\n")
            shape = p.createCollisionShape(p.GEOM_MESH, fileName=str(obj), physicsClientId=c)
        else:
            shape = p.createCollisionShape(p.GEOM_MESH, vertices=spec.points.tolist(), physicsClientId=c)
        oid = p.createMultiBody(
            spec.mass, shape, basePosition=list(obj_pose[:3, 3]), baseOrientation=xyzw(obj_pose), physicsClientId=c
        )
        p.changeDynamics(oid, -1, lateralFriction=spec.friction, physicsClientId=c)
        for _ in range(60):
            p.stepSimulation(physicsClientId=c)
        hand = p.loadURDF(self.hand_urdf, list(base[:3, 3]), xyzw(base), useFixedBase=True, physicsClientId=c)
        joints = list(range(5))
        for j, q in zip(joints, [0, 0, 0, OPEN, OPEN], strict=True):
            p.resetJointState(hand, j, q, physicsClientId=c)
        for j in (3, 4):
            p.changeDynamics(hand, j, lateralFriction=1.0, physicsClientId=c)
        z0 = p.getBasePositionAndOrientation(oid, physicsClientId=c)[0][2]
        for target, force in steps:
            fingers = FINGER_FORCE if force > 0 else FINGER_FORCE
            p.setJointMotorControlArray(
                hand,
                joints,
                p.POSITION_CONTROL,
                targetPositions=list(target),
                forces=[MOVE_FORCE] * 3 + [fingers] * 2,
                physicsClientId=c,
            )
            p.stepSimulation(physicsClientId=c)
        z = p.getBasePositionAndOrientation(oid, physicsClientId=c)[0][2]
        opening = sum(p.getJointState(hand, j, physicsClientId=c)[0] for j in (3, 4))
        return {"success": outcome(z0, z, opening), "rise": z - z0, "opening": opening}


# ---------------------------------------------------------------- main


def load_avg() -> str:
    try:
        return " ".join(f"{x:.2f}" for x in os.getloadavg())
    except OSError:
        return "n/a"


def hand_files(tmp: Path, coupled: bool = False) -> tuple[str, ferrobot.RobotModel]:
    """The floating hand's URDF (path) and its ferrobot model. ``coupled``: the second finger joint mimics
    the first (as the real Panda hand, whose fingers are geared to one motor), so the finger pair cannot
    drift sideways as a unit; ferrobot then has one finger DOF, and the PyBullet judge must add the gear
    constraint itself (PyBullet ignores ``<mimic>``)."""
    import pybullet_data

    mesh_dir = Path(pybullet_data.getDataPath()) / "franka_panda" / "meshes" / "collision"
    text = HAND_URDF.format(mesh_dir=mesh_dir, move_force=MOVE_FORCE, finger_force=FINGER_FORCE)
    if coupled:
        tail = f'<limit lower="0.0" upper="0.04" effort="{FINGER_FORCE}" velocity="0.2"/>\n  </joint>\n</robot>'
        assert text.rstrip().endswith(tail), "HAND_URDF's last joint changed"
        text = text.rstrip()[: -len("  </joint>\n</robot>")] + (
            '  <mimic joint="panda_finger_joint1" multiplier="1" offset="0"/>\n  </joint>\n</robot>\n'
        )
        path = tmp / "floating_panda_hand_coupled.urdf"
        path.write_text(text)
        return str(path), ferrobot.RobotModel.from_urdf(path, ee_link="panda_hand")
    path = tmp / "floating_panda_hand.urdf"
    path.write_text(text)
    return str(path), ferrobot.RobotModel.from_urdf(path, ee_link="panda_hand")


def evaluate(
    paths: list[Path],
    seed: int = 0,
    use_pybullet: bool = True,
    progress: bool = True,
    top_down: bool = True,
    options: dict | None = None,
) -> dict:
    """Runs the evaluation on object files; returns the result dictionary (see the module doc).

    ``top_down``: pass the world's -z (in the camera frame) as the detector's preferred approach
    direction, as one would for objects on a table; otherwise the detector's default (the camera's
    view direction). ``options``: extra detection options (``ferrobot.grasp.OPTIONS``).
    """
    rng = random.Random(seed)
    records = []
    det_wall, det_cpu = [], []
    with tempfile.TemporaryDirectory() as tmp:
        urdf, hand_model = hand_files(Path(tmp))
        pb = PyBulletJudge(urdf) if use_pybullet else None
        try:
            for k, path in enumerate(paths):
                rec: dict = {"object": str(path)}
                try:
                    spec = make_spec(path)
                except Exception as e:  # unreadable or degenerate mesh: reported, not counted
                    rec["skipped"] = f"{type(e).__name__}: {e}"
                    records.append(rec)
                    continue
                rec.update(scale_factor=spec.scale_factor, extents=spec.extents)
                scene = Scene(spec, rng)
                down_cam = scene.cam_pose[:3, :3].T @ np.array([0.0, 0.0, -1.0])
                opts = dict(options or {})
                if top_down:
                    opts["approach_direction"] = tuple(down_cam)
                gg, wall, cpu = scene.detect(**opts)
                det_wall.append(wall)
                det_cpu.append(cpu)
                rec.update(detect_ms=wall * 1e3, detect_cpu_ms=cpu * 1e3, num_grasps=len(gg))
                if len(gg) == 0:
                    rec["ferrobot"] = {"success": False, "reason": "no grasp"}
                    if pb:
                        rec["pybullet"] = {"success": False, "reason": "no grasp"}
                else:
                    top = gg[:1].transform(fg.camera_to_world(scene.cam_pose, "opencv"))
                    hand = hand_poses(top)[0]
                    base = hand.copy()
                    base[:3, 3] -= PREGRASP * hand[:3, 2]
                    rec.update(score=float(top.scores[0]), width=float(top.widths[0]), hand_pose=hand.tolist())
                    steps = hand_schedule(base)
                    settled = scene.settled.copy()
                    rec["ferrobot"] = judge_ferrobot(scene, hand_model, base, steps)
                    if pb:
                        rec["pybullet"] = pb.run(spec, settled, base, steps)
                records.append(rec)
                if progress:
                    done = [r for r in records if "ferrobot" in r]
                    fr = sum(r["ferrobot"]["success"] for r in done)
                    pr = sum(r.get("pybullet", {}).get("success", False) for r in done)
                    print(
                        f"\r[{k + 1}/{len(paths)}] ferrobot {fr}/{len(done)}  pybullet {pr}/{len(done)}  "
                        f"detect {statistics.median(det_wall) * 1e3:.1f} ms",
                        end="",
                        file=sys.stderr,
                        flush=True,
                    )
        finally:
            if pb:
                pb.close()
    if progress:
        print(file=sys.stderr)
    done = [r for r in records if "ferrobot" in r]
    n = len(done)
    result = {
        "num_objects": n,
        "num_skipped": len(records) - n,
        "num_scaled": sum(1 for r in done if r["scale_factor"] < 1.0),
        "success_rate": {
            "ferrobot": sum(r["ferrobot"]["success"] for r in done) / n if n else 0.0,
        },
        "median_detection_ms": statistics.median(det_wall) * 1e3 if det_wall else None,
        "median_detection_cpu_ms": statistics.median(det_cpu) * 1e3 if det_cpu else None,
        "frame": [WIDTH, HEIGHT],
        "cores": os.cpu_count(),
        "top_down": top_down,
        "detect_options": options or {},
        "load_average": load_avg(),
        "objects": records,
    }
    if use_pybullet:
        result["success_rate"]["pybullet"] = sum(r["pybullet"]["success"] for r in done) / n if n else 0.0
    return result


def split_of(path: Path) -> str:
    """The fixed dev / held-out rule: the last number in the file's name, even -> dev, odd -> heldout."""
    import re

    nums = re.findall(r"\d+", path.stem)
    return "heldout" if nums and int(nums[-1]) % 2 == 1 else "dev"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--objects", type=Path, default=None, help="folder of URDFs / OBJ / STL meshes")
    ap.add_argument("--n", type=int, default=100, help="number of objects drawn at random (0: all)")
    ap.add_argument(
        "--split",
        choices=("all", "dev", "heldout"),
        default="all",
        help="of the objects found, keep those whose name's number is even (dev) or odd (heldout); "
        "names without a number go to dev",
    )
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument("--no-pybullet", action="store_true")
    ap.add_argument(
        "--camera-approach",
        action="store_true",
        help="prefer approaching along the camera's view (the detector's default) instead of top-down",
    )
    ap.add_argument("--option", action="append", default=[], metavar="KEY=VALUE", help="a detection option (JSON)")
    args = ap.parse_args()
    options = {}
    for kv in args.option:
        key, _, value = kv.partition("=")
        options[key] = json.loads(value)
    paths = find_objects(args.objects) if args.objects else default_object_paths()
    if args.split != "all":
        paths = [p for p in paths if split_of(p) == args.split]
    if not paths:
        raise SystemExit("no objects (URDF, OBJ, STL) found")
    if 0 < args.n < len(paths):
        paths = sorted(random.Random(args.seed).sample(paths, args.n))
    print(f"{len(paths)} objects, cores {os.cpu_count()}, load {load_avg()}")
    t0 = time.perf_counter()
    res = evaluate(
        paths, seed=args.seed, use_pybullet=not args.no_pybullet, top_down=not args.camera_approach, options=options
    )
    print(f"objects {res['num_objects']} (skipped {res['num_skipped']}, scaled to fit the hand {res['num_scaled']})")
    for judge, rate in res["success_rate"].items():
        print(f"top-1 success, {judge:8s}: {rate * 100:.1f}%")
    print(
        f"detection per {WIDTH}x{HEIGHT} frame: median {res['median_detection_ms']:.1f} ms wall, "
        f"{res['median_detection_cpu_ms']:.1f} ms CPU (this process, all threads)"
    )
    print(f"total {time.perf_counter() - t0:.0f} s, load {load_avg()}")
    if args.json:
        args.json.write_text(json.dumps(res, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
