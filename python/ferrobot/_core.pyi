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
