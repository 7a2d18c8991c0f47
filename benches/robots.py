"""Every robot the environment's packages ship (issue 17, deliverable 8): per robot, load time,
automatic sphere count, worst protrusion and build time, IK rate, median plan time and
simulation steps/s, all in CPU time (`time.process_time`, this process; the spherizer and IK
batches use every core, so their CPU time is the sum over cores).

- load: `RobotModel.from_urdf` (URDF, meshes, SRDF), median of 3.
- spheres: `SphereModel.automatic(model)` (the default every checker and planner uses): count,
  worst measured protrusion over the links, build time (one run: it is seconds) with an empty
  sphere cache (the bench points `FERROBOT_CACHE_DIR` at a new temporary directory unless it is
  set), and the time of a second build of a freshly loaded model (`cached`: the disk cache).
- IK: `Planner.ik_batch` on 200 poses from FK of random configurations (reachable), solves per
  CPU second and the success rate.
- plan: 20 random collision-free start/goal pairs, `Planner.plan` (RRT-Connect, shortcutting,
  smooth time-parametrised trajectory), median CPU time and success rate.
- sim: `World.add_robot` on the ground, drives holding the start configuration, 480 steps of
  1/240 s, steps per CPU second.

    python benches/robots.py [--robots erd_ur5 pb_kuka_iiwa ...] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

import ferrobot

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
import robots_in_env as env  # noqa: E402


def cpu(fn):
    t = time.process_time()
    out = fn()
    return out, time.process_time() - t


def bench(name: str) -> dict:
    row: dict = {"robot": name}
    loads = [cpu(lambda: env.load(name))[1] for _ in range(3)]
    model = env.load(name)
    row.update(dof=model.num_dof, links=len(model.link_names), load_ms=1e3 * statistics.median(loads))
    spheres, t = cpu(lambda: ferrobot.SphereModel.automatic(model))
    again = env.load(name)
    _, t_cached = cpu(lambda: ferrobot.SphereModel.automatic(again))
    row["spheres_cached_s"] = t_cached
    row.update(
        spheres=spheres.count,
        max_protrusion_mm=1e3 * max((r.max_protrusion for r in spheres.report), default=0.0),
        spheres_s=t,
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        planner = ferrobot.Planner(model, spheres=spheres)
    rng = np.random.default_rng(0)
    lo = np.where(np.isfinite(model.lower_limits), model.lower_limits, -np.pi)
    hi = np.where(np.isfinite(model.upper_limits), model.upper_limits, np.pi)
    qs = rng.uniform(lo, hi, size=(200, model.num_dof))
    poses = np.array([model.fk(q, link=planner.ee_link) for q in qs])
    ik, t = cpu(lambda: planner.ik_batch(poses, seed=0))
    row.update(ik_per_s=len(poses) / t, ik_success=float(np.mean(ik.success)))
    plo, phi = planner.limits.lower, planner.limits.upper
    plo = np.where(np.isfinite(plo), plo, -np.pi)
    phi = np.where(np.isfinite(phi), phi, np.pi)

    def free_q(tries: int = 20_000):
        # Bounded: a robot whose every sampled configuration is reported in self-collision (pybullet's
        # franka_panda without an SRDF, 500 of 500 uniform samples) must not hang the bench.
        for _ in range(tries):
            q = rng.uniform(plo, phi)
            if not planner.in_collision(q):
                return q
        return None

    times, ok = [], 0
    for k in range(20):
        start, goal = free_q(), free_q()
        if start is None or goal is None:
            row["plan_note"] = "no collision-free configuration in 20,000 uniform samples"
            break
        r, t = cpu(lambda s=start, g=goal, k=k: planner.plan(s, goal_q=g, seed=k))
        times.append(t)
        ok += r.success
    row.update(
        plan_median_ms=1e3 * statistics.median(times) if times else float("nan"),
        plan_success=ok / 20,
    )
    world = ferrobot.World(dt=1 / 240)
    robot = world.add_robot(model, name=name)
    robot.set_joint_position_targets(robot.joint_positions)
    world.step(10)
    _, t = cpu(lambda: world.step(480))
    row["sim_steps_per_s"] = 480 / t
    return row


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--robots", nargs="*", default=None, help=f"default: all available ({', '.join(env.available())})")
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args()
    os.environ.setdefault("FERROBOT_CACHE_DIR", tempfile.mkdtemp(prefix="ferrobot-bench-cache-"))
    names = args.robots or env.available()
    cols = [
        ("robot", "{:<16}"),
        ("dof", "{:>3}"),
        ("load_ms", "{:>8.1f}"),
        ("spheres", "{:>7}"),
        ("max_protrusion_mm", "{:>8.1f}"),
        ("spheres_s", "{:>9.2f}"),
        ("spheres_cached_s", "{:>9.3f}"),
        ("ik_per_s", "{:>8.0f}"),
        ("ik_success", "{:>6.2f}"),
        ("plan_median_ms", "{:>9.2f}"),
        ("plan_success", "{:>6.2f}"),
        ("sim_steps_per_s", "{:>9.0f}"),
    ]
    heads = ["robot", "dof", "load ms", "spheres", "protr mm", "build s", "cached s"]
    heads += ["IK/s", "IK ok", "plan ms", "plan ok", "sim st/s"]
    print(" ".join(f"{h:>9}" if i else f"{h:<16}" for i, h in enumerate(heads)))
    rows = []
    for name in names:
        try:
            row = bench(name)
        except Exception as e:  # report and go on: one broken robot must not hide the others
            print(f"{name:<16} FAILED: {type(e).__name__}: {e}")
            rows.append({"robot": name, "error": f"{type(e).__name__}: {e}"})
            continue
        rows.append(row)
        cells = [fmt.format(row[key]) for key, fmt in cols]
        print(" ".join([cells[0]] + [f"{c:>9}" for c in cells[1:]]))
        sys.stdout.flush()
    if args.json:
        args.json.write_text(json.dumps(rows, indent=2))


if __name__ == "__main__":
    main()
