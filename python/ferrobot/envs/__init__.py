"""ferrobot tasks as Gymnasium environments (``pip install "ferrobot[gym]"``).

Importing this module registers the environments with Gymnasium::

    import gymnasium as gym
    import ferrobot.envs  # noqa: F401  (registers ferrobot/...)

    env = gym.make("ferrobot/PickPlace-v0", obs_mode="rgbd", control_mode="ee_delta")
    obs, info = env.reset(seed=0)

or, without the import, ``gym.make("ferrobot.envs:ferrobot/PickPlace-v0")`` (Gymnasium imports the module
named before the colon). Gymnasium 1.x has no plugin discovery; for Gymnasium 0.26-0.29, which loads the
``gymnasium.envs`` entry-point group, the package declares :func:`register_envs` there.

Environments (see :mod:`ferrobot.envs.tasks` for every ``make`` keyword argument):

- ``ferrobot/PickPlace-v0``: put the named target object onto the place location (200 control steps).
- ``ferrobot/PickPlaceClutter-v0``: the same among 6 objects (the scene generator's maximum).
- ``ferrobot/Lift-v0``: lift the target 5 cm above its resting height (100 control steps).
- ``ferrobot/Reach-v0``: bring the hand's TCP within 2 cm of a goal position (50 control steps).
"""

from __future__ import annotations

from .tasks import (
    ACTION_MODES,
    OBS_MODES,
    FerrobotEnv,
    LiftEnv,
    PickPlaceEnv,
    ReachEnv,
)

__all__ = [
    "ENV_IDS",
    "ACTION_MODES",
    "OBS_MODES",
    "FerrobotEnv",
    "PickPlaceEnv",
    "LiftEnv",
    "ReachEnv",
    "register_envs",
]

#: Registered ids: (entry point, default kwargs, max_episode_steps).
ENV_IDS: dict[str, tuple[str, dict, int]] = {
    "ferrobot/PickPlace-v0": ("ferrobot.envs.tasks:PickPlaceEnv", {}, 200),
    "ferrobot/PickPlaceClutter-v0": ("ferrobot.envs.tasks:PickPlaceEnv", {"num_objects": 6}, 200),
    "ferrobot/Lift-v0": ("ferrobot.envs.tasks:LiftEnv", {}, 100),
    "ferrobot/Reach-v0": ("ferrobot.envs.tasks:ReachEnv", {}, 50),
}


def register_envs() -> None:
    """Registers every id of :data:`ENV_IDS` with Gymnasium (idempotent)."""
    import functools

    import gymnasium

    from .vector import FerrobotVectorEnv

    for env_id, (entry, kwargs, steps) in ENV_IDS.items():
        if env_id in gymnasium.registry:
            continue
        gymnasium.register(
            id=env_id,
            entry_point=entry,
            kwargs=dict(kwargs),
            max_episode_steps=steps,
            vector_entry_point=functools.partial(FerrobotVectorEnv, env_id=env_id),
        )


register_envs()
