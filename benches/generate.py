"""Recorded-episode generation throughput: `ferrobot generate` as a benchmark.

    python benches/generate.py [--episodes 8] [--seed 0] [--format lerobot] [--cameras scene:640x480,wrist:320x240]
                               [--ray] [--keep] [--json FILE] [--no-segmentation]
                               [--robots panda,ur5e] [--objects DIR|pybullet|none] [--clutter K] [--workers 1,2]

Generates the same episodes with 1 local worker, then with 2 (all cores of this machine), then with a local
Ray instance when ``--ray`` is given, each into a fresh directory, and reports episodes per hour, recorded
frames (control steps) per second, CPU seconds per episode (and the episodes per hour per core of CPU time they
imply, the load-independent figure on a shared machine) and the scaling. A breakdown of one frame's cost
(render per camera, video encoding, physics per control step) says what bounds the rate. ``--keep`` keeps
the datasets (their paths are in the JSON); ``benches/lerobot_load.py DIR`` loads one with LeRobot.
``--robots`` and ``--objects`` run every robot with the procedural objects and (unless ``--objects none``) with
mesh objects from DIR (``pybullet``: pybullet_data's ``random_urdfs``, 1,000 objects, the default), ``--clutter``
of them (default 5) per scene, in one run, interleaved robot by robot so that the machine's drift hits all alike.
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
        world, robot, camera.world_transform, [CameraSpec(c["name"], c["width"], c["height"]) for c in cameras]
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
                "rgb": frame.rgb,
                "depth": np.where(np.isfinite(frame.depth), frame.depth, 0),
                "segmentation": frame.segmentation,
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


def run(label: str, args, workers: int | None, ray: str, robot: str = "panda", objects: str | None = None) -> dict:
    out = Path(tempfile.mkdtemp(prefix="ferrobot-bench-")) / "ds"
    cfg = GenerateConfig(
        episodes=args.episodes,
        seed=args.seed,
        format=args.format,
        cameras=parse_cameras(args.cameras),
        segmentation=args.segmentation,
        robot=robot,
        objects=objects,
        clutter=args.clutter if objects else None,
    )
    c0, t0 = cpu_seconds(), time.perf_counter()
    s = generate(out, cfg, workers=workers, ray=ray, progress=False)
    wall, cpu = time.perf_counter() - t0, cpu_seconds() - c0
    size = sum(p.stat().st_size for p in out.rglob("*") if p.is_file())
    r = {
        "label": label,
        "robot": robot,
        "objects": objects,
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
        f"{label:<40} {r['episodes']} episodes ({100 * r['success_rate']:.0f}% ok), {r['frames']} frames, "
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
    ap.add_argument("--robots", default="panda", help="comma-separated: panda, ur5e (bundled) or URDF paths")
    ap.add_argument(
        "--objects", default="none", help="mesh objects: a folder, 'pybullet' (pybullet_data/random_urdfs) or none"
    )
    ap.add_argument("--clutter", type=int, default=5, help="mesh objects per scene with --objects")
    ap.add_argument("--workers", default=None, help="comma-separated worker counts (default: 1 and all cores)")
    args = ap.parse_args()
    cores = os.cpu_count() or 1
    if args.objects == "pybullet":
        import pybullet_data

        args.objects = str(Path(pybullet_data.getDataPath()) / "random_urdfs")
    objects = [None] if args.objects == "none" else [None, args.objects]
    workers = [int(w) for w in args.workers.split(",")] if args.workers else [1, cores]
    print(
        f"ferrobot {ferrobot.__version__}, {cores} cores, load {os.getloadavg()}, cameras {args.cameras}, "
        f"segmentation {args.segmentation}"
    )
    bd = breakdown(parse_cameras(args.cameras))
    print("per-frame costs (ms): " + ", ".join(f"{k} {v:.1f}" for k, v in bd.items()), flush=True)
    runs = []
    for obj in objects:
        for w in workers:
            for robot in args.robots.split(","):  # interleaved: robots side by side at each setting
                what = f"{robot}{' + mesh objects' if obj else ''}"
                runs.append(run(f"{what}, local, {w} worker(s)", args, w, "off", robot, obj))
        if args.ray:
            for robot in args.robots.split(","):
                what = f"{robot}{' + mesh objects' if obj else ''}"
                runs.append(run(f"{what}, ray, {cores} CPUs", args, cores, "auto", robot, obj))
    for r in runs:
        base = next((b for b in runs if b["robot"] == r["robot"] and b["objects"] == r["objects"]), r)
        if r is not base:
            x = r["episodes_per_hour"] / base["episodes_per_hour"]
            print(f"scaling {r['label']}: x{x:.2f} over {base['label']}")
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
