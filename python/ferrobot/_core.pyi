"""Type stubs of the Rust extension module ``ferrobot._core``."""

from collections.abc import Iterator, Sequence
from os import PathLike
from typing import Any, TypedDict, final

import numpy as np
import numpy.typing as npt
from typing_extensions import Self, Unpack

__version__: str
# The extension's exported names (checked against the module by tests/test_stubs.py).
__all__ = [
    "RobotModel",
    "CollisionWorld",
    "SphereModel",
    "CollisionChecker",
    "Planner",
    "PlanResult",
    "IkResult",
    "JointTrajectory",
    "World",
    "Robot",
    "Camera",
    "JointPID",
    "ResolvedRateController",
    "depth_to_points",
    "opencv_to_opengl",
    "opengl_to_opencv",
    "look_at",
    "load_mesh",
    "bundled_robot",
    "ReactiveController",
    "PotentialFieldController",
    "grasp_detect",
    "grasp_detect_rgbd",
    "grasp_nms",
    "grasp_transform",
    "grasp_camera_to_world",
    "step_worlds",
    "execute_trajectories",
    "CommandDelay",
    "LinearPredictor",
    "StreamGuard",
    "EncoderNoise",
    "DepthNoise",
    "Arbiter",
    "camera_backproject",
    "camera_check_intrinsics",
    "camera_convert_pose",
    "urdf_check",
    "gravity_torques",
    "payload_regressor",
    "identify_payload",
    "identify_link_masses",
    "identify_friction",
    "trajectory_sample",
    "PlanOptions",
    "IkOptions",
    "DetectOptions",
    "__version__",
    "Gripper",
    # typed results (results.rs)
    "PlanTimes",
    "JointLimits",
    "WorldSyncStats",
    "TrackingReport",
    "ControlStepInfo",
    "DriveGains",
    "RenderFrame",
    "CollisionDistance",
    "Contact",
    "SelfCollisionAnalysis",
    "SphereFit",
    "SphereDistances",
    "Clearance",
    "GuidancePlan",
    "LinkInertial",
    "Inertial",
    "JointInfo",
    "Lighting",
    "PayloadFit",
    "LinkMassFit",
    "FrictionFit",
    "ArbiterConflict",
    "StreamGuardStep",
    "DepthNoiseParams",
    "UrdfFinding",
    "UrdfCheckReport",
    "LoadedMesh",
]

_ArrayLike = npt.ArrayLike
_F64 = npt.NDArray[np.float64]

class _ObjectProps(TypedDict, total=False):
    """Keywords of every ``World.add_*``: defaults mass 1 kg, friction 0.5, restitution 0, fixed False, grey."""

    mass: float
    friction: float
    restitution: float
    fixed: bool
    color: _ArrayLike | None

def bundled_robot(name: str) -> tuple[str, str, str]:
    """(URDF text, SRDF text, default ee link) of a bundled robot."""

@final
class RobotModel:
    """A robot model loaded from URDF (and optionally SRDF)."""

    @staticmethod
    def from_urdf(
        path: str | PathLike[str],
        *,
        srdf: str | PathLike[str] | None = None,
        package_dirs: list[str | PathLike[str]] | None = None,
        base_link: str | None = None,
        ee_link: str | None = None,
        group: str | None = None,
        strict: bool = False,
    ) -> RobotModel: ...
    @staticmethod
    def from_urdf_string(
        text: str,
        *,
        srdf: str | PathLike[str] | None = None,
        package_dirs: list[str | PathLike[str]] | None = None,
        base_link: str | None = None,
        ee_link: str | None = None,
        group: str | None = None,
        strict: bool = False,
    ) -> RobotModel: ...
    @staticmethod
    def from_usd(
        path: str | PathLike[str],
        *,
        root: str | None = None,
        srdf: str | PathLike[str] | None = None,
        base_link: str | None = None,
        ee_link: str | None = None,
        group: str | None = None,
    ) -> RobotModel:
        """A UsdPhysics articulation (needs usd-core; see ferrobot.usd)."""
    def to_usd(self, path: str | PathLike[str]) -> Any:
        """Writes the model as USD (needs usd-core; see ferrobot.usd.write_usd); returns the path."""
    @property
    def srdf_warnings(self) -> list[str]: ...
    @property
    def name(self) -> str: ...
    @property
    def dof_names(self) -> list[str]: ...
    @property
    def num_dof(self) -> int: ...
    @property
    def link_names(self) -> list[str]: ...
    @property
    def joint_names(self) -> list[str]: ...
    @property
    def lower_limits(self) -> _F64: ...
    @property
    def upper_limits(self) -> _F64: ...
    @property
    def velocity_limits(self) -> _F64: ...
    @property
    def effort_limits(self) -> _F64: ...
    @property
    def base_link(self) -> str: ...
    @property
    def ee_link(self) -> str: ...
    @property
    def group_name(self) -> str | None: ...
    @property
    def group_dof_indices(self) -> list[int]: ...
    @property
    def group_dof_names(self) -> list[str]: ...
    @property
    def mimic_joints(self) -> list[tuple[str, tuple[str, float, float]]]: ...
    @property
    def group_names(self) -> list[str]: ...
    @property
    def named_states(self) -> list[tuple[str, str]]: ...
    @property
    def disabled_collision_pairs(self) -> list[tuple[str, str, str]]: ...
    def group_joint_names(self, group: str) -> list[str]: ...
    def named_state(self, name: str, group: str | None = None) -> _F64: ...
    def neutral_configuration(self) -> _F64: ...
    def joint_info(self, name: str) -> JointInfo: ...
    def collision_geometry(self, link: str) -> list[dict[str, Any]]: ...
    def visual_geometry(self, link: str) -> list[dict[str, Any]]: ...
    def inertial(self, link: str) -> Inertial: ...
    def fk(self, q: _ArrayLike, link: str | None = None) -> _F64:
        """4x4 pose of ``link`` (default: ee) in the base frame."""
    def fk_all(self, q: _ArrayLike) -> _F64:
        """(num_links, 4, 4) poses in ``link_names`` order."""
    def fk_batch(self, q: _ArrayLike, link: str | None = None) -> _F64:
        """(N, 7) poses ``[x, y, z, qw, qx, qy, qz]`` for (N, num_dof) configurations."""
    def jacobian(self, q: _ArrayLike, link: str | None = None) -> _F64:
        """(6, num_dof) geometric Jacobian in the base frame, linear rows first."""

_Pose = _ArrayLike  # 4x4 matrix or [x, y, z, qw, qx, qy, qz]

@final
class CollisionWorld:
    """Named obstacles posed in the world (robot base) frame."""

    def __new__(cls) -> Self: ...
    @staticmethod
    def from_sim(world: World, ignore: str | list[str] | None = None, base_pose: _Pose | None = None) -> CollisionWorld:
        """Obstacles of a simulated World at their current poses, in the frame of ``base_pose``; ``ignore``
        substrings leave objects out (the ground plane is a slab named "ground")."""
    @staticmethod
    def from_moveit_scene(path: str | PathLike[str]) -> CollisionWorld: ...
    def add_box(self, name: str, size: _ArrayLike, pose: _Pose | None = None) -> None: ...
    def add_sphere(self, name: str, radius: float, pose: _Pose | None = None) -> None: ...
    def add_cylinder(self, name: str, radius: float, length: float, pose: _Pose | None = None) -> None: ...
    def add_capsule(self, name: str, radius: float, length: float, pose: _Pose | None = None) -> None: ...
    def add_mesh(self, name: str, vertices: _ArrayLike, faces: _ArrayLike, pose: _Pose | None = None) -> None: ...
    def add_pointcloud(
        self, name: str, points: _ArrayLike, radius: float = 0.005, pose: _Pose | None = None
    ) -> None: ...
    def remove(self, name: str) -> None: ...
    def set_pose(self, name: str, pose: _Pose) -> None: ...
    def get_pose(self, name: str) -> _F64: ...
    @property
    def names(self) -> list[str]: ...
    def kinds(self, name: str) -> list[str]: ...
    def signed_distance(self, points: _ArrayLike) -> _F64: ...
    def __len__(self) -> int: ...
    def __contains__(self, name: str, /) -> bool: ...

@final
class SphereModel:
    """A robot's sphere model: spheres per link in the link frame."""

    @staticmethod
    def automatic(
        model: RobotModel,
        *,
        tolerance: float = 0.001,
        total_budget: int | None = None,
        max_per_link: int | None = None,
        seed: int = 0,
    ) -> SphereModel: ...
    @staticmethod
    def from_spherized_urdf(model: RobotModel, path: str | PathLike[str]) -> SphereModel: ...
    @staticmethod
    def load(model: RobotModel, path: str | PathLike[str]) -> SphereModel: ...
    def save(self, path: str | PathLike[str]) -> None: ...
    def to_yaml(self) -> str: ...
    @property
    def count(self) -> int: ...
    def spheres(self, link: str) -> _F64: ...
    @property
    def report(self) -> list[SphereFit]: ...

@final
class CollisionChecker:
    """Collision queries for a robot in a world."""

    def __new__(
        cls,
        model: RobotModel,
        world: CollisionWorld | None = None,
        spheres: SphereModel | None = None,
        *,
        margin: float = 0.0,
    ) -> Self: ...
    def update_world(self, world: CollisionWorld) -> None: ...
    @property
    def world(self) -> CollisionWorld: ...
    margin: float
    def in_collision(self, q: _ArrayLike) -> bool: ...
    def in_collision_batch(self, q: _ArrayLike) -> npt.NDArray[np.bool_]: ...
    def motion_valid(self, q0: _ArrayLike, q1: _ArrayLike, resolution: float = 0.005) -> bool: ...
    def distance(self, q: _ArrayLike) -> CollisionDistance: ...
    def contacts(self, q: _ArrayLike) -> list[Contact]: ...
    def explain(self, q: _ArrayLike) -> str: ...
    def analyze_self_collisions(self, samples: int = 10000, seed: int = 0) -> SelfCollisionAnalysis: ...
    @property
    def allowed_collision_pairs(self) -> list[tuple[str, str, str]]: ...
    def allowed_collisions_srdf(self) -> str: ...
    def attach(
        self,
        name: str,
        link: str,
        shape: tuple[Any, ...],
        pose: _Pose | None = None,
        touch_links: list[str] = ...,
    ) -> None: ...
    def attach_world_object(self, name: str, link: str, q: _ArrayLike, touch_links: list[str] = ...) -> None: ...
    def detach(self, name: str, q: _ArrayLike | None = None) -> None: ...
    @property
    def attached(self) -> list[str]: ...
    @property
    def num_spheres(self) -> int: ...

# --- Simulation (ferrobot-sim on Rapier) ---

@final
class World:
    """A physics world: ground plane at z = 0, rigid objects, robots; z is up."""

    def __new__(
        cls,
        dt: float = 1 / 240,
        gravity: _ArrayLike | None = None,
        solver_iterations: int = 4,
        ground: bool = True,
        ground_friction: float = 0.8,
        *,
        contact_frequency: float = ...,  # 100.0 Hz
        allowed_penetration: float = ...,  # 0.001 m
        contact_damping_ratio: float = ...,  # 1.0
        friction_in_stabilization: bool = True,
    ) -> Self:
        """``friction_in_stabilization=True`` holds grasped objects to < 0.5 mm but topples stacks of 6+ boxes."""
    @property
    def dt(self) -> float: ...
    @property
    def time(self) -> float: ...
    @property
    def num_steps(self) -> int: ...
    @property
    def object_names(self) -> list[str]: ...
    @property
    def segmentation_labels(self) -> dict[int, str]:
        """Segmentation id -> name: 0 background, 1 ground, objects, "robot/link"."""
    def set_lighting(
        self,
        ambient: _ArrayLike | None = None,
        headlight: float = 0.65,
        lights: Sequence[tuple[_ArrayLike, _ArrayLike, float]] | None = None,
    ) -> None:
        """Lambert lighting of RGB renders: ambient (r, g, b) in [0, 1] (default 0.35 each), headlight in [0, 1],
        at most 8 directional lights (direction of travel in the world frame, colour in [0, 1]^3, intensity in
        [0, 10]). Pixel = 255 * albedo * (ambient + headlight * |n.r| + sum(colour * intensity * max(0, -n.l)))."""
    @property
    def lighting(self) -> Lighting:
        """``ambient`` [r, g, b], ``headlight``, ``lights`` [(direction, color, intensity), ...]."""
    def add_box(
        self,
        name: str,
        size: _ArrayLike,
        pose: _Pose | None = None,
        **props: Unpack[_ObjectProps],
    ) -> str: ...
    def add_sphere(
        self,
        name: str,
        radius: float,
        pose: _Pose | None = None,
        **props: Unpack[_ObjectProps],
    ) -> str: ...
    def add_cylinder(
        self,
        name: str,
        radius: float,
        length: float,
        pose: _Pose | None = None,
        **props: Unpack[_ObjectProps],
    ) -> str: ...
    def add_capsule(
        self,
        name: str,
        radius: float,
        length: float,
        pose: _Pose | None = None,
        **props: Unpack[_ObjectProps],
    ) -> str: ...
    def add_mesh(
        self,
        name: str,
        vertices: _ArrayLike,
        faces: _ArrayLike,
        pose: _Pose | None = None,
        *,
        approximation: str = "convex_hull",
        **props: Unpack[_ObjectProps],
    ) -> str:
        """``approximation``: "convex_hull", "convex_decomposition" or "trimesh" (static only)."""
    def add_mesh_file(
        self,
        name: str,
        path: str | PathLike[str],
        pose: _Pose | None = None,
        *,
        scale: float | _ArrayLike | None = None,
        approximation: str | None = None,
        density: float | None = None,
        resolution: int = 64,
        concavity: float = 0.01,
        max_convex_hulls: int = 32,
        **props: Unpack[_ObjectProps],
    ) -> str:
        """A mesh file (OBJ, STL, DAE); ``approximation`` None: "trimesh" if fixed, else "convex_decomposition"
        (V-HACD, cached per file, scale and parameters); mass or density (kg/m^3). Bad files raise MeshError."""
    def get_object_pose(self, name: str) -> _F64: ...
    def set_object_pose(self, name: str, pose: _Pose) -> None: ...
    def get_object_velocity(self, name: str) -> tuple[_F64, _F64]: ...
    def set_object_velocity(self, name: str, linear: _ArrayLike, angular: _ArrayLike | None = None) -> None: ...
    def add_robot(
        self,
        model: RobotModel,
        pose: _Pose | None = None,
        *,
        name: str = ...,
        q: _ArrayLike | None = None,
        gravity_compensation: bool = True,
        solver_iterations: int = 4,
        friction: float = 1.0,
    ) -> Robot: ...
    def step(self, n: int = 1, *, render: bool = False, step_sim: bool = True) -> None:
        """Advance ``n`` steps; raises ``errors.SimulationDiverged`` if the simulation blows up."""
    def reset(self) -> None: ...
    def mark_initial_state(self) -> None: ...

@final
class Robot:
    """A robot simulated in a World (API after Isaac Sim's Robot); joint vectors in ``dof_names`` order."""

    @property
    def name(self) -> str: ...
    @property
    def model(self) -> RobotModel: ...
    @property
    def dof_names(self) -> list[str]: ...
    @property
    def num_dof(self) -> int: ...
    @property
    def joint_positions(self) -> _F64:
        """Joint positions (num_dof,; rad or m)."""
    @property
    def joint_velocities(self) -> _F64:
        """Joint velocities (num_dof,; rad/s or m/s)."""
    def get_joint_positions(self) -> _F64:
        """Deprecated: read ``joint_positions``."""
    def get_joint_velocities(self) -> _F64:
        """Deprecated: read ``joint_velocities``."""
    def get_joint_position_targets(self) -> _F64:
        """Deprecated: read ``joint_position_targets``."""
    def get_applied_joint_efforts(self) -> _F64:
        """Deprecated: read ``applied_joint_efforts``."""
    def get_measured_joint_efforts(self) -> _F64:
        """Deprecated: read ``measured_joint_efforts``."""
    def get_gripper_positions(self) -> _F64:
        """Deprecated: read ``gripper_positions``."""
    def get_world_transform(self) -> _F64:
        """Deprecated: read ``world_transform``."""
    def get_gripper_opening(self) -> float:
        """Deprecated: read ``gripper_opening``."""
    def mass_matrix(self) -> _F64: ...
    def set_joint_positions(self, q: _ArrayLike) -> None: ...
    def set_joint_velocities(self, qd: _ArrayLike) -> None: ...
    def set_joint_position_targets(
        self, targets: _ArrayLike, joint_indices: list[int] | None = None, *, joint_names: list[str] | None = None
    ) -> None: ...
    def set_joint_velocity_targets(
        self, targets: _ArrayLike, joint_indices: list[int] | None = None, *, joint_names: list[str] | None = None
    ) -> None: ...
    def set_joint_efforts(
        self, efforts: _ArrayLike, joint_indices: list[int] | None = None, *, joint_names: list[str] | None = None
    ) -> None: ...
    @property
    def command_latency(self) -> float:
        """Seconds between setting a drive target or effort and its effect (applied in World.step)."""
    @command_latency.setter
    def command_latency(self, latency: float) -> None: ...
    def set_command_latency(self, latency: float) -> None:
        """Deprecated: assign ``command_latency``."""
    @property
    def pending_commands(self) -> int: ...
    @property
    def joint_position_targets(self) -> _F64:
        """Drive position targets (num_dof,; rad or m)."""
    @property
    def drive_gains(self) -> DriveGains: ...
    def get_drive_gains(self) -> tuple[_F64, _F64, _F64]:
        """Deprecated: read ``drive_gains``."""
    def set_drive_gains(
        self,
        stiffness: _ArrayLike,
        damping: _ArrayLike,
        max_force: _ArrayLike | None = None,
        joint_indices: list[int] | None = None,
        *,
        joint_names: list[str] | None = None,
    ) -> None: ...
    def set_solver_iterations(self, n: int) -> None:
        """Extra solver substeps for the robot's bodies while it touches something (default 4)."""
    # Isaac Sim shapes (issue 22)
    def get_world_pose(self) -> tuple[_F64, _F64]:
        """Base link pose as (position (3,), orientation (w, x, y, z))."""
    @property
    def world_transform(self) -> _F64:
        """World pose (4x4) of the base link."""
    def set_world_pose(self, position: _ArrayLike | None = None, orientation: _ArrayLike | None = None) -> None: ...
    def initialize(self, physics_sim_view: Any = None) -> None: ...
    def get_joints_state(self) -> Any:
        """A ferrobot.compat.isaac.JointsState (positions, velocities, efforts)."""
    @property
    def applied_joint_efforts(self) -> _F64:
        """Efforts set with ``set_joint_efforts`` (num_dof,; N·m or N)."""
    def apply_action(self, control_actions: Any) -> None: ...
    def set_solver_position_iteration_count(self, count: int) -> None: ...
    def get_solver_position_iteration_count(self) -> int: ...
    def set_solver_velocity_iteration_count(self, count: int) -> None: ...
    def set_stabilization_threshold(self, threshold: float) -> None: ...
    def get_link_pose(self, link: str | None = None) -> _F64: ...
    def open_gripper(self, force: float | None = None) -> None: ...
    def close_gripper(self, force: float | None = None) -> None: ...
    def set_gripper(self, joint_names: list[str], open: _ArrayLike, closed: _ArrayLike) -> None: ...
    @property
    def gripper_positions(self) -> _F64: ...
    @property
    def gripper_description(self) -> Gripper | None: ...
    def use_gripper(self, gripper: Gripper) -> None: ...
    def set_gripper_opening(self, opening: float, force: float | None = None) -> None: ...
    def set_gripper_driver(self, position: float, force: float | None = None) -> None: ...
    @property
    def gripper_opening(self) -> float:
        """Opening (m) between the pads."""
    def execute_trajectory(
        self,
        positions: _ArrayLike,
        dt: float,
        velocities: _ArrayLike | None = None,
        joint_indices: list[int] | None = None,
        settle_time: float = 0.0,
        *,
        joint_names: list[str] | None = None,
    ) -> TrackingReport:
        """How the drives tracked the positions (``joint_indices`` is deprecated: use ``joint_names``)."""
    def execute(self, trajectory: JointTrajectory | PlanResult, settle_time: float = 0.0) -> TrackingReport:
        """Runs a planned motion (joints matched by name; a PlanResult is sampled at the world's dt)."""
    # Sim-to-real additions.
    def set_link_inertial(self, link: str, mass: float, com: _ArrayLike, inertia: _ArrayLike) -> None:
        """Replaces a link's mass, centre of mass (3,) and inertia (3, 3) at run time."""
    def get_link_inertial(self, link: str) -> LinkInertial:
        """The simulated link's mass, com (3,) and inertia (3, 3) in the link frame."""
    def set_joint_dynamics(self, joint: str, damping: float, friction: float) -> None:
        """Sets a DOF's viscous damping and dry (Coulomb) friction."""
    def get_joint_dynamics(self, joint: str) -> tuple[float, float]:
        """A DOF's (damping, friction)."""
    @property
    def measured_joint_efforts(self) -> _F64:
        """Efforts the drives apply now (drive law at the current state, plus set efforts)."""

@final
class Camera:
    """Pinhole camera (OpenCV frame: x right, y down, z forward) fixed to the world or a robot link."""

    def __new__(
        cls,
        world: World,
        width: int,
        height: int,
        fx: float,
        fy: float | None = None,
        cx: float | None = None,
        cy: float | None = None,
        pose: _Pose | None = None,
        *,
        robot: Robot | None = None,
        link: str | None = None,
        near: float = 0.01,
        far: float = 100.0,
    ) -> Self: ...
    @property
    def width(self) -> int: ...
    @property
    def height(self) -> int: ...
    @property
    def intrinsic_matrix(self) -> _F64: ...
    @property
    def local_pose(self) -> _F64:
        """Pose (4x4) relative to the mount (OpenCV frame); assignable."""
    @local_pose.setter
    def local_pose(self, pose: _Pose) -> None: ...
    @property
    def world_transform(self) -> _F64:
        """World pose (4x4) of the OpenCV camera frame."""
    def get_local_pose(self) -> _F64:
        """Deprecated: read ``local_pose``."""
    def set_local_pose(self, pose: _Pose) -> None:
        """Deprecated: assign ``local_pose``."""
    def get_world_transform(self) -> _F64:
        """Deprecated: read ``world_transform``."""
    def get_world_pose(self, camera_axes: str = "world") -> tuple[_F64, _F64]: ...
    def render(self, rgb: bool = True) -> RenderFrame:
        """``depth`` (H, W) float32 (inf: no hit), ``segmentation`` (H, W) int32, ``rgb`` (H, W, 3) uint8 or None."""
    def depth_to_points(self, depth: _ArrayLike) -> tuple[_F64, npt.NDArray[np.int64]]: ...

def depth_to_points(
    depth: _ArrayLike, fx: float, fy: float, cx: float, cy: float
) -> tuple[_F64, npt.NDArray[np.int64]]: ...
def opencv_to_opengl(pose: _Pose) -> _F64: ...
def opengl_to_opencv(pose: _Pose) -> _F64: ...
def load_mesh(
    path: str | PathLike[str],
    scale: float | _ArrayLike | None = None,
    *,
    resolution: int = 64,
    concavity: float = 0.01,
    max_convex_hulls: int = 32,
) -> LoadedMesh:
    """An object mesh, checked and decomposed (cached): vertices, faces, parts [(vertices, faces)], volume, closed."""

def look_at(eye: _ArrayLike, target: _ArrayLike, up: _ArrayLike | None = None) -> _F64: ...

# --- cameras (crates/ferrobot-py/src/camera.rs; used through ferrobot.camera) ---

def camera_check_intrinsics(
    width: int, height: int, fx: float, fy: float, cx: float, cy: float, depth_scale: float
) -> None:
    """Raises the matching ferrobot.errors class for invalid intrinsics."""

def camera_backproject(
    depth: _ArrayLike,
    width: int,
    height: int,
    fx: float,
    fy: float,
    cx: float,
    cy: float,
    depth_scale: float,
    workspace: _ArrayLike | None = None,
) -> tuple[_F64, npt.NDArray[np.int64]]:
    """Back-projected points (N, 3) (OpenCV camera frame) and their pixels (N, 2) as (row, column)."""

def camera_convert_pose(pose: _ArrayLike, from_: str, to: str) -> _F64:
    """The 4x4 pose in convention ``to`` of a camera whose pose in convention ``from_`` is ``pose``."""

@final
class JointPID:
    """Joint-space PID with anti-windup (integral clamp + conditional integration)."""

    def __new__(
        cls,
        kp: _ArrayLike,
        ki: _ArrayLike | float,
        kd: _ArrayLike | float,
        integral_limit: _ArrayLike | float | None = None,
        output_limit: _ArrayLike | float | None = None,
    ) -> Self: ...
    def update(
        self, q: _ArrayLike, qd: _ArrayLike, target: _ArrayLike, dt: float, target_velocity: _ArrayLike | None = None
    ) -> _F64: ...
    @property
    def integral(self) -> _F64: ...
    def reset(self) -> None: ...

@final
class ResolvedRateController:
    """Cartesian resolved-rate control through the damped Jacobian pseudo-inverse."""

    def __new__(
        cls,
        model: RobotModel,
        link: str | None = None,
        joint_indices: list[int] | None = None,
        linear_gain: float = 5.0,
        angular_gain: float = 5.0,
        damping: float = 0.05,
        max_linear_speed: float = 0.5,
        max_angular_speed: float = 1.5,
        *,
        joint_names: list[str] | None = None,
    ) -> Self: ...
    def compute(self, q: _ArrayLike, target: _Pose) -> _F64: ...

@final
class JointTrajectory:
    """A trajectory sampled every ``dt`` seconds (the last sample at its end)."""

    dt: float
    joint_names: list[str]
    @property
    def times(self) -> npt.NDArray[np.float64]: ...
    @property
    def positions(self) -> npt.NDArray[np.float64]: ...
    @property
    def velocities(self) -> npt.NDArray[np.float64]: ...
    @property
    def accelerations(self) -> npt.NDArray[np.float64]: ...
    def __len__(self) -> int: ...

@final
class PlanResult:
    """Outcome of ``Planner.plan``; failures are reported in ``status``, never raised."""

    success: bool
    status: str
    message: str
    joint_names: list[str]
    samples: int
    stops_at_waypoints: bool
    recheck_samples: int
    refinements: int
    path_length: float
    duration: float | None
    @property
    def path(self) -> npt.NDArray[np.float64]: ...
    @property
    def goal(self) -> npt.NDArray[np.float64] | None: ...
    @property
    def times(self) -> PlanTimes: ...
    def interpolated(self, dt: float = 0.01) -> JointTrajectory: ...
    def __bool__(self) -> bool: ...

@final
class IkResult:
    """IK outcome: scalars for one solve, arrays for a batch."""

    joint_names: list[str]
    @property
    def success(self) -> bool | npt.NDArray[np.bool_]: ...
    @property
    def q(self) -> npt.NDArray[np.float64]: ...
    @property
    def position_error(self) -> float | npt.NDArray[np.float64]: ...
    @property
    def rotation_error(self) -> float | npt.NDArray[np.float64]: ...
    @property
    def goal_index(self) -> int | npt.NDArray[np.int64]: ...
    @property
    def seeds_tried(self) -> int | npt.NDArray[np.int64]: ...
    def __len__(self) -> int: ...

@final
class Planner:
    """Multi-seed IK, RRT-Connect, shortcutting and time-parametrised smooth trajectories."""

    def __new__(
        cls,
        model: RobotModel,
        world: CollisionWorld | None = None,
        spheres: SphereModel | None = None,
        *,
        margin: float = 0.0,
        ee_link: str | None = None,
    ) -> Self: ...
    joint_names: list[str]
    dof_names: list[str]
    ee_link: str
    @property
    def locked_positions(self) -> npt.NDArray[np.float64]: ...
    @locked_positions.setter
    def locked_positions(self, q: npt.ArrayLike) -> None: ...
    def set_locked_positions(self, q: npt.ArrayLike) -> None:
        """Deprecated: assign ``locked_positions``."""
    @property
    def limits(self) -> JointLimits: ...
    def set_limits(
        self,
        *,
        velocity: npt.ArrayLike | None = None,
        acceleration: npt.ArrayLike | None = None,
        jerk: npt.ArrayLike | None = None,
    ) -> None: ...
    def update_world(
        self, world: CollisionWorld | World, ignore: str | list[str] | None = None, base_pose: _Pose | None = None
    ) -> None:
        """Sets the world: a CollisionWorld (base frame; a copy without the ``ignore`` matches replaces it) or a
        simulated World seen from ``base_pose``, synced in place (poses moved, objects added/removed, hulls
        made once; ``ignore`` matches stay in the world but are ignored by every query). Attached objects
        stay out."""
    def set_object_enabled(self, name: str, enabled: bool) -> None:
        """Ignores (False) or enables world object ``name`` without rebuilding the world."""
    @property
    def ignored_objects(self) -> list[str]: ...
    @property
    def world_sync_stats(self) -> WorldSyncStats:
        """Scene-sync counters: full_builds, incremental, added, removed, moved."""
    def attach_world_object(
        self,
        name: str,
        q: npt.ArrayLike,
        link: str | None = None,
        touch_links: list[str] | None = None,
        joint_names: list[str] | None = None,
    ) -> None: ...
    def detach(self, name: str, q: npt.ArrayLike | None = None, joint_names: list[str] | None = None) -> None: ...
    @property
    def attached(self) -> list[str]: ...
    @property
    def sphere_model(self) -> SphereModel:
        """The robot's spheres used by this planner (``report`` empty)."""
    @property
    def world(self) -> CollisionWorld: ...
    def in_collision(self, q: npt.ArrayLike, joint_names: list[str] | None = None) -> bool: ...
    def ik(
        self,
        goal_pose: npt.ArrayLike,
        start: npt.ArrayLike | None = None,
        *,
        link: str | None = None,
        joint_names: list[str] | None = None,
        options: IkOptions | None = None,
        seed: int | npt.ArrayLike | None = None,
        random_seed: int | None = None,
        **overrides: Unpack[_IkOverrides],
    ) -> IkResult:
        """``start``: the first start configuration (then random ones); ``seed``: the random seed. Deprecated:
        ``seed=<configuration>`` (use ``start``), ``random_seed`` (use ``seed``)."""
    def ik_goalset(
        self,
        goal_poses: npt.ArrayLike,
        start: npt.ArrayLike | None = None,
        *,
        link: str | None = None,
        joint_names: list[str] | None = None,
        options: IkOptions | None = None,
        seed: int | npt.ArrayLike | None = None,
        random_seed: int | None = None,
        **overrides: Unpack[_IkOverrides],
    ) -> IkResult:
        """``start``: the first start configuration (then random ones); ``seed``: the random seed. Deprecated:
        ``seed=<configuration>`` (use ``start``), ``random_seed`` (use ``seed``)."""
    def ik_batch(
        self,
        goal_poses: npt.ArrayLike,
        starts: npt.ArrayLike | None = None,
        *,
        link: str | None = None,
        joint_names: list[str] | None = None,
        options: IkOptions | None = None,
        seed: int | None = None,
        seeds: npt.ArrayLike | None = None,
        random_seed: int | None = None,
        **overrides: Unpack[_IkOverrides],
    ) -> IkResult:
        """``starts``: (N, k) start configurations; ``seed``: the random seed. Without ``starts``, a batch of
        64 or more poses starts each pose from the nearest-pose entry of a 512-configuration random library
        (made from ``seed``; it counts as one of the seeds tried). Deprecated: ``seeds`` (use ``starts``),
        ``random_seed`` (use ``seed``)."""
    def plan(
        self,
        start: npt.ArrayLike,
        goal_q: npt.ArrayLike | None = None,
        goal_pose: npt.ArrayLike | None = None,
        joint_names: list[str] | None = None,
        *,
        options: PlanOptions | None = None,
        **overrides: Unpack[_PlanOverrides],
    ) -> PlanResult:
        """Options: ``options`` (default ``PlanOptions()``) with ``**overrides`` (any ``PlanOptions`` field)."""

# --- grasp detection (used through ferrobot.grasp) ---

_I64 = npt.NDArray[np.int64]

def grasp_detect(
    points: _ArrayLike,
    labels: npt.NDArray[np.int32] | None = None,
    seedable: npt.NDArray[np.bool_] | None = None,
    options: DetectOptions | None = None,
    gripper: Gripper | None = None,
    **overrides: Unpack[_DetectOverrides],
) -> _F64:
    """Grasps (M, 17) detected in a point cloud (N, 3), best first."""

def grasp_detect_rgbd(
    depth: _ArrayLike,
    fx: float,
    fy: float,
    cx: float,
    cy: float,
    scale: float,
    mask: npt.NDArray[np.int32] | None = None,
    object_id: int | None = None,
    workspace: _ArrayLike | None = None,
    options: DetectOptions | None = None,
    gripper: Gripper | None = None,
    **overrides: Unpack[_DetectOverrides],
) -> _F64:
    """Grasps (M, 17) detected in a depth image (H, W), best first, camera frame."""

def grasp_nms(grasps: _ArrayLike, translation: float = 0.03, rotation: float = ...) -> _I64:
    """Indices of the grasps (N, 17) kept by non-maximum suppression, best first."""

def grasp_transform(grasps: _ArrayLike, pose: _ArrayLike) -> _F64:
    """Grasps (N, 17) moved by a pose (4x4 or [x, y, z, qw, qx, qy, qz])."""

def grasp_camera_to_world(camera_pose: _ArrayLike, convention: str = "opencv") -> _F64:
    """4x4 transform from OpenCV-optical camera coordinates to the world."""

# batch stepping (crates/ferrobot-py/src/batch.rs)
def step_worlds(worlds: list[World], n: int = 1) -> None:
    """Steps each (distinct) world n times, in parallel on all cores with the GIL released."""

def execute_trajectories(
    worlds: list[World],
    robots: list[str],
    positions: list[_ArrayLike],
    dt: float,
    joint_indices: list[list[int]],
) -> None:
    """Robot.execute_trajectory once per (distinct) world, in parallel with the GIL released."""

# Sim-to-real tools (crates/ferrobot-py/src/sim2real.rs).

def urdf_check(
    path: str | PathLike[str],
    srdf: str | PathLike[str] | None = None,
    package_dirs: list[str] | None = None,
    skip_coverage: bool = False,
) -> UrdfCheckReport:
    """Checks a URDF: robot, source, tree (text) and findings (severity, code, line, element, message)."""

def gravity_torques(model: RobotModel, q: _ArrayLike, gravity: _ArrayLike) -> _F64:
    """Joint efforts holding the model still at q against gravity (base frame)."""

def payload_regressor(model: RobotModel, q: _ArrayLike, link: str, gravity: _ArrayLike) -> _F64:
    """(num_dof, 4) regressor: efforts = Y @ [m, m cx, m cy, m cz]."""

def identify_payload(
    model: RobotModel,
    link: str,
    qs: _ArrayLike,
    efforts: _ArrayLike,
    gravity: _ArrayLike,
    dofs: list[int] | None = None,
) -> PayloadFit:
    """Payload (mass, com) on a link from static efforts, with the fit quality."""

def identify_link_masses(
    model: RobotModel, links: list[str], qs: _ArrayLike, efforts: _ArrayLike, gravity: _ArrayLike
) -> LinkMassFit:
    """Mass offsets of links from static efforts, with the fit quality."""

def identify_friction(velocities: _ArrayLike, efforts: _ArrayLike, min_speed: float = 1e-3) -> FrictionFit:
    """Coulomb and viscous friction fitted to (velocity, effort) samples."""

def trajectory_sample(positions: _ArrayLike, dt: float, t: float) -> _F64:
    """A trajectory (N, n) sampled every dt, at time t (interpolated, held at the ends)."""

@final
class CommandDelay:
    """Commands issued at t take effect at t + delay."""

    def __new__(cls, delay: float, width: int) -> Self: ...
    @property
    def delay(self) -> float: ...
    @property
    def pending(self) -> int: ...
    def push(self, t: float, command: _ArrayLike) -> None: ...
    def pop_due(self, t: float) -> _F64 | None: ...
    def clear(self) -> None: ...

@final
class LinearPredictor:
    """Linear extrapolation of a command stream by a horizon."""

    def __new__(cls, horizon: float) -> Self: ...
    def update(self, t: float, c: _ArrayLike) -> _F64: ...

@final
class StreamGuard:
    """Holds on a command dropout and rate-limits the resume."""

    def __new__(cls, timeout: float, max_velocity: _ArrayLike) -> Self: ...
    def update(self, t: float, command: _ArrayLike | None, current: _ArrayLike) -> StreamGuardStep: ...

# --- fault injection (ferrobot_control::faults; wrapped by ferrobot.scenarios) ---

@final
class EncoderNoise:
    """Gaussian joint encoder noise then quantisation."""

    def __new__(cls, sigma: _ArrayLike, resolution: float = 0.0, seed: int = 0) -> Self: ...
    def apply(self, q: _ArrayLike) -> _F64: ...

@final
class DepthNoise:
    """Depth noise: axial sigma0 + sigma2 (z - z0)^2, random and edge dropout."""

    def __new__(
        cls,
        *,
        sigma0: float | None = None,
        sigma2: float | None = None,
        z0: float | None = None,
        dropout: float | None = None,
        edge_threshold: float | None = None,
        edge_dropout: float | None = None,
        missing_value: float | None = None,
        seed: int | None = None,
    ) -> Self:
        """Parameters left out take the Rust defaults (``DepthNoiseParams::default()``)."""
    def params(self) -> DepthNoiseParams: ...
    def sigma(self, z: _ArrayLike) -> _F64: ...
    def edges(self, depth: _ArrayLike) -> npt.NDArray[np.bool_]: ...
    def apply(self, depth: _ArrayLike) -> tuple[_F64, npt.NDArray[np.bool_]]: ...

@final
class Arbiter:
    """Priority, then latest command, then registration order; conflicts recorded."""

    def __new__(cls, num_joints: int, timeout: float, tolerance: float) -> Self: ...
    @property
    def sources(self) -> list[str]: ...
    @property
    def conflicts(self) -> list[ArbiterConflict]: ...
    def add_source(self, name: str, priority: int) -> None: ...
    def command(self, source: str, t: float, joints: list[int], values: _ArrayLike) -> None: ...
    def resolve(self, t: float) -> tuple[_F64, list[str | None]]: ...

# --- reactive control (ferrobot-control) ---

class _ControllerBase:  # stub-only: the methods both controller classes define
    def __new__(
        cls,
        model: RobotModel,
        world: CollisionWorld | None = None,
        spheres: SphereModel | None = None,
        *,
        ee_link: str | None = None,
        config: dict[str, float] | None = None,
        self_collision_samples: int = 2000,
    ) -> Self: ...
    @staticmethod
    def config_ranges() -> dict[str, tuple[float, float]]:
        """Every gain's accepted range {name: (low, high)}, inclusive."""
    @property
    def config(self) -> dict[str, float]: ...
    def set_config(self, config: dict[str, float]) -> None: ...
    @property
    def dof_names(self) -> list[str]: ...
    @property
    def active_joints(self) -> list[str]: ...
    @property
    def num_spheres(self) -> int: ...
    @property
    def num_self_pairs(self) -> int: ...
    def set_target(self, pose: _Pose, orientation: bool = True) -> None: ...
    def clear_target(self) -> None: ...
    @property
    def target(self) -> _F64 | None: ...
    def set_posture(self, q: _ArrayLike) -> None: ...
    def update_world(self, world: CollisionWorld) -> None: ...
    def set_obstacle_pose(self, name: str, pose: _Pose, velocity: _ArrayLike | None = None) -> None:
        """Moves an obstacle; ``velocity`` (3,) m/s or (6,) with angular rad/s, base frame."""
    def step(
        self, q: _ArrayLike, qd: _ArrayLike, dt: float, joint_names: list[str] | None = None
    ) -> tuple[_F64, _F64, _F64]:
        """One control step: ``(q_target, qd_target, qdd)`` from the measured ``q``, ``qd``."""
    @property
    def last_step(self) -> ControlStepInfo | None: ...
    def sphere_distances(self, q: _ArrayLike, reach: float = 1.0) -> SphereDistances:
        """Per sphere: ``distance``, ``direction`` (S, 3), ``gradient`` (S, num_dof), ``centers``, ``radii``."""
    def exact_clearance(self, q: _ArrayLike) -> Clearance:
        """Exact link-to-obstacle clearance (parry): ``distance`` and ``closest`` (link, object)."""
    def exact_self_clearance(self, q: _ArrayLike) -> Clearance:
        """Exact clearance of the checked link pairs (parry): ``distance`` and ``closest`` (link, link)."""
    @property
    def self_link_pairs(self) -> list[tuple[str, str]]: ...

@final
class ReactiveController(_ControllerBase):
    """Reactive (RMPflow-style) control towards an end-effector target around obstacles."""

    def set_waypoints(self, waypoints: _ArrayLike) -> None:
        """Global guidance: joint-space waypoints (N, num_dof) or (N, len(active_joints))."""
    def clear_waypoints(self) -> None: ...
    @property
    def waypoints_remaining(self) -> int: ...
    @property
    def guidance_last_plan(self) -> GuidancePlan | None:
        """The last guidance plan attempt: ``status``, ``message``, ``waypoints``, ``seconds``."""
    @property
    def guidance_error(self) -> str | None: ...

@final
class PotentialFieldController(_ControllerBase):
    """Potential-field control over voxelised distance fields of the obstacles."""

# Option classes (crates/ferrobot-py/src/options.rs): defaults from the Rust `Default`, checks from the crates'
# `validate`; every field is also a keyword (`**overrides`) of the calls that take the options.

class _PlanOverrides(TypedDict, total=False):
    time_limit: float
    max_samples: int
    resolution: float
    range: float
    seed: int
    velocity_scale: float
    acceleration_scale: float
    simplify: bool
    trajectory: bool
    goal_solutions: int
    coarse_factor: float
    refinements: int

class _IkOverrides(TypedDict, total=False):
    position_tolerance: float
    rotation_tolerance: float
    num_seeds: int
    max_iterations: int
    collision_free: bool

class _DetectOverrides(TypedDict, total=False):
    voxel_size: float
    normal_radius: float
    num_seeds: int
    seed_spacing: float
    num_rotations: int
    approach_tilts: Sequence[float]
    depths: Sequence[float]
    friction: float
    viewpoint: Sequence[float]
    approach_direction: Sequence[float]
    nms_translation: float
    nms_rotation: float
    max_grasps: int
    seed: int
    support_plane: bool
    plane_threshold: float
    torque_scale: float
    body_collision: bool
    single_object: bool
    occlusion: bool
    max_width: float
    finger_depth: float
    finger_width: float
    height: float
    approach_distance: float
    clearance: float
    palm_width: float
    palm_height: float
    palm_depth: float

@final
class PlanOptions:
    """Options of ``Planner.plan``: ranges in each field's documentation; out of range raises on set."""

    def __new__(cls, **overrides: Unpack[_PlanOverrides]) -> Self: ...
    def replace(self, **overrides: Unpack[_PlanOverrides]) -> PlanOptions: ...
    def to_dict(self) -> dict[str, Any]: ...
    def __eq__(self, value: object, /) -> bool: ...
    time_limit: float
    max_samples: int
    resolution: float
    range: float
    seed: int
    velocity_scale: float
    acceleration_scale: float
    simplify: bool
    trajectory: bool
    goal_solutions: int
    coarse_factor: float
    refinements: int

@final
class IkOptions:
    """Options of ``Planner.ik``, ``ik_goalset`` and ``ik_batch``."""

    def __new__(cls, **overrides: Unpack[_IkOverrides]) -> Self: ...
    def replace(self, **overrides: Unpack[_IkOverrides]) -> IkOptions: ...
    def to_dict(self) -> dict[str, Any]: ...
    def __eq__(self, value: object, /) -> bool: ...
    position_tolerance: float
    rotation_tolerance: float
    num_seeds: int
    max_iterations: int
    collision_free: bool
    seed: int

@final
class DetectOptions:
    """Options of grasp detection (``ferrobot.grasp.detect``, ``detect_from_rgbd``)."""

    def __new__(cls, **overrides: Unpack[_DetectOverrides]) -> Self: ...
    def replace(self, **overrides: Unpack[_DetectOverrides]) -> DetectOptions: ...
    def to_dict(self) -> dict[str, Any]: ...
    def __eq__(self, value: object, /) -> bool: ...
    voxel_size: float
    normal_radius: float
    num_seeds: int
    seed_spacing: float
    num_rotations: int
    approach_tilts: list[float]
    depths: list[float]
    friction: float
    viewpoint: list[float]
    approach_direction: list[float]
    nms_translation: float
    nms_rotation: float
    max_grasps: int
    seed: int
    support_plane: bool
    plane_threshold: float
    torque_scale: float
    body_collision: bool
    single_object: bool
    occlusion: bool
    max_width: float
    finger_depth: float
    finger_width: float
    height: float
    approach_distance: float
    clearance: float
    palm_width: float
    palm_height: float
    palm_depth: float

@final
class Gripper:
    """A parallel-jaw gripper: hand link, TCP, axes, driver and mimic followers, opening map, finger geometry."""

    def __new__(
        cls,
        name: str,
        hand_link: str,
        tcp: Sequence[float],
        approach: Sequence[float],
        closing: Sequence[float],
        driver: str,
        followers: Sequence[str],
        open_position: float,
        closed_position: float,
        opening_map: tuple[Any, ...],
        fingers: dict[str, float],
    ) -> Gripper: ...
    @staticmethod
    def panda_hand() -> Gripper: ...
    @staticmethod
    def robotiq_2f85() -> Gripper: ...
    @staticmethod
    def from_model(model: RobotModel) -> Gripper: ...
    def check_model(self, model: RobotModel) -> None: ...
    @property
    def name(self) -> str: ...
    @property
    def hand_link(self) -> str: ...
    @property
    def tcp(self) -> _F64: ...
    @property
    def approach(self) -> _F64: ...
    @property
    def closing(self) -> _F64: ...
    @property
    def driver(self) -> str: ...
    @property
    def followers(self) -> list[str]: ...
    @property
    def open_position(self) -> float: ...
    @property
    def closed_position(self) -> float: ...
    @property
    def max_opening(self) -> float: ...
    @property
    def min_opening(self) -> float: ...
    @property
    def fingers(self) -> dict[str, float]: ...
    @property
    def opening_map_kind(self) -> str: ...
    def opening(self, q: float) -> float: ...
    def driver_position(self, opening: float) -> float: ...
    def grasp_to_hand(self) -> _F64: ...
    def detection_options(self) -> dict[str, float]: ...

# --- typed results (results.rs): attributes, to_dict(); dict-style access deprecated (warns) ---

@final
class PlanTimes:
    """Wall-clock time (s) of each stage of ``Planner.plan``."""
    @property
    def ik(self) -> float: ...
    @property
    def planning(self) -> float: ...
    @property
    def simplify(self) -> float: ...
    @property
    def trajectory(self) -> float: ...
    @property
    def fit(self) -> float: ...
    @property
    def recheck(self) -> float: ...
    @property
    def total(self) -> float: ...
    def to_dict(self) -> dict[str, Any]: ...
    def __getitem__(self, key: str, /) -> Any: ...
    def __contains__(self, key: object, /) -> bool: ...
    def __iter__(self) -> Iterator[str]: ...
    def keys(self) -> list[str]: ...
    def values(self) -> list[Any]: ...
    def items(self) -> list[tuple[str, Any]]: ...
    def get(self, key: str, default: Any = None) -> Any: ...

@final
class JointLimits:
    """Limits of a planner's joints, arrays in ``Planner.joint_names`` order."""
    @property
    def lower(self) -> _F64: ...
    @property
    def upper(self) -> _F64: ...
    @property
    def velocity(self) -> _F64: ...
    @property
    def acceleration(self) -> _F64: ...
    @property
    def jerk(self) -> _F64: ...
    def to_dict(self) -> dict[str, Any]: ...
    def __getitem__(self, key: str, /) -> Any: ...
    def __contains__(self, key: object, /) -> bool: ...
    def __iter__(self) -> Iterator[str]: ...
    def keys(self) -> list[str]: ...
    def values(self) -> list[Any]: ...
    def items(self) -> list[tuple[str, Any]]: ...
    def get(self, key: str, default: Any = None) -> Any: ...

@final
class WorldSyncStats:
    """Counters of a planner's scene sync."""
    @property
    def full_builds(self) -> int: ...
    @property
    def incremental(self) -> int: ...
    @property
    def added(self) -> int: ...
    @property
    def removed(self) -> int: ...
    @property
    def moved(self) -> int: ...
    def to_dict(self) -> dict[str, Any]: ...
    def __getitem__(self, key: str, /) -> Any: ...
    def __contains__(self, key: object, /) -> bool: ...
    def __iter__(self) -> Iterator[str]: ...
    def keys(self) -> list[str]: ...
    def values(self) -> list[Any]: ...
    def items(self) -> list[tuple[str, Any]]: ...
    def get(self, key: str, default: Any = None) -> Any: ...

@final
class TrackingReport:
    """How the simulated robot tracked a trajectory (M steps, k joints)."""
    @property
    def times(self) -> _F64: ...
    @property
    def desired(self) -> _F64: ...
    @property
    def actual(self) -> _F64: ...
    @property
    def max_error(self) -> _F64: ...
    @property
    def rms_error(self) -> _F64: ...
    @property
    def final_error(self) -> _F64: ...
    def to_dict(self) -> dict[str, Any]: ...
    def __getitem__(self, key: str, /) -> Any: ...
    def __contains__(self, key: object, /) -> bool: ...
    def __iter__(self) -> Iterator[str]: ...
    def keys(self) -> list[str]: ...
    def values(self) -> list[Any]: ...
    def items(self) -> list[tuple[str, Any]]: ...
    def get(self, key: str, default: Any = None) -> Any: ...

@final
class ControlStepInfo:
    """Diagnostics of a controller's last step."""
    @property
    def world_clearance(self) -> float: ...
    @property
    def self_clearance(self) -> float: ...
    @property
    def active_avoidance(self) -> int: ...
    @property
    def position_error(self) -> float: ...
    @property
    def rotation_error(self) -> float: ...
    @property
    def acceleration_scale(self) -> float: ...
    @property
    def velocity_scale(self) -> float: ...
    @property
    def limit_braked(self) -> bool: ...
    @property
    def stalled(self) -> bool: ...
    @property
    def waypoints_remaining(self) -> int: ...
    @property
    def guidance(self) -> str: ...
    @property
    def guidance_plans(self) -> int: ...
    def to_dict(self) -> dict[str, Any]: ...
    def __getitem__(self, key: str, /) -> Any: ...
    def __contains__(self, key: object, /) -> bool: ...
    def __iter__(self) -> Iterator[str]: ...
    def keys(self) -> list[str]: ...
    def values(self) -> list[Any]: ...
    def items(self) -> list[tuple[str, Any]]: ...
    def get(self, key: str, default: Any = None) -> Any: ...

@final
class DriveGains:
    """Drive gains of a simulated robot, arrays (num_dof,)."""
    @property
    def stiffness(self) -> _F64: ...
    @property
    def damping(self) -> _F64: ...
    @property
    def max_force(self) -> _F64: ...
    def to_dict(self) -> dict[str, Any]: ...
    def __getitem__(self, key: str, /) -> Any: ...
    def __contains__(self, key: object, /) -> bool: ...
    def __iter__(self) -> Iterator[str]: ...
    def keys(self) -> list[str]: ...
    def values(self) -> list[Any]: ...
    def items(self) -> list[tuple[str, Any]]: ...
    def get(self, key: str, default: Any = None) -> Any: ...

@final
class RenderFrame:
    """One rendered camera frame (``Camera.render()``), H x W pixels."""
    @property
    def depth(self) -> npt.NDArray[np.float32]:
        """Depth (m) along the optical axis (H, W); inf: no hit."""
    @property
    def segmentation(self) -> npt.NDArray[np.int32]:
        """Segmentation ids (H, W) (``World.segmentation_labels``)."""
    @property
    def rgb(self) -> npt.NDArray[np.uint8] | None:
        """Colour (H, W, 3), None when rendered with ``rgb=False``."""
    def to_dict(self) -> dict[str, Any]: ...
    def __getitem__(self, key: str, /) -> Any: ...
    def __contains__(self, key: object, /) -> bool: ...
    def __iter__(self) -> Iterator[str]: ...
    def keys(self) -> list[str]: ...
    def values(self) -> list[Any]: ...
    def items(self) -> list[tuple[str, Any]]: ...
    def get(self, key: str, default: Any = None) -> Any: ...

@final
class CollisionDistance:
    """Signed distance to the world and to itself with its gradient (``CollisionChecker.distance``)."""
    @property
    def distance(self) -> float:
        """min(world_distance, self_distance) (m; negative: penetration)."""
    @property
    def world_distance(self) -> float: ...
    @property
    def self_distance(self) -> float: ...
    @property
    def gradient(self) -> _F64:
        """d distance / d q (num_dof,)."""
    @property
    def closest(self) -> tuple[str, str] | None: ...
    def to_dict(self) -> dict[str, Any]: ...
    def __getitem__(self, key: str, /) -> Any: ...
    def __contains__(self, key: object, /) -> bool: ...
    def __iter__(self) -> Iterator[str]: ...
    def keys(self) -> list[str]: ...
    def values(self) -> list[Any]: ...
    def items(self) -> list[tuple[str, Any]]: ...
    def get(self, key: str, default: Any = None) -> Any: ...

@final
class Contact:
    """One collision at a configuration (``CollisionChecker.contacts``)."""
    @property
    def body(self) -> str: ...
    @property
    def other(self) -> str: ...
    @property
    def self_collision(self) -> bool: ...
    @property
    def depth(self) -> float:
        """Penetration depth (m)."""
    def to_dict(self) -> dict[str, Any]: ...
    def __getitem__(self, key: str, /) -> Any: ...
    def __contains__(self, key: object, /) -> bool: ...
    def __iter__(self) -> Iterator[str]: ...
    def keys(self) -> list[str]: ...
    def values(self) -> list[Any]: ...
    def items(self) -> list[tuple[str, Any]]: ...
    def get(self, key: str, default: Any = None) -> Any: ...

@final
class SelfCollisionAnalysis:
    """Counts of ``CollisionChecker.analyze_self_collisions``."""
    @property
    def samples(self) -> int: ...
    @property
    def never(self) -> int: ...
    @property
    def always(self) -> int: ...
    @property
    def sometimes(self) -> int: ...
    def to_dict(self) -> dict[str, Any]: ...
    def __getitem__(self, key: str, /) -> Any: ...
    def __contains__(self, key: object, /) -> bool: ...
    def __iter__(self) -> Iterator[str]: ...
    def keys(self) -> list[str]: ...
    def values(self) -> list[Any]: ...
    def items(self) -> list[tuple[str, Any]]: ...
    def get(self, key: str, default: Any = None) -> Any: ...

@final
class SphereFit:
    """The automatic spherizer's report for one link (``SphereModel.report``)."""
    @property
    def link(self) -> str: ...
    @property
    def spheres(self) -> int: ...
    @property
    def coverage(self) -> float:
        """Fraction (0..1) of surface samples covered."""
    @property
    def mean_protrusion(self) -> float:
        """m."""
    @property
    def max_protrusion(self) -> float:
        """m."""
    def to_dict(self) -> dict[str, Any]: ...
    def __getitem__(self, key: str, /) -> Any: ...
    def __contains__(self, key: object, /) -> bool: ...
    def __iter__(self) -> Iterator[str]: ...
    def keys(self) -> list[str]: ...
    def values(self) -> list[Any]: ...
    def items(self) -> list[tuple[str, Any]]: ...
    def get(self, key: str, default: Any = None) -> Any: ...

@final
class SphereDistances:
    """Per robot sphere distances to the world (``sphere_distances``), S spheres."""
    @property
    def distance(self) -> _F64:
        """(S,) m; inf beyond reach."""
    @property
    def direction(self) -> _F64:
        """(S, 3) unit."""
    @property
    def gradient(self) -> _F64:
        """(S, num_dof)."""
    @property
    def centers(self) -> _F64:
        """(S, 3) m."""
    @property
    def radii(self) -> _F64:
        """(S,) m."""
    def to_dict(self) -> dict[str, Any]: ...
    def __getitem__(self, key: str, /) -> Any: ...
    def __contains__(self, key: object, /) -> bool: ...
    def __iter__(self) -> Iterator[str]: ...
    def keys(self) -> list[str]: ...
    def values(self) -> list[Any]: ...
    def items(self) -> list[tuple[str, Any]]: ...
    def get(self, key: str, default: Any = None) -> Any: ...

@final
class Clearance:
    """Exact clearance (``exact_clearance``, ``exact_self_clearance``)."""
    @property
    def distance(self) -> float:
        """m; 0 when touching."""
    @property
    def closest(self) -> tuple[str, str] | None: ...
    def to_dict(self) -> dict[str, Any]: ...
    def __getitem__(self, key: str, /) -> Any: ...
    def __contains__(self, key: object, /) -> bool: ...
    def __iter__(self) -> Iterator[str]: ...
    def keys(self) -> list[str]: ...
    def values(self) -> list[Any]: ...
    def items(self) -> list[tuple[str, Any]]: ...
    def get(self, key: str, default: Any = None) -> Any: ...

@final
class GuidancePlan:
    """The last global-guidance plan attempt (``ReactiveController.guidance_last_plan``)."""
    @property
    def status(self) -> str: ...
    @property
    def message(self) -> str: ...
    @property
    def waypoints(self) -> int: ...
    @property
    def seconds(self) -> float: ...
    def to_dict(self) -> dict[str, Any]: ...
    def __getitem__(self, key: str, /) -> Any: ...
    def __contains__(self, key: object, /) -> bool: ...
    def __iter__(self) -> Iterator[str]: ...
    def keys(self) -> list[str]: ...
    def values(self) -> list[Any]: ...
    def items(self) -> list[tuple[str, Any]]: ...
    def get(self, key: str, default: Any = None) -> Any: ...

@final
class LinkInertial:
    """A simulated link's mass properties in the link frame (``Robot.get_link_inertial``)."""
    @property
    def mass(self) -> float:
        """kg."""
    @property
    def com(self) -> _F64:
        """(3,) m, link frame."""
    @property
    def inertia(self) -> _F64:
        """(3, 3) kg m^2 about the com, link-frame axes."""
    def to_dict(self) -> dict[str, Any]: ...
    def __getitem__(self, key: str, /) -> Any: ...
    def __contains__(self, key: object, /) -> bool: ...
    def __iter__(self) -> Iterator[str]: ...
    def keys(self) -> list[str]: ...
    def values(self) -> list[Any]: ...
    def items(self) -> list[tuple[str, Any]]: ...
    def get(self, key: str, default: Any = None) -> Any: ...

@final
class Inertial:
    """A link's URDF ``<inertial>`` (``RobotModel.inertial``)."""
    @property
    def mass(self) -> float:
        """kg."""
    @property
    def origin(self) -> _F64:
        """4x4 inertial frame in the link frame."""
    @property
    def inertia(self) -> _F64:
        """(3, 3) kg m^2, inertial-frame axes."""
    def to_dict(self) -> dict[str, Any]: ...
    def __getitem__(self, key: str, /) -> Any: ...
    def __contains__(self, key: object, /) -> bool: ...
    def __iter__(self) -> Iterator[str]: ...
    def keys(self) -> list[str]: ...
    def values(self) -> list[Any]: ...
    def items(self) -> list[tuple[str, Any]]: ...
    def get(self, key: str, default: Any = None) -> Any: ...

@final
class JointInfo:
    """A joint's description (``RobotModel.joint_info``)."""
    @property
    def name(self) -> str: ...
    @property
    def type(self) -> str: ...
    @property
    def parent(self) -> str: ...
    @property
    def child(self) -> str: ...
    @property
    def origin(self) -> _F64: ...
    @property
    def axis(self) -> _F64: ...
    @property
    def lower(self) -> float: ...
    @property
    def upper(self) -> float: ...
    @property
    def velocity(self) -> float: ...
    @property
    def effort(self) -> float: ...
    @property
    def damping(self) -> float: ...
    @property
    def friction(self) -> float: ...
    @property
    def mimic(self) -> tuple[str, float, float] | None: ...
    def to_dict(self) -> dict[str, Any]: ...
    def __getitem__(self, key: str, /) -> Any: ...
    def __contains__(self, key: object, /) -> bool: ...
    def __iter__(self) -> Iterator[str]: ...
    def keys(self) -> list[str]: ...
    def values(self) -> list[Any]: ...
    def items(self) -> list[tuple[str, Any]]: ...
    def get(self, key: str, default: Any = None) -> Any: ...

@final
class Lighting:
    """A world's lighting (``World.lighting``)."""
    @property
    def ambient(self) -> list[float]: ...
    @property
    def headlight(self) -> float: ...
    @property
    def lights(self) -> list[tuple[list[float], list[float], float]]: ...
    def to_dict(self) -> dict[str, Any]: ...
    def __getitem__(self, key: str, /) -> Any: ...
    def __contains__(self, key: object, /) -> bool: ...
    def __iter__(self) -> Iterator[str]: ...
    def keys(self) -> list[str]: ...
    def values(self) -> list[Any]: ...
    def items(self) -> list[tuple[str, Any]]: ...
    def get(self, key: str, default: Any = None) -> Any: ...

@final
class PayloadFit:
    """A payload identified from static efforts (``_core.identify_payload``)."""
    @property
    def mass(self) -> float: ...
    @property
    def com(self) -> _F64: ...
    @property
    def rms_residual(self) -> float: ...
    @property
    def condition(self) -> float: ...
    @property
    def equations(self) -> int: ...
    def to_dict(self) -> dict[str, Any]: ...
    def __getitem__(self, key: str, /) -> Any: ...
    def __contains__(self, key: object, /) -> bool: ...
    def __iter__(self) -> Iterator[str]: ...
    def keys(self) -> list[str]: ...
    def values(self) -> list[Any]: ...
    def items(self) -> list[tuple[str, Any]]: ...
    def get(self, key: str, default: Any = None) -> Any: ...

@final
class LinkMassFit:
    """Link mass offsets identified from static efforts (``identify_link_masses``)."""
    @property
    def offsets(self) -> _F64: ...
    @property
    def rms_residual(self) -> float: ...
    @property
    def condition(self) -> float: ...
    @property
    def equations(self) -> int: ...
    def to_dict(self) -> dict[str, Any]: ...
    def __getitem__(self, key: str, /) -> Any: ...
    def __contains__(self, key: object, /) -> bool: ...
    def __iter__(self) -> Iterator[str]: ...
    def keys(self) -> list[str]: ...
    def values(self) -> list[Any]: ...
    def items(self) -> list[tuple[str, Any]]: ...
    def get(self, key: str, default: Any = None) -> Any: ...

@final
class FrictionFit:
    """Joint friction fitted as effort = coulomb sign(v) + viscous v (``_core.identify_friction``)."""
    @property
    def coulomb(self) -> float: ...
    @property
    def viscous(self) -> float: ...
    @property
    def rms_residual(self) -> float: ...
    @property
    def condition(self) -> float: ...
    @property
    def equations(self) -> int: ...
    def to_dict(self) -> dict[str, Any]: ...
    def __getitem__(self, key: str, /) -> Any: ...
    def __contains__(self, key: object, /) -> bool: ...
    def __iter__(self) -> Iterator[str]: ...
    def keys(self) -> list[str]: ...
    def values(self) -> list[Any]: ...
    def items(self) -> list[tuple[str, Any]]: ...
    def get(self, key: str, default: Any = None) -> Any: ...

@final
class ArbiterConflict:
    """One joint's command conflict resolved by an ``Arbiter`` (``Arbiter.conflicts``)."""
    @property
    def t(self) -> float: ...
    @property
    def joint(self) -> int: ...
    @property
    def winner(self) -> str: ...
    @property
    def losers(self) -> list[str]: ...
    def to_dict(self) -> dict[str, Any]: ...
    def __getitem__(self, key: str, /) -> Any: ...
    def __contains__(self, key: object, /) -> bool: ...
    def __iter__(self) -> Iterator[str]: ...
    def keys(self) -> list[str]: ...
    def values(self) -> list[Any]: ...
    def items(self) -> list[tuple[str, Any]]: ...
    def get(self, key: str, default: Any = None) -> Any: ...

@final
class StreamGuardStep:
    """One control tick of a ``StreamGuard`` (``StreamGuard.update``)."""
    @property
    def command(self) -> _F64: ...
    @property
    def holding(self) -> bool: ...
    @property
    def catching_up(self) -> bool: ...
    @property
    def step(self) -> float: ...
    def to_dict(self) -> dict[str, Any]: ...
    def __getitem__(self, key: str, /) -> Any: ...
    def __contains__(self, key: object, /) -> bool: ...
    def __iter__(self) -> Iterator[str]: ...
    def keys(self) -> list[str]: ...
    def values(self) -> list[Any]: ...
    def items(self) -> list[tuple[str, Any]]: ...
    def get(self, key: str, default: Any = None) -> Any: ...

@final
class DepthNoiseParams:
    """A depth-noise model's parameters (``DepthNoise.params``)."""
    @property
    def sigma0(self) -> float: ...
    @property
    def sigma2(self) -> float: ...
    @property
    def z0(self) -> float: ...
    @property
    def dropout(self) -> float: ...
    @property
    def edge_threshold(self) -> float: ...
    @property
    def edge_dropout(self) -> float: ...
    @property
    def missing_value(self) -> float: ...
    def to_dict(self) -> dict[str, Any]: ...
    def __getitem__(self, key: str, /) -> Any: ...
    def __contains__(self, key: object, /) -> bool: ...
    def __iter__(self) -> Iterator[str]: ...
    def keys(self) -> list[str]: ...
    def values(self) -> list[Any]: ...
    def items(self) -> list[tuple[str, Any]]: ...
    def get(self, key: str, default: Any = None) -> Any: ...

@final
class UrdfFinding:
    """One finding of the URDF checker (``UrdfCheckReport.findings``)."""
    @property
    def severity(self) -> str: ...
    @property
    def code(self) -> str: ...
    @property
    def line(self) -> int | None: ...
    @property
    def element(self) -> str: ...
    @property
    def message(self) -> str: ...
    def to_dict(self) -> dict[str, Any]: ...
    def __getitem__(self, key: str, /) -> Any: ...
    def __contains__(self, key: object, /) -> bool: ...
    def __iter__(self) -> Iterator[str]: ...
    def keys(self) -> list[str]: ...
    def values(self) -> list[Any]: ...
    def items(self) -> list[tuple[str, Any]]: ...
    def get(self, key: str, default: Any = None) -> Any: ...

@final
class UrdfCheckReport:
    """The URDF checker's report (``urdf_check``, ``ferrobot check``)."""
    @property
    def robot(self) -> str: ...
    @property
    def source(self) -> str: ...
    @property
    def tree(self) -> str: ...
    @property
    def findings(self) -> list[UrdfFinding]: ...
    def to_dict(self) -> dict[str, Any]: ...
    def __getitem__(self, key: str, /) -> Any: ...
    def __contains__(self, key: object, /) -> bool: ...
    def __iter__(self) -> Iterator[str]: ...
    def keys(self) -> list[str]: ...
    def values(self) -> list[Any]: ...
    def items(self) -> list[tuple[str, Any]]: ...
    def get(self, key: str, default: Any = None) -> Any: ...

@final
class LoadedMesh:
    """An object mesh, checked and decomposed into convex parts (``load_mesh``)."""
    @property
    def vertices(self) -> _F64: ...
    @property
    def faces(self) -> npt.NDArray[np.int64]: ...
    @property
    def parts(self) -> list[tuple[_F64, npt.NDArray[np.int64]]]: ...
    @property
    def volume(self) -> float: ...
    @property
    def closed(self) -> bool: ...
    def to_dict(self) -> dict[str, Any]: ...
    def __getitem__(self, key: str, /) -> Any: ...
    def __contains__(self, key: object, /) -> bool: ...
    def __iter__(self) -> Iterator[str]: ...
    def keys(self) -> list[str]: ...
    def values(self) -> list[Any]: ...
    def items(self) -> list[tuple[str, Any]]: ...
    def get(self, key: str, default: Any = None) -> Any: ...
