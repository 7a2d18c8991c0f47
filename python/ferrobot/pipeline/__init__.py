"""Pick-and-place end to end: scenes, the episode workflow, reports and batch runs (``ferrobot demo``).

from ferrobot.pipeline import PickPlace, random_scene
result = PickPlace().run(random_scene(seed=0))
print(result.success, result.failed_stage, result.reason)
"""

from __future__ import annotations

from .pick_place import STAGES, Episode, EpisodeResult, PickPlace, PickPlaceConfig, StageFailure, StageResult
from .scene import HOME, TABLE_TOP, ObjectSpec, SceneSpec, build_world, clutter_scene, random_scene

__all__ = [
    "HOME",
    "STAGES",
    "TABLE_TOP",
    "Episode",
    "EpisodeResult",
    "ObjectSpec",
    "PickPlace",
    "PickPlaceConfig",
    "SceneSpec",
    "StageFailure",
    "StageResult",
    "build_world",
    "clutter_scene",
    "random_scene",
]
