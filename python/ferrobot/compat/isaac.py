"""Isaac Sim's small data types, for :meth:`ferrobot.Robot.apply_action` and :meth:`ferrobot.Robot.get_joints_state`.

The Isaac Sim methods are on ferrobot's classes directly:

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

__all__ = ["ArticulationAction", "JointsState"]


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
