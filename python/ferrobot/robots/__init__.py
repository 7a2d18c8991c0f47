"""Robots bundled with ferrobot (written by this project, primitive geometry, no mesh files)."""

from __future__ import annotations

from .._core import RobotModel, bundled_robot

__all__ = ["panda", "panda_urdf", "panda_srdf", "ur5e", "ur5e_urdf", "ur5e_srdf", "bundled"]


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


def ur5e_urdf() -> str:
    """URDF text of the bundled UR5e with a Robotiq 2F-85."""
    return bundled_robot("ur5e")[0]


def ur5e_srdf() -> str:
    """SRDF text of the bundled UR5e (groups ``manipulator`` and ``gripper``, named states, disabled pairs)."""
    return bundled_robot("ur5e")[1]


def ur5e(*, ee_link: str | None = None, group: str | None = None) -> RobotModel:
    """The bundled UR5e with a Robotiq 2F-85, written by ferrobot from published parameters.

    Arm kinematics from Universal Robots' published DH parameters (``tool0`` is the DH flange frame), the
    published joint limits; the 2F-85 as its real descriptions model it, one driver (``finger_joint``) and
    five mimic followers on a parallel four-bar linkage with an 85 mm stroke. Collision geometry is
    cylinders, capsules and boxes. The end effector defaults to ``robotiq_85_base_link`` (the gripper
    frame: z approach, y closing; TCP ``robotiq_85_tcp``); ``ferrobot.Gripper.robotiq_2f85()`` describes it.
    """
    urdf, srdf, default_ee = bundled_robot("ur5e")
    return RobotModel.from_urdf_string(urdf, srdf=srdf, ee_link=ee_link or default_ee, group=group)


def bundled(name: str) -> RobotModel:
    """A bundled robot by name: ``"panda"`` or ``"ur5e"``."""
    if name == "panda":
        return panda()
    if name == "ur5e":
        return ur5e()
    bundled_robot(name)  # raises UnknownNameError listing the names
    raise AssertionError("unreachable")
