"""Type stubs of the Rust extension module ``ferrobot._core``."""

from os import PathLike
from typing import Any

import numpy as np
import numpy.typing as npt

__version__: str

ArrayLike = npt.ArrayLike
F64 = npt.NDArray[np.float64]

def bundled_robot(name: str) -> tuple[str, str, str]:
    """(URDF text, SRDF text, default ee link) of a bundled robot."""

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
    ) -> RobotModel: ...
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
    def lower_limits(self) -> F64: ...
    @property
    def upper_limits(self) -> F64: ...
    @property
    def velocity_limits(self) -> F64: ...
    @property
    def effort_limits(self) -> F64: ...
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
    def named_state(self, name: str, group: str | None = None) -> F64: ...
    def neutral_configuration(self) -> F64: ...
    def joint_info(self, name: str) -> dict[str, Any]: ...
    def collision_geometry(self, link: str) -> list[dict[str, Any]]: ...
    def visual_geometry(self, link: str) -> list[dict[str, Any]]: ...
    def inertial(self, link: str) -> dict[str, Any]: ...
    def fk(self, q: ArrayLike, link: str | None = None) -> F64:
        """4x4 pose of ``link`` (default: ee) in the base frame."""
    def fk_all(self, q: ArrayLike) -> F64:
        """(num_links, 4, 4) poses in ``link_names`` order."""
    def fk_batch(self, q: ArrayLike, link: str | None = None) -> F64:
        """(N, 7) poses ``[x, y, z, qw, qx, qy, qz]`` for (N, num_dof) configurations."""
    def jacobian(self, q: ArrayLike, link: str | None = None) -> F64:
        """(6, num_dof) geometric Jacobian in the base frame, linear rows first."""

Pose = ArrayLike  # 4x4 matrix or [x, y, z, qw, qx, qy, qz]

class CollisionWorld:
    """Named obstacles posed in the world (robot base) frame."""

    def __init__(self) -> None: ...
    @staticmethod
    def from_moveit_scene(path: str | PathLike[str]) -> CollisionWorld: ...
    def add_box(self, name: str, size: ArrayLike, pose: Pose | None = None) -> None: ...
    def add_sphere(self, name: str, radius: float, pose: Pose | None = None) -> None: ...
    def add_cylinder(self, name: str, radius: float, length: float, pose: Pose | None = None) -> None: ...
    def add_capsule(self, name: str, radius: float, length: float, pose: Pose | None = None) -> None: ...
    def add_mesh(self, name: str, vertices: ArrayLike, faces: ArrayLike, pose: Pose | None = None) -> None: ...
    def add_pointcloud(self, name: str, points: ArrayLike, radius: float = 0.005, pose: Pose | None = None) -> None: ...
    def remove(self, name: str) -> None: ...
    def set_pose(self, name: str, pose: Pose) -> None: ...
    def get_pose(self, name: str) -> F64: ...
    @property
    def names(self) -> list[str]: ...
    def kinds(self, name: str) -> list[str]: ...
    def signed_distance(self, points: ArrayLike) -> F64: ...
    def __len__(self) -> int: ...
    def __contains__(self, name: str) -> bool: ...

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
    def spheres(self, link: str) -> F64: ...
    @property
    def report(self) -> list[dict[str, Any]]: ...

class CollisionChecker:
    """Collision queries for a robot in a world."""

    def __init__(
        self,
        model: RobotModel,
        world: CollisionWorld | None = None,
        spheres: SphereModel | None = None,
        *,
        margin: float = 0.0,
    ) -> None: ...
    def update_world(self, world: CollisionWorld) -> None: ...
    @property
    def world(self) -> CollisionWorld: ...
    margin: float
    def in_collision(self, q: ArrayLike) -> bool: ...
    def in_collision_batch(self, q: ArrayLike) -> npt.NDArray[np.bool_]: ...
    def motion_valid(self, q0: ArrayLike, q1: ArrayLike, resolution: float = 0.005) -> bool: ...
    def distance(self, q: ArrayLike) -> dict[str, Any]: ...
    def contacts(self, q: ArrayLike) -> list[dict[str, Any]]: ...
    def explain(self, q: ArrayLike) -> str: ...
    def analyze_self_collisions(self, samples: int = 10000, seed: int = 0) -> dict[str, int]: ...
    @property
    def allowed_collision_pairs(self) -> list[tuple[str, str, str]]: ...
    def allowed_collisions_srdf(self) -> str: ...
    def attach(
        self,
        name: str,
        link: str,
        shape: tuple[Any, ...],
        pose: Pose | None = None,
        touch_links: list[str] = ...,
    ) -> None: ...
    def attach_world_object(self, name: str, link: str, q: ArrayLike, touch_links: list[str] = ...) -> None: ...
    def detach(self, name: str, q: ArrayLike | None = None) -> None: ...
    @property
    def attached(self) -> list[str]: ...
    @property
    def num_spheres(self) -> int: ...

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

class PlanResult:
    """Outcome of ``Planner.plan``; failures are reported in ``status``, never raised."""

    success: bool
    status: str
    message: str
    joint_names: list[str]
    samples: int
    stops_at_waypoints: bool
    path_length: float
    duration: float | None
    @property
    def path(self) -> npt.NDArray[np.float64]: ...
    @property
    def goal(self) -> npt.NDArray[np.float64] | None: ...
    @property
    def times(self) -> dict[str, float]: ...
    def interpolated(self, dt: float = 0.01) -> JointTrajectory: ...
    def __bool__(self) -> bool: ...

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

class Planner:
    """Multi-seed IK, RRT-Connect, shortcutting and time-parametrised smooth trajectories."""

    def __init__(
        self,
        model: RobotModel,
        world: CollisionWorld | None = None,
        spheres: SphereModel | None = None,
        *,
        margin: float = 0.0,
        ee_link: str | None = None,
    ) -> None: ...
    joint_names: list[str]
    dof_names: list[str]
    ee_link: str
    @property
    def locked_positions(self) -> npt.NDArray[np.float64]: ...
    def set_locked_positions(self, q: npt.ArrayLike) -> None: ...
    @property
    def limits(self) -> dict[str, npt.NDArray[np.float64]]: ...
    def set_limits(
        self,
        *,
        velocity: npt.ArrayLike | None = None,
        acceleration: npt.ArrayLike | None = None,
        jerk: npt.ArrayLike | None = None,
    ) -> None: ...
    def update_world(self, world: CollisionWorld) -> None: ...
    @property
    def world(self) -> CollisionWorld: ...
    def in_collision(self, q: npt.ArrayLike, joint_names: list[str] | None = None) -> bool: ...
    def ik(
        self,
        goal_pose: npt.ArrayLike,
        seed: npt.ArrayLike | None = None,
        *,
        link: str | None = None,
        joint_names: list[str] | None = None,
        position_tolerance: float = 1e-3,
        rotation_tolerance: float = 0.01,
        num_seeds: int = 200,
        max_iterations: int = 60,
        collision_free: bool = False,
        random_seed: int = 0,
    ) -> IkResult: ...
    def ik_goalset(
        self,
        goal_poses: npt.ArrayLike,
        seed: npt.ArrayLike | None = None,
        *,
        link: str | None = None,
        joint_names: list[str] | None = None,
        position_tolerance: float = 1e-3,
        rotation_tolerance: float = 0.01,
        num_seeds: int = 200,
        max_iterations: int = 60,
        collision_free: bool = False,
        random_seed: int = 0,
    ) -> IkResult: ...
    def ik_batch(
        self,
        goal_poses: npt.ArrayLike,
        seeds: npt.ArrayLike | None = None,
        *,
        link: str | None = None,
        joint_names: list[str] | None = None,
        position_tolerance: float = 1e-3,
        rotation_tolerance: float = 0.01,
        num_seeds: int = 200,
        max_iterations: int = 60,
        collision_free: bool = False,
        random_seed: int = 0,
    ) -> IkResult: ...
    def plan(
        self,
        start: npt.ArrayLike,
        goal_q: npt.ArrayLike | None = None,
        goal_pose: npt.ArrayLike | None = None,
        joint_names: list[str] | None = None,
        *,
        time_limit: float = 1.0,
        max_samples: int = 100_000,
        resolution: float = 0.005,
        range: float = 1.0,
        seed: int = 0,
        velocity_scale: float = 1.0,
        acceleration_scale: float = 1.0,
        simplify: bool = True,
        trajectory: bool = True,
        goal_solutions: int = 4,
        coarse_factor: float = 4.0,
    ) -> PlanResult: ...
