"""Recorded-episode generation throughput: `ferrobot generate` as a benchmark.

    python benches/generate.py [--episodes 8] [--seed 0] [--format lerobot] [--cameras scene:640x480,wrist:320x240]
                               [--ray] [--keep] [--json FILE] [--no-segmentation]

Generates the same episodes with 1 local worker, then with 2 (all cores of this machine), then with a local
Ray instance when ``--ray`` is given, each into a fresh directory, and reports episodes per hour, recorded
frames (control steps) per second, CPU seconds per episode (and the episodes per hour per core of CPU time they
imply, the load-independent figure on a shared machine) and the scaling. A breakdown of one frame's cost
(render per camera, video encoding, physics per control step) says what bounds the rate. ``--keep`` keeps
the datasets (their paths are in the JSON); ``benches/lerobot_load.py DIR`` loads one with LeRobot.
Target (2 cores, issue 19): >= 2,000 episodes/hour with a 640x480 RGB-D scene camera and a 320x240 wrist
camera at 10 Hz, LeRobot format.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np

import ferrobot
from ferrobot.dataset import GenerateConfig, generate, parse_cameras


def cpu_seconds() -> float:
    own = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def breakdown(cameras: list[dict]) -> dict:
    """Milliseconds per recorded frame of each part, measured in this process (one thread each)."""
    import av

    from ferrobot.control import CameraSpec, ControlStepper, make_cameras
    from ferrobot.dataset.staging import _Video
    from ferrobot.pipeline import build_world, random_scene

    spec = random_scene(0)
    world, robot, camera = build_world(spec)
    cams = make_cameras(
        world, robot, camera.get_world_transform(), [CameraSpec(c["name"], c["width"], c["height"]) for c in cameras]
    )
    out = {}
    for name, cam in cams.items():
        cam.render()
        t, c = time.perf_counter(), time.process_time()
        for _ in range(10):
            frame = cam.render()
        out[f"render_{name}_{cam.width}x{cam.height}_ms"] = 1e3 * (time.perf_counter() - t) / 10
        out[f"render_{name}_{cam.width}x{cam.height}_cpu_ms"] = 1e3 * (time.process_time() - c) / 10
        with tempfile.TemporaryDirectory() as d:
            images = {
                "rgb": frame["rgb"],
                "depth": np.where(np.isfinite(frame["depth"]), frame["depth"], 0),
                "segmentation": frame["segmentation"],
            }
            for kind, img in images.items():
                v = _Video(Path(d) / f"{kind}.mp4", cam.width, cam.height, 10, kind)
                t = time.perf_counter()
                for _ in range(20):
                    v.add(img)
                v.close()
                out[f"encode_{kind}_{name}_ms"] = 1e3 * (time.perf_counter() - t) / 20
    stepper = ControlStepper(world, robot)
    t = time.perf_counter()
    for _ in range(20):
        stepper.step(stepper.hold_action())
    out["physics_per_control_step_ms"] = 1e3 * (time.perf_counter() - t) / 20
    del av
    return out


def run(label: str, args, workers: int | None, ray: str) -> dict:
    out = Path(tempfile.mkdtemp(prefix="ferrobot-bench-")) / "ds"
    cfg = GenerateConfig(
        episodes=args.episodes,
        seed=args.seed,
        format=args.format,
        cameras=parse_cameras(args.cameras),
        segmentation=args.segmentation,
    )
    c0, t0 = cpu_seconds(), time.perf_counter()
    s = generate(out, cfg, workers=workers, ray=ray, progress=False)
    wall, cpu = time.perf_counter() - t0, cpu_seconds() - c0
    size = sum(p.stat().st_size for p in out.rglob("*") if p.is_file())
    r = {
        "label": label,
        "workers": workers,
        "episodes": s["episodes"],
        "success_rate": s["success_rate"],
        "frames": s["frames"],
        "wall_s": wall,
        "episodes_per_hour": 3600 * s["episodes"] / wall,
        "frames_per_s": s["frames"] / wall,
        "cpu_s_per_episode_local": cpu / s["episodes"] if ray == "off" else None,
        # CPU-time throughput: what one core would do if the run had it to itself (load-independent).
        "episodes_per_hour_per_core_cpu": 3600 * s["episodes"] / cpu if ray == "off" else None,
        "median_episode_wall_s": s["median_episode_wall_s"],
        "finalize_s": s["total_wall_s"] - s["generation_wall_s"],
        "dataset_mb": size / 1e6,
        "mb_per_episode": size / 1e6 / s["episodes"],
        "load_after": os.getloadavg(),
    }
    print(
        f"{label:<22} {r['episodes']} episodes ({100 * r['success_rate']:.0f}% ok), {r['frames']} frames, "
        f"{wall:.1f} s: {r['episodes_per_hour']:.0f} episodes/h, {r['frames_per_s']:.1f} frames/s, "
        f"{r['mb_per_episode']:.2f} MB/episode, median episode {r['median_episode_wall_s']:.1f} s"
        + (
            f", {r['cpu_s_per_episode_local']:.2f} CPU s/episode"
            f" ({r['episodes_per_hour_per_core_cpu']:.0f} episodes/h per core of CPU)"
            if r["cpu_s_per_episode_local"]
            else ""
        )
        + f", finalisation {r['finalize_s']:.2f} s, load {os.getloadavg()[0]:.1f}",
        flush=True,
    )
    r["path"] = str(out)
    return r


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--episodes", type=int, default=8)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--format", default="lerobot")
    ap.add_argument("--cameras", default="scene:640x480,wrist:320x240")
    ap.add_argument("--ray", action="store_true", help="also run on a local Ray instance")
    ap.add_argument("--keep", action="store_true", help="keep the generated datasets")
    ap.add_argument("--json", type=Path)
    ap.add_argument(
        "--segmentation",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="record segmentation (the default of `ferrobot generate`)",
    )
    args = ap.parse_args()
    cores = os.cpu_count() or 1
    print(
        f"ferrobot {ferrobot.__version__}, {cores} cores, load {os.getloadavg()}, cameras {args.cameras}, "
        f"segmentation {args.segmentation}"
    )
    bd = breakdown(parse_cameras(args.cameras))
    print("per-frame costs (ms): " + ", ".join(f"{k} {v:.1f}" for k, v in bd.items()), flush=True)
    runs = [run("local, 1 worker", args, 1, "off"), run(f"local, {cores} workers", args, cores, "off")]
    if args.ray:
        runs.append(run(f"ray, {cores} CPUs", args, cores, "auto"))
    base = runs[0]["episodes_per_hour"]
    for r in runs[1:]:
        print(f"scaling {r['label']}: x{r['episodes_per_hour'] / base:.2f} over 1 worker")
    result = {
        "breakdown_ms": bd,
        "runs": runs,
        "cameras": args.cameras,
        "format": args.format,
        "segmentation": args.segmentation,
    }
    if not args.keep:
        for r in runs:
            shutil.rmtree(Path(r["path"]).parent, ignore_errors=True)
    if args.json:
        args.json.write_text(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
