"""robomimic-layout HDF5, built from published (staged) episodes into ``<out>/dataset.hdf5``.

Layout (robomimic's ``get_dataset`` conventions, as MimicGen-style generators write it)::

    data                      attrs: total (frames), env_args (JSON: env_name, type, env_kwargs), fps,
                                     ferrobot (JSON: generation config)
    data/demo_<i>             attrs: num_samples, seed, success, task, stages (JSON), randomization (JSON),
                                     segmentation_labels (JSON: segmentation id -> name),
                                     model_file (JSON scene: ``scene_from_dict`` rebuilds it)
        obs/<key>             key = the observation name without "observation.": state, velocity, ee_pose,
                              gripper_opening, images.<camera> (T, H, W, 3) uint8, depth.<camera> (T, H, W)
                              float32 metres (0 = no reading), segmentation.<camera> (T, H, W) int32
        actions               (T, A) float32: arm joint targets + gripper command
        actions_ee_pose       (T, 7) float32
        states                (T, S) float64: simulator state after each action (``sim_state``)
        rewards, dones        (T,): 1 at the last step (reward only if the episode succeeded)
    mask/train, mask/valid    demo names (every 10th demo is in valid), mask/successful
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

__all__ = ["finalize_hdf5", "HDF5_NAME"]

HDF5_NAME = "dataset.hdf5"


def finalize_hdf5(root: Path, episode_dirs: list[Path], info_extra: dict, work: Path, fault=None) -> None:
    import h5py

    tmp = work / HDF5_NAME
    total = 0
    names, ok = [], []
    with h5py.File(tmp, "w") as out:
        data = out.create_group("data")
        for i, d in enumerate(episode_dirs):
            meta = json.loads((d / "episode.json").read_text())
            name = f"demo_{i}"
            with h5py.File(d / "episode.hdf5", "r") as src:
                src.copy(src["demo"], data, name=name)
            g = data[name]
            g.attrs["seed"] = int(meta["seed"])
            g.attrs["success"] = bool(meta["success"])
            g.attrs["task"] = meta["task"]
            g.attrs["stages"] = json.dumps(meta["stages"])
            g.attrs["randomization"] = json.dumps(meta.get("randomization", {}))
            g.attrs["segmentation_labels"] = json.dumps(meta.get("segmentation_labels", {}))
            total += int(g.attrs["num_samples"])
            names.append(name)
            if meta["success"]:
                ok.append(name)
        data.attrs["total"] = total
        data.attrs["fps"] = int(info_extra["fps"])
        data.attrs["env_args"] = json.dumps(
            {"env_name": "ferrobot-pick-place", "type": 4, "env_kwargs": info_extra.get("ferrobot", {})}
        )
        data.attrs["ferrobot"] = json.dumps(info_extra.get("ferrobot", {}))
        mask = out.create_group("mask")
        valid = names[9::10]
        mask.create_dataset("train", data=np.array([n for n in names if n not in valid], dtype="S"))
        mask.create_dataset("valid", data=np.array(valid, dtype="S"))
        mask.create_dataset("successful", data=np.array(ok, dtype="S"))
    if fault is not None:
        fault()  # test hook: a kill before the file is moved into place
    os.replace(tmp, root / HDF5_NAME)
