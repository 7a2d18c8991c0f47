"""The scripted expert: the pick-and-place pipeline driving an environment through its action space.

:class:`ExpertPolicy` runs :class:`ferrobot.pipeline.PickPlace`'s own stages (perceive, detect, select, then
pick and place with a motion plan per stage) against the environment's world, with two substitutions: the
pipeline's recorder, instead of feeding planned trajectories to the joint drives, turns them into
joint-position actions at the environment's control rate exactly as the dataset recorder
(:class:`ferrobot.pipeline.recording.ControlRecorder`) does, and its gripper commands become the action's
gripper entry. The stages run in a
worker thread that hands each action to :meth:`ExpertPolicy.act` and waits until the environment has
stepped it, so planning sees the state the environment actually reached (strictly alternating: deterministic).

Planning uses privileged information (the environment's world, for the planner's collision scene), so the
expert needs the environment: ``reset(env=...)``. It works with the ``joint_pos`` control mode.
"""

from __future__ import annotations

import math
import queue
import threading

import numpy as np

from .. import _core, transforms
from ..errors import InvalidArgumentError
from ..pipeline.pick_place import Episode, EpisodeResult, PickPlace, PickPlaceConfig, StageFailure
from ..pipeline.scene import TABLE_SIZE, TABLE_TOP, TABLE_XY

__all__ = ["ExpertPolicy"]


class _Abort(BaseException):
    """Ends a worker whose episode was abandoned (reset or close before the script finished)."""


class _ActionRecorder:
    """Stands in for the pipeline's recorder with the interface of
    :class:`ferrobot.pipeline.recording.ControlRecorder` (the dataset recorder), so the expert's actions are
    the ones a recorded dataset holds: planned motions sampled at the control period (``sample_dt``), each
    sample after the first one action; waits hold the targets for ``ceil(seconds * control_hz)`` steps."""

    def __init__(self, expert: ExpertPolicy, control_hz: float):
        self.expert = expert
        self.control_hz = control_hz
        self.sample_dt = 1.0 / control_hz

    def set_gripper(self, closed: bool, force: float | None = None) -> None:
        self.expert._gripper = 1.0 if closed else 0.0

    def execute(self, positions, velocities, joint_indices, stage):
        for row in np.asarray(positions, dtype=np.float64)[1:]:
            self.expert._emit(row)
        return 0.0

    def wait(self, seconds, stage):
        for _ in range(max(1, math.ceil(seconds * self.control_hz - 1e-9))):
            self.expert._emit(self.expert._arm)

    def snapshot(self, stage):
        pass


class ExpertPolicy:
    """Scripted pick-and-place expert for ``ferrobot/PickPlace-v0``, ``PickPlaceClutter-v0``, ``Lift-v0``
    (pick and lift) and ``Reach-v0`` (a planned motion to the goal); joint-position actions.

    After the script ends (or fails: :attr:`failure` names the stage and reason) it holds its last action."""

    def __init__(self, config: PickPlaceConfig | None = None):
        self.config = config
        self.pp: PickPlace | None = None
        self.failure: str = ""
        self._worker: threading.Thread | None = None
        self._pending = False
        self._done = False
        self._actions: queue.Queue = queue.Queue(maxsize=1)
        self._go: queue.Queue = queue.Queue(maxsize=1)

    # -- policy API -------------------------------------------------------------------------------------------

    def reset(self, env, obs=None, info=None) -> None:
        """Starts the script for ``env``'s new episode (call after ``env.reset``)."""
        self.close()
        env = env.unwrapped
        if env.control_mode != "joint_pos":
            raise InvalidArgumentError(f"ExpertPolicy: needs control_mode 'joint_pos', got {env.control_mode!r}")
        if self.pp is None or self.pp.model is not env.model or self.pp.gripper is not env.gripper:
            self.pp = PickPlace(self.config, robot=env.model, gripper=env.gripper)
        pp = self.pp
        (tx, ty), (sx, sy, _) = TABLE_XY, TABLE_SIZE
        arm_idx = [env.robot.dof_names.index(n) for n in pp.arm]
        if arm_idx != list(env.arm_idx):
            raise InvalidArgumentError("ExpertPolicy: the environment's arm joints differ from the planner's")
        result = EpisodeResult(seed=env.spec_scene.seed, target=env.spec_scene.target)
        pp.episode = Episode(
            spec=env.spec_scene,
            result=result,
            model=env.model,
            world=env.world,
            robot=env.robot,
            camera=env.scene_camera,
            base=env.base_pose,
            workspace=[tx - sx / 2, tx + sx / 2, ty - sy / 2, ty + sy / 2, TABLE_TOP - 0.02, TABLE_TOP + 0.3],
            arm_idx=arm_idx,
            recorder=_ActionRecorder(self, env.control_hz),
        )
        result.episode = pp.episode
        pp.planner.update_world(_core.CollisionWorld())
        for name in list(pp.planner.attached):
            pp.planner.detach(name)
        self.env = env
        self.control_hz = env.control_hz
        self.failure = ""
        self._arm = env.robot.joint_positions[env.arm_idx].copy()
        self._gripper = 0.0
        self._done = False
        self._pending = False
        self._actions = queue.Queue(maxsize=1)
        self._go = queue.Queue(maxsize=1)
        task = type(env).__name__
        self._worker = threading.Thread(target=self._run, args=(task,), daemon=True)
        self._worker.start()

    def act(self, obs=None) -> np.ndarray:
        """The next action (float32, the environment's ``joint_pos`` layout)."""
        if self._worker is None:
            raise InvalidArgumentError("ExpertPolicy: call reset(env) before act()")
        if not self._done:
            if self._pending:  # the previous action has been stepped: the worker may read the new state
                self._pending = False
                self._go.put(True)
            item = self._actions.get()
            if item is None:
                self._done = True
            else:
                self._pending = True
                return item
        return self._action()

    __call__ = act

    def close(self) -> None:
        """Stops the worker of an unfinished episode."""
        w = self._worker
        while w is not None and w.is_alive():
            try:
                self._go.put_nowait(False)
            except queue.Full:
                pass
            try:
                self._actions.get_nowait()
            except queue.Empty:
                pass
            w.join(timeout=0.05)
        self._worker = None

    # -- the script -------------------------------------------------------------------------------------------

    def _action(self) -> np.ndarray:
        return np.concatenate([self._arm, [self._gripper]]).astype(np.float32)

    def _emit(self, arm) -> None:
        """Hands one action to :meth:`act` and waits until the next ``act`` call (the env has stepped it)."""
        self._arm = np.asarray(arm, dtype=np.float64).copy()
        self._actions.put(self._action())
        if not self._go.get():
            raise _Abort()

    def _run(self, task: str) -> None:
        pp = self.pp
        try:
            if task == "ReachEnv":
                self._reach()
            else:
                pp._stage("perceive", pp.perceive)
                pp._stage("detect", pp.detect)
                pp._stage("select", pp.select)
                pp.pick()
                if task != "LiftEnv":
                    pp.place()
        except StageFailure as f:
            self.failure = f"{f.stage}: {f.reason}"
        except _Abort:
            return
        except Exception as e:  # reported as the expert's failure, never lost
            self.failure = f"{type(e).__name__}: {e}"
        self._actions.put(None)

    def _reach(self) -> None:
        env, pp = self.env, self.pp
        q = env.robot.joint_positions
        hand = env.model.fk(q, link=env.ee_link)
        tcp_in_hand = env.ee_to_tcp
        goal_tcp = hand @ tcp_in_hand
        goal_tcp[:3, 3] = (
            transforms.world_to_base(np.eye(4), env.base_pose)[:3, :3] @ env.goal
            + (transforms.world_to_base(np.eye(4), env.base_pose)[:3, 3])
        )
        goal_hand = goal_tcp @ np.linalg.inv(tcp_in_hand)
        pp._sync([])
        res = pp.planner.ik(goal_hand, pp._q(), num_seeds=32, collision_free=True)
        if not res.success:
            raise StageFailure("reach", "no collision-free IK solution for the goal")
        pp._move("reach", res.q, [])
