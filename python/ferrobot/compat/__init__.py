"""Drop-in shapes for code migrating from Isaac Sim, cuRobo and AnyGrasp / graspnetAPI.

Thin adapters over ferrobot's own API (no second implementation):

* :mod:`ferrobot.compat.isaac`: ``ArticulationAction`` and ``JointsState`` for ``Robot.apply_action`` /
  ``Robot.get_joints_state`` (the Isaac Sim methods themselves live on :class:`ferrobot.World`,
  :class:`ferrobot.Robot` and :class:`ferrobot.Camera`).
* :mod:`ferrobot.compat.curobo`: ``MotionGen``, ``MotionGenConfig``, ``MotionGenPlanConfig``, ``IKSolver``,
  ``IKSolverConfig``, ``JointState``, ``Pose`` and cuRobo robot / world configurations, numpy instead of torch.
* :mod:`ferrobot.compat.anygrasp`: ``AnyGrasp`` with ``load_net`` / ``get_grasp``.
"""
