"""Collision-check throughput for the Panda in the MotionBenchMaker dev scenes.

    python benches/collision.py [--spheres spherized|automatic|default] [--n 100000] [--scenes 20] [--json FILE]

For each scene (every N-th of the 200 problems, ``--scenes`` in all): configuration checks per
second on one thread and on all cores (``in_collision_batch``), the latency of one
``in_collision`` call from Python, and motions validated per second (``motion_valid`` at 5 mrad,
random motions of up to 0.3 rad per joint). Prints medians over scenes. Also reports, for every
problem, whether its start and goal are valid (collision-free) under the sphere model.
Targets (2-core machine): >= 10 million checks/s on 2 cores; one check < 200 ns.
Sphere models: ``spherized`` (MotionBenchMaker's 59 spheres), ``automatic`` (the spherizer with a
budget of 59), ``default`` (``SphereModel.automatic(model)``, what checkers and planners use).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import yaml

import ferrobot

SHARED = Path(__file__).resolve().parents[2] / "shared"
MBM = SHARED / "bench" / "mbm"


def load_panda(which: str):
    model = ferrobot.RobotModel.from_urdf(
        SHARED / "robots/panda/panda.urdf", srdf=SHARED / "robots/panda/panda.srdf", ee_link="panda_hand"
    )
    if which == "automatic":
        spheres = ferrobot.SphereModel.automatic(model, total_budget=59)
    elif which == "default":
        spheres = ferrobot.SphereModel.automatic(model)
    else:
        spheres = ferrobot.SphereModel.from_spherized_urdf(model, SHARED / "robots/panda/panda_spherized.urdf")
    return model, spheres


def problem_validity(model, checker) -> dict:
    out = {}
    for scene_dir in sorted(MBM.iterdir()):
        rows = []
        for scene in sorted(scene_dir.glob("scene*.yaml")):
            req = yaml.safe_load((scene_dir / scene.name.replace("scene", "request")).read_text())
            js = req["start_state"]["joint_state"]
            start = dict(zip(js["name"], js["position"], strict=True))
            goal = {c["joint_name"]: c["position"] for c in req["goal_constraints"][0]["joint_constraints"]}
            checker.update_world(ferrobot.CollisionWorld.from_moveit_scene(scene))
            s_ok = not checker.in_collision([start[n] for n in model.dof_names])
            g_ok = not checker.in_collision([goal[n] for n in model.dof_names])
            rows.append({"id": scene.stem[5:], "start_valid": s_ok, "goal_valid": g_ok})
        out[scene_dir.name] = rows
    return out


def run_scene(scene: Path, args) -> dict:
    """One scene, in this process (the thread count is fixed at process start)."""
    model, spheres = load_panda(args.spheres)
    checker = ferrobot.CollisionChecker(model, ferrobot.CollisionWorld.from_moveit_scene(scene), spheres)
    rng = np.random.default_rng(0)
    qs = rng.uniform(model.lower_limits, model.upper_limits, size=(args.n, model.num_dof))
    checker.in_collision_batch(qs[:1000])
    t_batch = statistics.median(_timed(lambda: checker.in_collision_batch(qs)) for _ in range(5))
    calls = 20000
    t_single = (
        statistics.median(_timed(lambda: [checker.in_collision(q) for q in qs[:calls]]) for _ in range(3)) / calls
    )
    starts = qs[:2000]
    ends = starts + rng.uniform(-0.3, 0.3, size=starts.shape)
    t_motion = statistics.median(
        _timed(lambda: [checker.motion_valid(a, b, 0.005) for a, b in zip(starts, ends, strict=True)]) for _ in range(3)
    ) / len(starts)
    return {
        "scene": f"{scene.parent.name}/{scene.name}",
        "collide_fraction": float(checker.in_collision_batch(qs).mean()),
        "checks_per_s": args.n / t_batch,
        "single_check_us": t_single * 1e6,
        "motions_per_s": 1 / t_motion,
    }


def _timed(fn) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--spheres", choices=["spherized", "automatic", "default"], default="spherized")
    ap.add_argument("--n", type=int, default=100_000)
    ap.add_argument("--scenes", type=int, default=20)
    ap.add_argument("--json", default=None)
    ap.add_argument("--one-scene", default=None, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.one_scene:
        print(json.dumps(run_scene(Path(args.one_scene), args)))
        return
    scenes = sorted(MBM.glob("*/scene*.yaml"))
    step = max(1, len(scenes) // args.scenes)
    chosen = scenes[::step][: args.scenes]
    results = {}
    for threads in (1, os.cpu_count() or 1):
        rows = []
        for scene in chosen:
            cmd = [sys.executable, __file__, "--one-scene", str(scene), "--n", str(args.n), "--spheres", args.spheres]
            env = dict(os.environ, RAYON_NUM_THREADS=str(threads))
            rows.append(json.loads(subprocess.run(cmd, env=env, capture_output=True, text=True, check=True).stdout))
        results[threads] = rows
        med = {k: statistics.median(r[k] for r in rows) for k in ("checks_per_s", "single_check_us", "motions_per_s")}
        print(
            f"{threads} thread(s), {len(rows)} scenes, {args.spheres} spheres: "
            f"batch {med['checks_per_s'] / 1e6:.2f} M checks/s | single in_collision {med['single_check_us']:.2f} us"
            f" | motion_valid(5 mrad) {med['motions_per_s'] / 1e3:.1f} k motions/s"
        )
    model, spheres = load_panda(args.spheres)
    validity = problem_validity(model, ferrobot.CollisionChecker(model, spheres=spheres))
    for scene_name, rows in validity.items():
        both = sum(r["start_valid"] and r["goal_valid"] for r in rows)
        bad = [r["id"] for r in rows if not (r["start_valid"] and r["goal_valid"])]
        print(
            f"{scene_name}: {both}/{len(rows)} problems valid (start and goal free); invalid: {', '.join(bad) or '-'}"
        )
    if args.json:
        Path(args.json).write_text(
            json.dumps({"cores": os.cpu_count(), "spheres": args.spheres, "by_threads": results, "validity": validity})
        )


if __name__ == "__main__":
    main()
