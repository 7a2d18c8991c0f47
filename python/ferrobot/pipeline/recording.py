"""Recording an episode for a robot-learning dataset: the motions run through a
:class:`ferrobot.control.ControlStepper` at the control rate, and every control step's observation and action
go to a sink (a dataset episode writer, or a list).

:class:`ControlRecorder` has the interface of the pipeline's physics-rate ``Recorder`` (``execute``, ``wait``,
``snapshot``, ``set_gripper``), so :class:`~ferrobot.pipeline.PickPlace` runs the same stages either way:

* ``execute(positions, ...)``: the plan sampled at the control period (``sample_dt``); each sample after the
  first is one action (its arm targets, the current gripper command).
* ``wait(seconds)``: the current targets held for ``ceil(seconds * control_hz)`` control steps.
* ``set_gripper(closed)``: changes the gripper command of the following actions.

Frame ``t`` holds the observation before action ``t`` and that action (LeRobot's convention); the
simulator's full state after each action (float64 joint positions and velocities, object poses) is kept in
``states`` so that a replay can be compared bit for bit.
"""

from __future__ import annotations

import math

import numpy as np

from ..control import ControlStepper, action_features, observe
from ..errors import InvalidArgumentError
from .pick_place import StageFailure

__all__ = ["ControlRecorder", "sim_state"]


def sim_state(world, robot) -> np.ndarray:
    """The simulator state as one float64 vector: joint positions, joint velocities, then each object's
    pose [x, y, z, qw, qx, qy, qz] and linear and angular velocity, objects in ``world.object_names`` order."""
    parts = [robot.joint_positions, robot.joint_velocities]
    from ..transforms import matrix_to_pose

    for name in world.object_names:
        lin, ang = world.get_object_velocity(name)
        parts += [matrix_to_pose(world.get_object_pose(name)), lin, ang]
    return np.concatenate(parts).astype(np.float64)


class ControlRecorder:
    """Runs the pipeline's motions at ``control_hz`` and sends each control step's frame to ``sink``.

    ``sink(frame: dict)`` receives the observation keys of :func:`ferrobot.control.observe`, ``action``,
    ``action.ee_pose``, plus ``stage`` (str) and ``state`` (float64, :func:`sim_state` after the action).
    ``cameras``: name -> :class:`ferrobot.Camera` (made for the episode's world). ``gripper``: the
    :class:`ferrobot.Gripper` whose TCP pose and opening are recorded (None: the model's end-effector link and
    finger joints, :func:`ferrobot.control.observe`).
    """

    def __init__(
        self,
        world,
        robot,
        cameras: dict,
        sink,
        *,
        control_hz: float = 10.0,
        arm_joint_names=None,
        arm_joint_indices=None,
        grip_force: float = 40.0,
        segmentation: bool = False,
        max_steps: int = 100_000,
        gripper=None,
    ):
        self.world, self.robot, self.cameras, self.sink = world, robot, cameras, sink
        self.stepper = ControlStepper(
            world,
            robot,
            control_hz=control_hz,
            arm_joint_names=arm_joint_names,
            grip_force=grip_force,
            **({} if arm_joint_indices is None else {"arm_joint_indices": arm_joint_indices}),
        )
        self.segmentation = segmentation
        self.gripper = gripper
        self.sample_dt = self.stepper.period
        self.gripper_cmd = 0.0
        self.steps = 0
        self.max_steps = max_steps
        self.stage_bounds: list[list] = []  # [name, first frame, end frame)

    # -- the Recorder interface --------------------------------------------------------------------------

    def snapshot(self, stage: str) -> None:
        """Nothing to do: frames are recorded at control steps."""

    def set_gripper(self, closed: bool, force: float | None = None) -> None:
        if force is not None:
            self.stepper.grip_force = float(force)
        self.gripper_cmd = 1.0 if closed else 0.0

    def execute(self, positions: np.ndarray, velocities: np.ndarray, joint_indices: list[int], stage: str):
        """Runs ``positions`` (N, A) sampled at ``sample_dt``: samples 1..N-1 become actions. Returns the
        largest tracking error (rad) seen at the control steps."""
        del velocities  # feed-forward is the targets' slope within each period (the contract)
        if list(joint_indices) != self.stepper.arm:
            raise InvalidArgumentError(
                f"joint_indices: expected the stepper's arm joints {self.stepper.arm}, got {list(joint_indices)}"
            )
        err = 0.0
        for row in np.asarray(positions, dtype=np.float64)[1:]:
            self._step(np.append(row, self.gripper_cmd), stage)
            q = self.robot.joint_positions[self.stepper.arm]
            err = max(err, float(np.max(np.abs(q - row))))
        return err

    def wait(self, seconds: float, stage: str) -> None:
        for _ in range(max(1, math.ceil(seconds * self.stepper.control_hz - 1e-9))):
            self._step(np.append(self.stepper.targets, self.gripper_cmd), stage)

    # -- internals ----------------------------------------------------------------------------------------

    def _step(self, action: np.ndarray, stage: str) -> None:
        if self.steps >= self.max_steps:
            raise StageFailure(stage, f"the episode exceeded {self.max_steps} control steps")
        # Datasets store actions as float32: the simulator gets exactly the stored values, so replaying a
        # dataset's actions reproduces its states bit for bit.
        action = np.asarray(action, dtype=np.float32).astype(np.float64)
        frame = observe(self.world, self.robot, self.cameras, segmentation=self.segmentation, gripper=self.gripper)
        frame.update(action_features(self.robot, self.stepper, action, gripper=self.gripper))
        self.stepper.step(action)
        frame["stage"] = stage
        frame["state"] = sim_state(self.world, self.robot)
        if self.stage_bounds and self.stage_bounds[-1][0] == stage:
            self.stage_bounds[-1][2] = self.steps + 1
        else:
            self.stage_bounds.append([stage, self.steps, self.steps + 1])
        self.sink(frame)
        self.steps += 1
