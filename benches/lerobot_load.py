"""Loads a dataset written by `ferrobot generate --format lerobot` with LeRobot's own `LeRobotDataset`.

    python benches/lerobot_load.py DIR        # in an environment with `pip install lerobot`

Needs only lerobot (not ferrobot): lerobot pins numpy and av versions of its own, so it usually lives in
its own virtualenv. Uses the PyAV video backend (torchcodec needs system FFmpeg libraries). Prints the
episode and frame counts, each item's keys and shapes at the first, middle and last frame, and checks
the middle frame's scene image against a direct PyAV decode of the same video frame.
"""

from __future__ import annotations

import sys
import time

import av
import numpy as np
from lerobot.datasets.lerobot_dataset import LeRobotDataset


def main() -> None:
    root = sys.argv[1]
    t = time.perf_counter()
    ds = LeRobotDataset("local/ferrobot", root=root, video_backend="pyav")
    print(f"LeRobotDataset: {ds.num_episodes} episodes, {len(ds)} frames, {ds.fps} fps")
    for i in (0, len(ds) // 2, len(ds) - 1):
        item = ds[i]
        shapes = {k: tuple(v.shape) for k, v in item.items() if hasattr(v, "shape")}
        print(i, item["task"], shapes)
    mid = len(ds) // 2
    img = ds[mid]["observation.images.scene"].permute(1, 2, 0).numpy() * 255
    ep = int(ds[mid]["episode_index"])
    with av.open(f"{root}/videos/observation.images.scene/chunk-000/file-000.mp4") as c:
        frames = [f.to_ndarray(format="rgb24") for f in c.decode(video=0)]
    assert ds.meta.episodes[ep]["videos/observation.images.scene/file_index"] == 0
    diff = float(np.abs(img - frames[mid]).max())
    print(f"middle frame vs direct PyAV decode: max difference {diff:.4f} (of 255); {time.perf_counter() - t:.1f} s")
    if diff > 0.5:
        raise SystemExit("LeRobotDataset returned a different frame")


if __name__ == "__main__":
    main()
