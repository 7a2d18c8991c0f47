"""Drop-in shapes for code migrating from Isaac Sim, cuRobo and AnyGrasp / graspnetAPI.

Thin adapters over ferrobot's own API (no second implementation):

* :mod:`ferrobot.compat.isaac`: ``Articulation`` (Isaac Sim's ``joint_indices`` and ``get_*`` getters over a
  :class:`ferrobot.Robot`, whose own API spells them ``joint_names=`` and properties), ``ArticulationAction``
  and ``JointsState`` for ``Robot.apply_action`` / ``Robot.get_joints_state`` (Isaac Sim calls with no ferrobot
  twin live on :class:`ferrobot.World`, :class:`ferrobot.Robot` and :class:`ferrobot.Camera`).
* :mod:`ferrobot.compat.curobo`: ``MotionGen``, ``MotionGenConfig``, ``MotionGenPlanConfig``, ``IKSolver``,
  ``IKSolverConfig``, ``JointState``, ``Pose`` and cuRobo robot / world configurations, numpy instead of torch.
* :mod:`ferrobot.compat.anygrasp`: ``AnyGrasp`` with ``load_net`` / ``get_grasp``.
"""
