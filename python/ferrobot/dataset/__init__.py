"""Recorded episodes as robot-learning datasets: LeRobot v3.0 and robomimic HDF5 (``ferrobot generate``).

from ferrobot.dataset import GenerateConfig, generate
summary = generate("data/pick", GenerateConfig(episodes=100, seed=0, format="lerobot"))

See :mod:`ferrobot.dataset.generate` (guarantees), :mod:`ferrobot.dataset.lerobot` and
:mod:`ferrobot.dataset.hdf5` (layouts), :mod:`ferrobot.control` (feature names, what an action does).
"""

from __future__ import annotations

from .generate import FORMATS, GenerateConfig, episode_seed, generate, parse_cameras, scene_from_dict

__all__ = ["FORMATS", "GenerateConfig", "episode_seed", "generate", "parse_cameras", "scene_from_dict"]
