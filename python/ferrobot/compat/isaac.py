"""Isaac Sim's articulation call shapes over ferrobot's own API.

:class:`Articulation` wraps a :class:`ferrobot.Robot` with Isaac Sim's spellings: joint subsets as
``joint_indices`` and ``get_*`` getters (``get_joint_positions(joint_indices=None)``, ...). ferrobot's own API
spells joint subsets ``joint_names=`` and reads state through properties (``Robot.joint_positions``); on
``Robot`` the Isaac spellings are deprecated (they warn), here they are not. ``ArticulationAction`` and
``JointsState`` are Isaac Sim's small data types.

These Isaac Sim methods are also on ferrobot's classes directly (they have no ferrobot spelling to clash with):

* ``World.step(render=False)`` (``render`` has no effect: cameras render on ``Camera.render()``;
  ``step_sim=False`` does not step);
* ``Robot.get_world_pose() -> (position (3,), orientation (w, x, y, z))``, ``Robot.set_world_pose(position=None,
  orientation=None)``, ``Robot.get_world_transform()`` (the 4x4), ``Robot.initialize()`` (no-op),
  ``Robot.get_joints_state()``, ``Robot.apply_action(ArticulationAction(...))``,
  ``Robot.set_solver_position_iteration_count(n)`` (ferrobot's extra contact substeps);
  ``set_solver_velocity_iteration_count`` and ``set_stabilization_threshold`` are accepted and warn that they
  have no effect (Rapier has neither);
* ``Camera.get_world_pose(camera_axes="world" | "ros" | "usd")``.
"""

from __future__ import annotations

import numpy as np

__all__ = ["Articulation", "ArticulationAction", "JointsState"]


def _opt(values):
    if values is None:
        return None
    if isinstance(values, np.ndarray):
        return values
    seq = list(values)
    if any(v is None for v in seq):
        return seq  # None entries leave those joints unchanged, as in Isaac Sim
    return np.asarray(seq, dtype=np.float64)


class ArticulationAction:
    """Joint commands for :meth:`ferrobot.Robot.apply_action`, as Isaac Sim's ``ArticulationAction``.

    ``joint_positions`` become drive position targets (rad or m), ``joint_velocities`` drive velocity targets,
    ``joint_efforts`` applied efforts (N·m or N); each is None (unchanged) or one value per entry of
    ``joint_indices`` (all DOFs in ``dof_names`` order when None); a None entry leaves that joint unchanged.
    """

    def __init__(self, joint_positions=None, joint_velocities=None, joint_efforts=None, joint_indices=None):
        self.joint_positions = _opt(joint_positions)
        self.joint_velocities = _opt(joint_velocities)
        self.joint_efforts = _opt(joint_efforts)
        self.joint_indices = None if joint_indices is None else [int(i) for i in np.asarray(joint_indices).ravel()]

    def get_dict(self) -> dict:
        """The fields as a dict (Isaac Sim's ``ArticulationAction.get_dict``)."""
        return {
            "joint_positions": self.joint_positions,
            "joint_velocities": self.joint_velocities,
            "joint_efforts": self.joint_efforts,
            "joint_indices": self.joint_indices,
        }

    def get_length(self) -> int | None:
        """Number of joints commanded (None when every field is None)."""
        for v in (self.joint_positions, self.joint_velocities, self.joint_efforts):
            if v is not None:
                return len(v)
        return None

    def __repr__(self) -> str:
        return f"ArticulationAction({self.get_dict()!r})"


class JointsState:
    """Isaac Sim's ``JointsState``: ``positions``, ``velocities``, ``efforts`` (num_dof,), ``dof_names`` order.

    ``efforts`` are those set with ``Robot.set_joint_efforts`` / ``apply_action`` (Isaac's applied efforts).
    """

    def __init__(self, positions, velocities, efforts):
        self.positions = positions
        self.velocities = velocities
        self.efforts = efforts

    def __repr__(self) -> str:
        return f"JointsState(positions={self.positions}, velocities={self.velocities}, efforts={self.efforts})"


class Articulation:
    """Isaac Sim's ``Articulation`` over a :class:`ferrobot.Robot` (``Articulation(world.add_robot(model))``).

    Joint subsets are ``joint_indices`` (DOF indices in ``dof_names`` order; all DOFs when None), passed to the
    robot as ``joint_names``; getters are ``get_*`` methods reading the robot's properties. Anything else
    (``dof_names``, ``apply_action``, ``get_world_pose``, ``close_gripper``, ...) is the robot's own attribute.
    """

    def __init__(self, robot):
        self.robot = robot
        self._names = list(robot.dof_names)

    def __getattr__(self, name):
        return getattr(self.robot, name)

    def _subset(self, joint_indices):
        if joint_indices is None:
            return None
        n = len(self._names)
        names = []
        for i in np.asarray(joint_indices).ravel().tolist():
            if not isinstance(i, int) or not 0 <= i < n:
                from ..errors import UnknownNameError

                raise UnknownNameError(f"joint index {i} out of range [0, {n})")
            names.append(self._names[i])
        return names

    def _pick(self, values, joint_indices):
        return values if joint_indices is None else values[np.asarray(joint_indices, dtype=np.int64)]

    def get_joint_positions(self, joint_indices=None):
        """Joint positions (rad or m) of ``joint_indices`` (all DOFs when None)."""
        return self._pick(self.robot.joint_positions, joint_indices)

    def get_joint_velocities(self, joint_indices=None):
        """Joint velocities (rad/s or m/s) of ``joint_indices`` (all DOFs when None)."""
        return self._pick(self.robot.joint_velocities, joint_indices)

    def get_applied_joint_efforts(self, joint_indices=None):
        """Efforts set with ``set_joint_efforts`` (N·m or N)."""
        return self._pick(self.robot.applied_joint_efforts, joint_indices)

    def get_measured_joint_efforts(self, joint_indices=None):
        """Efforts the drives apply now (N·m or N)."""
        return self._pick(self.robot.measured_joint_efforts, joint_indices)

    def get_joint_position_targets(self, joint_indices=None):
        """Drive position targets (rad or m)."""
        return self._pick(self.robot.joint_position_targets, joint_indices)

    def get_world_transform(self):
        """World pose (4x4) of the base link."""
        return self.robot.world_transform

    def get_gripper_opening(self):
        """Opening (m) between the pads."""
        return self.robot.gripper_opening

    def get_gripper_positions(self):
        """Finger DOF positions."""
        return self.robot.gripper_positions

    def get_drive_gains(self):
        """``(stiffness, damping, max_force)``, each (num_dof,)."""
        g = self.robot.drive_gains
        return g.stiffness, g.damping, g.max_force

    def set_joint_positions(self, positions, joint_indices=None):
        """Teleports ``joint_indices`` (all DOFs when None; the others keep their positions)."""
        if joint_indices is None:
            self.robot.set_joint_positions(positions)
            return
        q = np.array(self.robot.joint_positions)
        q[np.asarray(joint_indices, dtype=np.int64)] = np.asarray(positions, dtype=np.float64)
        self.robot.set_joint_positions(q)

    def set_joint_position_targets(self, positions, joint_indices=None):
        """Drive position targets (rad or m) for ``joint_indices``."""
        self.robot.set_joint_position_targets(positions, joint_names=self._subset(joint_indices))

    def set_joint_velocity_targets(self, velocities, joint_indices=None):
        """Drive velocity targets (rad/s or m/s) for ``joint_indices``."""
        self.robot.set_joint_velocity_targets(velocities, joint_names=self._subset(joint_indices))

    def set_joint_efforts(self, efforts, joint_indices=None):
        """Efforts (N·m or N) applied every step on top of the drives, for ``joint_indices``."""
        self.robot.set_joint_efforts(efforts, joint_names=self._subset(joint_indices))

    def set_gains(self, kps=None, kds=None, joint_indices=None):
        """Drive stiffness ``kps`` and damping ``kds`` for ``joint_indices`` (None keeps the current values)."""
        g = self.robot.drive_gains
        ix = slice(None) if joint_indices is None else np.asarray(joint_indices, dtype=np.int64)
        k = g.stiffness[ix] if kps is None else kps
        d = g.damping[ix] if kds is None else kds
        self.robot.set_drive_gains(k, d, joint_names=self._subset(joint_indices))

    def get_gains(self, joint_indices=None):
        """``(kps, kds)`` of ``joint_indices``."""
        g = self.robot.drive_gains
        return self._pick(g.stiffness, joint_indices), self._pick(g.damping, joint_indices)

    def execute_trajectory(self, positions, dt, velocities=None, joint_indices=None, settle_time=0.0):
        """``Robot.execute_trajectory`` with the joints as ``joint_indices``; returns its ``TrackingReport``."""
        return self.robot.execute_trajectory(
            positions, dt, velocities=velocities, settle_time=settle_time, joint_names=self._subset(joint_indices)
        )

    def __repr__(self) -> str:
        return f"Articulation({self.robot!r})"
