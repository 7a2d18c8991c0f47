"""The environments: table-top tasks of :mod:`ferrobot.pipeline.scene` behind Gymnasium's interface.

Stepping and observations come from :mod:`ferrobot.control` (the module the dataset recorder uses), so a
policy trained on recorded data sees the same features, name for name, and a recorded episode's actions
replay exactly.

``make`` keyword arguments (all environments):

- ``obs_mode``: ``"state"`` (joint positions and velocities, end-effector pose, gripper opening, and the
  task's ``observation.environment_state``), ``"rgb"`` (+ ``observation.images.<camera>``) or ``"rgbd"``
  (+ ``observation.depth.<camera>``). ``segmentation=True`` adds ``observation.segmentation.<camera>``.
- ``control_mode``: ``"joint_pos"`` (arm joint position targets + gripper), ``"ee_delta"`` (end-effector
  translation (m) and rotation vector (rad) in the robot base frame, applied to the measured TCP pose,
  + gripper) or ``"ee_abs"`` (end-effector pose [x, y, z, qw, qx, qy, qz] in the base frame + gripper). The
  end effector is the gripper's TCP, as in ``observation.ee_pose``.
  The gripper command is in [0, 1] (0 open, 1 closed). Actions outside the declared bounds, of the wrong
  shape or not finite raise (``ShapeError``, ``NonFiniteError``, ``InvalidArgumentError``); nothing is
  clipped. In ``ee_abs`` the quaternion is normalised (any norm above 1e-6; each component in [-1, 1]).
  In the end-effector modes the joint targets come from IK seeded with the current joint positions; when
  IK finds no solution the previous joint targets are held and ``info["ik_failed"]`` is True.
- ``reward_type``: ``"sparse"`` (1 on success, else 0) or ``"dense"`` (shaped, in [0, 1], 1 on success).
- ``control_hz`` (default 10, in (0, 240]): control rate over the 240 Hz physics.
- ``robot``: ``"panda"``, ``"ur5e"`` (bundled), a URDF path (``srdf`` beside it) or a
  :class:`ferrobot.RobotModel`: any arm with a parallel-jaw gripper. ``gripper``: a :class:`ferrobot.Gripper`,
  ``"panda_hand"`` / ``"robotiq_2f85"``, or None (the model's own, ``ferrobot.Gripper.from_model``). The arm
  starts at :func:`ferrobot.pipeline.scene.home_for` (the Panda's ``HOME``; else the SRDF's first named
  state), gripper open; the scene camera is placed for the robot's reach
  (:func:`~ferrobot.pipeline.scene.place_camera`).
- ``num_objects`` (1-6, default: 3-5 drawn per scene), ``scene_fn`` (a callable ``seed -> SceneSpec`` that
  replaces :func:`ferrobot.pipeline.random_scene`), ``randomize`` (False: every reset uses
  ``scene_seed``), ``init_noise`` (rad, >= 0: uniform noise on the arm's start configuration).
- ``cameras``: the recorded datasets' cameras by name (``"scene"``: the scene's perception camera, 640 x 480;
  ``"wrist"``: on the gripper's hand link, 320 x 240; see :mod:`ferrobot.control`), ``"side"`` (a fixed side view,
  320 x 240), ``"name:WxH"`` strings, or :class:`ferrobot.control.CameraSpec` objects; default
  ``["scene", "wrist"]`` (the datasets' default) in the image modes, none in ``"state"``. ``image_size``
  (width, height) replaces the size of every named camera (default: their own sizes).
- ``terminate_on_success`` (default True), ``render_mode`` (``"rgb_array"``: a 320 x 240 side view).

``reset(seed=s)`` builds the scene ``random_scene(s)`` (the same scene as ``ferrobot demo --seed s``); without a
seed, the next scene seed is drawn from the environment's generator. ``reset(options={"scene": spec})`` uses a
given :class:`SceneSpec` (or its dict), as is; ``options["randomization"]`` (a recorded episode's domain
randomisation, :func:`ferrobot.dataset.generate.randomize_scene`) applies its rendering draws too: the lighting
(``World.set_lighting``) and the wrist camera's mount pose. ``info`` has ``is_success``, ``failure_cause`` (what
is wrong if the episode ended now, "" on success), ``scene_seed`` and ``ik_failed``.
"""

from __future__ import annotations

import math
import os
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from .. import _core, robots, transforms
from ..control import DEFAULT_CAMERAS, CameraSpec, ControlStepper, make_cameras, observe, tcp_pose
from ..dataset.generate import apply_lighting, scene_fov, scene_from_dict
from ..errors import FerrobotError, InvalidArgumentError, NonFiniteError, ShapeError
from ..pipeline.pick_place import placement_failure
from ..pipeline.scene import (
    BASE_POSE,
    TABLE_TOP,
    SceneSpec,
    build_world,
    clear_of_reach,
    home_for,
    place_camera,
    random_scene,
)

__all__ = ["OBS_MODES", "ACTION_MODES", "FerrobotEnv", "PickPlaceEnv", "LiftEnv", "ReachEnv", "EXTRA_CAMERAS"]

OBS_MODES = ("state", "rgb", "rgbd")
ACTION_MODES = ("joint_pos", "ee_delta", "ee_abs")
REWARD_TYPES = ("sparse", "dense")

#: Largest end-effector step per control step in ``ee_delta`` mode: translation (m), rotation (rad).
EE_DELTA_MAX_TRANSLATION = 0.05
EE_DELTA_MAX_ROTATION = 0.25
#: Position bounds (m) of ``ee_abs`` targets in the base frame: a box around the arm's reach.
EE_ABS_POSITION_BOUNDS = ((-1.2, -1.2, -0.5), (1.2, 1.2, 1.5))
#: Joint position bounds of ``observation.state`` are the joint limits widened by this (rad or m): drives
#: settle a hair past a limit and contacts push joints slightly beyond it.
STATE_MARGIN = 0.1

#: Camera names beyond ferrobot.control's ("scene", "wrist"): name -> (eye, target) in the world, size.
EXTRA_CAMERAS: dict[str, tuple[tuple, tuple, tuple[int, int]]] = {
    "side": ((1.05, -0.85, 1.05), (0.42, 0.0, TABLE_TOP + 0.08), (320, 240)),
}
#: The render camera of ``render_mode="rgb_array"`` (a fixed side view).
RENDER_VIEW = EXTRA_CAMERAS["side"]


def _rotvec_to_matrix(v: np.ndarray) -> np.ndarray:
    """Rodrigues: the rotation by |v| about v / |v|."""
    theta = float(np.linalg.norm(v))
    if theta < 1e-12:
        return np.eye(3)
    k = v / theta
    kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + math.sin(theta) * kx + (1.0 - math.cos(theta)) * (kx @ kx)


# rayon's global thread pool does not survive fork(): a child forked after the parent ran ferrobot's parallel
# code (planner construction, rendering, batch stepping) hangs at its first parallel call. Environments made
# in such a child raise instead (Gymnasium's AsyncVectorEnv forks by default on Linux).
_PARALLEL_USED = [False]
_FORKED_AFTER_PARALLEL = [False]


def _after_fork_in_child() -> None:
    _FORKED_AFTER_PARALLEL[0] = _PARALLEL_USED[0]


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_after_fork_in_child)

_BUNDLED: dict[str, Any] = {}
_PLANNERS: dict[int, tuple[Any, Any]] = {}


def _bundled(name: str):
    """One model per bundled robot per process: planners built for it share their sphere model."""
    if name not in _BUNDLED:
        _BUNDLED[name] = robots.bundled(name)
    return _BUNDLED[name]


def _planner(model):
    """A planner for ``model`` (IK only; no world), built once per model object (building the sphere model
    takes about a second)."""
    hit = _PLANNERS.get(id(model))
    if hit is None or hit[0] is not model:
        hit = (model, _core.Planner(model))
        _PLANNERS[id(model)] = hit
    return hit[1]


def _box(low, high, dtype=np.float32) -> spaces.Box:
    return spaces.Box(low=np.asarray(low, dtype=dtype), high=np.asarray(high, dtype=dtype), dtype=dtype)


class FerrobotEnv(gym.Env):
    """Base class of the table-top tasks: scene, robot, cameras, control and observation modes.

    Subclasses define the task: ``_task_reset``, ``_task_state`` (``observation.environment_state``),
    ``_evaluate`` (success, failure cause, dense reward)."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}
    #: Length of ``observation.environment_state``.
    task_state_dim = 0

    def __init__(
        self,
        *,
        obs_mode: str = "state",
        control_mode: str = "joint_pos",
        reward_type: str = "sparse",
        control_hz: float = 10.0,
        robot: Any = "panda",
        gripper: Any = None,
        srdf: str | None = None,
        num_objects: int | None = None,
        scene_fn=None,
        randomize: bool = True,
        scene_seed: int = 0,
        init_noise: float = 0.0,
        cameras: Any = None,
        image_size: tuple[int, int] | None = None,
        segmentation: bool = False,
        terminate_on_success: bool = True,
        render_mode: str | None = None,
    ):
        super().__init__()
        if _FORKED_AFTER_PARALLEL[0]:
            raise FerrobotError(
                "ferrobot environments cannot run in a process forked after its parent built one: the simulator's "
                "thread pool does not survive fork() and the child would hang. Start worker processes with "
                "'spawn' (gymnasium.vector.AsyncVectorEnv(..., context='spawn')) or use "
                "ferrobot.envs.vector.FerrobotVectorEnv (threads)."
            )
        _PARALLEL_USED[0] = True
        if obs_mode not in OBS_MODES:
            raise InvalidArgumentError(f"obs_mode: expected one of {OBS_MODES}, got {obs_mode!r}")
        if control_mode not in ACTION_MODES:
            raise InvalidArgumentError(f"control_mode: expected one of {ACTION_MODES}, got {control_mode!r}")
        if reward_type not in REWARD_TYPES:
            raise InvalidArgumentError(f"reward_type: expected one of {REWARD_TYPES}, got {reward_type!r}")
        if not (math.isfinite(control_hz) and 0.0 < control_hz <= 240.0):
            raise InvalidArgumentError(f"control_hz: expected a value in (0, 240], got {control_hz}")
        if num_objects is not None and not 1 <= int(num_objects) <= 6:
            raise InvalidArgumentError(f"num_objects: expected 1 to 6 or None, got {num_objects}")
        if not (math.isfinite(init_noise) and init_noise >= 0.0):
            raise InvalidArgumentError(f"init_noise: expected a finite value >= 0 (rad), got {init_noise}")
        if render_mode not in (None, "rgb_array"):
            raise InvalidArgumentError(f"render_mode: expected None or 'rgb_array', got {render_mode!r}")
        if image_size is not None:
            w, h = (int(v) for v in image_size)
            if not (8 <= w <= 4096 and 8 <= h <= 4096):
                raise InvalidArgumentError(f"image_size: expected (width, height) in 8..4096, got {image_size}")
            image_size = (w, h)
        self.obs_mode, self.control_mode, self.reward_type = obs_mode, control_mode, reward_type
        self.control_hz = float(control_hz)
        self.num_objects = None if num_objects is None else int(num_objects)
        self.scene_fn = scene_fn
        self.randomize, self.scene_seed = bool(randomize), int(scene_seed)
        self.init_noise = float(init_noise)
        self.segmentation = bool(segmentation)
        self.terminate_on_success = bool(terminate_on_success)
        self.render_mode = render_mode

        from ..pipeline.pick_place import resolve_robot

        what = "'panda', 'ur5e', a URDF path or a ferrobot.RobotModel"
        if isinstance(robot, str) and robot in ("panda", "ur5e"):
            robot = _bundled(robot)
        elif isinstance(robot, str):
            if not (robot.endswith(".urdf") and os.path.isfile(robot)):
                raise InvalidArgumentError(f"robot: expected {what}, got {robot!r}")
        elif not isinstance(robot, _core.RobotModel):
            raise InvalidArgumentError(f"robot: expected {what}, got {type(robot).__name__}")
        self.model, self.gripper = resolve_robot(robot, srdf, gripper)
        self.planner = _planner(self.model)
        self.arm_names = list(self.planner.joint_names)
        dof = list(self.model.dof_names)
        self.arm_idx = [dof.index(n) for n in self.arm_names]
        self.ee_link = self.model.ee_link
        self.home = home_for(self.model, self.gripper)
        # The end-effector frame of observations and ee actions is the gripper's TCP; IK moves the model's
        # end-effector link, rigidly joined to the hand: tcp = ee @ ee_to_tcp.
        q0 = self.model.neutral_configuration()
        tcp0 = transforms.pose_to_matrix(tcp_pose(self.model, q0, self.gripper))
        self.ee_to_tcp = np.linalg.inv(self.model.fk(q0, link=self.ee_link)) @ tcp0
        self._robot_name = "panda" if self.gripper.hand_link == "panda_hand" else "robot"
        self.camera_specs = self._camera_specs(cameras, image_size)

        self.action_space = self._make_action_space()
        self.observation_space = self._make_observation_space()
        self.world = None
        self.spec_scene: SceneSpec | None = None

    # -- spaces -----------------------------------------------------------------------------------------------

    def _camera_specs(self, cameras, size) -> list[CameraSpec]:
        if cameras is None:
            cameras = [] if self.obs_mode == "state" else list(DEFAULT_CAMERAS)
        if isinstance(cameras, (str, CameraSpec)):
            cameras = [cameras]
        specs: list[CameraSpec] = []
        for c in cameras:
            if isinstance(c, CameraSpec):
                spec = CameraSpec(c.name, c.width, c.height, c.fov_deg, c.link, c.pose)
            elif isinstance(c, str):
                name, _, wh = c.partition(":")
                if name in DEFAULT_CAMERAS:
                    w, h = DEFAULT_CAMERAS[name]
                    spec = CameraSpec(name, w, h)
                elif name in EXTRA_CAMERAS:
                    eye, target, (w, h) = EXTRA_CAMERAS[name]
                    spec = CameraSpec(name, w, h, pose=_core.look_at(self._clear(eye, target), target))
                else:
                    raise InvalidArgumentError(
                        f"cameras: unknown camera {name!r}; known: {[*DEFAULT_CAMERAS, *EXTRA_CAMERAS]} "
                        "(or pass ferrobot.control.CameraSpec objects)"
                    )
                if wh:
                    try:
                        spec.width, spec.height = (int(v) for v in wh.lower().split("x"))
                    except ValueError:
                        raise InvalidArgumentError(f"cameras: expected 'name:WxH', got {c!r}") from None
                elif size is not None:
                    spec.width, spec.height = size
            else:
                raise InvalidArgumentError(f"cameras: expected names or CameraSpec objects, got {type(c).__name__}")
            spec.validate()
            if spec.link is not None and spec.link not in self.model.link_names:
                raise InvalidArgumentError(f"cameras: {spec.name}: the robot has no link {spec.link!r}")
            if any(o.name == spec.name for o in specs):
                raise InvalidArgumentError(f"cameras: '{spec.name}' given twice")
            specs.append(spec)
        if self.obs_mode != "state" and not specs:
            raise InvalidArgumentError(f"cameras: obs_mode {self.obs_mode!r} needs at least one camera")
        return specs

    def _clear(self, eye, target, base=None) -> tuple:
        """A fixed view's eye, moved back along its ray when the robot could reach it
        (:func:`~ferrobot.pipeline.scene.clear_of_reach`; unchanged for the bundled robots)."""
        base = BASE_POSE[:3] if base is None else base
        return clear_of_reach(eye, target, base, self.model, self.gripper) or tuple(eye)

    def _make_action_space(self) -> spaces.Box:
        g = ([0.0], [1.0])
        if self.control_mode == "joint_pos":
            lo = self.model.lower_limits[self.arm_idx]
            hi = self.model.upper_limits[self.arm_idx]
            if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
                lo, hi = np.where(np.isfinite(lo), lo, -np.pi), np.where(np.isfinite(hi), hi, np.pi)
            return _box([*lo, *g[0]], [*hi, *g[1]])
        if self.control_mode == "ee_delta":
            t, r = EE_DELTA_MAX_TRANSLATION, EE_DELTA_MAX_ROTATION
            return _box([-t] * 3 + [-r] * 3 + g[0], [t] * 3 + [r] * 3 + g[1])
        lo, hi = EE_ABS_POSITION_BOUNDS
        return _box([*lo, -1, -1, -1, -1, *g[0]], [*hi, 1, 1, 1, 1, *g[1]])

    def _make_observation_space(self) -> spaces.Dict:
        n = self.model.num_dof
        lo = np.where(np.isfinite(self.model.lower_limits), self.model.lower_limits - STATE_MARGIN, -np.inf)
        hi = np.where(np.isfinite(self.model.upper_limits), self.model.upper_limits + STATE_MARGIN, np.inf)
        inf = np.inf
        d: dict[str, spaces.Space] = {
            "observation.state": _box(lo, hi),
            "observation.velocity": _box([-inf] * n, [inf] * n),
            "observation.ee_pose": _box([-inf] * 3 + [-1.0] * 4, [inf] * 3 + [1.0] * 4),
            "observation.gripper_opening": _box([-inf], [inf]),
        }
        if self.task_state_dim:
            d["observation.environment_state"] = _box([-inf] * self.task_state_dim, [inf] * self.task_state_dim)
        for c in self.camera_specs:
            name, shape = c.name, (c.height, c.width)
            d[f"observation.images.{name}"] = spaces.Box(0, 255, (*shape, 3), np.uint8)
            if self.obs_mode == "rgbd":
                d[f"observation.depth.{name}"] = spaces.Box(0.0, inf, shape, np.float32)
            if self.segmentation:
                d[f"observation.segmentation.{name}"] = spaces.Box(
                    np.iinfo(np.int32).min, np.iinfo(np.int32).max, shape, np.int32
                )
        return spaces.Dict(d)

    # -- scene ------------------------------------------------------------------------------------------------

    def _scene(self, seed: int) -> SceneSpec:
        if self.scene_fn is not None:
            spec = self.scene_fn(seed)
            if not isinstance(spec, SceneSpec):
                raise InvalidArgumentError(f"scene_fn: expected it to return a SceneSpec, got {type(spec).__name__}")
            return spec
        return random_scene(seed, self.num_objects)

    @staticmethod
    def _scene_from(obj) -> SceneSpec:
        if isinstance(obj, SceneSpec):
            return obj
        if isinstance(obj, dict):
            return scene_from_dict(obj)
        raise InvalidArgumentError(f"options['scene']: expected a SceneSpec or its dict, got {type(obj).__name__}")

    def _build_cameras(self) -> dict[str, Any]:
        specs = [CameraSpec(c.name, c.width, c.height, c.fov_deg, c.link, c.pose) for c in self.camera_specs]
        wrist = self.randomization.get("wrist_camera")
        for c in specs:
            if c.name == "wrist" and c.link is None and wrist is not None:  # the recorded mount pose
                c.link = self.gripper.hand_link
                c.pose = _core.look_at(wrist["eye"], wrist["target"], tuple(wrist.get("up", (1.0, 0.0, 0.0))))
        return make_cameras(
            self.world,
            self.robot,
            self.scene_camera.world_transform,
            specs,
            scene_fov_deg=scene_fov(self.spec_scene),
            gripper=self.gripper,
        )

    # -- gymnasium API ----------------------------------------------------------------------------------------

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        options = options or {}
        rand = options.get("randomization") or {}
        if not isinstance(rand, dict):
            raise InvalidArgumentError(f"options['randomization']: expected a dict, got {type(rand).__name__}")
        if "scene" in options:
            spec = self._scene_from(options["scene"])
        else:
            if not self.randomize:
                scene_seed = self.scene_seed
            elif seed is not None:
                scene_seed = int(seed)
            else:
                scene_seed = int(self.np_random.integers(0, 2**31 - 1))
            spec = place_camera(self._scene(scene_seed), self.model, self.gripper)
        self.spec_scene = spec
        # As the pick-and-place pipeline builds it (PickPlace.run): recorded episodes replay bit for bit.
        self.world, self.robot, self.scene_camera = build_world(spec, self.model, q=self.home, name=self._robot_name)
        self.robot.use_gripper(self.gripper)
        apply_lighting(self.world, rand)
        self.randomization = rand
        self.base_pose = self.robot.world_transform
        self.to_base = transforms.world_to_base(np.eye(4), self.base_pose)
        if self.init_noise > 0.0:
            rng = np.random.default_rng([spec.seed, 7])
            q = self.home.copy()
            q[self.arm_idx] += rng.uniform(-self.init_noise, self.init_noise, len(self.arm_idx))
            lo, hi = self.model.lower_limits, self.model.upper_limits
            q = np.clip(q, lo, hi)  # documented: the noisy start stays inside the joint limits
            self.robot.set_joint_positions(q)
            self.robot.set_joint_position_targets(q)
            self.world.mark_initial_state()
        self.cameras = self._build_cameras()
        self._render_camera = None
        self.stepper = ControlStepper(
            self.world,
            self.robot,
            control_hz=self.control_hz,
            arm_joint_names=[self.robot.dof_names[i] for i in self.arm_idx],
        )
        self._arm_target = self.robot.joint_positions[self.arm_idx].copy()
        self.elapsed_steps = 0
        self._task_reset()
        obs = self._observe()
        info = self._info(False)
        return obs, info

    def step(self, action):
        ik_failed = self._step_begin(action)
        return self._step_end(ik_failed)

    def _step_begin(self, action) -> bool:
        """Checks ``action`` and hands it to the control stepper (which steps the physics); returns whether
        IK failed. Split from :meth:`_step_end` so that a vector env can defer the physics of several
        environments to one parallel call."""
        if self.world is None:
            raise InvalidArgumentError("step: call reset() before step()")
        a = self.check_action(action)
        target, ik_failed = self._joint_action(a)
        self.stepper.step(target)
        self._arm_target = target[:-1].copy()
        self.elapsed_steps += 1
        return ik_failed

    def _step_end(self, ik_failed: bool):
        obs = self._observe()
        success, cause, dense = self._evaluate()
        reward = 1.0 if success else (dense if self.reward_type == "dense" else 0.0)
        terminated = bool(success and self.terminate_on_success)
        info = self._info(ik_failed, success, cause)
        return obs, float(reward), terminated, False, info

    def render(self):
        if self.render_mode != "rgb_array" or self.world is None:
            return None
        if self._render_camera is None:
            eye, target, (w, h) = RENDER_VIEW
            pose = _core.look_at(self._clear(eye, target, self.base_pose[:3, 3]), target)
            self._render_camera = _core.Camera(self.world, w, h, 0.82 * w, 0.82 * w, (w - 1) / 2, (h - 1) / 2, pose)
        return self._render_camera.render(rgb=True).rgb

    # -- actions ----------------------------------------------------------------------------------------------

    def check_action(self, action) -> np.ndarray:
        """``action`` as float64 after checking shape, finiteness and bounds against the action space;
        raises ``ShapeError``, ``NonFiniteError`` or ``InvalidArgumentError`` naming the space."""
        space = self.action_space
        what = f"action ({self.control_mode!r} action space {space})"
        try:
            a = np.asarray(action, dtype=np.float64)
        except (TypeError, ValueError) as e:
            raise InvalidArgumentError(f"{what}: not a numeric array ({e})") from None
        if a.shape != space.shape:
            raise ShapeError(f"{what}: expected shape {space.shape}, got {a.shape}")
        if not np.all(np.isfinite(a)):
            raise NonFiniteError(f"{what}: non-finite values at indices {np.flatnonzero(~np.isfinite(a)).tolist()}")
        lo, hi = space.low.astype(np.float64), space.high.astype(np.float64)
        tol = 1e-6 * (1.0 + np.maximum(np.abs(lo), np.abs(hi)))  # float32 rounding of the declared bounds
        bad = np.flatnonzero((a < lo - tol) | (a > hi + tol))
        if len(bad):
            detail = ", ".join(f"[{i}] = {a[i]:.6g} not in [{lo[i]:.6g}, {hi[i]:.6g}]" for i in bad[:4])
            raise InvalidArgumentError(f"{what}: out of bounds: {detail} (actions are not clipped)")
        if self.control_mode == "ee_abs":
            norm = float(np.linalg.norm(a[3:7]))
            if norm < 1e-6:
                raise InvalidArgumentError(f"{what}: the quaternion a[3:7] has norm {norm:.3g}, expected > 1e-6")
        return a

    def _joint_action(self, a: np.ndarray) -> tuple[np.ndarray, bool]:
        """The stepper's action (arm joint targets + gripper) for a checked action of this mode."""
        if self.control_mode == "joint_pos":
            return a, False
        q = self.robot.joint_positions
        if self.control_mode == "ee_delta":
            cur = self.model.fk(q, link=self.ee_link) @ self.ee_to_tcp
            goal = np.eye(4)
            goal[:3, :3] = _rotvec_to_matrix(a[3:6]) @ cur[:3, :3]
            goal[:3, 3] = cur[:3, 3] + a[:3]
        else:
            goal = transforms.pose_to_matrix(np.concatenate([a[:3], a[3:7] / np.linalg.norm(a[3:7])]))
        goal = goal @ np.linalg.inv(self.ee_to_tcp)  # TCP goal -> the planner's end-effector link
        seed = q[self.arm_idx]
        lo, hi = self.model.lower_limits[self.arm_idx], self.model.upper_limits[self.arm_idx]
        res = self.planner.ik(goal, np.clip(seed, lo, hi), num_seeds=8, seed=0)
        if res.success:
            arm = np.asarray(res.q, dtype=np.float64)
            return np.concatenate([arm, a[-1:]]), False
        return np.concatenate([self._arm_target, a[-1:]]), True

    # -- observations -----------------------------------------------------------------------------------------

    def _observe(self) -> dict[str, np.ndarray]:
        obs = observe(self.world, self.robot, self.cameras, segmentation=self.segmentation, gripper=self.gripper)
        if self.obs_mode != "rgbd":
            obs = {k: v for k, v in obs.items() if not k.startswith("observation.depth.")}
        if self.task_state_dim:
            obs["observation.environment_state"] = self._task_state().astype(np.float32)
        out = {}
        for key, space in self.observation_space.spaces.items():
            if key not in obs:
                raise InvalidArgumentError(f"observation: ferrobot.control.observe gave no {key!r} ({sorted(obs)})")
            out[key] = np.asarray(obs[key], dtype=space.dtype).reshape(space.shape)
        return out

    def _info(self, ik_failed: bool, success: bool | None = None, cause: str | None = None) -> dict:
        if success is None:
            success, cause, _ = self._evaluate()
        return {
            "is_success": bool(success),
            "failure_cause": "" if success else cause,
            "scene_seed": int(self.spec_scene.seed),
            "ik_failed": bool(ik_failed),
        }

    # -- task helpers -----------------------------------------------------------------------------------------

    def _tcp(self) -> np.ndarray:
        """The gripper's TCP in the world."""
        hand = self.robot.get_link_pose(self.gripper.hand_link)
        return (hand @ np.append(self.gripper.tcp, 1.0))[:3]

    def _object_pos(self, name: str) -> np.ndarray:
        return self.world.get_object_pose(name)[:3, 3]

    def _base(self, p_world: np.ndarray) -> np.ndarray:
        return (self.to_base @ np.append(p_world, 1.0))[:3]

    def _task_reset(self) -> None:
        raise NotImplementedError

    def _task_state(self) -> np.ndarray:
        raise NotImplementedError

    def _evaluate(self) -> tuple[bool, str, float]:
        raise NotImplementedError


class _ObjectTask(FerrobotEnv):
    """Tasks about the scene's target object."""

    #: Height (m) above its resting height at which the target counts as lifted.
    lift_threshold = 0.05

    def _task_reset(self) -> None:
        self.target = self.spec_scene.target
        self.target_spec = self.spec_scene.object(self.target)
        if self.target_spec.kind == "mesh":
            # A mesh object rests in a pile on some face: its resting height is where it settled.
            self.rest_z = float(self._object_pos(self.target)[2])
        else:
            self.rest_z = TABLE_TOP + self.target_spec.height / 2
        self.max_rise = 0.0

    def _rise(self) -> float:
        rise = float(self._object_pos(self.target)[2] - self.rest_z)
        self.max_rise = max(self.max_rise, rise)
        return rise


class PickPlaceEnv(_ObjectTask):
    """Pick the scene's target object and put it down on the place location.

    Success: the target's centre within 3 cm of the place location in x, y; resting upright (centre within
    1 cm of its resting height, spheres and mesh objects excepted; speed under 5 cm/s); the gripper open (the
    last command at most 0.5). The placement part is the pipeline's own criterion
    (:func:`ferrobot.pipeline.pick_place.placement_failure`), so a recorded pipeline success is an
    environment success.
    ``observation.environment_state`` (10,): the target's pose [x, y, z, qw, qx, qy, qz] and the place
    location [x, y, z] (on the table top), both in the robot base frame."""

    task_state_dim = 10
    place_tolerance = 0.03

    def _task_state(self) -> np.ndarray:
        pose = transforms.matrix_to_pose(self.to_base @ self.world.get_object_pose(self.target))
        place = self._base(np.array([*self.spec_scene.place_xy, TABLE_TOP]))
        return np.concatenate([pose, place])

    def _evaluate(self) -> tuple[bool, str, float]:
        p = self._object_pos(self.target)
        self._rise()
        err = float(np.hypot(p[0] - self.spec_scene.place_xy[0], p[1] - self.spec_scene.place_xy[1]))
        speed = float(np.linalg.norm(self.world.get_object_velocity(self.target)[0]))
        # The pipeline's criterion (one definition: ferrobot.pipeline.pick_place.placement_failure).
        placed, _ = placement_failure(
            p, speed, self.rest_z, self.spec_scene.place_xy, self.target_spec.kind, self.place_tolerance
        )
        if placed == "not_at_place":
            cause = "not_lifted" if self.max_rise < 0.02 else "not_at_place"
        elif placed:
            cause = placed
        elif self.stepper.gripper_closed:
            cause = "not_released"
        else:
            cause = ""
        d_reach = float(np.linalg.norm(self._tcp() - p))
        lifted = 1.0 if self.max_rise >= 0.02 else 0.0
        dense = 0.3 * (1 - math.tanh(10 * d_reach)) + 0.2 * lifted + 0.5 * lifted * (1 - math.tanh(10 * err))
        return cause == "", cause, 0.95 * dense


class LiftEnv(_ObjectTask):
    """Lift the scene's target 5 cm above its resting height. ``observation.environment_state`` (7,): the
    target's pose in the robot base frame."""

    task_state_dim = 7

    def _task_state(self) -> np.ndarray:
        return transforms.matrix_to_pose(self.to_base @ self.world.get_object_pose(self.target))

    def _evaluate(self) -> tuple[bool, str, float]:
        rise = self._rise()
        ok = rise >= self.lift_threshold
        cause = "" if ok else ("not_lifted" if self.max_rise < self.lift_threshold else "dropped")
        d = float(np.linalg.norm(self._tcp() - self._object_pos(self.target)))
        dense = 0.5 * (1 - math.tanh(10 * d)) + 0.5 * min(max(rise / self.lift_threshold, 0.0), 1.0)
        return ok, cause, 0.95 * dense


class ReachEnv(FerrobotEnv):
    """Bring the hand's TCP within 2 cm of a goal position drawn above the table (from the scene seed).
    ``observation.environment_state`` (3,): the goal in the robot base frame."""

    task_state_dim = 3
    tolerance = 0.02

    def _task_reset(self) -> None:
        rng = np.random.default_rng([self.spec_scene.seed, 11])
        self.goal = np.array([rng.uniform(0.35, 0.65), rng.uniform(-0.25, 0.25), TABLE_TOP + rng.uniform(0.15, 0.35)])

    def _task_state(self) -> np.ndarray:
        return self._base(self.goal)

    def _evaluate(self) -> tuple[bool, str, float]:
        d = float(np.linalg.norm(self._tcp() - self.goal))
        ok = d <= self.tolerance
        return ok, "" if ok else "not_reached", 0.95 * (1 - math.tanh(10 * d))
