"""CPU cost of recording: the renderer per camera and whole recorded episodes, one thread, steady state.

``python benches/render.py [--scenes N] [--episodes K] [--cameras scene:640x480,wrist:320x240] [--json FILE]``

* Renders: the generation scenes of seeds 0..N-1 (``ferrobot.pipeline.random_scene``) seen by the recording
  cameras (``ferrobot.control.make_cameras``), RGB + depth + segmentation, CPU ms per frame
  (``time.process_time``) with ``RAYON_NUM_THREADS=1``, so the figure is CPU work whatever the machine's load.
* Episodes: ``ferrobot.dataset.generate.run_episode`` for episodes 0..K-1 of seed 0 written as LeRobot v3.0
  into a temporary directory, the planner built beforehand; CPU seconds per episode and per recorded frame,
  and the episodes per hour per core that implies (3,600 / CPU s per episode).

Run it from two trees (e.g. ``PYTHONPATH=<old tree>``) alternately to compare builds on a shared machine.
"""

from __future__ import annotations

import argparse
import importlib
import json
import os
import tempfile
import time

os.environ["RAYON_NUM_THREADS"] = "1"


def renders(n: int, cameras: str) -> dict:
    from ferrobot.control import CameraSpec, make_cameras
    from ferrobot.dataset.generate import parse_cameras
    from ferrobot.pipeline import build_world, random_scene

    total: dict[str, float] = {}
    for seed in range(n):
        spec = random_scene(seed)
        world, robot, camera = build_world(spec)
        specs = [CameraSpec(c["name"], c["width"], c["height"]) for c in parse_cameras(cameras)]
        cams = make_cameras(world, robot, camera.world_transform, specs)
        for name, cam in cams.items():
            cam.render()
            c = time.process_time()
            for _ in range(5):
                cam.render()
            total[name] = total.get(name, 0.0) + (time.process_time() - c) / 5
    return {f"render_{k}_cpu_ms": round(1e3 * v / n, 2) for k, v in total.items()}


def episodes(k: int, cameras: str) -> dict:
    from ferrobot.pipeline import PickPlace, PickPlaceConfig

    g = importlib.import_module("ferrobot.dataset.generate")  # the module (the package exports a function)

    g._PP[("panda", None, None)] = PickPlace(PickPlaceConfig())
    cfg = g.GenerateConfig(episodes=k, seed=0, cameras=g.parse_cameras(cameras)).to_dict()
    cpu, frames = [], []
    with tempfile.TemporaryDirectory() as d:
        os.makedirs(os.path.join(d, g.STATE_DIR, "episodes"))
        os.makedirs(os.path.join(d, g.STATE_DIR, "tmp"))
        for i in range(k):
            c = time.process_time()
            r = g.run_episode(cfg, i, d)
            cpu.append(time.process_time() - c)
            frames.append(r["length"])
    s = sum(cpu)
    return {
        "episodes": k,
        "frames": sum(frames),
        "cpu_s_per_episode": round(s / k, 3),
        "cpu_ms_per_frame": round(1e3 * s / sum(frames), 2),
        "episodes_per_hour_per_core": round(3600 * k / s),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", type=int, default=4)
    ap.add_argument("--episodes", type=int, default=0)
    ap.add_argument("--cameras", default="scene:640x480,wrist:320x240")
    ap.add_argument("--json")
    a = ap.parse_args()
    import ferrobot

    out = {"ferrobot": os.path.dirname(ferrobot.__file__), "load_average": os.getloadavg()[0]}
    if a.scenes:
        out.update(renders(a.scenes, a.cameras))
    if a.episodes:
        out.update(episodes(a.episodes, a.cameras))
    out["load_average_end"] = os.getloadavg()[0]
    print(json.dumps(out))
    if a.json:
        with open(a.json, "a") as f:
            f.write(json.dumps(out) + "\n")


if __name__ == "__main__":
    main()
