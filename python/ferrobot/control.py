"""Control at a fixed rate and the observation/action contract shared by recorded datasets and environments.

A robot-learning dataset and the environment that replays it must agree on three things, fixed here once:

* **What an action does** (:class:`ControlStepper`). An action is a float64 vector
  ``[arm joint position targets..., gripper]`` applied for one control period (``1 / control_hz`` s of
  simulated time, 0.1 s at the default 10 Hz). Within the period the arm's drive targets move linearly from
  the previous targets to the new ones, with the constant slope as velocity feed-forward, one target per
  physics step (``Robot.execute_trajectory`` on the two samples: 24 physics steps at 240 Hz). The gripper
  command is in [0, 1]: > 0.5 closes with ``grip_force`` N per finger, otherwise opens; the gripper is only
  commanded when that state changes. The same actions from the same state give bit-identical states.
* **What an observation holds** (:func:`observe`): the keys below, batch-free arrays.
* **What the feature names are** (:func:`features`): the dataset schema, name for name.

Observation keys (``N`` = ``robot.num_dof``, ``A`` = number of arm joints):

=================================== ============ ===========================================================
key                                 dtype, shape meaning
=================================== ============ ===========================================================
``observation.state``               f32 (N,)     joint positions (rad, m), ``robot.dof_names`` order
``observation.velocity``            f32 (N,)     joint velocities (rad/s, m/s)
``observation.ee_pose``             f32 (7,)     the gripper's TCP pose [x, y, z, qw, qx, qy, qz], base frame
                                                 (the end-effector link's when no gripper is given)
``observation.gripper_opening``     f32 (1,)     distance between the fingers (m): the gripper's
                                                 joint-to-opening map at its driver joint
``observation.images.<camera>``     u8 (H, W, 3) RGB
``observation.depth.<camera>``      f32 (H, W)   depth along the optical axis (m); **0 where nothing was hit**
                                                 (the renderer's ``inf``), the common depth-sensor convention
``observation.segmentation.<cam>``  i32 (H, W)   ids of ``World.segmentation_labels`` (only if requested)
``action``                          f32 (A + 1,) arm joint position targets + gripper command in [0, 1]
``action.ee_pose``                  f32 (7,)     TCP pose (base frame) at the arm targets (FK)
=================================== ============ ===========================================================

Default cameras: ``scene`` (fixed, 640x480, the scene's perception camera) and ``wrist`` (on the gripper's
hand link, 320x240, looking along the approach at the fingertips, :func:`wrist_mount`), sizes configurable.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from . import _core
from .errors import InvalidArgumentError, NonFiniteError, ShapeError, UnknownNameError

__all__ = [
    "ControlStepper",
    "CameraSpec",
    "DEFAULT_CAMERAS",
    "observe",
    "features",
    "make_cameras",
    "GRIPPER_CLOSE_THRESHOLD",
]

#: A gripper command above this closes the gripper; at or below, it opens.
GRIPPER_CLOSE_THRESHOLD = 0.5


class ControlStepper:
    """Advances a simulated world at a control rate, one action per control period.

    ``world``: a :class:`ferrobot.World`; ``robot``: a :class:`ferrobot.Robot` in it. ``control_hz`` in
    (0, physics rate], and the physics rate (``1 / world.dt``) must be an integer multiple of it.
    ``arm_joint_names``: the robot DOFs driven by the first ``A`` action entries, by name (default: the model's
    planning group; ``arm_joint_indices``, DOF indices, is the deprecated spelling). ``arm`` holds their DOF
    indices (positions in ``robot.dof_names``), ``arm_names`` their names. ``gripper``: True (the robot's
    gripper, last action entry) or False (no gripper entry). ``grip_force``: squeezing force per finger
    (N, > 0) when closed.

    The previous targets start as the robot's current drive targets, the gripper state as ``gripper_closed``
    (open by default: the state a freshly built scene has).
    """

    def __init__(
        self,
        world,
        robot,
        *,
        control_hz: float = 10.0,
        arm_joint_names=None,
        arm_joint_indices=None,
        gripper: bool = True,
        grip_force: float = 40.0,
        gripper_closed: bool = False,
    ):
        if not (isinstance(control_hz, (int, float)) and math.isfinite(control_hz) and control_hz > 0):
            raise InvalidArgumentError(f"control_hz: expected a finite number > 0, got {control_hz!r}")
        physics_hz = 1.0 / world.dt
        ratio = physics_hz / control_hz
        if ratio < 1 - 1e-9 or abs(ratio - round(ratio)) > 1e-6:
            raise InvalidArgumentError(
                f"control_hz: must divide the physics rate {physics_hz:g} Hz (world.dt = {world.dt:g} s) "
                f"a whole number of times, got {control_hz:g} Hz"
            )
        if not (math.isfinite(grip_force) and grip_force > 0):
            raise InvalidArgumentError(f"grip_force: expected a finite number > 0 (N), got {grip_force!r}")
        self.world, self.robot = world, robot
        self.control_hz = float(control_hz)
        self.period = 1.0 / self.control_hz
        self.substeps = int(round(ratio))
        names = list(robot.dof_names)
        if arm_joint_indices is not None:
            if arm_joint_names is not None:
                raise InvalidArgumentError("give arm_joint_names or arm_joint_indices, not both")
            warnings.warn(
                "ControlStepper(arm_joint_indices=...) is deprecated: use arm_joint_names=",
                DeprecationWarning,
                stacklevel=2,
            )
            arm = [int(i) for i in arm_joint_indices]
            if any(i < 0 or i >= robot.num_dof for i in arm):
                raise InvalidArgumentError(
                    f"arm_joint_indices: expected distinct indices in [0, {robot.num_dof}), got {arm_joint_indices!r}"
                )
        elif arm_joint_names is not None:
            if isinstance(arm_joint_names, str):
                raise InvalidArgumentError(f"arm_joint_names: expected a list of joint names, got {arm_joint_names!r}")
            unknown = [n for n in arm_joint_names if n not in names]
            if unknown:
                raise UnknownNameError(f"arm_joint_names: unknown joint {unknown[0]!r}; the robot's DOFs: {names}")
            arm = [names.index(n) for n in arm_joint_names]
        else:
            arm = list(robot.model.group_dof_indices)
        if not arm or len(set(arm)) != len(arm):
            raise InvalidArgumentError(f"arm joints: expected distinct joints, got {[names[i] for i in arm]!r}")
        self.arm = arm
        self.arm_names = [names[i] for i in arm]
        self.gripper = bool(gripper)
        self.grip_force = float(grip_force)
        self.gripper_closed = bool(gripper_closed)
        self.targets = np.asarray(robot.joint_position_targets, dtype=np.float64)[arm].copy()
        self.steps = 0

    @property
    def action_size(self) -> int:
        return len(self.arm) + (1 if self.gripper else 0)

    def check_action(self, action) -> np.ndarray:
        """``action`` as a float64 vector, or ``ShapeError`` / ``NonFiniteError`` / ``InvalidArgumentError``."""
        a = np.asarray(action, dtype=np.float64)
        if a.shape != (self.action_size,):
            raise ShapeError(f"action: expected shape ({self.action_size},), got {a.shape}")
        if not np.all(np.isfinite(a)):
            raise NonFiniteError(f"action: contains NaN or infinite values: {a.tolist()}")
        if self.gripper and not 0.0 <= a[-1] <= 1.0:
            raise InvalidArgumentError(f"action: gripper command (last entry) must be in [0, 1], got {a[-1]}")
        return a

    def step(self, action) -> None:
        """Applies ``action`` for one control period (``substeps`` physics steps)."""
        a = self.check_action(action)
        new = a[: len(self.arm)].copy()
        if self.gripper:
            close = bool(a[-1] > GRIPPER_CLOSE_THRESHOLD)
            if close != self.gripper_closed:
                if close:
                    self.robot.close_gripper(force=self.grip_force)
                else:
                    self.robot.open_gripper()
                self.gripper_closed = close
        samples = np.stack([self.targets, new])
        self.robot.execute_trajectory(samples, self.period, joint_names=self.arm_names)
        self.targets = new
        self.steps += 1

    def hold_action(self) -> np.ndarray:
        """The action that keeps the current targets and gripper state."""
        out = self.targets.copy()
        if self.gripper:
            out = np.append(out, 1.0 if self.gripper_closed else 0.0)
        return out


@dataclass
class CameraSpec:
    """A recorded camera: ``name``, image ``width`` x ``height`` (pixels, 8 to 4096), horizontal field of view
    ``fov_deg`` (1 to 179 degrees), and where it is: ``link`` (None = fixed in the world at ``pose``, a
    4x4 OpenCV camera pose; or a robot link with ``pose`` relative to it)."""

    name: str
    width: int
    height: int
    fov_deg: float = 60.0
    link: str | None = None
    pose: np.ndarray | None = None

    def validate(self) -> None:
        if not self.name or not self.name.replace("_", "").isalnum():
            raise InvalidArgumentError(f"cameras: name must be alphanumeric/underscore, got {self.name!r}")
        for what, v in (("width", self.width), ("height", self.height)):
            if not (isinstance(v, (int, np.integer)) and 8 <= v <= 4096):
                raise InvalidArgumentError(f"cameras: {self.name}.{what} must be an integer in [8, 4096], got {v!r}")
        if not 1.0 <= self.fov_deg <= 179.0:
            raise InvalidArgumentError(f"cameras: {self.name}.fov_deg must be in [1, 179], got {self.fov_deg}")

    @property
    def focal(self) -> float:
        return 0.5 * self.width / math.tan(math.radians(self.fov_deg) / 2)


#: The wrist camera's pose in the Panda hand frame: 6 cm off the hand's side (outside its housing) and 3 cm
#: back from the flange, looking at the point between the fingertips (10.3 cm along the approach axis z).
WRIST_EYE = (0.06, 0.0, 0.03)
WRIST_TARGET = (0.0, 0.0, 0.14)
#: The wrist mount relative to any gripper's TCP (:func:`wrist_mount`): the eye this far to the side of the
#: hand (along closing x approach, away from the fingers' sweep) and back from the TCP along the approach;
#: the look-at point this far beyond the TCP. For the Panda hand they give WRIST_EYE / WRIST_TARGET.
WRIST_SIDE = 0.06
WRIST_BACK = 0.0734
WRIST_AHEAD = 0.0366


def wrist_mount(gripper=None) -> tuple[tuple, tuple, tuple]:
    """(eye, target, up) of the wrist camera in ``gripper``'s hand-link frame (a :class:`ferrobot.Gripper`;
    None: the Panda hand, :data:`WRIST_EYE` / :data:`WRIST_TARGET`): the eye :data:`WRIST_SIDE` to the side
    of the hand along ``closing x approach`` and :data:`WRIST_BACK` behind the TCP, looking at the point
    :data:`WRIST_AHEAD` beyond the TCP along the approach (between the fingertips), ``up`` the side axis."""
    if gripper is None or gripper.hand_link == "panda_hand" and np.allclose(gripper.tcp, (0, 0, 0.1034), atol=1e-9):
        return WRIST_EYE, WRIST_TARGET, (1.0, 0.0, 0.0)
    a = np.asarray(gripper.approach, dtype=float)
    a = a / np.linalg.norm(a)
    side = np.cross(np.asarray(gripper.closing, dtype=float), a)
    side = side / np.linalg.norm(side)
    tcp = np.asarray(gripper.tcp, dtype=float)
    eye = tcp - WRIST_BACK * a + WRIST_SIDE * side
    target = tcp + WRIST_AHEAD * a
    return tuple(eye.tolist()), tuple(target.tolist()), tuple(side.tolist())


def wrist_pose(gripper=None) -> np.ndarray:
    """The wrist camera's 4x4 pose (OpenCV axes) in ``gripper``'s hand-link frame (:func:`wrist_mount`)."""
    eye, target, up = wrist_mount(gripper)
    return _core.look_at(eye, target, up)


#: Default cameras: name -> (width, height). ``scene`` is the scene's fixed perception camera.
DEFAULT_CAMERAS = {"scene": (640, 480), "wrist": (320, 240)}


def make_cameras(world, robot, scene_camera_pose, specs: list[CameraSpec], scene_fov_deg=None, gripper=None) -> dict:
    """Creates the cameras of ``specs`` in ``world``: name -> :class:`ferrobot.Camera`. A spec named
    ``scene`` without a pose uses ``scene_camera_pose`` (the perception camera's pose) and, when given,
    ``scene_fov_deg`` (its horizontal field of view); ``wrist`` without a link is on ``gripper``'s hand link
    (a :class:`ferrobot.Gripper`; None: ``panda_hand``) at :func:`wrist_pose`."""
    cams = {}
    for s in specs:
        if s.name == "scene" and scene_fov_deg is not None:
            s.fov_deg = float(scene_fov_deg)
        s.validate()
        if s.name in cams:
            raise InvalidArgumentError(f"cameras: '{s.name}' given twice")
        f = s.focal
        cx, cy = (s.width - 1) / 2, (s.height - 1) / 2
        if s.link is None and s.name == "wrist":
            s.link, s.pose = ("panda_hand" if gripper is None else gripper.hand_link), wrist_pose(gripper)
        if s.link is None:
            pose = scene_camera_pose if s.pose is None else s.pose
            cams[s.name] = _core.Camera(world, s.width, s.height, f, f, cx, cy, pose)
        else:
            pose = np.eye(4) if s.pose is None else s.pose
            cams[s.name] = _core.Camera(world, s.width, s.height, f, f, cx, cy, pose, robot=robot, link=s.link)
    return cams


def gripper_opening(model, q: np.ndarray, gripper=None) -> float:
    """Distance between the fingers (m). With ``gripper`` (a :class:`ferrobot.Gripper`): its joint-to-opening
    map at the driver joint's position (linear for prismatic fingers, the linkage's map for a 2F-85). Without:
    the finger DOFs (those outside the planning group) plus the mimic joints driven by them (for the Panda,
    ``2 * panda_finger_joint1``)."""
    if gripper is not None:
        return float(gripper.opening(float(q[list(model.dof_names).index(gripper.driver)])))
    group = set(model.group_dof_indices)
    names = list(model.dof_names)
    fingers = {names[i]: float(q[i]) for i in range(len(names)) if i not in group}
    total = sum(fingers.values())
    for _, (driver, mult, off) in model.mimic_joints:
        if driver in fingers:
            total += mult * fingers[driver] + off
    return total


def tcp_pose(model, q: np.ndarray, gripper=None, ee_link: str | None = None) -> np.ndarray:
    """[x, y, z, qw, qx, qy, qz] (base frame, w >= 0) of ``gripper``'s TCP at ``q``: its hand link's pose moved
    by the TCP offset (hand frame). Without a gripper: the pose of ``ee_link`` (default the model's)."""
    if gripper is None:
        return model.fk_batch(np.asarray(q, dtype=np.float64)[None, :], ee_link)[0]
    pose = model.fk_batch(np.asarray(q, dtype=np.float64)[None, :], gripper.hand_link)[0].copy()
    w, x, y, z = pose[3:]
    rot = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )
    pose[:3] += rot @ np.asarray(gripper.tcp, dtype=np.float64)
    return pose


def observe(
    world, robot, cameras: dict, *, segmentation: bool = False, ee_link: str | None = None, gripper=None
) -> dict:
    """The observation of the current state: the keys in this module's docstring, batch-free arrays.
    ``cameras``: name -> :class:`ferrobot.Camera`; depth 0 where the renderer saw nothing (inf). ``gripper``
    (a :class:`ferrobot.Gripper`): ``observation.ee_pose`` is its TCP's pose and ``observation.gripper_opening``
    its joint-to-opening map at the driver (without: the ``ee_link`` pose and the finger joints' sum)."""
    del world  # the robot and cameras carry their world; kept in the signature for the contract
    model = robot.model
    q = robot.joint_positions
    obs = {
        "observation.state": q.astype(np.float32),
        "observation.velocity": robot.joint_velocities.astype(np.float32),
        "observation.ee_pose": tcp_pose(model, q, gripper, ee_link).astype(np.float32),
        "observation.gripper_opening": np.array([gripper_opening(model, q, gripper)], dtype=np.float32),
    }
    for name, cam in cameras.items():
        frame = cam.render(rgb=True)
        d = frame.depth
        obs[f"observation.images.{name}"] = frame.rgb
        obs[f"observation.depth.{name}"] = np.where(np.isfinite(d), d, 0.0).astype(np.float32)
        if segmentation:
            obs[f"observation.segmentation.{name}"] = frame.segmentation.astype(np.int32)
    return obs


def action_features(robot, stepper: ControlStepper, action, ee_link: str | None = None, gripper=None) -> dict:
    """``action`` (float32) and ``action.ee_pose`` (FK of the arm targets, base frame: ``gripper``'s TCP, or
    ``ee_link`` without one) for a step's action."""
    a = np.asarray(action, dtype=np.float64)
    q = np.asarray(robot.joint_position_targets, dtype=np.float64).copy()
    q[stepper.arm] = a[: len(stepper.arm)]
    return {
        "action": a.astype(np.float32),
        "action.ee_pose": tcp_pose(robot.model, q, gripper, ee_link).astype(np.float32),
    }


def features(robot, stepper: ControlStepper | None, cameras: dict, *, segmentation: bool = False) -> dict:
    """The dataset features: name -> {"dtype", "shape", "names"} (LeRobot's ``info.json`` style; images as
    dtype "video", depth "depth"). ``robot``: a Robot or RobotModel; ``stepper``: the ControlStepper (None:
    the model's planning group as the arm, with a gripper entry); ``cameras``: name -> Camera or
    (width, height). Joint names are the model's ``dof_names`` (arm joints and the gripper's driver; mimic
    followers are not degrees of freedom, their positions follow from the driver's); the ``action``'s last
    entry is ``"gripper"`` (the command in [0, 1])."""
    dof = list(robot.dof_names)
    model = robot.model if hasattr(robot, "model") else robot
    arm_idx = stepper.arm if stepper is not None else list(model.group_dof_indices)
    gripper = stepper.gripper if stepper is not None else True
    arm = [dof[i] for i in arm_idx]
    pose_names = ["x", "y", "z", "qw", "qx", "qy", "qz"]
    out = {
        "observation.state": {"dtype": "float32", "shape": [len(dof)], "names": dof},
        "observation.velocity": {"dtype": "float32", "shape": [len(dof)], "names": dof},
        "observation.ee_pose": {"dtype": "float32", "shape": [7], "names": pose_names},
        "observation.gripper_opening": {"dtype": "float32", "shape": [1], "names": ["opening"]},
    }
    for name, cam in cameras.items():
        w, h = (cam.width, cam.height) if hasattr(cam, "width") else (int(cam[0]), int(cam[1]))
        out[f"observation.images.{name}"] = {
            "dtype": "video",
            "shape": [h, w, 3],
            "names": ["height", "width", "channels"],
        }
        out[f"observation.depth.{name}"] = {"dtype": "depth", "shape": [h, w], "names": ["height", "width"]}
        if segmentation:
            out[f"observation.segmentation.{name}"] = {
                "dtype": "segmentation",
                "shape": [h, w],
                "names": ["height", "width"],
            }
    out["action"] = {
        "dtype": "float32",
        "shape": [len(arm) + (1 if gripper else 0)],
        "names": arm + (["gripper"] if gripper else []),
    }
    out["action.ee_pose"] = {"dtype": "float32", "shape": [7], "names": pose_names}
    return out
