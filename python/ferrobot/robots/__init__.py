"""Robots bundled with ferrobot (written by this project, primitive geometry, no mesh files)."""

from __future__ import annotations

from .._core import RobotModel, bundled_robot

__all__ = ["panda", "panda_urdf", "panda_srdf"]


def panda_urdf() -> str:
    """URDF text of the bundled Franka Panda with its hand."""
    return bundled_robot("panda")[0]


def panda_srdf() -> str:
    """SRDF text of the bundled Panda (groups ``panda_arm`` and ``hand``, named states)."""
    return bundled_robot("panda")[1]


def panda(*, ee_link: str | None = None, group: str | None = None) -> RobotModel:
    """The bundled Franka Panda: arm and hand, finger 2 a mimic of finger 1.

    Kinematics from Franka's published parameters (``panda_hand`` agrees with the
    MotionBenchMaker Panda); joint limits are Franka's published ones; collision
    geometry is capsules, cylinders and boxes. The end effector defaults to
    ``panda_hand``.
    """
    urdf, srdf, default_ee = bundled_robot("panda")
    return RobotModel.from_urdf_string(urdf, srdf=srdf, ee_link=ee_link or default_ee, group=group)
