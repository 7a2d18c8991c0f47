"""Pick-and-place from a camera frame to an object placed: the seed workflow as one API.

The steps people write around Isaac Sim + cuRobo + AnyGrasp, each a method of :class:`PickPlace`:

1. ``perceive``: the camera renders RGB-D and segmentation.
2. ``detect``: grasps on the target's pixels (``ferrobot.grasp.detect_from_rgbd``), camera -> world -> base.
3. ``select``: collision-free IK goal sets; keep the best-scored grasp whose pre-grasp (8 cm back along the
   approach) and grasp poses have IK solutions free of collision (the target and the table are ignored
   for the grasp pose, where the fingers must touch them).
4. ``plan/execute`` pre-grasp, approach, close the gripper, lift (the target attached to the planner's robot),
   move above the place location, lower, open, retreat, each a time-parametrised trajectory executed by the
   simulated robot's joint drives. The lift and the retreat start with a straight Cartesian part on which only
   the contacts present when the gripper closes (opens) are allowed (a neighbour in a pile, the table, the
   released object), until the hand and what it holds are clear of everything; the rest is planned with
   nothing ignored (MoveIt's post-grasp retreat).
5. ``verify``: the object rests at the place location.

Every stage's outcome and time land in an :class:`EpisodeResult`; a failure names its stage and reason
(no traceback). The planner's world is synced from the simulation before each motion, with ignore lists
(cuRobo's pattern).
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np

from .. import _core, grasp, robots, transforms
from .. import camera as camera_model
from ..errors import InvalidArgumentError
from .scene import (
    HOME,
    ROBOT_MOUNT,
    TABLE_SIZE,
    TABLE_TOP,
    TABLE_XY,
    SceneSpec,
    build_world,
    clear_of_reach,
    home_for,
)

__all__ = ["PickPlace", "PickPlaceConfig", "Episode", "EpisodeResult", "StageResult", "StageFailure", "STAGES"]

#: The stages of an episode, in order.
STAGES = (
    "scene",
    "perceive",
    "detect",
    "select",
    "pregrasp",
    "approach",
    "grasp",
    "lift",
    "transport",
    "lower",
    "release",
    "retreat",
    "verify",
)


class StageFailure(Exception):
    """A stage could not do its job: ``stage`` and ``reason`` say which and why."""

    def __init__(self, stage: str, reason: str):
        super().__init__(f"{stage}: {reason}")
        self.stage = stage
        self.reason = reason


#: Largest speed (m/s) at which a placed object counts as resting: the one criterion of a successful place,
#: shared by :meth:`PickPlace.verify` and :class:`ferrobot.envs.PickPlaceEnv`.
REST_SPEED = 0.05
#: Largest offset (m) of a placed box's or cylinder's centre from its resting height (upright on the table).
UPRIGHT_TOLERANCE = 0.01
#: Longest time (s) :meth:`PickPlace.verify` waits, after the first 0.3 s, for a placed object to come to rest.
SETTLE_WAIT = 1.0


def placement_failure(
    position, speed: float, rest_z: float, place_xy, kind: str, place_tolerance: float
) -> tuple[str, str]:
    """Whether an object at ``position`` (x, y, z in the world, m) moving at ``speed`` (m/s) is placed:
    ``("", "")`` if so, else ``(cause, message)`` with cause ``"not_at_place"`` (centre further than
    ``place_tolerance`` from ``place_xy`` in x, y) or ``"not_resting"`` (faster than :data:`REST_SPEED`, or,
    for kinds other than ``"sphere"`` and ``"mesh"``, which have no upright pose, its centre more than
    :data:`UPRIGHT_TOLERANCE` from ``rest_z``). The one definition of a successful place, used by the
    pipeline's ``verify`` and the Gymnasium ``PickPlaceEnv``."""
    err = float(np.hypot(position[0] - place_xy[0], position[1] - place_xy[1]))
    if err > place_tolerance:
        return "not_at_place", f"object rests {1e3 * err:.0f} mm from the place location"
    if abs(position[2] - rest_z) > UPRIGHT_TOLERANCE and kind not in ("sphere", "mesh"):
        return "not_resting", f"object is not resting upright on the table (centre {position[2]:.3f} m)"
    if speed > REST_SPEED:
        return "not_resting", f"object still moving at {1e3 * speed:.0f} mm/s"
    return "", ""


@dataclass
class PickPlaceConfig:
    """Settings of the pick-and-place workflow (SI units)."""

    #: Distance of the pre-grasp pose back along the approach (m).
    pregrasp_distance: float = 0.08
    #: Height of the lift above the grasp, and of the carry above the place location (m).
    lift_height: float = 0.12
    #: Distance of the retreat back along the approach after releasing (m).
    retreat_distance: float = 0.10
    #: Largest angle (rad) between a grasp's approach and straight down that is tried.
    max_approach_angle: float = math.radians(60.0)
    #: Length scale (m) of the ranking's penalty for grasps away from the target's centroid.
    centre_scale: float = 0.02
    #: How many of the best-ranked grasps are tried for reachability.
    max_candidates: int = 24
    #: Height (m) above resting on the table at which the object is released.
    place_clearance: float = 0.008
    #: Squeezing force per finger (N).
    grip_force: float = 40.0
    #: Placed successfully if the object's centre is this close to the place location in x, y (m).
    place_tolerance: float = 0.03
    #: Velocity scale of planned trajectories (1 = the robot's limits).
    velocity_scale: float = 0.5
    #: Acceleration scale of planned trajectories.
    acceleration_scale: float = 0.5
    #: Planning time limit per motion (s).
    plan_time_limit: float = 1.0
    #: Grasp detection options (see ``ferrobot.grasp.OPTIONS``). Table-top picking approaches from above:
    #: hands are searched with the approach along each seed's normal (no tilted variants).
    detect_options: dict = field(default_factory=lambda: {"approach_tilts": (0.0,)})
    #: Measured joint positions beyond a joint limit by at most this much (rad) are moved onto the limit
    #: before planning (drives settle a hair past a limit); larger violations fail the stage.
    limit_tolerance: float = 1e-3
    #: Step (m, in [0.001, 0.05]) of the straight first part of the lift and of the retreat. Contacts of the
    #: hand and the held object with what they touch when the gripper closes (or opens) are allowed on that
    #: part only (MoveIt's post-grasp retreat): the hand moves straight up (back along the approach) until
    #: it and the object are clear of everything, then the rest of the motion is planned with nothing ignored.
    escape_step: float = 0.005
    #: Distance (m, in [0, 0.05]) the straight part continues past the first configuration clear of
    #: everything (the simulated contact surfaces sit a hair beyond the planner's).
    escape_clearance: float = 0.01
    #: Opening (m, in [0, 0.05]) added to the chosen grasp's width for the fingers' pre-shape: the gripper
    #: opens to that width (at most its largest opening) before the pre-grasp motion, and the planner checks
    #: the pre-grasp, the grasp pose and the approach with the fingers at it (not fully open: open fingers
    #: meet walls and neighbours the grasp's own fingers clear). None (the default): approach with the
    #: gripper fully open. Off by default in ``PickPlace`` because on single objects on a table it measured
    #: worse (Panda, seeds 0-99: 98/100 pre-shaped against 99/100 fully open; in seeds 11 and 52 the released
    #: cylinder, dropped from ``place_clearance``, lands rocking on its rim and the rocking grows in the
    #: simulator until it falls, with the fingers already above it: not the retreat; with ``place_clearance``
    #: 4 mm both ways give 100/100, see BENCHMARKS.md, retreat18f); ``benches/clutter.py`` pre-shapes (better
    #: per grasp in piles and bins, paired A/B in BENCHMARKS.md).
    preshape_margin: float | None = None
    #: Clearance (m, in [0, 0.02]; None: off) that the links' exact geometry must keep from every object but
    #: the target and the table on the final approach, where the planner's sphere model alone would refuse
    #: it. The spheres reach a few millimetres (up to ~2 cm at a box-shaped hand's corners) beyond the
    #: links, so a grasp the detector found clear of a bin's wall or a neighbour can be "in collision" for
    #: the planner; then the straight approach from the pre-grasp is measured exactly
    #: (:meth:`ferrobot.Planner.exact_clearance`, conservative advancement: each step no longer than the
    #: measured clearance allows) and, if clear by this much all along, taken with those sphere contacts
    #: ignored on that segment only.
    exact_approach_clearance: float | None = 0.0005
    #: Grasp detection with the hand grown to cover the robot model's own collision geometry of the hand and
    #: finger links (``ferrobot.Gripper.covering``), so that no returned grasp puts the simulated / planned
    #: hand into the cloud. Off by default: with the bundled Panda's primitives (fingers 2.65 cm thick at
    #: their base, a 23.25 cm housing) the arm bin demo found almost no grasps (seeds 0-5: 14 -> 2 objects
    #: cleared of 36, held-out 8 -> 4; BENCHMARKS.md, branch ``hand18h``); the detector needs the fingers'
    #: taper (the real finger is 1.55 cm thick at the tip) before this can be the default.
    hand_covers_model: bool = False


@dataclass
class StageResult:
    name: str
    ok: bool
    time_s: float
    detail: dict = field(default_factory=dict)
    reason: str = ""


@dataclass
class EpisodeResult:
    """Outcome of one episode: success, the failing stage and reason if any, per-stage results."""

    seed: int
    success: bool = False
    failed_stage: str | None = None
    reason: str = ""
    stages: list[StageResult] = field(default_factory=list)
    wall_time_s: float = 0.0
    sim_time_s: float = 0.0
    place_error_m: float | None = None
    target: str = ""
    #: Everything the episode made (scene, frames, grasps, chosen configurations, recorder): what reports
    #: and viewers read. Not part of :meth:`to_dict`.
    episode: Episode | None = field(default=None, repr=False, compare=False)

    def to_dict(self) -> dict:
        return {
            "seed": self.seed,
            "success": self.success,
            "failed_stage": self.failed_stage,
            "reason": self.reason,
            "target": self.target,
            "wall_time_s": self.wall_time_s,
            "sim_time_s": self.sim_time_s,
            "place_error_m": self.place_error_m,
            "stages": [
                {"name": s.name, "ok": s.ok, "time_s": s.time_s, "reason": s.reason, **s.detail} for s in self.stages
            ],
        }


@dataclass(eq=False)
class Episode:
    """The record of one episode: the scene it built and what each stage produced, in the order the stages
    fill it in (None until then). :meth:`PickPlace.run` makes one per episode, so nothing of an episode leaks
    into the next; reports (:func:`ferrobot.pipeline.report.write_episode`) and viewers read it."""

    #: The scene description.
    spec: SceneSpec
    #: The outcome (its ``episode`` field points back here).
    result: EpisodeResult
    #: The robot model and the planner's sphere model (for viewers).
    model: Any = None
    spheres: Any = None
    #: The :class:`ferrobot.Gripper` (its finger geometry draws the grasps).
    gripper: Any = None
    #: The simulated world, its robot and the perception camera (``scene``).
    world: Any = None
    robot: Any = None
    camera: Any = None
    #: Pose (4x4) of the robot base in the world.
    base: np.ndarray | None = None
    #: Grasp workspace [xmin, xmax, ymin, ymax, zmin, zmax] (world frame).
    workspace: list[float] | None = None
    #: Indices of the planner's joints in the simulated robot's DOFs.
    arm_idx: list[int] = field(default_factory=list)
    #: What recorded the robot's motion (:class:`Recorder` or a dataset recorder).
    recorder: Any = None
    #: The camera frame (``perceive``): depth, segmentation, rgb; and the target's segmentation id.
    frame: dict | None = None
    target_id: int | None = None
    #: Detected grasps in the world and camera frames, and the target's top-surface centroid (``detect``).
    grasps_world: Any = None
    grasps_camera: Any = None
    target_centroid: np.ndarray | None = None
    #: Index of the chosen grasp in ``grasps_world``, its hand pose (base frame) and the pre-grasp and grasp
    #: configurations (``select``).
    choice: int | None = None
    hand_grasp: np.ndarray | None = None
    q_pre: np.ndarray | None = None
    q_grasp: np.ndarray | None = None
    #: Objects the sphere model touches on the final approach that the exact geometry clears
    #: (``PickPlaceConfig.exact_approach_clearance``): ignored on that straight segment only.
    approach_allowed: list[str] = field(default_factory=list)
    #: Configurations of the lift, above the place location and at it; the place hand pose (``lift``,
    #: ``transport``).
    q_lift: np.ndarray | None = None
    q_above: np.ndarray | None = None
    q_place: np.ndarray | None = None
    place_hand: np.ndarray | None = None
    #: Opening (m) of the fingers for the approach to the chosen grasp (``select``, see
    #: :attr:`PickPlaceConfig.preshape_margin`).
    preshape_opening: float | None = None

    def scene_shapes(self) -> list[tuple[str, str, tuple, tuple]]:
        """(name, kind, size, colour) of every object of the scene, table and robot mount included."""
        return scene_shapes(self.spec)


def scene_shapes(spec: SceneSpec) -> list[tuple[str, str, tuple, tuple]]:
    """(name, kind, size, colour) of every object of ``spec``, table and robot mount included."""
    out = [
        ("table", "box", TABLE_SIZE, (0.55, 0.42, 0.30)),
        (ROBOT_MOUNT, "box", (0.3, 0.3, TABLE_TOP), (0.3, 0.3, 0.32)),
    ]
    out += [(o.name, o.kind, tuple(o.size), o.color) for o in spec.objects]
    return out


#: Old per-episode attribute names of :class:`PickPlace` -> the :class:`Episode` field now holding them.
_EPISODE_ATTRS = {f.name: f.name for f in fields(Episode) if f.name not in ("model", "spheres")} | {"rec": "recorder"}


class Recorder:
    """Collects what the robot did (joint positions per physics step, labelled by stage) and, when a
    ``frame_camera`` is given, RGB frames every ``frame_every`` steps for an animation."""

    def __init__(self, world, robot, frame_camera=None, frame_every: int = 16):
        self.world, self.robot = world, robot
        self.camera = frame_camera
        self.every = frame_every
        self.times: list[float] = []
        self.q: list[np.ndarray] = []
        self.desired: list[np.ndarray] = []
        self.stage: list[str] = []
        self.frames: list[tuple[float, str, np.ndarray]] = []
        self.states: list[dict] = []  # robot and object states at the frames, for the 3D viewer
        self._since_frame = frame_every
        #: Period (s) at which planned motions are sampled for :meth:`execute`: every physics step.
        self.sample_dt = world.dt

    def set_gripper(self, closed: bool, force: float | None = None) -> None:
        """Closes (squeezing with ``force`` N per finger) or opens the gripper."""
        if closed:
            self.robot.close_gripper(force=force)
        else:
            self.robot.open_gripper()

    def set_gripper_opening(self, opening: float) -> None:
        """Opens (or closes) the gripper to ``opening`` (m, within its range): the pre-shape before an approach."""
        self.robot.set_gripper_opening(opening)

    def _frame(self, stage: str) -> None:
        if self.camera is not None and self._since_frame >= self.every:
            self.frames.append((self.world.time, stage, self.camera.render(rgb=True).rgb))
            self.states.append(
                {
                    "t": self.world.time,
                    "stage": stage,
                    "q": self.robot.joint_positions,
                    "objects": {n: self.world.get_object_pose(n) for n in self.world.object_names},
                }
            )
            self._since_frame = 0

    def snapshot(self, stage: str) -> None:
        self._since_frame = self.every
        self._frame(stage)

    def execute(self, positions: np.ndarray, velocities: np.ndarray, joint_indices: list[int], stage: str):
        """Runs (N, k) position targets of the DOFs ``joint_indices`` (positions in ``dof_names``) through the
        drives, one per physics step."""
        dt = self.world.dt
        names = [self.robot.dof_names[i] for i in joint_indices]
        chunk = self.every if self.camera is not None else len(positions)
        errs = []
        for s in range(0, len(positions), chunk):
            rep = self.robot.execute_trajectory(
                positions[s : s + chunk], dt, velocities=velocities[s : s + chunk], joint_names=names
            )
            self._log(rep, joint_indices, stage)
            errs.append(rep.max_error)
            self._since_frame += len(positions[s : s + chunk])
            self._frame(stage)
        return float(np.max(errs)) if errs else 0.0

    def wait(self, seconds: float, stage: str) -> None:
        """Steps the world for ``seconds`` holding the current targets."""
        steps = max(1, int(round(seconds / self.world.dt)))
        chunk = self.every if self.camera is not None else steps
        done = 0
        while done < steps:
            n = min(chunk, steps - done)
            self.world.step(n)
            done += n
            self.times.append(self.world.time)
            self.q.append(self.robot.joint_positions)
            self.desired.append(self.robot.joint_position_targets)
            self.stage.append(stage)
            self._since_frame += n
            self._frame(stage)

    def _log(self, rep, joint_indices: list[int], stage: str) -> None:
        times = rep.times
        if len(times) == 0:
            return
        end = self.world.time
        full = self.robot.joint_positions
        target = self.robot.joint_position_targets
        for k in range(len(times)):
            row, des = full.copy(), target.copy()
            row[joint_indices] = rep.actual[k]
            des[joint_indices] = rep.desired[k]
            self.times.append(end - (times[-1] - times[k]))
            self.q.append(row)
            self.desired.append(des)
            self.stage.append(stage)

    def arrays(self) -> dict[str, np.ndarray]:
        return {
            "times": np.asarray(self.times),
            "positions": np.asarray(self.q).reshape(len(self.q), -1),
            "desired": np.asarray(self.desired).reshape(len(self.desired), -1),
            "stage": np.asarray(self.stage),
        }


def _translate(pose: np.ndarray, offset) -> np.ndarray:
    out = np.array(pose, dtype=float)
    out[..., :3, 3] += offset
    return out


def _along(pose: np.ndarray, axis: np.ndarray, distance: float) -> np.ndarray:
    """``pose`` moved ``distance`` along ``axis`` given in its own frame (a hand's approach)."""
    out = np.array(pose, dtype=float)
    out[..., :3, 3] += distance * (out[..., :3, :3] @ np.asarray(axis, dtype=float))
    return out


def _along_z(pose: np.ndarray, distance: float) -> np.ndarray:
    """``pose`` moved ``distance`` along its own z axis (the Panda hand's approach)."""
    return _along(pose, (0.0, 0.0, 1.0), distance)


def _reach(shape: dict, pose: np.ndarray, u: np.ndarray) -> float | None:
    """Largest ``p . u`` over the points ``p`` of a solid (a collision-geometry dict: ``type`` box with
    ``size``, sphere with ``radius``, cylinder or capsule along its z axis with ``radius`` and ``length``,
    mesh with ``vertices`` and ``scale``) at ``pose`` (4x4), for a unit direction ``u`` in the same frame as
    ``pose``. None for a shape without that data (a mesh without vertices)."""
    r, c = pose[:3, :3], pose[:3, 3]
    v = r.T @ u  # the direction in the shape's frame
    kind = shape["type"]
    if kind == "box":
        return float(c @ u + 0.5 * np.abs(v) @ np.asarray(shape["size"], dtype=float))
    if kind == "sphere":
        return float(c @ u + shape["radius"])
    if kind in ("cylinder", "capsule"):
        axial = 0.5 * shape["length"] * abs(v[2])
        radial = shape["radius"] if kind == "capsule" else shape["radius"] * math.sqrt(max(0.0, 1.0 - v[2] ** 2))
        return float(c @ u + axial + radial)
    if kind == "mesh" and shape.get("vertices") is not None:
        pts = np.asarray(shape["vertices"], dtype=float) * np.asarray(shape.get("scale", (1.0, 1.0, 1.0)), float)
        return float(c @ u + np.max(pts @ v))
    return None


def resolve_robot(robot=None, srdf=None, gripper=None, cover: bool = False):
    """(model, gripper) for ``robot``: ``"panda"`` / ``"ur5e"`` (bundled), a URDF path (with ``srdf``), or a
    :class:`ferrobot.RobotModel`; ``gripper``: a :class:`ferrobot.Gripper`, ``"panda_hand"`` /
    ``"robotiq_2f85"``, or None to find the model's own (``Gripper.from_model``). ``cover``: the gripper returned
    has its finger and housing boxes grown to cover the model's own collision geometry of them
    (``Gripper.covering``; off by default, see ``PickPlaceConfig.hand_covers_model``)."""
    if robot is None or isinstance(robot, str) and robot in ("panda", "ur5e"):
        model = robots.bundled(robot or "panda")
    elif isinstance(robot, (str, bytes)) or hasattr(robot, "__fspath__"):
        model = _core.RobotModel.from_urdf(str(robot), srdf=None if srdf is None else str(srdf))
    else:
        model = robot
    if gripper is None:
        g = _core.Gripper.from_model(model)
    elif isinstance(gripper, str):
        known = {"panda_hand": _core.Gripper.panda_hand, "robotiq_2f85": _core.Gripper.robotiq_2f85}
        if gripper not in known:
            raise InvalidArgumentError(f"gripper: unknown name '{gripper}'; known: {sorted(known)}")
        g = known[gripper]()
    else:
        g = gripper
    if cover:
        # The detector's hand covers the model's own hand and finger collision geometry (what the planner and
        # the simulator collide with); raises unless the model has this gripper.
        return model, g.covering(model)
    g.check_model(model)
    return model, g


class PickPlace:
    """Runs pick-and-place episodes of any arm with a parallel-jaw gripper (default the bundled Panda) on
    table-top scenes: ``PickPlace(robot="ur5e")``, ``PickPlace(robot="arm.urdf", srdf="arm.srdf")``.

    One instance keeps the robot model and planner across episodes (``run(spec)`` per scene)::

        pp = PickPlace()
        result = pp.run(ferrobot.pipeline.random_scene(seed=0))
        print(result.success, result.failed_stage, result.reason)
    """

    def __init__(self, config: PickPlaceConfig | None = None, model=None, *, robot=None, gripper=None, srdf=None):
        """``robot``: ``"panda"`` (default), ``"ur5e"``, a URDF path (``srdf`` beside it) or a
        :class:`ferrobot.RobotModel` (``model`` is the older name); ``gripper``: a :class:`ferrobot.Gripper`
        or a shipped one's name, default the model's own (``ferrobot.Gripper.from_model``)."""
        self.config = config or PickPlaceConfig()
        for name, lo, hi in (("escape_step", 0.001, 0.05), ("escape_clearance", 0.0, 0.05)):
            v = getattr(self.config, name)
            if not (isinstance(v, (int, float)) and lo <= v <= hi):
                raise InvalidArgumentError(f"config.{name}: {v!r} m is outside [{lo}, {hi}]")
        m = self.config.preshape_margin
        if m is not None and not (isinstance(m, (int, float)) and 0.0 <= m <= 0.05):
            raise InvalidArgumentError(f"config.preshape_margin: {m!r} m is outside [0, 0.05] (or None)")
        m = self.config.exact_approach_clearance
        if m is not None and not (isinstance(m, (int, float)) and 0.0 <= m <= 0.02):
            raise InvalidArgumentError(f"config.exact_approach_clearance: {m!r} m is outside [0, 0.02] (or None)")
        if not isinstance(self.config.hand_covers_model, bool):
            raise InvalidArgumentError(
                f"config.hand_covers_model: expected a bool, got {self.config.hand_covers_model!r}"
            )
        self.model, self.gripper = resolve_robot(
            model if robot is None else robot, srdf, gripper, cover=self.config.hand_covers_model
        )
        self.hand_link = self.gripper.hand_link
        self.planner = _core.Planner(self.model)
        # The planner moves the model's end-effector link; hands are placed for the gripper's hand link.
        # Both are rigidly joined (fixed joints): ee = hand @ hand_to_ee.
        q0 = self.model.neutral_configuration()
        ee = self.model.ee_link
        self._hand_to_ee = np.linalg.inv(self.model.fk(q0, self.hand_link)) @ self.model.fk(q0, ee)
        self.home = home_for(self.model, self.gripper)
        self.arm = list(self.planner.joint_names)
        # The farthest any link's geometry reaches from its link's origin (from the sphere model, which
        # holds it): for the exact approach's motion bound.
        sm = self.planner.sphere_model
        ext = [np.linalg.norm(s[:, :3], axis=1) + s[:, 3] for s in map(sm.spheres, self.model.link_names)]
        self._link_extent = float(max((e.max() for e in ext if len(e)), default=0.0))
        idx = self._arm_dofs = [self.model.dof_names.index(n) for n in self.arm]
        self.lower, self.upper = self.model.lower_limits[idx], self.model.upper_limits[idx]
        # Joints whose range spans more than a turn (UR arms: +-2 pi) keep IK goals within half a turn of home:
        # their far solutions (an arm folded down through its mount) are valid for the planner, whose world
        # leaves the robot's mount out, but not for the simulated robot standing on it.
        home_arm = self.home[idx]
        wide = self._wide = (self.upper - self.lower) > 2 * math.pi + 1e-9
        self._win_lo = np.where(wide, np.maximum(self.lower, home_arm - math.pi), self.lower)
        self._win_hi = np.where(wide, np.minimum(self.upper, home_arm + math.pi), self.upper)
        # The hand link and every link below it (fingers, pads, knuckles): what must clear a released object.
        children: dict[str, list[str]] = {}
        for j in self.model.joint_names:
            info = self.model.joint_info(j)
            children.setdefault(info.parent, []).append(info.child)
        self._gripper_links, todo = [], [self.hand_link]
        while todo:
            link = todo.pop()
            self._gripper_links.append(link)
            todo += children.get(link, [])

    # -- helpers ---------------------------------------------------------------------------------------------

    def preshape_opening(self, width: float) -> float:
        """The fingers' opening (m) for the approach to a grasp of ``width`` (m): the width plus
        ``config.preshape_margin``, within the gripper's range (its largest opening without a margin, or when
        the episode's recorder has no ``set_gripper_opening``)."""
        g, m = self.gripper, self.config.preshape_margin
        # A recorder without a continuous gripper command (datasets record open / closed) approaches open.
        ep = getattr(self, "episode", None)
        rec = None if ep is None else ep.recorder
        if m is None or (rec is not None and not hasattr(rec, "set_gripper_opening")):
            return float(g.max_opening)
        return float(min(g.max_opening, max(g.min_opening, width + m)))

    def _set_planner_fingers(self, opening: float) -> None:
        """The planner checks the robot with the gripper at ``opening`` (m): its locked driver position is
        set through the gripper description's opening map (the followers mimic it)."""
        names = list(self.planner.dof_names)
        if self.gripper.driver not in names:
            return
        q = np.asarray(self.planner.locked_positions, dtype=float).copy()
        q[names.index(self.gripper.driver)] = self.gripper.driver_position(opening)
        self.planner.locked_positions = q

    def _sync(self, ignore: list[str]) -> None:
        """Planner world := the simulation's objects (base frame), without ``ignore`` and attached objects."""
        self.planner.update_world(self.episode.world, ignore=[ROBOT_MOUNT, *ignore], base_pose=self.episode.base)

    def _q(self) -> np.ndarray:
        """The simulated arm's joint positions in planner order; positions a hair past a joint limit (at most
        ``limit_tolerance``) are put on the limit, larger violations are left for the planner to report."""
        q = self.episode.robot.joint_positions[self.episode.arm_idx]
        lo, hi = self.lower, self.upper
        tol = self.config.limit_tolerance
        near = ((q < lo) & (q >= lo - tol)) | ((q > hi) & (q <= hi + tol))
        return np.where(near, np.clip(q, lo, hi), q)

    def _ik(self, poses: np.ndarray, seeds: np.ndarray | None, collision_free: bool):
        return self.planner.ik_batch(poses, seeds, collision_free=collision_free, num_seeds=64)

    def _in_window(self, q: np.ndarray) -> bool:
        """Whether the arm configuration ``q`` lies within the IK window around home (see ``__init__``)."""
        return bool(np.all((q >= self._win_lo - 1e-9) & (q <= self._win_hi + 1e-9)))

    def _move(self, stage: str, goal_q: np.ndarray, ignore: list[str], straight: bool = False) -> dict:
        """Plans from the current state to ``goal_q`` in the synced world and executes it; with ``straight``
        the plan must be the straight joint-space segment (else the stage fails)."""
        self._sync(ignore)
        start = self._q()
        t0 = time.perf_counter()
        res = self.planner.plan(
            start,
            goal_q=goal_q,
            time_limit=self.config.plan_time_limit,
            velocity_scale=self.config.velocity_scale,
            acceleration_scale=self.config.acceleration_scale,
            seed=self.episode.spec.seed,
        )
        plan_s = time.perf_counter() - t0
        if not res.success:
            raise StageFailure(stage, f"planning failed ({res.status}): {res.message}")
        if straight and len(res.path) != 2:
            raise StageFailure(stage, f"the plan is not the straight segment ({len(res.path)} waypoints)")
        traj = res.interpolated(self.episode.recorder.sample_dt)
        err = self.episode.recorder.execute(traj.positions, traj.velocities, self.episode.arm_idx, stage)
        self.episode.recorder.wait(0.1, stage)
        return {"plan_ms": 1e3 * plan_s, "duration_s": float(res.duration), "tracking_error_rad": err}

    def scene_shapes(self) -> list[tuple[str, str, tuple, tuple]]:
        """(name, kind, size, colour) of every object of the current episode's scene."""
        return scene_shapes(self.episode.spec)

    def __getattr__(self, name: str):
        # Deprecated for one release: the per-episode attributes now live in the episode record.
        target = _EPISODE_ATTRS.get(name)
        ep = self.__dict__.get("episode")
        if target is None or ep is None:
            raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")
        warnings.warn(
            f"PickPlace.{name} is deprecated: read result.episode.{target} (the episode record)",
            DeprecationWarning,
            stacklevel=2,
        )
        return getattr(ep, target)

    def _hand_world(self) -> np.ndarray:
        return self.episode.robot.get_link_pose(self.hand_link)

    def _ee(self, hand: np.ndarray) -> np.ndarray:
        """Planner end-effector pose(s) for hand-link pose(s) (base frame)."""
        return hand @ self._hand_to_ee

    def _back(self, hand: np.ndarray, distance: float) -> np.ndarray:
        """Hand pose(s) moved ``distance`` back along the gripper's approach."""
        return _along(hand, self.gripper.approach, -distance)

    def _past_object(self, name: str) -> float:
        """Distance (m, >= 0) the hand must move back along the gripper's approach for every point of the
        gripper (the hand link and the links below it, at the simulated state: the fingers as they are now)
        to be beyond the farthest point of the world object ``name`` along that direction: after a release,
        how far the fingertips still reach down beside the placed object (a tall object grasped near its
        top). From the model's collision geometry and the object's shape (``spec``) at its simulated pose;
        the gripper's TCP (between the fingertips) stands in for links without usable geometry."""
        ep = self.episode
        hand = self._hand_world()
        u = -(hand[:3, :3] @ np.asarray(self.gripper.approach, dtype=float))  # back along the approach, world
        tips = [float((hand @ np.append(self.gripper.tcp, 1.0))[:3] @ u)]
        for link in self._gripper_links:
            pose = ep.robot.get_link_pose(link)
            for shape in self.model.collision_geometry(link):
                r = _reach(shape, pose @ shape["origin"], -u)
                if r is not None:
                    tips.append(-r)
        spec = ep.spec.object(name)
        pose = ep.world.get_object_pose(name)
        if spec.kind == "box":
            shape = {"type": "box", "size": spec.size}
        elif spec.kind == "cylinder":
            shape = {"type": "cylinder", "radius": spec.size[0], "length": spec.size[1]}
        elif spec.kind == "sphere":
            shape = {"type": "sphere", "radius": spec.size[0]}
        else:
            shape = {"type": "mesh", "vertices": _core.load_mesh(spec.mesh, spec.scale).vertices}
        top = _reach(shape, pose, u)
        return max(0.0, top - min(tips))

    # -- the stages -------------------------------------------------------------------------------------------

    def perceive(self) -> dict:
        self.episode.frame = self.episode.camera.render(rgb=True)
        labels = self.episode.world.segmentation_labels
        self.episode.target_id = next(i for i, n in labels.items() if n == self.episode.spec.target)
        visible = int(np.count_nonzero(self.episode.frame.segmentation == self.episode.target_id))
        if visible < 50:
            raise StageFailure(
                "perceive", f"target '{self.episode.spec.target}' covers only {visible} pixels in the camera"
            )
        return {"target_pixels": visible}

    def detect(self) -> dict:
        """Grasps on the target, sought in the world frame: the depth image is back-projected, moved to the
        world by the camera pose, cropped to the table's workspace, and searched with the approach
        preferred straight down; every other point is an obstacle for the hand."""
        depth = np.where(np.isfinite(self.episode.frame.depth), self.episode.frame.depth, 0.0)
        k = self.episode.camera.intrinsic_matrix
        cam = self.episode.camera.world_transform
        intrinsics = camera_model.Intrinsics.from_matrix(k, depth.shape[1], depth.shape[0])
        points, pixels = camera_model.backproject(depth, intrinsics)
        points = grasp.transform_points(points, cam)
        labels = self.episode.frame.segmentation[pixels[:, 0], pixels[:, 1]].astype(np.int64)
        opts = {
            "approach_direction": (0.0, 0.0, -1.0),
            "viewpoint": tuple(cam[:3, 3]),
            **self.config.detect_options,
        }
        gg = grasp.detect(
            points,
            labels=labels,
            seed_mask=labels == self.episode.target_id,
            workspace=self.episode.workspace,
            gripper=self.gripper,
            **opts,
        )
        if len(gg) == 0:
            w = np.asarray(self.episode.workspace)
            inside = np.all((points >= w[0::2]) & (points <= w[1::2]), axis=1)
            n = int(np.count_nonzero(inside & (labels == self.episode.target_id)))
            raise StageFailure("detect", f"no grasp found on the target ({n} of its points in the workspace)")
        self.episode.grasps_world = gg
        # Centre estimate of an upright object on the table: the centroid of its top surface (the points
        # within 5 mm of its highest), which the side faces seen by the camera do not bias.
        tp = points[labels == self.episode.target_id]
        self.episode.target_centroid = tp[tp[:, 2] > tp[:, 2].max() - 0.005].mean(axis=0)
        self.episode.grasps_camera = gg.transform(np.linalg.inv(cam))
        return {"points": int(len(points)), "grasps": len(gg), "best_score": float(gg.scores[0])}

    def select(self) -> dict:
        cfg = self.config
        gw = self.episode.grasps_world
        approach = gw.rotation_matrices[:, :, 0]
        angle = np.arccos(np.clip(-approach[:, 2], -1.0, 1.0))
        # Rank: detector score, discounted for grasps far from the target's visible centroid (off-centre
        # grasps twist the object in the fingers) and for tilted approaches (which push it sideways).
        centre = gw.translations + 0.5 * gw.depths[:, None] * approach
        off = np.linalg.norm((centre - self.episode.target_centroid)[:, :2], axis=1)
        rank = gw.scores * np.exp(-((off / cfg.centre_scale) ** 2)) * np.cos(angle)
        order = [i for i in np.argsort(-rank) if angle[i] <= cfg.max_approach_angle][: cfg.max_candidates]
        if not order:
            raise StageFailure(
                "select", f"no grasp approaches within {math.degrees(cfg.max_approach_angle):.0f} deg of vertical"
            )
        hands_world = gw.to_hand(self.gripper)[order]
        to_base = transforms.world_to_base(np.eye(4), self.episode.base)
        hands = np.einsum("ij,njk->nik", to_base, hands_world)
        pre = self._ee(self._back(hands, cfg.pregrasp_distance))
        # Seeded from home when the window matters (joints of more than a turn), else from random seeds only.
        seeds = np.tile(self.home[self._arm_dofs], (len(pre), 1)) if self._wide.any() else None
        tried = reachable = 0
        for j in range(len(order)):
            # The fingers pre-shaped to this grasp's width (plus the margin) for every check of its approach.
            opening = self.preshape_opening(float(gw.widths[order[j]]))
            self._set_planner_fingers(opening)
            # Pre-grasp: free of collision with everything, target included. Where it is not (the hand
            # still between a bin's walls), farther back along the approach (1.5 and 2 times the distance:
            # the longer approach is measured exactly if the spheres touch anything on it).
            self._sync([])
            seed_j = None if seeds is None else seeds[j : j + 1]
            ik_pre = self._ik(pre[j : j + 1], seed_j, collision_free=True)
            for factor in (1.5, 2.0) if cfg.exact_approach_clearance is not None else ():
                if ik_pre.success[0] and self._in_window(ik_pre.q[0]):
                    break
                far = self._ee(self._back(hands[j : j + 1], factor * cfg.pregrasp_distance))
                ik_pre = self._ik(far, seed_j, collision_free=True)
            if not ik_pre.success[0] or not self._in_window(ik_pre.q[0]):
                continue
            reachable += 1
            q_pre = ik_pre.q[0]
            # Grasp: the fingers touch the target and come close to the table: both ignored.
            self._sync([self.episode.spec.target, "table"])
            tried += 1
            ik_g = self.planner.ik(self._ee(hands[j]), q_pre, collision_free=True, num_seeds=8)
            allowed: list[str] = []
            if not ik_g.success and cfg.exact_approach_clearance is not None:
                # The spheres may report a contact the links do not have: the pose without the collision
                # test, then the straight approach to it measured exactly.
                ik_g = self.planner.ik(self._ee(hands[j]), q_pre, collision_free=False, num_seeds=8)
                if ik_g.success and np.max(np.abs(ik_g.q - q_pre)) <= 1.0 and self._in_window(ik_g.q):
                    found = self._exact_segment(q_pre, ik_g.q)
                    if found is None:
                        continue
                    allowed = found
            if not ik_g.success or np.max(np.abs(ik_g.q - q_pre)) > 1.0 or not self._in_window(ik_g.q):
                continue
            for n in allowed:
                self.planner.set_object_enabled(n, False)
            try:
                res = self.planner.plan(q_pre, goal_q=ik_g.q, trajectory=False, time_limit=0.2)
            finally:
                for n in allowed:
                    self.planner.set_object_enabled(n, True)
            if not res.success or (allowed and len(res.path) != 2):
                continue
            self.episode.approach_allowed = allowed
            self.episode.choice = order[j]
            self.episode.q_pre, self.episode.q_grasp = q_pre, ik_g.q
            self.episode.hand_grasp = hands[j]
            self.episode.preshape_opening = opening
            g = gw[order[j]]
            return {
                "candidates": len(order),
                "reachable_pregrasps": reachable,
                "tried": tried,
                "grasp_index": int(order[j]),
                "score": g.score,
                "rank": float(rank[order[j]]),
                "off_centre_mm": 1e3 * float(off[order[j]]),
                "width": g.width,
                "preshape_opening": opening,
                "approach_angle_deg": math.degrees(angle[order[j]]),
                "exact_approach": allowed,
            }
        raise StageFailure(
            "select",
            f"none of {len(order)} grasps reachable: {reachable} pre-grasps had collision-free IK, "
            f"{tried} grasp poses tried",
        )

    def pick(self) -> None:
        cfg = self.config

        def pregrasp():
            # Pre-shape: the fingers open to the grasp's width plus the margin while the arm moves (the planner
            # checks the motion with them there, see select).
            opening = self.episode.preshape_opening
            self._set_planner_fingers(opening)
            if hasattr(self.episode.recorder, "set_gripper_opening"):
                self.episode.recorder.set_gripper_opening(opening)
            return {**self._move("pregrasp", self.episode.q_pre, []), "preshape_opening_mm": 1e3 * opening}

        self._stage("pregrasp", pregrasp)

        def approach():
            ignore = [self.episode.spec.target, "table"]
            allowed = self.episode.approach_allowed
            if not allowed:
                return self._move("approach", self.episode.q_grasp, ignore)
            # The sphere contacts select measured exactly: the straight segment from where the arm is now,
            # measured again, is the motion (planned with them ignored, it must stay one straight segment).
            self._sync(ignore)
            found = self._exact_segment(self._q(), self.episode.q_grasp)
            if found is None:
                raise StageFailure("approach", "the straight approach comes closer to an object than allowed")
            out = self._move("approach", self.episode.q_grasp, ignore + found, straight=True)
            return {**out, "exact_approach": found}

        self._stage("approach", approach)

        def close():
            self.episode.recorder.set_gripper(True, cfg.grip_force)
            self.episode.recorder.wait(0.3, "grasp")
            width = float(self.episode.robot.gripper_opening)
            if width < self.gripper.min_opening + 0.008:
                raise StageFailure("grasp", f"the fingers closed on nothing (opening {1e3 * width:.1f} mm)")
            self._set_planner_fingers(min(width, self.gripper.max_opening))
            self._sync([])  # the target must be in the world to be attached
            self.planner.attach_world_object(self.episode.spec.target, self._q())
            return {"opening_mm": 1e3 * width}

        self._stage("grasp", close)

        def lift():
            # Straight up, the contacts at grasp time (a neighbour in a pile, the table under the fingers)
            # allowed, until clear of everything; then planned to the lift pose with nothing ignored.
            up_base = transforms.world_to_base(np.eye(4), self.episode.base)[:3, :3] @ np.array([0.0, 0.0, 1.0])
            hand0 = self._hand_base()
            esc = self._escape("lift", up_base, cfg.lift_height)
            up = _translate(hand0, cfg.lift_height * up_base)
            if esc["escape_distance_mm"] >= 1e3 * cfg.lift_height - 1e-6:
                self.episode.q_lift = self._q()
                out = {}
            else:
                self.episode.q_lift = self._ik_near(self._ee(up), self._q(), "lift")
                out = self._move("lift", self.episode.q_lift, [])
            self._check_held("lift")
            return {**out, **esc}

        self._stage("lift", lift)

    def _place_poses(self) -> list[np.ndarray]:
        """Hand poses (base frame) that put the object at the place location: the grasp pose turned about
        the vertical through the object's perceived centre by 0, 180, 90 or -90 degrees (a parallel gripper
        can hold a box or a cylinder either way), then moved over the place location."""
        to_base = transforms.world_to_base(np.eye(4), self.episode.base)
        c_world = np.array([*self.episode.target_centroid[:2], TABLE_TOP, 1.0])
        p_world = np.array([*self.episode.spec.place_xy, TABLE_TOP, 1.0])
        c, p = (to_base @ c_world)[:3], (to_base @ p_world)[:3]
        up = to_base[:3, :3] @ np.array([0.0, 0.0, 1.0])
        out = []
        for psi in (0.0, math.pi, math.pi / 2, -math.pi / 2):
            k = np.array([[0, -up[2], up[1]], [up[2], 0, -up[0]], [-up[1], up[0], 0]])
            rot = np.eye(3) + math.sin(psi) * k + (1 - math.cos(psi)) * (k @ k)
            m = np.eye(4)
            m[:3, :3] = rot
            m[:3, 3] = p - rot @ c + self.config.place_clearance * up
            out.append(m @ self.episode.hand_grasp)
        return out

    def place(self) -> None:
        cfg = self.config

        def transport():
            for k, hand in enumerate(self._place_poses()):
                above = _translate(hand, [0.0, 0.0, cfg.lift_height])
                self._sync([])
                res = self.planner.ik(self._ee(above), self.episode.q_lift, num_seeds=32, collision_free=True)
                if not res.success or not self._in_window(res.q):
                    continue
                self._sync(["table"])
                low = self.planner.ik(self._ee(hand), res.q, num_seeds=8, collision_free=True)
                if not low.success:
                    continue
                self.episode.place_hand, self.episode.q_place, self.episode.q_above = hand, low.q, res.q
                out = self._move("transport", res.q, [])
                self._check_held("transport")
                return {**out, "turn_deg": [0, 180, 90, -90][k]}
            raise StageFailure("transport", "no hand turn has collision-free IK above and at the place location")

        self._stage("transport", transport)

        def lower():
            return self._move("lower", self.episode.q_place, ["table"])

        self._stage("lower", lower)

        def release():
            self.episode.recorder.set_gripper(False)
            self.episode.recorder.wait(0.3, "release")
            self.planner.detach(self.episode.spec.target)
            self._set_planner_fingers(self.gripper.max_opening)
            return {}

        self._stage("release", release)

        def retreat():
            # Straight back along the approach, the contacts at release (the placed object, the table)
            # allowed, until clear of everything; then planned with nothing ignored to the retreat pose, or
            # where that is out of reach, up to the pose the object was carried in (its IK is known).
            hand = self._hand_base()
            back_dir = -(hand[:3, :3] @ np.asarray(self.gripper.approach, dtype=float))
            # The straight part goes on at least until the open fingers are past the top of the released
            # object (by escape_clearance): the planner's spheres can be clear of a tall object while the
            # simulated fingertips still reach down beside it, and the planned rest of the retreat, which
            # need not go straight up, would sweep them into it.
            past = self._past_object(self.episode.spec.target)
            need = past + cfg.escape_clearance if past > 0.0 else 0.0
            esc = self._escape(
                "retreat",
                back_dir,
                max(cfg.retreat_distance, need),
                min_distance=need,
                allow=[self.episode.spec.target],
            )
            esc["fingers_below_top_mm"] = 1e3 * past
            # The released object can follow the fingers (friction, tipping) while the hand backs out, so the
            # executed state is checked again: still touching, the hand backs out further along the same line
            # (within the retreat distance).
            moved = esc["escape_distance_mm"]
            while 0.0 < moved < 1e3 * cfg.retreat_distance - 1e-6 and self._touching("retreat", self._q()):
                more = self._escape("retreat", back_dir, cfg.retreat_distance - 1e-3 * moved)
                if more["escape_distance_mm"] <= 0.0:
                    break
                moved += more["escape_distance_mm"]
                esc = {**esc, **more, "escape_distance_mm": moved}
            if esc["escape_distance_mm"] >= 1e3 * cfg.retreat_distance - 1e-6:
                return {**esc, "retreat": "back along the approach"}
            back = self._back(hand, cfg.retreat_distance)
            res = self.planner.ik(self._ee(back), self._q(), num_seeds=32)
            q, how = (
                (res.q, "back along the approach") if res.success else (self.episode.q_above, "up to the carry pose")
            )
            return {**self._move("retreat", q, []), **esc, "retreat": how}

        self._stage("retreat", retreat)

    def verify(self) -> dict:
        """Waits 0.3 s, then up to :data:`SETTLE_WAIT` more while the object still moves faster than
        :data:`REST_SPEED`, and judges the place with :func:`placement_failure`."""
        ep = self.episode
        world, target = ep.world, ep.spec.target
        ep.recorder.wait(0.3, "verify")
        waited = 0.0
        while np.linalg.norm(world.get_object_velocity(target)[0]) > REST_SPEED and waited < SETTLE_WAIT - 1e-9:
            ep.recorder.wait(0.1, "verify")
            waited += 0.1
        pose = world.get_object_pose(target)
        spec = ep.spec.object(target)
        rest_z = TABLE_TOP + spec.height / 2
        speed = float(np.linalg.norm(world.get_object_velocity(target)[0]))
        err = float(np.hypot(pose[0, 3] - ep.spec.place_xy[0], pose[1, 3] - ep.spec.place_xy[1]))
        ep.result.place_error_m = err
        detail = {
            "place_error_mm": 1e3 * err,
            "height_error_mm": 1e3 * (pose[2, 3] - rest_z),
            "speed_mm_s": 1e3 * speed,
            "settle_wait_s": waited,
        }
        cause, message = placement_failure(
            pose[:3, 3], speed, rest_z, ep.spec.place_xy, spec.kind, self.config.place_tolerance
        )
        if cause:
            raise StageFailure("verify", message)
        return detail

    # -- helpers used by stages -----------------------------------------------------------------------------

    def _hand_base(self) -> np.ndarray:
        """The hand link's pose (base frame) at the simulated arm's configuration."""
        return transforms.world_to_base(self._hand_world(), self.episode.base)

    def _hand_fk(self, q_arm: np.ndarray) -> np.ndarray:
        """The hand link's pose (base frame) of the planner at arm configuration ``q_arm``."""
        full = self.home.copy()
        full[self._arm_dofs] = q_arm
        return self.model.fk(full, self.hand_link)

    def _reach_bound(self, q: np.ndarray) -> float:
        """An upper bound (m) on how far any point of the robot's geometry moves per radian of any joint
        near ``q``: twice the largest distance from the base of a link's origin plus its geometry's
        extent (a joint axis passes through the robot, so no point is farther from it), with 25 % slack
        for the configurations between samples."""
        full = np.asarray(self.planner.locked_positions, dtype=float).copy()
        names = list(self.planner.dof_names)
        for k, n in enumerate(self.arm):
            full[names.index(n)] = q[k]
        poses = self.model.fk_all(full)
        r = float(np.max(np.linalg.norm(poses[:, :3, 3], axis=1))) + self._link_extent
        return 2.5 * r

    def _exact_segment(self, q_a: np.ndarray, q_b: np.ndarray) -> list[str] | None:
        """The straight joint-space segment ``q_a`` -> ``q_b`` measured with the links' exact geometry
        against the planner's world as synced: None when some configuration on it comes closer to an
        object than ``config.exact_approach_clearance``, else the objects the sphere model reports in
        contact at the measured configurations (to be ignored on this segment; a plan that then leaves the
        straight segment is refused by the callers). Conservative advancement: from each
        measured configuration the next lies no farther than its clearance margin allows (joint motion
        times :meth:`_reach_bound`), so the whole segment, not just the samples, keeps the clearance."""
        c_min = float(self.config.exact_approach_clearance or 0.0)
        q_a, q_b = np.asarray(q_a, dtype=float), np.asarray(q_b, dtype=float)
        step = np.abs(q_b - q_a).sum()
        r = max(self._reach_bound(q_a), self._reach_bound(q_b))
        t = 0.0
        touching: set[str] = set()
        for _ in range(10_000):
            q = q_a + t * (q_b - q_a)
            touching.update(self._sphere_contacts(q))
            found = self.planner.exact_clearance(q, joint_names=self.arm)
            d = min((c.distance for c in found.values()), default=math.inf)
            if d < c_min:
                return None
            if t >= 1.0:
                break
            # Each point moves at most r * (sum of |dq|) from here: keep it within the margin d - c_min,
            # and never less than 0.1 mm per step (below that the margin is gone anyway).
            dt = (d - c_min) / max(r * step, 1e-12)
            t = min(1.0, t + max(dt, 1e-4 / max(r * step, 1e-12)))
            if dt * r * step < 1e-4:
                return None
        else:
            return None
        return sorted(touching)

    def _sphere_contacts(self, q: np.ndarray, stage: str | None = None) -> list[str]:
        """Objects of the planner's world as synced (enabled ones) the robot or what it holds collides with at
        ``q`` by the sphere model: each enabled alone among the others, which are ignored meanwhile. With
        ``stage``, raises :class:`StageFailure` when ``q`` collides with no object enabled (self-collision);
        without, self-collision is not an object's contact."""
        if not self.planner.in_collision(q):
            return []
        names = [n for n in self.planner.world.names if n != ROBOT_MOUNT]
        for n in names:
            self.planner.set_object_enabled(n, False)
        try:
            if stage is not None and self.planner.in_collision(q):
                raise StageFailure(stage, "the robot (or what it holds) is in self-collision")
            out = []
            for n in names:
                self.planner.set_object_enabled(n, True)
                if self.planner.in_collision(q):
                    out.append(n)
                self.planner.set_object_enabled(n, False)
            return out
        finally:
            for n in names:
                self.planner.set_object_enabled(n, True)

    def _touching(self, stage: str, q: np.ndarray) -> list[str]:
        """World objects the robot or what it holds collides with at ``q`` (planner world, synced from the
        simulation with nothing ignored): see :meth:`_sphere_contacts`. Raises :class:`StageFailure` when
        ``q`` collides with no world object enabled (self-collision)."""
        self._sync([])
        return self._sphere_contacts(q, stage)

    def _escape(
        self, stage: str, direction: np.ndarray, max_distance: float, min_distance: float = 0.0, allow=()
    ) -> dict:
        """The straight first part of a lift or retreat: the hand moves along ``direction`` (unit, base frame)
        from where it is, the objects it (or what it holds) touches now allowed, every other object checked,
        until it is clear of everything by ``escape_clearance`` and has moved at least ``min_distance`` (m;
        at most ``max_distance``), and the motion is executed; with ``min_distance`` > 0 the objects named in
        ``allow`` are allowed as well (a released object the fingers back away from). Raises
        :class:`StageFailure` when the straight path is out of reach or hits another object."""
        cfg = self.config
        q0 = self._q()
        touching = self._touching(stage, q0)
        if not touching and min_distance <= 0.0:
            return {"escape_distance_mm": 0.0, "allowed_contacts": []}
        if min_distance > 0.0:
            touching += [n for n in allow if n not in touching and n in self.planner.world.names]
        hand0 = self._hand_base()
        path, dists = [q0], [0.0]
        d, free_at, q = 0.0, (0.0 if not touching else None), q0
        while d < max_distance - 1e-9 and (
            free_at is None or d < free_at + cfg.escape_clearance - 1e-9 or d < min_distance - 1e-9
        ):
            d = min(d + cfg.escape_step, max_distance)
            res = self.planner.ik(self._ee(_translate(hand0, d * direction)), q, num_seeds=4)
            if not res.success or np.max(np.abs(res.q - q)) > 0.25:
                raise StageFailure(
                    stage, f"the straight path out of contact leaves the arm's reach at {1e3 * d:.0f} mm"
                )
            q = res.q
            for n in touching:
                self.planner.set_object_enabled(n, False)
            hit = self.planner.in_collision(q)
            for n in touching:
                self.planner.set_object_enabled(n, True)
            if hit:
                raise StageFailure(
                    stage,
                    f"the straight path out of contact with {touching} hits another object at {1e3 * d:.0f} mm",
                )
            if free_at is None and not self.planner.in_collision(q):
                free_at = d
            path.append(q)
            dists.append(d)
        # Executed as straight joint-space segments between IK points, each short enough that the hand stays
        # within 2 mm of the straight line (checked by FK at the segment's midpoints).
        for n in touching:
            self.planner.set_object_enabled(n, False)
        try:
            segments, i = [], 0
            while i < len(path) - 1:
                j = i + 1
                while j + 1 < len(path) and self._straight_enough(path[i], path[j + 1], hand0, direction):
                    j += 1
                segments.append((path[i], path[j]))
                i = j
            t_plan, dur, err = 0.0, 0.0, 0.0
            for a, b in segments:
                t0 = time.perf_counter()
                res = self.planner.plan(
                    a,
                    goal_q=b,
                    time_limit=cfg.plan_time_limit,
                    velocity_scale=cfg.velocity_scale,
                    acceleration_scale=cfg.acceleration_scale,
                    seed=self.episode.spec.seed,
                )
                t_plan += time.perf_counter() - t0
                if not res.success or len(res.path) != 2:
                    raise StageFailure(
                        stage, f"the straight path out of contact is blocked ({res.status}): {res.message}"
                    )
                traj = res.interpolated(self.episode.recorder.sample_dt)
                err = max(
                    err, self.episode.recorder.execute(traj.positions, traj.velocities, self.episode.arm_idx, stage)
                )
                dur += float(res.duration)
        finally:
            for n in touching:
                self.planner.set_object_enabled(n, True)
        return {
            "escape_distance_mm": 1e3 * dists[-1],
            "allowed_contacts": touching,
            "escape_segments": len(segments),
            "escape_plan_ms": 1e3 * t_plan,
            "escape_duration_s": dur,
            "escape_tracking_error_rad": err,
        }

    def _straight_enough(self, qa: np.ndarray, qb: np.ndarray, hand0: np.ndarray, direction: np.ndarray) -> bool:
        """Whether the joint-space line from ``qa`` to ``qb`` keeps the hand within 2 mm of the line through
        ``hand0`` along ``direction`` and its orientation within 0.02 rad (FK at 4 interior points)."""
        for t in (0.2, 0.4, 0.6, 0.8):
            h = self._hand_fk((1 - t) * qa + t * qb)
            off = h[:3, 3] - hand0[:3, 3]
            if np.linalg.norm(off - np.dot(off, direction) * direction) > 0.002:
                return False
            c = (np.trace(hand0[:3, :3].T @ h[:3, :3]) - 1) / 2
            if math.acos(min(1.0, max(-1.0, c))) > 0.02:
                return False
        return True

    def _ik_near(self, pose_base: np.ndarray, seed: np.ndarray, stage: str, collision_free: bool = False):
        res = self.planner.ik(pose_base, seed, num_seeds=32, collision_free=collision_free)
        if not res.success:
            raise StageFailure(
                stage, f"no IK solution for the hand pose {np.round(pose_base[:3, 3], 3).tolist()} (base frame)"
            )
        return res.q

    def _check_held(self, stage: str) -> None:
        obj = self.episode.world.get_object_pose(self.episode.spec.target)[:3, 3]
        tcp = (self._hand_world() @ np.append(self.gripper.tcp, 1.0))[:3]
        d = float(np.linalg.norm(obj - tcp))
        if d > 0.08:
            raise StageFailure(stage, f"the object slipped out of the hand ({1e3 * d:.0f} mm from the fingers)")

    def _stage(self, name: str, fn) -> None:
        t0 = time.perf_counter()
        try:
            detail = fn() or {}
        except StageFailure as f:
            self.episode.result.stages.append(StageResult(name, False, time.perf_counter() - t0, reason=f.reason))
            raise
        except Exception as e:  # a library error inside a stage is that stage's failure
            reason = f"{type(e).__name__}: {e}"
            self.episode.result.stages.append(StageResult(name, False, time.perf_counter() - t0, reason=reason))
            raise StageFailure(name, reason) from e
        self.episode.result.stages.append(StageResult(name, True, time.perf_counter() - t0, detail))

    # -- one episode ------------------------------------------------------------------------------------------

    def run(self, spec: SceneSpec, record_frames: bool = False, frame_every: int = 20, recorder=None) -> EpisodeResult:
        """Runs one episode on ``spec``. With ``record_frames``, a second camera records RGB frames for an
        animation (``result.episode.recorder.frames``). ``recorder``: a callable ``(world, robot, camera, arm_indices)``
        returning a :class:`~ferrobot.pipeline.recording.ControlRecorder` (or anything with its interface)
        made once the scene is built: the motions then run at its control rate and it records every control
        step (dataset generation). Never raises for a failed stage: see the result."""
        # A new record per episode: nothing of the previous episode can leak into this one's report.
        result = EpisodeResult(seed=spec.seed, target=spec.target)
        self.episode = Episode(
            spec=spec, result=result, model=self.model, spheres=self.planner.sphere_model, gripper=self.gripper
        )
        result.episode = self.episode
        t0 = time.perf_counter()
        try:

            def scene():
                name = "panda" if self.hand_link == "panda_hand" else "robot"
                self.episode.world, self.episode.robot, self.episode.camera = build_world(
                    spec, self.model, q=self.home, name=name
                )
                self.episode.robot.use_gripper(self.gripper)
                self.episode.base = self.episode.robot.world_transform
                # Grasp workspace: the table top and 30 cm above it.
                (tx, ty), (sx, sy, _) = TABLE_XY, TABLE_SIZE
                self.episode.workspace = [
                    tx - sx / 2,
                    tx + sx / 2,
                    ty - sy / 2,
                    ty + sy / 2,
                    TABLE_TOP - 0.02,
                    TABLE_TOP + 0.3,
                ]
                self.episode.arm_idx = [self.episode.robot.dof_names.index(n) for n in self.arm]
                self.planner.update_world(_core.CollisionWorld())
                for name in list(self.planner.attached):
                    self.planner.detach(name)
                cam = None
                if record_frames:
                    eye, at = (1.05, -0.85, 1.05), (0.42, 0.0, TABLE_TOP + 0.08)  # a side view, kept clear of
                    base = self.episode.base[:3, 3]  # the arm's reach (robots longer than the bundled ones)
                    eye = clear_of_reach(eye, at, base, self.model, self.gripper) or eye
                    view = _core.look_at(eye, at)
                    cam = _core.Camera(self.episode.world, 400, 300, 330.0, 330.0, 199.5, 149.5, view)
                if recorder is not None:
                    self.episode.recorder = recorder(
                        self.episode.world, self.episode.robot, self.episode.camera, self.episode.arm_idx
                    )
                else:
                    self.episode.recorder = Recorder(self.episode.world, self.episode.robot, cam, frame_every)
                self.episode.recorder.snapshot("scene")
                return {"objects": len(spec.objects)}

            self._stage("scene", scene)
            self._stage("perceive", self.perceive)
            self._stage("detect", self.detect)
            self._stage("select", self.select)
            self.pick()
            self.place()
            self._stage("verify", self.verify)
            self.episode.result.success = True
        except StageFailure as f:
            self.episode.result.failed_stage = f.stage
            self.episode.result.reason = f.reason
        result.wall_time_s = time.perf_counter() - t0
        result.sim_time_s = float(self.episode.world.time) if self.episode.world is not None else 0.0
        return result


def home_configuration() -> np.ndarray:
    """The home configuration used by the scenes (Franka's ``ready`` pose, fingers open)."""
    return HOME.copy()
