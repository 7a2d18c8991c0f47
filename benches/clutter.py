"""Clutter clearing: perceive, grasp, remove until the table (or bin) is empty or 2 attempts in a row fail.

    python benches/clutter.py [--objects DIR] [--scenes N] [--objects-per-scene K] [--bin] [--json FILE]
                              [--seed S] [--no-pybullet] [--option KEY=JSON ...]

Objects: ``ferrobot.pipeline.clutter`` draws K files per scene from DIR (URDFs, OBJ, STL, DAE; default
``pybullet_data/random_urdfs`` and ``pybullet_data/objects``) with random scale (within the hand's
opening), mass, friction and orientation, drops them onto a 2 x 2 m table (top at 0.4 m) over a disc
(touching, partly stacked) or into a 30 x 24 x 10 cm bin (``--bin``), as convex decompositions (V-HACD,
cached per file and scale), and lets them settle.

Each attempt (the setting of VGN's clutter removal, with grasp_eval's floating Panda hand):

- the scene is rebuilt from the objects' current poses in a fresh ``ferrobot.World`` (240 Hz) and settles
  for up to 1 s; one 640 x 480 camera (fx = fy = 525) 0.7 m from the pile's centre, 60 degrees above
  the table, renders depth and segmentation;
- ``detect_from_rgbd`` runs once on the whole frame, grasps sought on the remaining objects' pixels (the
  instance masks), every pixel (neighbours, bin walls, table) an obstacle, the world's -z as the preferred
  approach, the detector's own depth policy on tables and in bins alike (``DetectOptions.depths``);
  the top-scored grasp is executed (no grasp: a failed attempt);
- the floating Panda hand of ``benches/grasp_eval.py`` (pybullet_data's hand and finger meshes on three
  driven slides; the two fingers geared together as the real Panda's, the second a mimic of the first,
  ``--independent-fingers`` for two free finger joints) runs pre-grasp 5 cm back, approach, close (20 N
  per finger), lift 10 cm, hold 2 s; in a
  bin the lift goes back along the approach until the hand has risen 10 cm (a tilted hand lifted straight
  up drags along the walls);
- success: an object rose >= 8 cm and the fingers did not close on nothing; objects that rose are removed
  (a clean lift removes exactly one); objects pushed off the table or out of the bin are lost (not
  cleared); the scene ends when no object remains or after 2 failed attempts in a row, or after 2 K
  attempts;
- a frame without a grasp gets a push of some object into free space instead (``ferrobot.pipeline.push``,
  ``--no-push``) or, in a bin when no push exists, a drag of an object away from the walls with a fingertip
  pressed on its top (``ferrobot.pipeline.drag``, ``--no-drag``) or, when no drag exists either, a slide of an
  object along the wall it lies at (``ferrobot.pipeline.slide``, ``--no-slide``); at most 3 in a row, not counted
  as grasp attempts;
- the bin is one part: its floor (the table's top under it) has the walls' friction, 0.6
  (``--bin-floor-friction``; 1.0, the table's, before bins18g), and drags run only where Coulomb friction lets a
  pressed fingertip move the heaviest, grippiest object over that floor (``drag_enabled``).

The **PyBullet judge** replays every attempt: the same objects (each the same convex parts, as OBJ files)
at the poses they settled to in ferrobot, the same hand URDF, base pose and joint targets per step, and the
same success test (the fingers geared by a gear constraint: PyBullet ignores ``<mimic>``). The sequence of
the scene follows ferrobot's outcome; PyBullet's success rate is per attempt. ``--mujoco`` adds a third
judge, MuJoCo (``benches/mujoco_judge.py``), replaying alike; it contacts the exact convex parts without a
margin, where PyBullet's convex shapes keep one (measured: fingers stop 2.1 mm short of a box's faces each),
and the JSON counts per attempt which judges lift it (``judges``).

Each attempt is printed with its stage (``ok``, ``no grasp`` with the number of grasps the detector returns
with each of its clutter checks off (four more detections, counted in the attempt's CPU time), ``blocked on
approach``, ``closed on nothing``, ``slipped out``, ``held, not lifted``, ``lifted a neighbour``; see
``failure_stage``) and its grasp; ``--pictures DIR`` saves a picture of each attempt.

Reported: completion rate (objects removed / objects), grasp success per attempt under each judge, clean
lifts, attempts per removed object, detection time per frame, and time per pick (CPU seconds of this
process per attempt: rebuilding, rendering, detection, simulating the 4 s hand sequence; plus the
simulated seconds of the sequence).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import grasp_eval as ge  # noqa: E402

import ferrobot  # noqa: E402
import ferrobot.camera  # noqa: E402
import ferrobot.grasp as fg  # noqa: E402
from ferrobot.pipeline import clutter  # noqa: E402
from ferrobot.pipeline import drag as drag_mod  # noqa: E402
from ferrobot.pipeline import push as push_mod  # noqa: E402
from ferrobot.pipeline import slide as slide_mod  # noqa: E402

DT = ge.DT
TABLE_TOP = ge.TABLE_TOP
CENTER = (0.0, 0.0)
CAM_DISTANCE, CAM_ELEVATION = 0.7, 60.0
SETTLE_S = 1.0
LOST_DROP = 0.05
#: Most pushes in a row without a successful grasp between them (then a frame without a grasp is a failed attempt).
MAX_PUSHES_IN_ROW = 3
#: Opening (m) added to the grasp's width for the fingers' pre-shape before the approach.
PRESHAPE_MARGIN = 0.01
#: Largest force (N) of the PyBullet judge's gear constraint between the coupled fingers (well above the
#: 2 x 20 N squeeze, so it holds them equal as the ferrobot mimic coupling does).
GEAR_FORCE = 1000.0
#: Friction of the bin's floor: a bin is one part, its floor of the walls' material (0.6, ``clutter.add_bin``). The
#: floor is the table's top under the bin, so in a bin scene the table gets this friction (``--bin-floor-friction``;
#: 1.0, the table's, before bins18g). Tables keep 1.0.
BIN_FLOOR_FRICTION = 0.6
#: ``--paired-floor F``: every bin grasp is also run from the same poses on a floor of friction F (None: not).
PAIRED_FLOOR: float | None = None


def floor_friction(spec: clutter.ClutterSpec) -> float:
    """The table's friction in a scene: the bin's floor material with a bin, 1.0 without."""
    return BIN_FLOOR_FRICTION if spec.bin is not None else 1.0


class State:
    """The objects still in play and their poses (4x4)."""

    def __init__(self, spec: clutter.ClutterSpec):
        self.spec = spec
        self.objects = {o.name: o for o in spec.objects}
        self.poses: dict[str, np.ndarray] = {}

    def build(self, floor: float | None = None) -> ferrobot.World:
        w = ferrobot.World(dt=DT)
        w.add_box(
            "table",
            [ge.TABLE_SIZE, ge.TABLE_SIZE, TABLE_TOP],
            [CENTER[0], CENTER[1], TABLE_TOP / 2, 1, 0, 0, 0],
            fixed=True,
            friction=floor_friction(self.spec) if floor is None else floor,
        )
        if self.spec.bin is not None:
            clutter.add_bin(w, self.spec.bin, TABLE_TOP)
        for name, o in self.objects.items():
            pose = ge.pose7(self.poses[name]) if name in self.poses else o.pose
            w.add_mesh_file(name, o.mesh, pose, scale=o.scale, mass=o.mass, friction=o.friction, color=o.color)
        return w

    def in_play(self, name: str, pose: np.ndarray) -> bool:
        """Whether an object is still on the table (and in the bin, with one)."""
        p = pose[:3, 3]
        if p[2] < TABLE_TOP - LOST_DROP:
            return False
        b = self.spec.bin
        if b is not None:
            if (
                abs(p[0] - b.center[0]) > b.inner[0] / 2 + b.thickness
                or abs(p[1] - b.center[1]) > b.inner[1] / 2 + b.thickness
            ):
                return False
        return abs(p[0] - CENTER[0]) < ge.TABLE_SIZE / 2 and abs(p[1] - CENTER[1]) < ge.TABLE_SIZE / 2


def camera_pose() -> np.ndarray:
    target = np.array([CENTER[0], CENTER[1], TABLE_TOP])
    e = np.radians(CAM_ELEVATION)
    eye = target + CAM_DISTANCE * np.array([np.cos(e), 0.0, np.sin(e)])
    return np.asarray(ferrobot.look_at(eye, target))


def part_files(o: clutter.ClutterObject, tmp: Path, cache: dict) -> tuple[list[str], np.ndarray]:
    """OBJ files of an object's convex parts and the decomposition's centre of mass (mesh frame)."""
    key = (o.mesh, tuple(o.scale))
    if key in cache:
        return cache[key]
    info = ferrobot.load_mesh(o.mesh, o.scale)
    files, com, vol = [], np.zeros(3), 0.0
    for k, (v, f) in enumerate(info.parts):
        path = tmp / f"part_{len(cache)}_{k}.obj"
        lines = [f"v {x:.9g} {y:.9g} {z:.9g}" for x, y, z in v] + [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in f]
        path.write_text("\n".join(lines) + "\n")
        files.append(str(path))
        o_ = v.mean(axis=0)
        tri = v[f]
        tv = np.einsum("ij,ij->i", tri[:, 0] - o_, np.cross(tri[:, 1] - o_, tri[:, 2] - o_)) / 6.0
        com += ((tri.sum(axis=1) + o_) / 4.0 * tv[:, None]).sum(axis=0)
        vol += tv.sum()
    cache[key] = (files, com / vol if vol > 0 else np.zeros(3))
    return cache[key]


class PyBulletClutterJudge(ge.PyBulletJudge):
    """Replays an attempt on the whole pile in PyBullet."""

    def __init__(self, hand_urdf: str, tmp: Path, coupled: bool = False):
        super().__init__(hand_urdf)
        self.tmp = tmp
        self.parts: dict = {}
        #: Whether the fingers are geared together (``grasp_eval.hand_files(coupled=True)``): PyBullet ignores
        #: ``<mimic>``, so a gear constraint keeps the two finger joints equal.
        self.coupled = coupled

    def run_pile(self, state: State, poses: dict, base: np.ndarray, steps, on_step=None) -> dict:
        """Replays ``steps`` on the pile at ``poses``; ``on_step(k, hand, ids)`` (optional) is called after each
        step with the hand's and the objects' PyBullet body ids (for per-step logs)."""
        p, c = self.p, self.cid
        p.resetSimulation(physicsClientId=c)
        p.setGravity(0, 0, -9.81, physicsClientId=c)
        p.setTimeStep(DT, physicsClientId=c)
        half = [ge.TABLE_SIZE / 2, ge.TABLE_SIZE / 2, TABLE_TOP / 2]
        tid = p.createMultiBody(
            0,
            p.createCollisionShape(p.GEOM_BOX, halfExtents=half, physicsClientId=c),
            -1,
            [CENTER[0], CENTER[1], TABLE_TOP / 2],
            physicsClientId=c,
        )
        p.changeDynamics(tid, -1, lateralFriction=floor_friction(state.spec), physicsClientId=c)
        if state.spec.bin is not None:
            for _, size, pose in state.spec.bin.walls(TABLE_TOP):
                sid = p.createCollisionShape(p.GEOM_BOX, halfExtents=[s / 2 for s in size], physicsClientId=c)
                bid = p.createMultiBody(0, sid, -1, pose[:3], physicsClientId=c)
                p.changeDynamics(bid, -1, lateralFriction=0.6, physicsClientId=c)
        ids = {}
        for name, pose in poses.items():
            o = state.objects[name]
            files, com = part_files(o, self.tmp, self.parts)
            sid = p.createCollisionShapeArray(shapeTypes=[p.GEOM_MESH] * len(files), fileNames=files, physicsClientId=c)
            bid = p.createMultiBody(
                o.mass,
                sid,
                -1,
                list(pose[:3, 3]),
                ge.xyzw(pose),
                baseInertialFramePosition=list(com),
                physicsClientId=c,
            )
            p.changeDynamics(bid, -1, lateralFriction=o.friction, physicsClientId=c)
            ids[name] = bid
        for _ in range(60):
            p.stepSimulation(physicsClientId=c)
        hand = p.loadURDF(self.hand_urdf, list(base[:3, 3]), ge.xyzw(base), useFixedBase=True, physicsClientId=c)
        joints = list(range(5))
        for j, q in zip(joints, [0, 0, 0, *steps[0][0][3:]], strict=True):
            p.resetJointState(hand, j, q, physicsClientId=c)
        for j in (3, 4):
            p.changeDynamics(hand, j, lateralFriction=1.0, physicsClientId=c)
        if self.coupled:
            gear = p.createConstraint(
                hand, 3, hand, 4, p.JOINT_GEAR, [1, 0, 0], [0, 0, 0], [0, 0, 0], physicsClientId=c
            )
            p.changeConstraint(gear, gearRatio=-1, erp=0.2, maxForce=GEAR_FORCE, physicsClientId=c)
        z0 = {n: p.getBasePositionAndOrientation(b, physicsClientId=c)[0][2] for n, b in ids.items()}
        for k, (target, _force) in enumerate(steps):
            p.setJointMotorControlArray(
                hand,
                joints,
                p.POSITION_CONTROL,
                targetPositions=list(target),
                forces=[ge.MOVE_FORCE] * 3 + [ge.FINGER_FORCE] * 2,
                physicsClientId=c,
            )
            p.stepSimulation(physicsClientId=c)
            if on_step is not None:
                on_step(k, hand, ids)
        fingers = [p.getJointState(hand, j, physicsClientId=c)[0] for j in (3, 4)]
        opening = sum(fingers)
        lifted = [
            n
            for n, b in ids.items()
            if p.getBasePositionAndOrientation(b, physicsClientId=c)[0][2] - z0[n] >= ge.MIN_RISE
        ]
        return {
            "success": bool(lifted) and opening > ge.MIN_OPENING,
            "lifted": lifted,
            "opening": opening,
            "fingers": fingers,
        }


def preshape_finger(width: float, margin: float | None) -> float:
    """Position of each of the floating hand's finger joints before the approach: the opening ``width`` (the
    grasp's, m) plus ``margin`` (m), at most the hand's largest opening, through the Panda gripper
    description's opening map (``Gripper.driver_position``); ``margin`` None: fully open (no pre-shape)."""
    g = ge.PANDA_HAND
    if margin is None:
        return g.driver_position(g.max_opening)
    return g.driver_position(min(g.max_opening, max(g.min_opening, width + margin)))


def table_schedule(base: np.ndarray, finger: float) -> list[tuple[np.ndarray, float]]:
    """grasp_eval's schedule with the fingers pre-shaped to ``finger`` (each joint's position) for the
    approach."""
    steps = ge.hand_schedule(base)
    n = int(round(ge.APPROACH_S / DT))
    return [(np.r_[t[:3], finger, finger], f) if k < n else (t, f) for k, (t, f) in enumerate(steps)]


def bin_schedule(base: np.ndarray, finger: float = ge.OPEN) -> list[tuple[np.ndarray, float]]:
    """grasp_eval's schedule, but the lift goes back along the approach (as the pick-and-place pipeline's
    retreat) far enough to rise ``LIFT``: a tilted hand lifted straight up drags along the bin's walls.
    The fingers approach pre-shaped to ``finger`` (each joint's position)."""
    up = max(-float(base[2, 2]), 0.5)  # the approach's downward component
    q_grasp = np.array([0.0, 0.0, ge.PREGRASP])
    q_lift = q_grasp - np.array([0.0, 0.0, ge.LIFT / up])
    steps: list[tuple[np.ndarray, float]] = []
    for q in ge.smooth(np.zeros(3), q_grasp, ge.APPROACH_S):
        steps.append((np.r_[q, finger, finger], 0.0))
    for _ in range(int(round(ge.CLOSE_S / DT))):
        steps.append((np.r_[q_grasp, 0.0, 0.0], ge.FINGER_FORCE))
    for q in ge.smooth(q_grasp, q_lift, ge.LIFT_S):
        steps.append((np.r_[q, 0.0, 0.0], ge.FINGER_FORCE))
    for _ in range(int(round(ge.HOLD_S / DT))):
        steps.append((np.r_[q_lift, 0.0, 0.0], ge.FINGER_FORCE))
    return steps


def save_picture(w: ferrobot.World, path: Path) -> None:
    """An RGB picture of the scene (the hand at its grasp pose) from the detection camera."""
    from PIL import Image

    cam = ferrobot.Camera(w, ge.WIDTH, ge.HEIGHT, fx=ge.F, cx=ge.CX, cy=ge.CY, pose=camera_pose())
    rgb = np.asarray(cam.render()["rgb"])
    if rgb.dtype != np.uint8:
        rgb = np.clip(rgb * 255.0, 0, 255).astype(np.uint8)
    Image.fromarray(rgb).save(path)


def scene_observation(state: State, frame, depth: np.ndarray, cam_pose: np.ndarray, ids: dict):
    """The frame's cloud in the world with instance labels (0: not an object), the heightmap's bounds (the bin
    or the table around the pile), the heightmap and the camera's free space, for the push and slide planners."""
    intr = ferrobot.camera.Intrinsics(ge.WIDTH, ge.HEIGHT, ge.F, ge.F, ge.CX, ge.CY, 1.0)
    pts, pix = ferrobot.camera.backproject(depth, intr)
    pts = fg.transform_points(pts, fg.camera_to_world(cam_pose, "opencv"))
    labels = np.asarray(frame.segmentation)[pix[:, 0], pix[:, 1]].astype(np.int64)
    labels = np.where(np.isin(labels, list(ids)), labels, 0)
    b = state.spec.bin
    if b is not None:
        bounds = [b.center[0] - b.inner[0] / 2 - 0.05, b.center[0] + b.inner[0] / 2 + 0.05]
        bounds += [b.center[1] - b.inner[1] / 2 - 0.05, b.center[1] + b.inner[1] / 2 + 0.05]
    else:
        bounds = [CENTER[0] - 0.35, CENTER[0] + 0.35, CENTER[1] - 0.35, CENTER[1] + 0.35]
    hm = push_mod.Heightmap.from_points(pts, labels, TABLE_TOP, bounds)
    seg = np.asarray(frame.segmentation)
    view = push_mod.FreeSpace(
        depth,
        np.where(np.isin(seg, list(ids)), seg, 0),
        ge.F,
        ge.F,
        ge.CX,
        ge.CY,
        fg.camera_to_world(cam_pose, "opencv"),
    )
    return pts, labels, bounds, hm, view


#: Stiffness (N/m) of the floating hand's drive while it presses and slides (stiff, 2e4, otherwise).
SLIDE_STIFFNESS = 2.0e3
#: Duration (s) of the slide leg.
SLIDE_S = 1.5
#: A slide that moved its object less than this (m) is not tried on that object again (the same frame would
#: give the same plan).
SLIDE_STUCK = 0.005


def plan_scene_slide(state: State, frame, depth: np.ndarray, cam_pose: np.ndarray, ids: dict):
    """The best slide along a wall (``ferrobot.pipeline.slide.plan_slide``) of any remaining object, or None;
    objects whose last slide moved them less than ``SLIDE_STUCK`` are skipped."""
    return best_scene_plan(
        state,
        scene_observation(state, frame, depth, cam_pose, ids),
        ids,
        "slide_stuck",
        lambda pts, labels, label, bounds, hm, view: slide_mod.plan_slide(
            pts, labels, label, ge.PANDA_HAND, TABLE_TOP, bounds, heightmap=hm, view=view
        ),
    )


def best_scene_plan(state: State, observation, ids: dict, stuck_attr: str, plan):
    """The highest-scoring plan ``plan(pts, labels, label, bounds, heightmap, view)`` over the remaining objects
    of ``observation`` (``scene_observation``'s tuple), skipping the objects in ``state.<stuck_attr>``; None
    when no object has one."""
    pts, labels, bounds, hm, view = observation
    stuck = getattr(state, stuck_attr, set())
    best = None
    for label in ids:
        if ids[label] in stuck:
            continue
        found = plan(pts, labels, label, bounds, hm, view)
        if found is not None and (best is None or found.score > best.score):
            best = found
    return best


def closed_hand_at(w, hand_model, plan):
    """The floating hand for a push or a slide, fingers closed, at ``plan.pre`` (the planned fingertip pose moved
    back to the simulated hand's frame); returns the robot, its slide and finger joint names and its rotation."""
    # The simulated fingers' tips are TCP_OFFSET from the hand frame (the gripper description's TCP is 0.1034).
    shift = (ge.TCP_OFFSET - ge.PANDA_HAND.tcp[2]) * plan.pre[:3, 2]
    base = plan.pre.copy()
    base[:3, 3] -= shift
    robot = w.add_robot(hand_model, ge.pose7(base), name="hand", q=np.zeros(hand_model.num_dof))
    slide, fingers = robot.dof_names[:3], robot.dof_names[3:]
    robot.set_drive_gains(stiffness=[2.0e4] * 3, damping=[1.0e3] * 3, joint_names=slide)
    robot.set_joint_position_targets(np.zeros(hand_model.num_dof))
    return robot, slide, fingers, base[:3, :3]


def objects_moved(state: State, w, plan, names: list, ids: dict, before: dict) -> dict:
    """After a push or a slide: the objects' new poses become the state; returns the report's common part (target,
    planned direction and tilt, where the fingertip started, how far the target and the others moved)."""
    after = {n: w.get_object_pose(n) for n in names}
    for n in names:
        state.poses[n] = after[n]
    target = ids.get(plan.target)
    moved = {n: float(np.linalg.norm(after[n][:3, 3] - before[n])) for n in names}
    return {
        "target": target,
        "direction": plan.direction.tolist(),
        "distance": plan.distance,
        "tilt": plan.tilt,
        "tip_start": plan.tip_start.tolist(),
        "target_moved": moved.get(target, 0.0),
        "target_displacement": (after[target][:3, 3] - before[target]).tolist() if target in after else None,
        "others_moved_max": max((v for n, v in moved.items() if n != target), default=0.0),
    }


def execute_slide(state: State, w, hand_model, plan, names: list, ids: dict, on_step=None) -> dict:
    """Runs a planned slide with the floating hand, fingers closed: down the approach to the start (0.5 s),
    towards the wall by the press leg (0.5 s), along the wall (1.5 s), back up the approach 10 cm (0.5 s); the
    objects' new poses become the state. ``on_step(robot)``, if given, is called after every step."""
    robot, slide, fingers, rot = closed_hand_at(w, hand_model, plan)
    q_start = np.array([0.0, 0.0, 0.05])
    q_pressed = q_start + rot.T @ (plan.pressed[:3, 3] - plan.start[:3, 3])
    q_end = q_start + rot.T @ (plan.end[:3, 3] - plan.start[:3, 3])
    q_up = q_end - np.array([0.0, 0.0, 0.10])
    before = {n: w.get_object_pose(n)[:3, 3].copy() for n in names}
    legs = ((np.zeros(3), q_start, 0.5), (q_start, q_pressed, 0.5), (q_pressed, q_end, SLIDE_S), (q_end, q_up, 0.5))
    for leg, (a, b_, sec) in enumerate(legs):
        # Press and slide with a soft drive: the press force is its stiffness times the overlap past the face
        # (SLIDE_STIFFNESS x plan.press: about 40 N), not the stiff drive's hundreds of newtons, which squeeze
        # rounded objects out from under the fingers.
        if leg in (1, 3):
            k = SLIDE_STIFFNESS if leg == 1 else 2.0e4
            robot.set_drive_gains(
                stiffness=[k] * 3, damping=[2.0 * (k * 1.0) ** 0.5 if leg == 1 else 1.0e3] * 3, joint_names=slide
            )
        for q in ge.smooth(a, b_, sec):
            robot.set_joint_position_targets(q, joint_names=slide)
            robot.set_joint_position_targets(np.zeros(len(fingers)), joint_names=fingers)
            w.step(1)
            if on_step is not None:
                on_step(robot)
    rec = {"kind": "slide", **objects_moved(state, w, plan, names, ids, before)}
    rec.update(normal=plan.normal.tolist(), press=plan.press, lean=plan.lean, room=plan.room)
    return rec


#: Stiffness (N/m) of the floating hand's drive along its approach while a drag presses and pulls: the press force
#: is this times the planned press depth (2e3 x 1.5 cm: about 30 N).
DRAG_STIFFNESS = 2.0e3
#: Duration (s) of the drag leg.
DRAG_S = 1.5
#: The heaviest object (kg) and the highest object friction the bench's sets hold, for the check that a drag can
#: move an object on the bin's floor at all (``drag.drag_feasible``).
DRAG_MASS, DRAG_MU_OBJECT = 0.3, 1.0
#: The hand's leans (rad) towards the drag that the drag planner tries (``--drag-tilts``; the planner's default).
DRAG_TILTS = drag_mod.plan_drag.__kwdefaults__["tilts"]


def drag_enabled(spec: clutter.ClutterSpec) -> bool:
    """Drags only in bins whose floor lets a pressed fingertip move the heaviest, grippiest object (with the table's
    1.0 under the bin the finger-object and object-floor frictions are equal and no press drags anything)."""
    if spec.bin is None:
        return False
    press = DRAG_STIFFNESS * drag_mod.plan_drag.__kwdefaults__["press"]
    return drag_mod.drag_feasible(1.0, DRAG_MU_OBJECT, floor_friction(spec), DRAG_MASS, press)


def plan_scene_drag(state: State, frame, depth: np.ndarray, cam_pose: np.ndarray, ids: dict):
    """The best drag away from the walls (``ferrobot.pipeline.drag.plan_drag``) of any remaining object, or None;
    objects whose last drag moved them less than ``SLIDE_STUCK`` are skipped. The tipping check assumes the
    grippiest object on this floor (Rapier averages the two coefficients)."""
    tip_mu = 0.5 * (DRAG_MU_OBJECT + floor_friction(state.spec))
    return best_scene_plan(
        state,
        scene_observation(state, frame, depth, cam_pose, ids),
        ids,
        "drag_stuck",
        lambda pts, labels, label, bounds, hm, view: drag_mod.plan_drag(
            pts,
            labels,
            label,
            ge.PANDA_HAND,
            TABLE_TOP,
            bounds,
            heightmap=hm,
            view=view,
            tilts=DRAG_TILTS,
            tip_friction=tip_mu,
        ),
    )


def execute_drag(state: State, w, hand_model, plan, names: list, ids: dict, on_step=None) -> dict:
    """Runs a planned drag with the floating hand, fingers closed: down the approach to the start (0.5 s, stiff),
    pressing down the approach onto the object's top (0.5 s) and dragging (``DRAG_S``) with a soft drive along the
    approach (``DRAG_STIFFNESS``: the press force is it times the overlap) and a stiff one across it, back up the
    approach 10 cm (0.5 s, stiff); the objects' new poses become the state. ``on_step(robot)``, if given, is called
    after every step."""
    robot, slide, fingers, rot = closed_hand_at(w, hand_model, plan)
    q_start = np.array([0.0, 0.0, 0.05])
    q_pressed = q_start + rot.T @ (plan.pressed[:3, 3] - plan.start[:3, 3])
    q_end = q_start + rot.T @ (plan.end[:3, 3] - plan.start[:3, 3])
    q_up = q_end - np.array([0.0, 0.0, 0.10])
    before = {n: w.get_object_pose(n)[:3, 3].copy() for n in names}
    legs = ((np.zeros(3), q_start, 0.5), (q_start, q_pressed, 0.5), (q_pressed, q_end, DRAG_S), (q_end, q_up, 0.5))
    for leg, (a, b_, sec) in enumerate(legs):
        if leg == 1:
            k = DRAG_STIFFNESS
            robot.set_drive_gains(stiffness=[2.0e4, 2.0e4, k], damping=[1.0e3, 1.0e3, 2.0 * k**0.5], joint_names=slide)
        elif leg == 3:
            robot.set_drive_gains(stiffness=[2.0e4] * 3, damping=[1.0e3] * 3, joint_names=slide)
        for q in ge.smooth(a, b_, sec):
            robot.set_joint_position_targets(q, joint_names=slide)
            robot.set_joint_position_targets(np.zeros(len(fingers)), joint_names=fingers)
            w.step(1)
            if on_step is not None:
                on_step(robot)
    rec = {"kind": "drag", **objects_moved(state, w, plan, names, ids, before)}
    rec.update(press=plan.press, top=plan.top, clearance_after=plan.clearance_after)
    return rec


def plan_scene_push(state: State, w, frame, depth: np.ndarray, cam_pose: np.ndarray, ids: dict):
    """The best push (``ferrobot.pipeline.push.plan_push``) of any remaining object, on the frame's cloud in
    the world (instance labels from the segmentation), or None."""
    intr = ferrobot.camera.Intrinsics(ge.WIDTH, ge.HEIGHT, ge.F, ge.F, ge.CX, ge.CY, 1.0)
    pts, pix = ferrobot.camera.backproject(depth, intr)
    pts = fg.transform_points(pts, fg.camera_to_world(cam_pose, "opencv"))
    labels = np.asarray(frame.segmentation)[pix[:, 0], pix[:, 1]].astype(np.int64)
    labels = np.where(np.isin(labels, list(ids)), labels, 0)
    b = state.spec.bin
    if b is not None:
        bounds = [b.center[0] - b.inner[0] / 2 - 0.05, b.center[0] + b.inner[0] / 2 + 0.05]
        bounds += [b.center[1] - b.inner[1] / 2 - 0.05, b.center[1] + b.inner[1] / 2 + 0.05]
    else:
        bounds = [CENTER[0] - 0.35, CENTER[0] + 0.35, CENTER[1] - 0.35, CENTER[1] + 0.35]
    hm = push_mod.Heightmap.from_points(pts, labels, TABLE_TOP, bounds)
    seg = np.asarray(frame.segmentation)
    view = push_mod.FreeSpace(
        depth,
        np.where(np.isin(seg, list(ids)), seg, 0),
        ge.F,
        ge.F,
        ge.CX,
        ge.CY,
        fg.camera_to_world(cam_pose, "opencv"),
    )
    best = None
    for label in ids:
        plan = push_mod.plan_push(pts, labels, label, ge.PANDA_HAND, TABLE_TOP, bounds, heightmap=hm, view=view)
        if plan is not None and (best is None or plan.score > best.score):
            best = plan
    return best


def execute_push(state: State, w, hand_model, plan, names: list, settled: dict, ids: dict) -> dict:
    """Runs a planned push with the floating hand, fingers closed: down the approach to the start (0.5 s),
    along the push (1 s), back up the approach 10 cm (0.5 s); the objects' new poses become the state."""
    robot, slide, fingers, rot = closed_hand_at(w, hand_model, plan)
    q_start = np.array([0.0, 0.0, 0.05])
    q_end = q_start + rot.T @ (plan.travel * plan.direction)
    q_up = q_end - np.array([0.0, 0.0, 0.10])
    before = {n: w.get_object_pose(n)[:3, 3].copy() for n in names}
    for a, b_, sec in ((np.zeros(3), q_start, 0.5), (q_start, q_end, 1.0), (q_end, q_up, 0.5)):
        for q in ge.smooth(a, b_, sec):
            robot.set_joint_position_targets(q, joint_names=slide)
            robot.set_joint_position_targets(np.zeros(len(fingers)), joint_names=fingers)
            w.step(1)
    return {**objects_moved(state, w, plan, names, ids, before), "travel": plan.travel}


def failure_stage(res: dict, diag: dict, target: str | None, after: dict, z0: dict) -> str:
    """What an attempt ended with: ``ok``, ``ok (two objects)``, ``blocked on approach`` (the hand stopped
    >= 1 cm short of its grasp pose: a wall or a neighbour), ``closed on nothing``, ``held, not lifted``
    (the fingers stayed apart but nothing rose 8 cm: slipped or stuck), ``lifted a neighbour``."""
    if res["success"]:
        if target is not None and target not in res["lifted"]:
            return "lifted a neighbour"
        return "ok" if len(res["lifted"]) == 1 else "ok (two objects)"
    if diag.get("approach_error", 0.0) >= 0.01:
        return "blocked on approach"
    if diag.get("closed_opening", 1.0) <= ge.MIN_OPENING:
        return "closed on nothing"
    if res["opening"] <= ge.MIN_OPENING:
        return "slipped out"
    return "held, not lifted"


def run_hand(
    w, hand_model, base, steps, finger, names, settled, z0, target, picture_dir=None, picture_tag=""
) -> tuple[dict, dict, object, float]:
    """Executes a grasp schedule with the floating hand in ``w`` (fingers starting at ``finger``); returns the
    ferrobot judgement (success, lifted, opening, clean, stage and diagnostics), the objects' final poses,
    the hand robot and the final opening."""
    # A coupled hand (``grasp_eval.hand_files(coupled=True)``) has one finger DOF, the second finger its mimic:
    # the driver squeezes with twice the per-finger force (each finger gets ``force``).
    coupled = hand_model.num_dof == 4
    nf = 1 if coupled else 2
    q_start = np.r_[0.0, 0.0, 0.0, [finger] * nf]
    robot = w.add_robot(hand_model, ge.pose7(base), name="hand", q=q_start)
    slide, fingers = robot.dof_names[:3], robot.dof_names[3:]
    robot.set_drive_gains(stiffness=[2.0e4] * 3, damping=[1.0e3] * 3, joint_names=slide)
    robot.set_gripper(fingers, [ge.OPEN] * nf, [0.0] * nf)

    def hand_opening(q):
        return float(2.0 * q[3] if coupled else q[3] + q[4])

    robot.set_joint_position_targets(q_start)
    closing = False
    diag: dict = {}
    k_close = -1
    n_close = int(round(ge.CLOSE_S / DT))
    for k, (tgt, force) in enumerate(steps):
        robot.set_joint_position_targets(tgt[:3], joint_names=slide)
        if force > 0 and not closing:
            q = robot.joint_positions
            diag["approach_error"] = float(ge.PREGRASP - q[2])
            diag["pushed"] = {n: float(np.linalg.norm(w.get_object_pose(n)[:3, 3] - settled[n][:3, 3])) for n in names}
            if picture_dir is not None:
                save_picture(w, picture_dir / f"{picture_tag}_grasp.png")
            robot.close_gripper(force=force * (2 if coupled else 1))
            closing = True
            k_close = k
        elif force == 0:
            robot.set_joint_position_targets(tgt[3 : 3 + nf], joint_names=fingers)
        w.step(1)
        if closing and k == k_close + n_close - 1:
            q = robot.joint_positions
            diag["closed_opening"] = hand_opening(q)
    q = robot.joint_positions
    opening = hand_opening(q)
    after = {n: w.get_object_pose(n) for n in names}
    lifted = [n for n in names if after[n][2, 3] - z0[n] >= ge.MIN_RISE]
    success = bool(lifted) and opening > ge.MIN_OPENING
    res = {"success": success, "lifted": lifted, "opening": opening, "clean": success and len(lifted) == 1}
    res["stage"] = failure_stage(res, diag, target, after, z0)
    res.update(diag)
    return res, after, robot, opening


def attempt(
    state: State,
    hand_model,
    pb,
    options: dict,
    picture_dir: Path | None = None,
    picture_tag: str = "",
    preshape_margin: float | None = PRESHAPE_MARGIN,
    push: bool = True,
    paired: bool = False,
    slide: bool = True,
    mj_judge=None,
    drag: bool = True,
) -> dict:
    """One perceive-grasp-lift attempt; updates ``state`` (removes lifted and lost objects). The fingers
    approach open to the grasp's width plus ``preshape_margin`` (None: fully open). With ``push``, a frame
    without a grasp gets a push of a remaining object instead (``rec["push"]``, no grasp attempt) when one
    is feasible; in a bin, with ``slide``, when no push is, a slide of an object along a wall
    (``rec["push"]["kind"] == "slide"``)."""
    t_cpu = time.process_time()
    w = state.build()
    names = list(state.objects)
    clutter.settle(w, names, max_seconds=SETTLE_S)
    settled = {n: w.get_object_pose(n) for n in names}
    for n in names:
        if not state.in_play(n, settled[n]):
            del state.objects[n]
            state.poses.pop(n, None)
    names = list(state.objects)
    rec: dict = {"objects_before": len(names)}
    if not names:
        return rec
    cam_pose = camera_pose()
    cam = ferrobot.Camera(w, ge.WIDTH, ge.HEIGHT, fx=ge.F, cx=ge.CX, cy=ge.CY, pose=cam_pose)
    frame = cam.render(rgb=False)
    masks = clutter.instance_masks(frame.segmentation, w, names)
    ids = {i: n for i, n in w.segmentation_labels.items() if n in state.objects}
    seg = np.where(np.isin(frame.segmentation, list(ids)), frame.segmentation, 0).astype(np.int32)
    rec["visible"] = sum(bool(m.any()) for m in masks.values())
    depth = np.where(np.isfinite(frame.depth), frame.depth, 0.0)
    opts = dict(options)
    opts.setdefault("approach_direction", tuple(cam_pose[:3, :3].T @ np.array([0.0, 0.0, -1.0])))
    t0, c0 = time.perf_counter(), time.process_time()
    gg = fg.detect_from_rgbd(depth, ge.F, ge.F, ge.CX, ge.CY, scale=1.0, mask=seg, **opts)
    rec["detect_ms"] = (time.perf_counter() - t0) * 1e3
    rec["detect_cpu_ms"] = (time.process_time() - c0) * 1e3
    rec["num_grasps"] = len(gg)
    if len(gg) == 0 and push:
        plan = plan_scene_push(state, w, frame, depth, cam_pose, ids)
        if plan is not None:
            rec["push"] = execute_push(state, w, hand_model, plan, names, settled, ids)
            rec["cpu_s"] = time.process_time() - t_cpu
            return rec
        if drag and drag_enabled(state.spec):
            dplan = plan_scene_drag(state, frame, depth, cam_pose, ids)
            if dplan is not None:
                rec["push"] = execute_drag(state, w, hand_model, dplan, names, ids)
                if rec["push"]["target_moved"] < SLIDE_STUCK:
                    state.drag_stuck = getattr(state, "drag_stuck", set()) | {rec["push"]["target"]}
                rec["cpu_s"] = time.process_time() - t_cpu
                return rec
        if slide and state.spec.bin is not None:
            splan = plan_scene_slide(state, frame, depth, cam_pose, ids)
            if splan is not None:
                rec["push"] = execute_slide(state, w, hand_model, splan, names, ids)
                if rec["push"]["target_moved"] < SLIDE_STUCK:
                    state.slide_stuck = getattr(state, "slide_stuck", set()) | {rec["push"]["target"]}
                rec["cpu_s"] = time.process_time() - t_cpu
                return rec
    if len(gg) == 0:
        rec["ferrobot"] = {"success": False, "reason": "no grasp"}
        # Which of the detector's clutter checks left nothing: re-run with each one off.
        rec["ferrobot"]["grasps_without"] = {
            k: len(fg.detect_from_rgbd(depth, ge.F, ge.F, ge.CX, ge.CY, scale=1.0, mask=seg, **{**opts, k: False}))
            for k in ("body_collision", "single_object", "occlusion", "support_plane")
        }
        if picture_dir is not None:
            save_picture(w, picture_dir / f"{picture_tag}_nograsp.png")
        if pb:
            rec["pybullet"] = {"success": False, "reason": "no grasp"}
        if mj_judge is not None:
            rec["mujoco"] = {"success": False, "reason": "no grasp"}
        for n in names:
            state.poses[n] = settled[n]
        rec["cpu_s"] = time.process_time() - t_cpu
        return rec
    top = gg[:1].transform(fg.camera_to_world(cam_pose, "opencv"))
    rec["target"] = ids.get(int(top.object_ids[0]), None)
    hand = ge.hand_poses(top)[0]
    base = hand.copy()
    base[:3, 3] -= ge.PREGRASP * hand[:3, 2]
    finger = preshape_finger(float(top.widths[0]), preshape_margin)
    steps = bin_schedule(base, finger) if state.spec.bin is not None else table_schedule(base, finger)
    rec["hand_base"] = base.tolist()
    rec["settled"] = {n: ge.pose7(settled[n]) for n in names}
    rec["grasp"] = {
        "position": hand[:3, 3].tolist(),
        "approach": hand[:3, 2].tolist(),
        "width": float(top.widths[0]),
        "depth": float(top.depths[0]),
        "score": float(top.scores[0]),
        "preshape_opening": 2.0 * finger,
    }
    z0 = {n: settled[n][2, 3] for n in names}
    if PAIRED_FLOOR is not None and state.spec.bin is not None:
        # The same grasp from the same poses on the other bin floor (a fresh world settled alike), judged by ferrobot:
        # the floor's own effect on grasps, apart from the different piles it leads to.
        w3 = state.build(floor=PAIRED_FLOOR)
        clutter.settle(w3, names, max_seconds=SETTLE_S)
        dev = max(float(np.abs(w3.get_object_pose(n) - settled[n]).max()) for n in names)
        z3 = {n: w3.get_object_pose(n)[2, 3] for n in names}
        r3, _, _, _ = run_hand(w3, hand_model, base, steps, finger, names, settled, z3, rec.get("target"))
        rec["paired_floor"] = {"floor": PAIRED_FLOOR, "ferrobot": r3, "state_deviation": dev}
    if paired:
        # The same attempt from the same state with the other pre-shape (fully open <-> pre-shaped): a fresh
        # world rebuilt and settled as this one (deterministic), judged alike; the scene follows this run.
        alt = preshape_finger(float(top.widths[0]), None if preshape_margin is not None else PRESHAPE_MARGIN)
        alt_steps = bin_schedule(base, alt) if state.spec.bin is not None else table_schedule(base, alt)
        w2 = state.build()
        clutter.settle(w2, names, max_seconds=SETTLE_S)
        dev = max(float(np.abs(w2.get_object_pose(n) - settled[n]).max()) for n in names)
        r2, _, _, _ = run_hand(w2, hand_model, base, alt_steps, alt, names, settled, z0, rec.get("target"))
        rec["paired"] = {
            "preshape_opening": 2.0 * alt,
            "this_run_preshaped": preshape_margin is not None,
            "ferrobot": r2,
            "state_deviation": dev,
        }
        if pb:
            rec["paired"]["pybullet"] = pb.run_pile(state, {n: settled[n] for n in names}, base, alt_steps)
    res, after, robot, opening = run_hand(
        w, hand_model, base, steps, finger, names, settled, z0, rec.get("target"), picture_dir, picture_tag
    )
    rec["ferrobot"] = res
    lifted, success = res["lifted"], res["success"]
    if pb:
        rec["pybullet"] = pb.run_pile(state, {n: settled[n] for n in names}, base, steps)
    if mj_judge is not None:
        rec["mujoco"] = mj_judge.run_pile(state, {n: settled[n] for n in names}, base, steps, part_files)
    removed = lifted if success else []
    for n in names:
        if n in removed:
            del state.objects[n]
            state.poses.pop(n, None)
        else:
            state.poses[n] = after[n]
    rec["removed"] = removed
    # Where the simulator has each removed object and the hand at the end of the hold (for checks).
    rec["removed_poses"] = {n: ge.pose7(after[n]) for n in removed}
    rec["hand_final"] = {"pose": ge.pose7(robot.get_link_pose("panda_hand")), "opening": opening}
    rec["cpu_s"] = time.process_time() - t_cpu
    rec["sim_s"] = len(steps) * DT
    return rec


def run_scene(
    spec: clutter.ClutterSpec,
    hand_model,
    pb,
    options: dict,
    picture_dir: Path | None = None,
    preshape_margin: float | None = PRESHAPE_MARGIN,
    push: bool = True,
    paired: bool = False,
    slide: bool = True,
    mj_judge=None,
    drag: bool = True,
) -> dict:
    """Clears one scene; returns its record (counts are read from the simulator's state). ``slide``: bins
    only (slides along a wall when neither a grasp nor a push is found); ``drag``: bins only, with a floor that
    allows it (``drag_enabled``: drags away from the walls when neither a grasp nor a push is found, before
    slides)."""
    # Settle the drop once in its own world: the first state.
    w = ferrobot.World(dt=DT)
    w.add_box(
        "table",
        [ge.TABLE_SIZE, ge.TABLE_SIZE, TABLE_TOP],
        [*CENTER, TABLE_TOP / 2, 1, 0, 0, 0],
        fixed=True,
        friction=floor_friction(spec),
    )
    names = clutter.add_clutter(w, spec)
    state = State(spec)
    state.poses = {n: w.get_object_pose(n) for n in names}
    total = len(names)
    attempts, pushes, fails, in_row = [], [], 0, 0
    while state.objects and fails < 2 and len(attempts) < 2 * total:
        tag = f"s{spec.seed}_a{len(attempts)}"
        can_push = push and in_row < MAX_PUSHES_IN_ROW
        rec = attempt(
            state, hand_model, pb, options, picture_dir, tag, preshape_margin, can_push, paired, slide, mj_judge, drag
        )
        if "push" in rec:
            pushes.append(rec)
            in_row += 1
            continue
        if "ferrobot" not in rec:
            break
        attempts.append(rec)
        fails = 0 if rec["ferrobot"]["success"] else fails + 1
        in_row = 0 if rec["ferrobot"]["success"] else in_row
    removed = sum(len(a.get("removed", [])) for a in attempts)
    return {
        "seed": spec.seed,
        "objects": total,
        "removed": removed,
        "remaining": len(state.objects),
        "lost": total - removed - len(state.objects),
        "final_state": {n: ge.pose7(state.poses[n]) for n in state.objects},
        "attempts": attempts,
        "pushes": pushes,
        "files": [o.source for o in spec.objects],
    }


def summarise(scenes: list[dict], use_pybullet: bool) -> dict:
    att = [a for s in scenes for a in s["attempts"]]
    n_obj = sum(s["objects"] for s in scenes)
    removed = sum(s["removed"] for s in scenes)
    out = {
        "scenes": len(scenes),
        "objects": n_obj,
        "removed": removed,
        "lost": sum(s["lost"] for s in scenes),
        "completion_rate": removed / n_obj if n_obj else 0.0,
        "attempts": len(att),
        "grasp_success": {"ferrobot": sum(a["ferrobot"]["success"] for a in att) / len(att) if att else 0.0},
        "clean_lifts": sum(a["ferrobot"].get("clean", False) for a in att),
        "pushes": sum(len(s.get("pushes", [])) for s in scenes),
        "slides": sum(p["push"].get("kind") == "slide" for s in scenes for p in s.get("pushes", [])),
        "drags": sum(p["push"].get("kind") == "drag" for s in scenes for p in s.get("pushes", [])),
        "attempts_per_removed_object": len(att) / removed if removed else None,
        "median_detection_ms": statistics.median(a["detect_ms"] for a in att) if att else None,
        "median_detection_cpu_ms": statistics.median(a["detect_cpu_ms"] for a in att) if att else None,
        "median_cpu_s_per_attempt": statistics.median(a["cpu_s"] for a in att) if att else None,
        "sim_s_per_pick": max((a.get("sim_s", 0.0) for a in att), default=None),
    }
    stages: dict[str, int] = {}
    for a in att:
        st = a["ferrobot"].get("stage", a["ferrobot"].get("reason", "?"))
        stages[st] = stages.get(st, 0) + 1
    out["stages"] = stages
    pf = [a for a in att if "paired_floor" in a]
    if pf:
        out["paired_floor"] = {
            "attempts": len(pf),
            "floor": pf[0]["paired_floor"]["floor"],
            "this": sum(a["ferrobot"]["success"] for a in pf) / len(pf),
            "other": sum(a["paired_floor"]["ferrobot"]["success"] for a in pf) / len(pf),
            "stages_other": {},
            "max_state_deviation": max(a["paired_floor"]["state_deviation"] for a in pf),
        }
        for a in pf:
            st = a["paired_floor"]["ferrobot"]["stage"]
            out["paired_floor"]["stages_other"][st] = out["paired_floor"]["stages_other"].get(st, 0) + 1
    pa = [a for a in att if "paired" in a]
    if pa:
        # Paired A/B: every grasp executed from the same state with both pre-shapes (the scene follows this run's).
        out["paired"] = {
            "attempts": len(pa),
            "this_run": "pre-shaped" if pa[0]["paired"].get("this_run_preshaped") else "fully open",
            "ferrobot": {
                "this": sum(a["ferrobot"]["success"] for a in pa) / len(pa),
                "other": sum(a["paired"]["ferrobot"]["success"] for a in pa) / len(pa),
            },
            "max_state_deviation": max(a["paired"]["state_deviation"] for a in pa),
        }
        if use_pybullet:
            out["paired"]["pybullet"] = {
                "this": sum(a["pybullet"]["success"] for a in pa) / len(pa),
                "other": sum(a["paired"]["pybullet"]["success"] for a in pa) / len(pa),
            }
    if use_pybullet:
        out["grasp_success"]["pybullet"] = sum(a["pybullet"]["success"] for a in att) / len(att) if att else 0.0
    mj = [a for a in att if "mujoco" in a]
    if mj:
        out["grasp_success"]["mujoco"] = sum(a["mujoco"]["success"] for a in mj) / len(mj)
        # Per attempt, which judges lift it: the disagreements between ferrobot and PyBullet, settled by MuJoCo.
        votes: dict[str, int] = {}
        for a in mj:
            key = "/".join(
                f"{j}:{'ok' if a[j]['success'] else 'fail'}" for j in ("ferrobot", "pybullet", "mujoco") if j in a
            )
            votes[key] = votes.get(key, 0) + 1
        out["judges"] = votes
    return out


def main() -> int:
    global BIN_FLOOR_FRICTION, PAIRED_FLOOR, DRAG_TILTS
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--objects", type=Path, default=None, help="folder of URDFs / OBJ / STL / DAE files")
    ap.add_argument("--scenes", type=int, default=10)
    ap.add_argument("--objects-per-scene", type=int, default=8)
    ap.add_argument("--bin", action="store_true", help="drop the objects into a bin")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument("--no-pybullet", action="store_true")
    ap.add_argument("--pictures", type=Path, default=None, help="save a picture of each grasp (hand in place)")
    ap.add_argument(
        "--preshape-margin",
        type=float,
        default=PRESHAPE_MARGIN,
        help="opening (m, in [0, 0.08]) added to the grasp's width for the approach (default %(default)s)",
    )
    ap.add_argument("--no-preshape", action="store_true", help="approach with the fingers fully open")
    ap.add_argument("--no-push", action="store_true", help="no pushes: a frame without a grasp is a failed attempt")
    ap.add_argument(
        "--no-slide", action="store_true", help="bins: no slides along a wall when neither a grasp nor a push is found"
    )
    ap.add_argument(
        "--no-drag", action="store_true", help="bins: no drags away from the walls with a fingertip on the object"
    )
    ap.add_argument(
        "--bin-floor-friction",
        type=float,
        default=BIN_FLOOR_FRICTION,
        help="bins: friction of the bin's floor (the table under it; in [0, 2], default %(default)s, the walls' "
        "material; 1.0: the table's, as before bins18g)",
    )
    ap.add_argument(
        "--drag-tilts",
        type=float,
        nargs="+",
        default=list(DRAG_TILTS),
        help="bins: the hand's leans (rad, in [0, 1.2]) towards the drag that drags try (default %(default)s)",
    )
    ap.add_argument(
        "--paired-floor",
        type=float,
        default=None,
        metavar="F",
        help="bins: also run every grasp from the same poses on a bin floor of friction F (in [0, 2]), ferrobot judge",
    )
    ap.add_argument(
        "--paired",
        action="store_true",
        help="also run every grasp from the same state with the other pre-shape (fully open <-> pre-shaped)",
    )
    ap.add_argument(
        "--independent-fingers",
        action="store_true",
        help="the hand's two fingers on independent joints (before table18e); default: geared together as the "
        "real Panda hand's",
    )
    ap.add_argument(
        "--mujoco",
        action="store_true",
        help="also replay every grasp in MuJoCo (benches/mujoco_judge.py), a third judge",
    )
    ap.add_argument("--option", action="append", default=[], metavar="KEY=VALUE", help="a detection option (JSON)")
    args = ap.parse_args()
    if not 1 <= args.objects_per_scene <= 30:
        raise SystemExit("--objects-per-scene: expected 1 to 30")
    if not 0.0 <= args.preshape_margin <= 0.08:
        raise SystemExit("--preshape-margin: expected 0 to 0.08 m")
    preshape = None if args.no_preshape else args.preshape_margin
    if not 0.0 <= args.bin_floor_friction <= 2.0:
        raise SystemExit("--bin-floor-friction: expected 0 to 2")
    BIN_FLOOR_FRICTION = args.bin_floor_friction
    if args.paired_floor is not None and not 0.0 <= args.paired_floor <= 2.0:
        raise SystemExit("--paired-floor: expected 0 to 2")
    PAIRED_FLOOR = args.paired_floor
    if not all(0.0 <= t <= 1.2 for t in args.drag_tilts):
        raise SystemExit("--drag-tilts: expected values in [0, 1.2]")
    DRAG_TILTS = tuple(args.drag_tilts)
    options = {}
    for kv in args.option:
        key, _, value = kv.partition("=")
        options[key] = json.loads(value)
    files = clutter.find_object_files(args.objects) if args.objects else None
    if args.pictures:
        args.pictures.mkdir(parents=True, exist_ok=True)
    print(f"cores {os.cpu_count()}, load {ge.load_avg()}", flush=True)
    t0 = time.perf_counter()
    scenes = []
    with tempfile.TemporaryDirectory() as tmp:
        coupled = not args.independent_fingers
        urdf, hand_model = ge.hand_files(Path(tmp), coupled=coupled)
        pb = None if args.no_pybullet else PyBulletClutterJudge(urdf, Path(tmp), coupled=coupled)
        mj_judge = None
        if args.mujoco:
            import mujoco_judge

            mj_judge = mujoco_judge.MuJoCoClutterJudge(Path(tmp), coupled=coupled)
        try:
            for k in range(args.scenes):
                spec = clutter.random_clutter(
                    args.seed + k, args.objects_per_scene, files, bin=args.bin, table_top=TABLE_TOP, center=CENTER
                )
                s = run_scene(
                    spec,
                    hand_model,
                    pb,
                    options,
                    args.pictures,
                    preshape,
                    not args.no_push,
                    args.paired,
                    not args.no_slide,
                    mj_judge,
                    not args.no_drag,
                )
                for p in s["pushes"]:
                    pp = p["push"]
                    print(
                        f"  {pp.get('kind', 'push')}: {pp['target']} along {np.round(pp['direction'], 2).tolist()} "
                        f"by {pp['distance']:.2f} m "
                        f"(tilt {pp['tilt']:.1f}): moved {pp['target_moved'] * 100:.1f} cm, "
                        f"others up to {pp['others_moved_max'] * 100:.1f} cm",
                        flush=True,
                    )
                for i, a in enumerate(s["attempts"]):
                    f = a.get("ferrobot", {})
                    g = a.get("grasp", {})
                    print(
                        f"  attempt {i}: {f.get('stage', f.get('reason'))} {f.get('grasps_without', '')}, "
                        f"target {a.get('target')}, "
                        f"lifted {f.get('lifted')}, approach {np.round(g.get('approach', []), 2).tolist()}, "
                        f"width {g.get('width', float('nan')):.3f}, depth {g.get('depth', float('nan')):.3f}, "
                        f"approach error {f.get('approach_error', float('nan')):.3f}, "
                        f"closed {f.get('closed_opening', float('nan')):.4f}"
                        + (f", pybullet {a['pybullet'].get('success')}" if "pybullet" in a else "")
                        + (f", mujoco {a['mujoco'].get('success')}" if "mujoco" in a else ""),
                        flush=True,
                    )
                scenes.append(s)
                sm = summarise(scenes, pb is not None)
                print(
                    f"scene {k + 1}/{args.scenes}: removed {s['removed']}/{s['objects']} in {len(s['attempts'])} "
                    f"attempts; so far cleared {sm['completion_rate'] * 100:.1f}%, success "
                    + ", ".join(f"{j} {r * 100:.1f}%" for j, r in sm["grasp_success"].items())
                    + (
                        f"; paired ({sm['paired']['attempts']}): "
                        + ", ".join(
                            f"{j} {v['this'] * 100:.1f}% / other {v['other'] * 100:.1f}%"
                            for j, v in sm["paired"].items()
                            if isinstance(v, dict)
                        )
                        if "paired" in sm
                        else ""
                    ),
                    flush=True,
                )
        finally:
            if pb:
                pb.close()
    res = summarise(scenes, not args.no_pybullet)
    res.update(
        object_set=str(args.objects or "pybullet_data random_urdfs + objects"),
        objects_per_scene=args.objects_per_scene,
        bin=args.bin,
        seed=args.seed,
        detect_options=options,
        preshape_margin=preshape,
        push=not args.no_push,
        slide=not args.no_slide,
        drag=not args.no_drag,
        drag_tilts=list(DRAG_TILTS),
        bin_floor_friction=BIN_FLOOR_FRICTION if args.bin else None,
        paired_run=args.paired,
        coupled_fingers=not args.independent_fingers,
        cores=os.cpu_count(),
        load_average=ge.load_avg(),
        wall_s=time.perf_counter() - t0,
    )
    print(
        f"cleared {res['removed']}/{res['objects']} ({res['completion_rate'] * 100:.1f}%), lost {res['lost']}, "
        f"attempts {res['attempts']} ({res['attempts_per_removed_object'] or float('nan'):.2f} per removed object), "
        f"clean lifts {res['clean_lifts']}, pushes {res['pushes']} (slides {res['slides']}, drags {res['drags']})"
    )
    print("stages: " + ", ".join(f"{k} {v}" for k, v in sorted(res["stages"].items(), key=lambda kv: -kv[1])))
    if "paired_floor" in res:
        pf = res["paired_floor"]
        print(
            f"paired floor ({pf['attempts']} grasps from the same poses, "
            f"max deviation {pf['max_state_deviation']:.1e}): "
            f"ferrobot this floor {pf['this'] * 100:.1f}% / floor {pf['floor']} {pf['other'] * 100:.1f}% "
            f"(stages there: {pf['stages_other']})"
        )
    if "paired" in res:
        pr = res["paired"]
        print(
            f"paired ({pr['attempts']} grasps from identical states, "
            f"max pose deviation {pr['max_state_deviation']:.1e}): "
            + ", ".join(
                f"{j} this run {v['this'] * 100:.1f}% / other pre-shape {v['other'] * 100:.1f}%"
                for j, v in pr.items()
                if isinstance(v, dict)
            )
        )
    for judge, rate in res["grasp_success"].items():
        print(f"grasp success per attempt, {judge:8s}: {rate * 100:.1f}%")
    if "judges" in res:
        print(
            "judges per attempt: "
            + ", ".join(f"{k} {v}" for k, v in sorted(res["judges"].items(), key=lambda kv: -kv[1]))
        )
    if res["attempts"]:
        print(
            f"detection per {ge.WIDTH}x{ge.HEIGHT} frame: median {res['median_detection_ms']:.1f} ms wall, "
            f"{res['median_detection_cpu_ms']:.1f} ms CPU; per attempt {res['median_cpu_s_per_attempt']:.2f} CPU s "
            f"(+ {res['sim_s_per_pick']:.2f} simulated s of hand motion)"
        )
    print(f"total {res['wall_s']:.0f} s, load {ge.load_avg()}")
    if args.json:
        res["scene_records"] = scenes
        args.json.write_text(json.dumps(res, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
