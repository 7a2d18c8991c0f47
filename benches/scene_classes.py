"""Collision and planning cost per scene class, on generated scenes with many and close obstacles.

    python benches/scene_classes.py [--worlds 6] [--problems 10] [--classes table,shelves,cage,clutter]
    python benches/scene_classes.py --ab /tmp/ferrobot-main-pkg --rounds 3   # interleaved A/B
    python benches/scene_classes.py --classes cage --dump /tmp/cage.txt      # problems for plan_ab.rs

Scene classes (Panda at the origin, generated from a seed; see the functions below):
  table    an open table with a few objects on it;
  shelves  a bookshelf in front of the arm, with boards and vertical dividers (narrow cells);
  cage     a cage of thin bars around the workspace (~100-200 bars), plus a table;
  clutter  a table with 60-150 small boxes, cylinders and spheres on it and floating above it.

Per class it reports: obstacles, batch collision throughput (configurations/s from Python, wall and per CPU
second), a single check from Python (includes the binding's call overhead), and per plan (start and goal random
free configurations, joint goals): solved, plan + simplify median / p95 (wall time from Python with
trajectory=False), finished trajectory median / p95 (wall time, trajectory=True), and the stage times the
planner reports (planning = RRT-Connect, simplify = shortcutting + fine re-check, trajectory = spline fit,
dense re-check, time scaling; builds that report them split it into fit (spline fits and time scaling) and
re-check, with the configurations re-checked). Every path and trajectory is re-checked by a separate
CollisionChecker at 5 mrad.

With --ab DIR the script runs itself alternately with ferrobot imported from DIR (the A side, e.g. a copy of
`main`'s python/ferrobot with its built extension) and from the installed package (B), --rounds times each.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
SHARED = HERE.parent.parent / "shared"
# The re-check resolution (5 mrad) and path densification of the MotionBenchMaker bench.
sys.path.insert(0, str(HERE))
from mbm import RESOLUTION, densify  # noqa: E402


def _pose(x, y, z, yaw=0.0):
    return [x, y, z, np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)]


def table(world, rng, n=4):
    world.add_box("table", [0.8, 1.2, 0.04], _pose(0.6, 0.0, 0.2))
    for i in range(n):
        s = rng.uniform(0.04, 0.1, 3)
        pose = _pose(rng.uniform(0.4, 0.8), rng.uniform(-0.4, 0.4), 0.22 + s[2] / 2, rng.uniform(-3, 3))
        world.add_box(f"obj{i}", s, pose)


def shelves(world, rng):
    x0 = rng.uniform(0.55, 0.7)
    depth, width, th = 0.35, 1.2, 0.02
    levels = np.linspace(0.0, 1.1, 5)
    for k, z in enumerate(levels):
        world.add_box(f"board{k}", [depth, width, th], _pose(x0 + depth / 2, 0.0, z))
    world.add_box("back", [th, width, 1.1], _pose(x0 + depth, 0.0, 0.55))
    for k, z in enumerate(levels[:-1]):
        for j, y in enumerate(np.linspace(-width / 2, width / 2, 5)):
            h = levels[k + 1] - z
            world.add_box(f"divider{k}_{j}", [depth, th, h], _pose(x0 + depth / 2, y, z + h / 2))
    for i in range(6):
        k = rng.integers(0, 4)
        s = rng.uniform(0.03, 0.07, 3)
        world.add_box(
            f"book{i}", s, _pose(x0 + rng.uniform(0.08, 0.25), rng.uniform(-0.5, 0.5), levels[k] + th / 2 + s[2] / 2)
        )


def cage(world, rng):
    world.add_box("table", [0.7, 1.0, 0.04], _pose(0.55, 0.0, 0.15))
    r = rng.uniform(0.75, 0.85)
    bar = 0.015
    k = 0
    # Vertical bars on a circle, horizontal rings of bars, and a roof grid.
    for a in np.linspace(0, 2 * np.pi, 28, endpoint=False):
        if abs(np.angle(np.exp(1j * (a - np.pi)))) < 0.5:
            continue  # an opening behind the robot
        world.add_cylinder(f"bar{k}", bar, 1.3, _pose(r * np.cos(a), r * np.sin(a), 0.45))
        k += 1
    for z in (0.35, 0.7, 1.05):
        for a in np.linspace(0, 2 * np.pi, 28, endpoint=False):
            size = [bar * 2, 2 * r * np.sin(np.pi / 28), bar * 2]
            world.add_box(f"ring{k}", size, _pose(r * np.cos(a), r * np.sin(a), z, a))
            k += 1
    for x in np.linspace(-r, r, 12):
        world.add_box(f"roof{k}", [bar * 2, 2 * r, bar * 2], _pose(x, 0.0, 1.1))
        k += 1
    for i in range(8):
        s = rng.uniform(0.03, 0.08, 3)
        world.add_box(f"obj{i}", s, _pose(rng.uniform(0.35, 0.8), rng.uniform(-0.4, 0.4), 0.17 + s[2] / 2))


def clutter(world, rng):
    world.add_box("table", [0.9, 1.4, 0.04], _pose(0.6, 0.0, 0.1))
    for i in range(int(rng.integers(60, 150))):
        x, y = rng.uniform(0.3, 0.95), rng.uniform(-0.65, 0.65)
        z = 0.12 + (rng.uniform(0.0, 0.6) if i % 3 == 0 else 0.0)
        kind = i % 3
        if kind == 0:
            s = rng.uniform(0.02, 0.06, 3)
            world.add_box(f"c{i}", s, _pose(x, y, z + s[2] / 2, rng.uniform(-3, 3)))
        elif kind == 1:
            rad, length = rng.uniform(0.01, 0.03), rng.uniform(0.03, 0.12)
            world.add_cylinder(f"c{i}", rad, length, _pose(x, y, z + length / 2))
        else:
            rad = rng.uniform(0.01, 0.03)
            world.add_sphere(f"c{i}", rad, _pose(x, y, z + rad))


CLASSES = {"table": table, "shelves": shelves, "cage": cage, "clutter": clutter}


class _Recorder:
    """Forwards add_box / add_cylinder / add_sphere to a world and writes them as MoveIt scene objects (--dump)."""

    def __init__(self, world):
        self.world, self.lines = world, ["world:", "  collision_objects:"]

    def _add(self, name, kind, dims, pose):
        x, y, z, qw, qx, qy, qz = (float(v) for v in pose)
        self.lines += [
            f"    - id: {name}",
            f"      primitives: [{{type: {kind}, dimensions: [{', '.join(repr(float(d)) for d in dims)}]}}]",
            f"      primitive_poses: [{{position: [{x!r}, {y!r}, {z!r}], "
            f"orientation: [{qx!r}, {qy!r}, {qz!r}, {qw!r}]}}]",
        ]

    def add_box(self, name, size, pose):
        self.world.add_box(name, size, pose)
        self._add(name, "box", size, pose)

    def add_cylinder(self, name, radius, length, pose):
        self.world.add_cylinder(name, radius, length, pose)
        # shape_msgs/SolidPrimitive: [height, radius]
        self._add(name, "cylinder", [length, radius], pose)

    def add_sphere(self, name, radius, pose):
        self.world.add_sphere(name, radius, pose)
        self._add(name, "sphere", [radius], pose)


def run(args) -> dict:
    import ferrobot

    model = ferrobot.RobotModel.from_urdf(SHARED / "robots/panda/panda.urdf", srdf=SHARED / "robots/panda/panda.srdf")
    spheres = ferrobot.SphereModel.from_spherized_urdf(model, SHARED / "robots/panda/panda_spherized.urdf")
    planner = ferrobot.Planner(model, spheres=spheres)
    checker = ferrobot.CollisionChecker(model, spheres=spheres)
    idx = [planner.dof_names.index(n) for n in planner.joint_names]
    lo, hi = np.asarray(planner.limits.lower), np.asarray(planner.limits.upper)
    vmax = planner.limits.velocity.max()
    out = {"ferrobot": ferrobot.__file__, "classes": {}}
    for cname in args.classes.split(","):
        rows = {"obstacles": [], "batch_wall": [], "batch_cpu": [], "single_us": [], "plans": []}
        for w in range(args.worlds):
            rng = np.random.default_rng(1000 * w + len(cname))
            world = ferrobot.CollisionWorld()
            rec = _Recorder(world)
            CLASSES[cname](rec, rng)
            planner.update_world(world)
            checker.update_world(world)
            rows["obstacles"].append(len(world))
            full = np.tile(planner.locked_positions, (args.batch, 1))
            full[:, idx] = rng.uniform(lo, hi, (args.batch, len(idx)))
            checker.in_collision_batch(full[:1000])  # the grid and its first cells
            c0, t0 = time.process_time(), time.perf_counter()
            flags = checker.in_collision_batch(full)
            c1, t1 = time.process_time(), time.perf_counter()
            rows["batch_wall"].append(args.batch / (t1 - t0))
            rows["batch_cpu"].append(args.batch / (c1 - c0))
            t0 = time.perf_counter()
            for q in full[:2000]:
                checker.in_collision(q)
            rows["single_us"].append((time.perf_counter() - t0) / 2000 * 1e6)
            free = full[~flags][:, idx]
            if args.dump:
                scene = Path(args.dump).with_name(f"{Path(args.dump).stem}_{cname}{w}.scene")
                scene.write_text("\n".join(rec.lines) + "\n")
                with open(args.dump, "a") as f:
                    for p in range(args.problems):
                        q = " ".join(repr(float(v)) for v in (*free[2 * p], *free[2 * p + 1]))
                        f.write(f"{scene.resolve()} {q}\n")
                continue
            for p in range(args.problems):
                start, goal = free[2 * p], free[2 * p + 1]
                t0 = time.perf_counter()
                r = planner.plan(start, goal_q=goal, seed=p, trajectory=False)
                ps = time.perf_counter() - t0
                t0 = time.perf_counter()
                rt = planner.plan(start, goal_q=goal, seed=p)
                tr = time.perf_counter() - t0
                row = {"solved": bool(r.success and rt.success), "plan_simplify": ps, "trajectory": tr}
                if row["solved"]:
                    ok = True
                    for res in (r, rt):
                        path = densify(res.path)
                        qs = np.tile(planner.locked_positions, (len(path), 1))
                        qs[:, idx] = path
                        ok = ok and not checker.in_collision_batch(qs).any()
                    traj = rt.interpolated(dt=0.8 * RESOLUTION / vmax).positions
                    qs = np.tile(planner.locked_positions, (len(traj), 1))
                    qs[:, idx] = traj
                    ok = ok and not checker.in_collision_batch(qs).any()
                    ok = ok and np.abs(np.diff(traj, axis=0)).max() <= RESOLUTION
                    row["clean"] = bool(ok)
                    t = rt.times
                    row["stages"] = dict(t.to_dict() if hasattr(t, "to_dict") else t)
                    # Older builds report neither (the A side of an A/B run).
                    row["recheck_samples"] = getattr(rt, "recheck_samples", None)
                rows["plans"].append(row)
        out["classes"][cname] = rows
    return out


def report(res: dict, label: str = "") -> None:
    print(f"{label}ferrobot from {res['ferrobot']}")
    for cname, rows in res["classes"].items():
        plans = rows["plans"]
        solved = [p for p in plans if p["solved"]]
        clean = [p for p in solved if p.get("clean")]
        ps = np.array([p["plan_simplify"] for p in solved]) * 1e6
        tr = np.array([p["trajectory"] for p in solved]) * 1e6
        st = {
            k: np.median([p["stages"].get(k, np.nan) for p in solved]) * 1e6
            for k in ("planning", "simplify", "trajectory", "fit", "recheck")
        }
        counts = [p["recheck_samples"] for p in solved if p.get("recheck_samples") is not None]
        print(
            f"  {cname:8s} obstacles {np.median(rows['obstacles']):5.0f}  "
            f"batch {np.median(rows['batch_wall']) / 1e6:5.2f} M/s wall "
            f"({np.median(rows['batch_cpu']) / 1e6:5.2f} M/CPU-s)  single {np.median(rows['single_us']):5.2f} us  "
            f"solved {len(solved)}/{len(plans)} clean {len(clean)}"
        )
        if len(solved):
            print(
                f"           plan+simplify median {np.median(ps):7.0f} us p95 {np.percentile(ps, 95):7.0f}  "
                f"trajectory median {np.median(tr):7.0f} us p95 {np.percentile(tr, 95):7.0f}  "
                f"stages (median, trajectory=True run): rrt {st['planning']:.0f} simplify {st['simplify']:.0f} "
                f"spline+recheck+timing {st['trajectory']:.0f} us"
            )
            if counts:
                print(
                    f"           of which fit+timing {st['fit']:.0f} us, re-check {st['recheck']:.0f} us "
                    f"(median), {np.mean(counts):.0f} configurations re-checked per trajectory (mean)"
                )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--worlds", type=int, default=6)
    ap.add_argument("--problems", type=int, default=10)
    ap.add_argument("--batch", type=int, default=100_000)
    ap.add_argument("--classes", default="table,shelves,cage,clutter")
    ap.add_argument("--ab", help="directory holding the A side's ferrobot package")
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--json", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument(
        "--dump",
        help="only write the problems (scene file, 7 start and 7 goal values a line; the scenes beside it) for "
        "crates/ferrobot-planning/examples/plan_ab.rs to this file (appended)",
    )
    args = ap.parse_args()
    if args.ab:
        print(f"load average {os.getloadavg()}")
        base = [a for a in sys.argv[1:] if a not in ("--ab", args.ab)]
        for k in range(args.rounds):
            for side, env in (("A", {"PYTHONPATH": args.ab}), ("B", {})):
                e = dict(os.environ, **env)
                cmd = [sys.executable, __file__, *base, "--json"]
                got = subprocess.run(cmd, env=e, capture_output=True, text=True, check=True)
                report(json.loads(got.stdout), f"round {k} {side}: ")
        print(f"load average {os.getloadavg()}")
        return
    res = run(args)
    if args.dump:
        return
    if args.json:
        print(json.dumps(res))
    else:
        print(f"load average {os.getloadavg()}")
        report(res)


if __name__ == "__main__":
    main()
