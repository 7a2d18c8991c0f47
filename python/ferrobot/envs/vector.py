"""N environments stepped together in one process.

The simulation releases the GIL while it steps and renders, so environments stepped from different threads
run their physics on different cores; the Python around it (action checks, observations) is serialised by
the GIL. :class:`ThreadedVectorStepper` does that for any Gymnasium environments;
:class:`FerrobotVectorEnv` is the Gymnasium ``VectorEnv`` built on it (next-step auto-reset, as Gymnasium's
``SyncVectorEnv`` and ``AsyncVectorEnv``), registered as each id's ``vector_entry_point``::

    envs = gym.make_vec("ferrobot/PickPlace-v0", num_envs=8, vectorization_mode="vector_entry_point")

Each environment keeps its own :class:`ferrobot.control.ControlStepper`, so a step is exactly the single
environment's step. ``benches/envs.py`` compares it with ``SyncVectorEnv``, ``AsyncVectorEnv`` (one
process per environment) and with stepping the bare worlds through ``ferrobot._core.step_worlds``.
"""

from __future__ import annotations

import copy
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space, concatenate, create_empty_array

from ..errors import InvalidArgumentError

__all__ = ["ThreadedVectorStepper", "FerrobotVectorEnv"]


class ThreadedVectorStepper:
    """Steps several environments at once, one thread each (``step({i: action})`` -> ``{i: result}``, where a
    result is ``env.step``'s 5-tuple or the exception it raised)."""

    def __init__(self, envs: list):
        self.envs = list(envs)
        self.pool = ThreadPoolExecutor(max_workers=len(self.envs)) if len(self.envs) > 1 else None

    def step(self, actions: dict[int, Any]) -> dict[int, Any]:
        def one(i):
            try:
                return self.envs[i].step(actions[i])
            except Exception as e:
                return e

        if self.pool is None or len(actions) <= 1:
            return {i: one(i) for i in actions}
        futures = {i: self.pool.submit(one, i) for i in actions}
        return {i: f.result() for i, f in futures.items()}

    def close(self) -> None:
        if self.pool is not None:
            self.pool.shutdown(wait=True)
            self.pool = None


class _DeferredRobot:
    """The robot as the control stepper sees it, with ``execute_trajectory`` recorded instead of run."""

    def __init__(self, robot, calls: list):
        self._robot, self._calls = robot, calls

    def __getattr__(self, name):
        return getattr(self._robot, name)

    def execute_trajectory(
        self, positions, dt, velocities=None, joint_indices=None, settle_time=0.0, *, joint_names=None
    ):
        if joint_names is not None:
            joint_indices = [self._robot.dof_names.index(n) for n in joint_names]
        if velocities is not None or settle_time != 0.0 or joint_indices is None:
            raise InvalidArgumentError("batched stepping supports execute_trajectory(positions, dt, joint_indices)")
        self._calls.append((np.asarray(positions, dtype=np.float64), float(dt), [int(i) for i in joint_indices]))


def rust_batch_step(envs: list, actions: dict[int, Any]) -> dict[int, Any]:
    """Steps the environments ``envs[i]`` (``gym.make`` results) with ``actions[i]``: each control stepper
    runs with its physics deferred, then one ``ferrobot._core.execute_trajectories`` call runs every world's
    control period in parallel (GIL released), then the observations are taken. The same result, bit for
    bit, as ``env.step`` one after the other. Honours each environment's time limit (``spec``); results as
    :meth:`ThreadedVectorStepper.step`."""
    from .. import _core

    out: dict[int, Any] = {}
    pending = []
    for i, a in actions.items():
        u = envs[i].unwrapped
        calls: list = []
        real = u.stepper.robot
        u.stepper.robot = _DeferredRobot(real, calls)
        try:
            ik_failed = u._step_begin(a)
        except Exception as e:
            out[i] = e
            continue
        finally:
            u.stepper.robot = real
        if len(calls) != 1:
            out[i] = InvalidArgumentError(f"batched stepping: the stepper made {len(calls)} trajectory calls, not 1")
            continue
        pending.append((i, u, ik_failed, calls[0]))
    if pending:
        dts = {c[1] for _, _, _, c in pending}
        if len(dts) != 1:
            raise InvalidArgumentError(f"batched stepping needs one control period, got {sorted(dts)}")
        _core.execute_trajectories(
            [u.world for _, u, _, _ in pending],
            [u.robot.name for _, u, _, _ in pending],
            [c[0] for _, _, _, c in pending],
            dts.pop(),
            [c[2] for _, _, _, c in pending],
        )
    for i, u, ik_failed, _ in pending:
        obs, reward, terminated, truncated, info = u._step_end(ik_failed)
        limit = envs[i].spec.max_episode_steps if envs[i].spec is not None else None
        truncated = bool(limit is not None and u.elapsed_steps >= limit and not terminated)
        out[i] = (obs, reward, terminated, truncated, info)
    return out


class FerrobotVectorEnv(VectorEnv):
    """``num_envs`` copies of ``env_id`` (made with ``gym.make(env_id, **kwargs)``, so with its time limit),
    stepped together by :class:`ThreadedVectorStepper` (``batch="threads"``, the default) or by
    :func:`rust_batch_step` (``batch="rust"``: the physics of all environments in one parallel Rust call,
    the rest one environment after the other); next-step auto-reset. ``reset(seed=s)`` seeds the
    copies with s, s + 1, ...; an environment that raises during ``step`` re-raises here."""

    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": []}

    def __init__(self, num_envs: int = 1, *, env_id: str, batch: str = "threads", **kwargs):
        if not isinstance(num_envs, int) or num_envs < 1:
            raise InvalidArgumentError(f"num_envs: expected an integer >= 1, got {num_envs!r}")
        if batch not in ("threads", "rust"):
            raise InvalidArgumentError(f"batch: expected 'threads' or 'rust', got {batch!r}")
        self.batch = batch
        self.envs = [gym.make(env_id, **kwargs) for _ in range(num_envs)]
        self.num_envs = num_envs
        self.single_observation_space = self.envs[0].observation_space
        self.single_action_space = self.envs[0].action_space
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)
        self.spec = self.envs[0].spec
        self._stepper = ThreadedVectorStepper(self.envs)
        self._obs = create_empty_array(self.single_observation_space, n=num_envs, fn=np.zeros)
        self._autoreset = np.zeros(num_envs, dtype=bool)

    def reset(self, *, seed: int | list[int | None] | None = None, options: dict | None = None):
        if isinstance(seed, list):
            seeds = seed
        else:
            seeds = [None if seed is None else seed + i for i in range(self.num_envs)]
        if len(seeds) != self.num_envs:
            raise InvalidArgumentError(f"seed: expected {self.num_envs} seeds, got {len(seeds)}")
        obs, infos = [], {}
        for i, (env, s) in enumerate(zip(self.envs, seeds, strict=True)):
            o, info = env.reset(seed=s, options=options)
            obs.append(o)
            infos = self._add_info(infos, info, i)
        self._obs = concatenate(self.single_observation_space, obs, self._obs)
        self._autoreset[:] = False
        return copy.deepcopy(self._obs), infos

    def step(self, actions):
        actions = list(actions) if not isinstance(actions, np.ndarray) else list(actions)
        if len(actions) != self.num_envs:
            raise InvalidArgumentError(f"actions: expected {self.num_envs} actions (one per environment)")
        todo = {i: actions[i] for i in range(self.num_envs) if not self._autoreset[i]}
        results = self._stepper.step(todo) if self.batch == "threads" else rust_batch_step(self.envs, todo)
        obs = [None] * self.num_envs
        rewards = np.zeros(self.num_envs)
        terms = np.zeros(self.num_envs, dtype=bool)
        truncs = np.zeros(self.num_envs, dtype=bool)
        infos: dict = {}
        for i in range(self.num_envs):
            if self._autoreset[i]:
                o, info = self.envs[i].reset()
            else:
                r = results[i]
                if isinstance(r, BaseException):
                    raise r
                o, rewards[i], terms[i], truncs[i], info = r
            obs[i] = o
            infos = self._add_info(infos, info, i)
        self._autoreset = terms | truncs
        self._obs = concatenate(self.single_observation_space, obs, self._obs)
        return copy.deepcopy(self._obs), rewards, terms, truncs, infos

    def close_extras(self, **kwargs):
        self._stepper.close()
        for e in self.envs:
            e.close()
