"""cuRobo's call shapes over ferrobot's planner (numpy instead of torch tensors, CPU instead of CUDA).

Code written for cuRobo keeps its structure::

    from ferrobot.compat.curobo import (MotionGen, MotionGenConfig, MotionGenPlanConfig, JointState, Pose,
                                        IKSolver, IKSolverConfig, WorldConfig)

    config = MotionGenConfig.load_from_robot_config("franka.yml", world_cfg, interpolation_dt=0.01)
    motion_gen = MotionGen(config)
    motion_gen.warmup()
    start = JointState.from_position(q0.reshape(1, -1), joint_names=motion_gen.joint_names)
    result = motion_gen.plan_single(start, Pose.from_list([0.4, 0.2, 0.4, 0, 1, 0, 0]), MotionGenPlanConfig())
    if result.success.item():
        traj = result.get_interpolated_plan()          # JointState, one row per interpolation_dt
        traj = traj.get_ordered_joint_state(sim_joint_names)

What it does underneath is ferrobot's :class:`ferrobot.Planner` (collision-free multi-seed IK, RRT-Connect,
shortcutting, a smooth time-parametrised spline), not cuRobo's trajectory optimisation: plans are valid and
smooth but not the same trajectories cuRobo would give.

Robot configuration: cuRobo's ``robot_cfg`` as a dict or a YAML path (with or without the top-level
``robot_cfg`` key). Read: ``kinematics.urdf_path`` (relative paths against ``kinematics.asset_root_path``,
then the YAML file's folder, then the working directory), ``base_link``, ``ee_link``, ``collision_spheres``
(a ``{link: [{center, radius}]}`` dict or a path to cuRobo's spheres YAML; links listed in ``extra_links``
are skipped, they are placeholders for attached objects), ``collision_sphere_buffer`` (the planner's
``margin``), ``lock_joints`` (held at their value) and ``cspace.joint_names``, ``cspace.retract_config``,
``cspace.max_acceleration``, ``cspace.max_jerk`` (scalars or per joint). Without ``collision_spheres`` the
spheres are made automatically from the link geometry. Other keys (GPU, optimiser and debug settings) are
listed in ``IGNORED_ROBOT_KEYS`` and have no counterpart.

World configuration: a :class:`WorldConfig` or cuRobo's dict
``{"cuboid": {name: {"dims", "pose"}}, "sphere": {name: {"radius", "pose" or "position"}},
"capsule": {name: {"radius", "base", "tip", "pose"}}, "cylinder": {name: {"radius", "height", "pose"}},
"mesh": {name: {"file_path" or ("vertices", "faces"), "pose", "scale"}}}``, poses ``[x, y, z, qw, qx, qy, qz]``
in the robot base frame, becoming a :class:`ferrobot.CollisionWorld`.
"""

from __future__ import annotations

import os
import tempfile
import time
from pathlib import Path

import numpy as np

from .. import _core
from ..errors import InvalidArgumentError, ShapeError, UnknownNameError

__all__ = [
    "IGNORED_ROBOT_KEYS",
    "IKResult",
    "IKSolver",
    "IKSolverConfig",
    "JointState",
    "MotionGen",
    "MotionGenConfig",
    "MotionGenPlanConfig",
    "MotionGenResult",
    "Pose",
    "RobotConfig",
    "WorldConfig",
    "load_yaml",
]

#: cuRobo ``robot_cfg.kinematics`` keys with no counterpart in ferrobot (accepted, not used).
IGNORED_ROBOT_KEYS = frozenset(
    {
        "collision_link_names",
        "self_collision_ignore",
        "self_collision_buffer",
        "use_global_cumul",
        "mesh_link_names",
        "extra_collision_spheres",
        "usd_path",
        "usd_robot_root",
        "isaac_usd_path",
        "usd_flip_joints",
        "usd_flip_joint_limits",
        "external_asset_path",
        "external_robot_configs_path",
        "cuda_robot_model_config",
        "ee_links",
        "link_names",
    }
)

#: MotionGenConfig / IKSolverConfig keywords that only steer cuRobo's GPU optimisers (accepted, not used).
_IGNORED_SOLVER_KWARGS = frozenset(
    {
        "tensor_args",
        "use_cuda_graph",
        "collision_cache",
        "collision_checker_type",
        "trajopt_tsteps",
        "num_trajopt_seeds",
        "num_graph_seeds",
        "num_trajopt_noisy_seeds",
        "store_ik_debug",
        "store_trajopt_debug",
        "evaluate_interpolated_trajectory",
        "self_collision_opt",
        "collision_activation_distance",
        "grad_trajopt_iters",
        "trajopt_dt",
        "js_trajopt_dt",
        "finetune_dt_scale",
        "maximum_trajectory_dt",
        "minimum_trajectory_dt",
        "use_particle_opt",
        "high_precision",
        "regularization",
        "gradient_trajopt_file",
        "particle_ik_file",
        "gradient_ik_file",
        "fixed_iters",
        "fixed_iters_trajopt",
        "project_pose_to_goal_frame",
        "world_coll_checker",
    }
)


def load_yaml(path) -> dict:
    """Reads a YAML file (cuRobo's ``curobo.util_file.load_yaml``)."""
    import yaml

    with open(path) as f:
        return yaml.safe_load(f)


def _f64(a, what: str, last: int) -> np.ndarray:
    arr = np.asarray(a, dtype=np.float64)
    if arr.ndim == 1:
        arr = arr[None]
    if arr.ndim != 2 or arr.shape[1] != last:
        raise ShapeError(f"{what}: expected shape ({last},) or (N, {last}), got {np.shape(a)}")
    if not np.all(np.isfinite(arr)):
        raise InvalidArgumentError(f"{what}: contains NaN or infinite values")
    return arr


# --------------------------------------------------------------------------- state types


class Pose:
    """cuRobo's ``Pose``: ``position`` (N, 3) and ``quaternion`` (N, 4) as (w, x, y, z), in the robot base frame."""

    def __init__(self, position=None, quaternion=None, *, normalize_rotation: bool = True, **_ignored):
        if position is None:
            raise InvalidArgumentError("position: required")
        self.position = _f64(position, "position", 3)
        if quaternion is None:
            quaternion = np.tile([1.0, 0.0, 0.0, 0.0], (len(self.position), 1))
        q = _f64(quaternion, "quaternion", 4)
        if len(q) != len(self.position):
            raise ShapeError(f"quaternion: {len(q)} rows for {len(self.position)} positions")
        n = np.linalg.norm(q, axis=1, keepdims=True)
        if np.any(n < 1e-9):
            raise InvalidArgumentError("quaternion: zero quaternion")
        self.quaternion = q / n if normalize_rotation else q

    @classmethod
    def from_list(cls, pose, tensor_args=None, q_xyzw: bool = False) -> Pose:
        """``[x, y, z, qw, qx, qy, qz]`` (``q_xyzw=True``: ``[x, y, z, qx, qy, qz, qw]``)."""
        p = np.asarray(pose, dtype=np.float64).reshape(-1)
        if p.shape != (7,):
            raise ShapeError(f"pose: expected 7 values, got {p.shape}")
        q = p[[6, 3, 4, 5]] if q_xyzw else p[3:]
        return cls(p[:3], q)

    @classmethod
    def from_matrix(cls, matrix) -> Pose:
        """From (4, 4) or (N, 4, 4) homogeneous matrices."""
        from ..transforms import matrix_to_pose

        m = np.asarray(matrix, dtype=np.float64)
        m = m[None] if m.ndim == 2 else m
        p = np.stack([np.asarray(matrix_to_pose(x)) for x in m])
        return cls(p[:, :3], p[:, 3:])

    def to_list(self) -> list[float]:
        """The first pose as ``[x, y, z, qw, qx, qy, qz]``."""
        return np.concatenate([self.position[0], self.quaternion[0]]).tolist()

    def get_numpy_matrix(self) -> np.ndarray:
        """(N, 4, 4) matrices."""
        from ..transforms import pose_to_matrix

        return np.stack(
            [pose_to_matrix(np.concatenate([p, q])) for p, q in zip(self.position, self.quaternion, strict=True)]
        )

    def as_7(self) -> np.ndarray:
        """(N, 7) ``[x, y, z, qw, qx, qy, qz]`` (ferrobot's pose vectors)."""
        return np.concatenate([self.position, self.quaternion], axis=1)

    @property
    def batch(self) -> int:
        return len(self.position)

    def __len__(self) -> int:
        return len(self.position)

    def __repr__(self) -> str:
        return f"Pose(position={self.position.tolist()}, quaternion={self.quaternion.tolist()})"


class JointState:
    """cuRobo's ``JointState``: ``position`` (N, dof) or (dof,), ``velocity``, ``acceleration``, ``jerk``,
    ``joint_names``."""

    def __init__(self, position, velocity=None, acceleration=None, joint_names=None, jerk=None, **_ignored):
        self.position = np.asarray(position, dtype=np.float64)
        if self.position.ndim not in (1, 2, 3):
            raise ShapeError(f"position: expected (dof,), (N, dof) or (B, T, dof), got {self.position.shape}")
        if not np.all(np.isfinite(self.position)):
            raise InvalidArgumentError("position: contains NaN or infinite values")
        shape = self.position.shape

        def same(v, what):
            if v is None:
                return np.zeros(shape)
            a = np.asarray(v, dtype=np.float64)
            if a.shape != shape:
                raise ShapeError(f"{what}: expected shape {shape} like position, got {a.shape}")
            return a

        self.velocity = same(velocity, "velocity")
        self.acceleration = same(acceleration, "acceleration")
        self.jerk = same(jerk, "jerk")
        self.joint_names = None if joint_names is None else list(joint_names)
        if self.joint_names is not None and len(self.joint_names) != shape[-1]:
            raise ShapeError(f"joint_names: {len(self.joint_names)} names for {shape[-1]} joint values")

    @classmethod
    def from_position(cls, position, joint_names=None) -> JointState:
        """Positions with zero velocity, acceleration and jerk."""
        return cls(position, joint_names=joint_names)

    @property
    def shape(self) -> tuple[int, ...]:
        return self.position.shape

    def __len__(self) -> int:
        return self.position.shape[0]

    def __getitem__(self, index) -> JointState:
        return JointState(
            self.position[index], self.velocity[index], self.acceleration[index], self.joint_names, self.jerk[index]
        )

    def clone(self) -> JointState:
        return JointState(
            self.position.copy(), self.velocity.copy(), self.acceleration.copy(), self.joint_names, self.jerk.copy()
        )

    def unsqueeze(self, dim: int) -> JointState:
        """Adds a batch dimension (torch's ``unsqueeze``)."""
        return JointState(
            *(np.expand_dims(a, dim) for a in (self.position, self.velocity, self.acceleration)),
            self.joint_names,
            np.expand_dims(self.jerk, dim),
        )

    def squeeze(self, dim: int = 0) -> JointState:
        return JointState(
            *(np.squeeze(a, dim) for a in (self.position, self.velocity, self.acceleration)),
            self.joint_names,
            np.squeeze(self.jerk, dim),
        )

    def get_ordered_joint_state(self, ordered_joint_names) -> JointState:
        """The same state with its columns in ``ordered_joint_names`` order (each name must be present)."""
        if self.joint_names is None:
            raise InvalidArgumentError("get_ordered_joint_state: this JointState has no joint_names")
        missing = [n for n in ordered_joint_names if n not in self.joint_names]
        if missing:
            raise UnknownNameError(f"ordered_joint_names: {missing} not in this state's joints {self.joint_names}")
        ix = [self.joint_names.index(n) for n in ordered_joint_names]
        return JointState(
            self.position[..., ix],
            self.velocity[..., ix],
            self.acceleration[..., ix],
            list(ordered_joint_names),
            self.jerk[..., ix],
        )

    def __repr__(self) -> str:
        return f"JointState(position shape {self.position.shape}, joint_names={self.joint_names})"


# --------------------------------------------------------------------------- world


def _rot_z_to(d: np.ndarray) -> np.ndarray:
    """A rotation matrix taking +z to the unit vector ``d``."""
    z = np.array([0.0, 0.0, 1.0])
    c = float(np.dot(z, d))
    if c > 1 - 1e-12:
        return np.eye(3)
    if c < -1 + 1e-12:
        return np.diag([1.0, -1.0, -1.0])
    v = np.cross(z, d)
    s = np.linalg.norm(v)
    k = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]]) / s
    ang = np.arctan2(s, c)
    return np.eye(3) + np.sin(ang) * k + (1 - np.cos(ang)) * k @ k


def _pose7(d: dict, what: str, default_position=None) -> np.ndarray:
    if "pose" in d and d["pose"] is not None:
        p = np.asarray(d["pose"], dtype=np.float64).reshape(-1)
        if p.shape != (7,):
            raise ShapeError(f"{what}.pose: expected [x, y, z, qw, qx, qy, qz], got {p.shape}")
        return p
    if default_position is not None:
        return np.concatenate([np.asarray(default_position, dtype=np.float64).reshape(3), [1.0, 0, 0, 0]])
    raise InvalidArgumentError(f"{what}: needs a 'pose' [x, y, z, qw, qx, qy, qz]")


def _load_mesh_file(path: str, scale) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and faces of an STL / OBJ / DAE file, through ferrobot's URDF mesh loader."""
    p = Path(path).resolve()
    if not p.is_file():
        raise InvalidArgumentError(f"mesh file_path: no file at {path}")
    s = " ".join(str(float(x)) for x in np.broadcast_to(np.asarray(scale, dtype=np.float64), (3,)))
    urdf = (
        '<robot name="m"><link name="m"><collision><geometry>'
        f'<mesh filename="{p.as_posix()}" scale="{s}"/></geometry></collision></link></robot>'
    )
    g = _core.RobotModel.from_urdf_string(urdf).collision_geometry("m")[0]
    return np.asarray(g["vertices"]) * np.asarray(g["scale"]), np.asarray(g["faces"])


class WorldConfig:
    """cuRobo's ``WorldConfig`` as a dict of obstacle kinds: ``cuboid``, ``sphere``, ``capsule``, ``cylinder``,
    ``mesh`` (see the module docstring). :meth:`to_collision_world` gives the :class:`ferrobot.CollisionWorld`."""

    KINDS = ("cuboid", "sphere", "capsule", "cylinder", "mesh")

    def __init__(self, cuboid=None, sphere=None, capsule=None, cylinder=None, mesh=None, **others):
        unknown = {k for k, v in others.items() if v}
        if unknown:
            raise InvalidArgumentError(
                f"world config: obstacle kind(s) {sorted(unknown)} not supported; known: {list(self.KINDS)}"
            )
        self.cuboid = dict(cuboid or {})
        self.sphere = dict(sphere or {})
        self.capsule = dict(capsule or {})
        self.cylinder = dict(cylinder or {})
        self.mesh = dict(mesh or {})

    @classmethod
    def from_dict(cls, data: dict) -> WorldConfig:
        """cuRobo's dict form (``{"cuboid": {name: {...}}, ...}``); kinds may also be lists of dicts with ``name``."""
        data = dict(data or {})
        for k in cls.KINDS:
            if isinstance(data.get(k), list):
                data[k] = {o["name"]: o for o in data[k]}
        return cls(**data)

    @classmethod
    def load(cls, world) -> WorldConfig:
        """A :class:`WorldConfig`, a dict or a YAML path."""
        if world is None:
            return cls()
        if isinstance(world, WorldConfig):
            return world
        if isinstance(world, (str, os.PathLike)):
            world = load_yaml(world)
        if not isinstance(world, dict):
            raise InvalidArgumentError(f"world_model: expected a WorldConfig, a dict or a YAML path, got {type(world)}")
        return cls.from_dict(world)

    def to_collision_world(self) -> _core.CollisionWorld:
        w = _core.CollisionWorld()
        for name, o in self.cuboid.items():
            w.add_box(name, o["dims"], _pose7(o, f"cuboid '{name}'"))
        for name, o in self.sphere.items():
            w.add_sphere(name, float(o["radius"]), _pose7(o, f"sphere '{name}'", o.get("position")))
        for name, o in self.cylinder.items():
            w.add_cylinder(name, float(o["radius"]), float(o["height"]), _pose7(o, f"cylinder '{name}'"))
        for name, o in self.capsule.items():
            from ..transforms import matrix_to_pose, pose_to_matrix

            base = np.asarray(o["base"], dtype=np.float64)
            tip = np.asarray(o["tip"], dtype=np.float64)
            axis = tip - base
            length = float(np.linalg.norm(axis))
            local = np.eye(4)
            local[:3, 3] = (base + tip) / 2
            if length > 0:
                local[:3, :3] = _rot_z_to(axis / length)
            pose = pose_to_matrix(_pose7(o, f"capsule '{name}'", [0, 0, 0])) @ local
            w.add_capsule(name, float(o["radius"]), length, matrix_to_pose(pose))
        for name, o in self.mesh.items():
            if o.get("file_path"):
                v, f = _load_mesh_file(o["file_path"], o.get("scale", 1.0))
            elif o.get("vertices") is not None:
                v = np.asarray(o["vertices"], dtype=np.float64) * np.asarray(o.get("scale", 1.0), dtype=np.float64)
                f = np.asarray(o["faces"], dtype=np.int64)
            else:
                raise InvalidArgumentError(f"mesh '{name}': needs 'file_path' or 'vertices' and 'faces'")
            w.add_mesh(name, v, f, _pose7(o, f"mesh '{name}'", [0, 0, 0]))
        return w


# --------------------------------------------------------------------------- robot


class RobotConfig:
    """cuRobo's robot configuration, resolved: the :class:`ferrobot.RobotModel`, spheres and joint names."""

    def __init__(self, robot_cfg, *, base_dir: str | os.PathLike | None = None):
        if isinstance(robot_cfg, RobotConfig):
            self.__dict__.update(robot_cfg.__dict__)
            return
        if isinstance(robot_cfg, (str, os.PathLike)):
            base_dir = Path(robot_cfg).resolve().parent
            robot_cfg = load_yaml(robot_cfg)
        if not isinstance(robot_cfg, dict):
            raise InvalidArgumentError(f"robot_cfg: expected a dict or a YAML path, got {type(robot_cfg)}")
        cfg = robot_cfg.get("robot_cfg", robot_cfg)
        kin = cfg.get("kinematics")
        if not isinstance(kin, dict):
            raise InvalidArgumentError("robot_cfg: needs a 'kinematics' section")
        roots = [Path(p) for p in (kin.get("asset_root_path"), kin.get("external_asset_path")) if p]
        roots += [Path(base_dir)] if base_dir else []
        roots += [Path.cwd()]
        self.urdf_path = self._resolve(kin.get("urdf_path"), roots, "kinematics.urdf_path")
        self.model = _core.RobotModel.from_urdf(
            self.urdf_path, base_link=kin.get("base_link"), ee_link=kin.get("ee_link")
        )
        self.ee_link = self.model.ee_link
        self.margin = float(kin.get("collision_sphere_buffer", 0.0) or 0.0)
        extra = set((kin.get("extra_links") or {}).keys())
        spheres = kin.get("collision_spheres")
        if spheres is None:
            self.spheres = _core.SphereModel.automatic(self.model)
        else:
            if isinstance(spheres, (str, os.PathLike)):
                path = self._resolve(spheres, roots, "kinematics.collision_spheres")
                spheres = load_yaml(path)
            spheres = spheres.get("collision_spheres", spheres)
            spheres = {k: v for k, v in spheres.items() if k not in extra}
            import yaml

            with tempfile.NamedTemporaryFile("w", suffix=".yml", delete=False) as f:
                yaml.safe_dump({"collision_spheres": spheres}, f)
            try:
                self.spheres = _core.SphereModel.load(self.model, f.name)
            finally:
                os.unlink(f.name)
        cspace = kin.get("cspace") or cfg.get("cspace") or {}
        self.lock_joints = {str(k): float(v) for k, v in (kin.get("lock_joints") or {}).items()}
        names = list(cspace.get("joint_names") or self.model.group_dof_names)
        dof = list(self.model.dof_names)
        mimic = {m[0] for m in self.model.mimic_joints}
        unknown = [n for n in names if n not in dof and n not in mimic]
        if unknown:
            raise UnknownNameError(f"cspace.joint_names: {unknown} are not joints of {self.urdf_path}: {dof}")
        #: cuRobo's active joints: cspace joints not locked.
        self.joint_names = [n for n in names if n not in self.lock_joints]
        self.cspace_joint_names = names
        retract = cspace.get("retract_config")
        self.retract_config = None if retract is None else np.asarray(retract, dtype=np.float64)
        self.max_acceleration = cspace.get("max_acceleration")
        self.max_jerk = cspace.get("max_jerk")

    @staticmethod
    def _resolve(p, roots, what) -> str:
        if not p:
            raise InvalidArgumentError(f"robot_cfg: {what} is required")
        if os.path.isabs(p):
            if not os.path.isfile(p):
                raise InvalidArgumentError(f"robot_cfg: {what} '{p}' does not exist")
            return p
        tried = [r / p for r in roots]
        for t in tried:
            if t.is_file():
                return str(t)
        raise InvalidArgumentError(f"robot_cfg: {what} '{p}' not found; tried {[str(t) for t in tried]}")

    def planner(self, world: WorldConfig) -> _core.Planner:
        planner = _core.Planner(
            self.model, world.to_collision_world(), self.spheres, margin=self.margin, ee_link=self.ee_link
        )
        if self.lock_joints:
            q = np.asarray(planner.locked_positions, dtype=np.float64).copy()
            dof = list(self.model.dof_names)
            for n, v in self.lock_joints.items():
                if n in dof:
                    q[dof.index(n)] = v
            planner.locked_positions = q
        self._apply_limits(planner)
        return planner

    def _apply_limits(self, planner) -> None:
        n = len(planner.joint_names)
        kw = {}
        for key, name in (("acceleration", self.max_acceleration), ("jerk", self.max_jerk)):
            if name is not None:
                kw[key] = np.broadcast_to(np.asarray(name, dtype=np.float64), (n,)).copy()
        if kw:
            planner.set_limits(**kw)


def _check_kwargs(kwargs: dict, known: set, where: str) -> None:
    unknown = set(kwargs) - known - _IGNORED_SOLVER_KWARGS
    if unknown:
        raise InvalidArgumentError(f"{where}: unknown or unsupported argument(s) {sorted(unknown)}")


# --------------------------------------------------------------------------- IK


class IKSolverConfig:
    """cuRobo's ``IKSolverConfig``; build with :meth:`load_from_robot_config`."""

    def __init__(
        self,
        robot: RobotConfig,
        world: WorldConfig,
        position_threshold: float,
        rotation_threshold: float,
        num_seeds: int,
        self_collision_check: bool,
    ):
        self.robot, self.world = robot, world
        self.position_threshold, self.rotation_threshold = position_threshold, rotation_threshold
        self.num_seeds, self.self_collision_check = num_seeds, self_collision_check

    @classmethod
    def load_from_robot_config(
        cls,
        robot_cfg,
        world_model=None,
        tensor_args=None,
        *,
        rotation_threshold=0.05,
        position_threshold=0.005,
        num_seeds=20,
        self_collision_check=True,
        **kwargs,
    ) -> IKSolverConfig:
        """``position_threshold`` (m) and ``rotation_threshold`` (rad) are the IK tolerances; ``num_seeds`` the
        number of random restarts (ferrobot uses at least 20). Collision checking is always on."""
        _check_kwargs(kwargs, set(), "IKSolverConfig.load_from_robot_config")
        if not self_collision_check:
            raise InvalidArgumentError("self_collision_check=False is not supported: ferrobot's IK always checks")
        return cls(
            RobotConfig(robot_cfg),
            WorldConfig.load(world_model),
            float(position_threshold),
            float(rotation_threshold),
            int(num_seeds),
            True,
        )


class IKResult:
    """cuRobo's ``IKResult``: ``success`` (B, 1) bool, ``solution`` (B, 1, dof), ``js_solution`` (a JointState),
    ``position_error`` / ``rotation_error`` (B, 1), ``solve_time`` (s)."""

    def __init__(self, ik, joint_names, solve_time):
        succ = np.atleast_1d(np.asarray(ik.success))
        q = np.asarray(ik.q, dtype=np.float64).reshape(len(succ), -1)
        self.success = succ.reshape(-1, 1)
        self.solution = q[:, None, :]
        self.position_error = np.atleast_1d(np.asarray(ik.position_error, dtype=np.float64)).reshape(-1, 1)
        self.rotation_error = np.atleast_1d(np.asarray(ik.rotation_error, dtype=np.float64)).reshape(-1, 1)
        self.js_solution = JointState.from_position(self.solution, joint_names=joint_names)
        self.solve_time = solve_time
        self.joint_names = joint_names


class IKSolver:
    """cuRobo's ``IKSolver`` over :meth:`ferrobot.Planner.ik` / ``ik_batch`` (collision-free)."""

    def __init__(self, config: IKSolverConfig):
        self.config = config
        self.robot = config.robot
        self.planner = config.robot.planner(config.world)
        self.joint_names = list(self.planner.joint_names)
        self.kinematics = self.robot.model

    def update_world(self, world_config) -> None:
        self.planner.update_world(WorldConfig.load(world_config).to_collision_world())

    def _kw(self, num_seeds):
        return dict(
            position_tolerance=self.config.position_threshold,
            rotation_tolerance=self.config.rotation_threshold,
            num_seeds=max(20, int(num_seeds or self.config.num_seeds)),
            collision_free=True,
        )

    def solve_single(
        self, goal_pose: Pose, retract_config=None, seed_config=None, return_seeds: int = 1, num_seeds=None, **_ignored
    ) -> IKResult:
        """IK for one pose (ferrobot's end effector, the robot's ``ee_link``)."""
        if goal_pose.batch != 1:
            raise ShapeError(f"goal_pose: solve_single takes one pose, got {goal_pose.batch} (use solve_batch)")
        seed = None
        if seed_config is not None:
            seed = np.asarray(seed_config, dtype=np.float64).reshape(-1, len(self.joint_names))[0]
        t = time.perf_counter()
        ik = self.planner.ik(goal_pose.as_7()[0], seed, **self._kw(num_seeds))
        return IKResult(ik, self.joint_names, time.perf_counter() - t)

    def solve_batch(
        self, goal_pose: Pose, retract_config=None, seed_config=None, num_seeds=None, **_ignored
    ) -> IKResult:
        """IK for each pose of a batch (in parallel)."""
        t = time.perf_counter()
        ik = self.planner.ik_batch(goal_pose.as_7(), **self._kw(num_seeds))
        return IKResult(ik, self.joint_names, time.perf_counter() - t)

    def fk(self, q) -> _KinematicsState:
        """End-effector poses for joint positions (N, dof) in ``joint_names`` order."""
        return _fk(self.robot.model, self.joint_names, q, self.robot.ee_link)


class _KinematicsState:
    def __init__(self, poses7):
        self.ee_position = poses7[:, :3]
        self.ee_quaternion = poses7[:, 3:]
        self.ee_pose = Pose(self.ee_position, self.ee_quaternion)


def _fk(model, joint_names, q, link) -> _KinematicsState:
    q = np.asarray(q, dtype=np.float64).reshape(-1, len(joint_names))
    full = np.tile(model.neutral_configuration(), (len(q), 1))
    dof = list(model.dof_names)
    for j, n in enumerate(joint_names):
        full[:, dof.index(n)] = q[:, j]
    return _KinematicsState(np.asarray(model.fk_batch(full, link)))


# --------------------------------------------------------------------------- motion generation


class MotionGenPlanConfig:
    """cuRobo's ``MotionGenPlanConfig``. Used: ``max_attempts`` (plans tried with different random seeds),
    ``timeout`` (s, per attempt), ``time_dilation_factor`` (in (0, 1]: velocity scale, and its square the
    acceleration scale). The graph / optimiser switches (``enable_graph``, ``enable_opt``,
    ``enable_finetune_trajopt``, ``num_trajopt_seeds``...) have no counterpart and are kept only as attributes."""

    def __init__(
        self,
        enable_graph: bool = False,
        enable_opt: bool = True,
        max_attempts: int = 60,
        timeout: float = 10.0,
        time_dilation_factor: float | None = None,
        **others,
    ):
        if int(max_attempts) < 1:
            raise InvalidArgumentError(f"max_attempts: expected >= 1, got {max_attempts}")
        if not (float(timeout) > 0):
            raise InvalidArgumentError(f"timeout: expected > 0 s, got {timeout}")
        if time_dilation_factor is not None and not (0 < float(time_dilation_factor) <= 1):
            raise InvalidArgumentError(f"time_dilation_factor: expected in (0, 1], got {time_dilation_factor}")
        self.enable_graph, self.enable_opt = enable_graph, enable_opt
        self.max_attempts, self.timeout, self.time_dilation_factor = (
            int(max_attempts),
            float(timeout),
            time_dilation_factor,
        )
        self.__dict__.update(others)

    def clone(self) -> MotionGenPlanConfig:
        c = MotionGenPlanConfig.__new__(MotionGenPlanConfig)
        c.__dict__.update(self.__dict__)
        return c


class MotionGenConfig:
    """cuRobo's ``MotionGenConfig``; build with :meth:`load_from_robot_config`."""

    def __init__(
        self,
        robot: RobotConfig,
        world: WorldConfig,
        interpolation_dt: float,
        ik: IKSolverConfig,
        velocity_scale: float,
        acceleration_scale: float,
    ):
        self.robot, self.world, self.interpolation_dt, self.ik = robot, world, interpolation_dt, ik
        self.velocity_scale, self.acceleration_scale = velocity_scale, acceleration_scale

    @classmethod
    def load_from_robot_config(
        cls,
        robot_cfg,
        world_model=None,
        tensor_args=None,
        *,
        interpolation_dt=0.02,
        num_ik_seeds=32,
        position_threshold=0.005,
        rotation_threshold=0.05,
        velocity_scale=1.0,
        acceleration_scale=1.0,
        self_collision_check=True,
        **kwargs,
    ) -> MotionGenConfig:
        """``interpolation_dt`` (s, > 0) is the spacing of :meth:`MotionGenResult.get_interpolated_plan`;
        ``velocity_scale`` / ``acceleration_scale`` in (0, 1] scale the joint limits."""
        _check_kwargs(kwargs, set(), "MotionGenConfig.load_from_robot_config")
        if not (float(interpolation_dt) > 0):
            raise InvalidArgumentError(f"interpolation_dt: expected > 0 s, got {interpolation_dt}")
        for name, v in (("velocity_scale", velocity_scale), ("acceleration_scale", acceleration_scale)):
            if np.ndim(v) or not (0 < float(v) <= 1):
                raise InvalidArgumentError(f"{name}: expected a scalar in (0, 1], got {v}")
        robot = RobotConfig(robot_cfg)
        world = WorldConfig.load(world_model)
        ik = IKSolverConfig(
            robot,
            world,
            float(position_threshold),
            float(rotation_threshold),
            int(num_ik_seeds),
            bool(self_collision_check),
        )
        if not self_collision_check:
            raise InvalidArgumentError("self_collision_check=False is not supported: ferrobot's planner always checks")
        return cls(robot, world, float(interpolation_dt), ik, float(velocity_scale), float(acceleration_scale))


class MotionGenResult:
    """cuRobo's ``MotionGenResult``: ``success`` (1,) bool array (``.item()`` works), ``status``,
    ``interpolation_dt``, ``motion_time`` (s), ``optimized_plan`` (the spline's waypoints), ``solve_time``,
    ``attempts`` and :meth:`get_interpolated_plan`. ``plan`` is ferrobot's :class:`ferrobot.PlanResult`."""

    def __init__(self, plan, joint_names, interpolation_dt, solve_time, attempts):
        self.plan = plan
        ok = bool(plan is not None and plan.success)
        self.success = np.array([ok])
        self.valid_query = True
        self.status = None if ok else (plan.status if plan is not None else "IK_FAIL")
        self.message = "" if plan is None else plan.message
        self.interpolation_dt = interpolation_dt
        self.solve_time = solve_time
        self.total_time = solve_time
        self.attempts = attempts
        self.joint_names = joint_names
        self.motion_time = np.array([plan.duration if ok else 0.0])
        self._interpolated = None
        if ok:
            traj = plan.interpolated(dt=interpolation_dt)
            self._interpolated = JointState(traj.positions, traj.velocities, traj.accelerations, list(traj.joint_names))
            self.optimized_plan = JointState.from_position(plan.path, joint_names=list(plan.joint_names))
            self.optimized_dt = np.array([interpolation_dt])
        else:
            self.optimized_plan = None

    def get_interpolated_plan(self) -> JointState:
        """The trajectory (T, dof) sampled every ``interpolation_dt`` s, positions, velocities, accelerations."""
        if self._interpolated is None:
            raise InvalidArgumentError(f"get_interpolated_plan: planning failed ({self.status}: {self.message})")
        return self._interpolated

    def get_successful_paths(self) -> list[JointState]:
        return [] if self._interpolated is None else [self._interpolated]


class MotionGen:
    """cuRobo's ``MotionGen`` over :class:`ferrobot.Planner` (see the module docstring)."""

    def __init__(self, config: MotionGenConfig):
        self.config = config
        self.robot = config.robot
        self.planner = config.robot.planner(config.world)
        self.interpolation_dt = config.interpolation_dt
        #: the active joints (cuRobo's ``cspace.joint_names`` less ``lock_joints``), the order of plans
        self.joint_names = list(self.robot.joint_names)
        self.kinematics = self.robot.model
        self.ik_solver = IKSolver.__new__(IKSolver)
        self.ik_solver.config, self.ik_solver.robot, self.ik_solver.planner = config.ik, self.robot, self.planner
        self.ik_solver.joint_names, self.ik_solver.kinematics = list(self.planner.joint_names), self.robot.model

    def warmup(self, *args, **kwargs) -> None:
        """Nothing to warm up (no CUDA graphs); kept for cuRobo scripts."""

    def reset(self, reset_seed: bool = True) -> None:
        """Nothing to reset (plans are seeded per attempt)."""

    def update_world(self, world_config) -> None:
        """Replaces the obstacles (a WorldConfig, cuRobo dict or YAML path, robot base frame)."""
        self.planner.update_world(WorldConfig.load(world_config).to_collision_world())

    def get_retract_config(self) -> np.ndarray:
        if self.robot.retract_config is None:
            return np.zeros(len(self.joint_names))
        names = self.robot.cspace_joint_names
        return np.array([self.robot.retract_config[names.index(n)] for n in self.joint_names])

    def compute_kinematics(self, state: JointState) -> _KinematicsState:
        """End-effector poses for a JointState."""
        js = state.get_ordered_joint_state(self.joint_names) if state.joint_names else state
        return _fk(self.robot.model, self.joint_names, js.position, self.robot.ee_link)

    def _start(self, start_state: JointState) -> tuple[np.ndarray, list[str]]:
        if not isinstance(start_state, JointState):
            raise InvalidArgumentError(f"start_state: expected a JointState, got {type(start_state).__name__}")
        names = start_state.joint_names or self.joint_names
        q = start_state.position.reshape(-1, len(names))
        if len(q) != 1:
            raise ShapeError(f"start_state: plan_single takes one state, got {len(q)}")
        return q[0], list(names)

    def _plan(self, start_state, plan_config, **goal) -> MotionGenResult:
        cfg = plan_config or MotionGenPlanConfig()
        q0, names = self._start(start_state)
        vs, acc = self.config.velocity_scale, self.config.acceleration_scale
        if cfg.time_dilation_factor is not None:
            vs, acc = vs * cfg.time_dilation_factor, acc * cfg.time_dilation_factor**2
        t = time.perf_counter()
        plan = None
        for attempt in range(cfg.max_attempts):
            plan = self.planner.plan(
                q0,
                joint_names=names,
                time_limit=cfg.timeout,
                seed=attempt,
                velocity_scale=vs,
                acceleration_scale=acc,
                **goal,
            )
            # a goal or start in collision will not change with another seed
            if plan.success or plan.status in (
                "start_in_collision",
                "goal_in_collision",
                "start_out_of_limits",
                "goal_out_of_limits",
            ):
                break
        return MotionGenResult(plan, self.joint_names, self.interpolation_dt, time.perf_counter() - t, attempt + 1)

    def plan_single(
        self, start_state: JointState, goal_pose: Pose, plan_config: MotionGenPlanConfig | None = None, link_poses=None
    ) -> MotionGenResult:
        """Plans from ``start_state`` to the end-effector pose ``goal_pose`` (robot base frame)."""
        if link_poses:
            raise InvalidArgumentError("link_poses: goals for several links are not supported")
        if goal_pose.batch != 1:
            raise ShapeError(f"goal_pose: plan_single takes one pose, got {goal_pose.batch} (use plan_goalset)")
        return self._plan(start_state, plan_config, goal_pose=goal_pose.as_7()[0])

    def plan_goalset(
        self, start_state: JointState, goal_pose: Pose, plan_config: MotionGenPlanConfig | None = None
    ) -> MotionGenResult:
        """Plans to whichever of the poses in ``goal_pose`` (N poses) is reachable."""
        return self._plan(start_state, plan_config, goal_pose=goal_pose.as_7())

    def plan_single_js(
        self, start_state: JointState, goal_state: JointState, plan_config: MotionGenPlanConfig | None = None
    ) -> MotionGenResult:
        """Plans to a joint-space goal (``goal_state`` in the same joint names as ``start_state``)."""
        q0, names = self._start(start_state)
        g = goal_state.get_ordered_joint_state(names) if goal_state.joint_names else goal_state
        return self._plan(start_state, plan_config, goal_q=g.position.reshape(-1, len(names))[0])
