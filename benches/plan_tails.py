"""Where plan + simplify time goes, problem by problem, and which problems make the p95 (issue 23).

    python benches/plan_tails.py ../shared/bench/mbm/table_pick_panda ../shared/bench/mbm/bookshelf_small_panda \
        [--slowest 10] [--ab PKGDIR --rounds 3] [--repeats 1]

Plans every valid MotionBenchMaker problem of the given folders (joint goals, spherized Panda, seed = problem
index, as `benches/mbm.py`) with `trajectory=True`, and reports per folder: the planner's own stage timers
(planning = RRT-Connect, simplify = shortcutting + certification of the final path, trajectory), the calling
thread's CPU time per plan (`time.thread_time`: the plan runs on the calling thread, so this is robust to
other processes on a shared machine), RRT-Connect samples and path waypoints; then the slowest problems with
their stage breakdown. Every path and trajectory is re-checked at 5 mrad by a separate checker (as mbm.py).

`--dump FILE` writes the problems for the in-process A/B of planner variants
(`cargo run --release -p ferrobot-planning --example plan_ab -- FILE URDF SRDF SPHERIZED`).

`--ab PKGDIR` runs the same thing alternately with `PYTHONPATH=PKGDIR` (side A, e.g. an older build) and
without it (side B), `--rounds` times, and prints both sides' summaries per round.
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

sys.path.insert(0, str(Path(__file__).resolve().parent))
from mbm import RESOLUTION, SHARED, dense_ok, densify, load_request  # noqa: E402


def run(args) -> dict:
    import ferrobot

    model = ferrobot.RobotModel.from_urdf(SHARED / "robots/panda/panda.urdf", srdf=SHARED / "robots/panda/panda.srdf")
    spheres = ferrobot.SphereModel.from_spherized_urdf(model, SHARED / "robots/panda/panda_spherized.urdf")
    planner = ferrobot.Planner(model, spheres=spheres)
    checker = ferrobot.CollisionChecker(model, spheres=spheres)
    vmax = planner.limits.velocity.max()
    rows = []
    scenes = [s for d in args.dirs for s in sorted(Path(d).glob("scene*.yaml"))]
    for k, scene in enumerate(scenes):
        world = ferrobot.CollisionWorld.from_moveit_scene(scene)
        planner.update_world(world)
        checker.update_world(world)
        start_d, goal_d = load_request(scene)
        start = np.array([start_d[n] for n in planner.joint_names])
        goal = np.array([goal_d[n] for n in planner.joint_names])
        row = {"scene": scene.parent.name, "id": scene.stem[5:]}
        best, best_ps = None, None
        for _ in range(args.repeats):
            c0 = time.thread_time()
            r = planner.plan(start, goal_q=goal, seed=k, trajectory=False)
            c1 = time.thread_time()
            best_ps = c1 - c0 if best_ps is None else min(best_ps, c1 - c0)
            c0, t0 = time.thread_time(), time.perf_counter()
            r = planner.plan(start, goal_q=goal, seed=k)
            c1, t1 = time.thread_time(), time.perf_counter()
            if best is None or c1 - c0 < best[0]:
                best = (c1 - c0, t1 - t0, r)
        cpu, wall, r = best
        if r.status in ("start_in_collision", "goal_in_collision"):
            continue
        row.update(status=r.status, cpu=cpu, cpu_ps=best_ps, wall=wall)
        if r.success:
            traj = r.interpolated(dt=0.8 * RESOLUTION / vmax)
            ok = dense_ok(checker, planner, densify(r.path)) and dense_ok(checker, planner, traj.positions)
            ok = ok and np.abs(np.diff(traj.positions, axis=0)).max() <= RESOLUTION
            # Older builds (the A side of an A/B run) return the times as a dict.
            t = r.times if isinstance(r.times, dict) else r.times.to_dict()
            row.update(
                clean=bool(ok),
                planning=t["planning"],
                simplify=t["simplify"],
                trajectory=t["trajectory"],
                total=t["total"],
                samples=r.samples,
                waypoints=len(r.path),
            )
        rows.append(row)
    return {"ferrobot": ferrobot.__file__, "rows": rows}


def report(res: dict, label: str, slowest: int) -> None:
    print(f"{label}ferrobot from {res['ferrobot']}")
    by: dict[str, list] = {}
    for r in res["rows"]:
        by.setdefault(r["scene"], []).append(r)
    for scene, rows in by.items():
        ok = [r for r in rows if r["status"] == "solved"]
        clean = sum(r["clean"] for r in ok)
        ps = np.array([r["planning"] + r["simplify"] for r in ok]) * 1e6
        tr = np.array([r["total"] for r in ok]) * 1e6
        cpu = np.array([r["cpu"] for r in ok]) * 1e6
        cpu_ps = np.array([r["cpu_ps"] for r in ok]) * 1e6

        def stat(v):
            return f"{np.median(v):7.0f} / {v.mean():7.0f} / {np.percentile(v, 95):7.0f}"

        print(f"  {scene}: solved {len(ok)}/{len(rows)}, clean at 5 mrad {clean}")
        print(f"    plan+simplify (timers) median/mean/p95 {stat(ps)} us")
        print(f"    finished trajectory    median/mean/p95 {stat(tr)} us")
        print(f"    CPU, plan+simplify     median/mean/p95 {stat(cpu_ps)} us (trajectory=False call)")
        print(f"    CPU, trajectory        median/mean/p95 {stat(cpu)} us (trajectory=True call)")
        for r in rows:
            if r["status"] != "solved":
                print(f"    not solved: {r['id']} {r['status']}")
        print(
            "    stage medians: planning {:.0f} simplify {:.0f} trajectory {:.0f} us; samples mean {:.1f}, "
            "direct (2 waypoints) {}/{}".format(
                np.median([r["planning"] for r in ok]) * 1e6,
                np.median([r["simplify"] for r in ok]) * 1e6,
                np.median([r["trajectory"] for r in ok]) * 1e6,
                np.mean([r["samples"] for r in ok]),
                sum(r["waypoints"] == 2 for r in ok),
                len(ok),
            )
        )
        if slowest:
            print(
                "    slowest (CPU, plan+simplify): id CPU | timers: planning simplify trajectory (us) samples waypoints"
            )
            for r in sorted(ok, key=lambda r: -r["cpu_ps"])[:slowest]:
                print(
                    f"      {r['id']}  {r['cpu_ps'] * 1e6:8.0f} | {r['planning'] * 1e6:8.0f}  "
                    f"{r['simplify'] * 1e6:8.0f}  {r['trajectory'] * 1e6:8.0f}  {r['samples']:6d}  {r['waypoints']:3d}"
                )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("dirs", nargs="+", help="MotionBenchMaker problem folders")
    ap.add_argument("--slowest", type=int, default=10, help="slowest problems listed per folder")
    ap.add_argument("--repeats", type=int, default=1, help="plans per problem; the least CPU time is kept")
    ap.add_argument("--ab", help="directory holding the A side's ferrobot package")
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--json", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument(
        "--dump",
        help="only write the problems (scene, 7 start and 7 goal values a line) for "
        "crates/ferrobot-planning/examples/plan_ab.rs to this file",
    )
    args = ap.parse_args()
    if args.dump:
        with open(args.dump, "w") as out:
            for scene in (s for d in args.dirs for s in sorted(Path(d).glob("scene*.yaml"))):
                start, goal = load_request(scene)
                arm = [f"panda_joint{i}" for i in range(1, 8)]
                values = [start[n] for n in arm] + [goal[n] for n in arm]
                out.write(" ".join([str(scene.resolve()), *(repr(float(v)) for v in values)]) + "\n")
        return
    if args.ab:
        print(f"load average {os.getloadavg()}")
        base = [a for a in sys.argv[1:] if a not in ("--ab", args.ab)]
        for k in range(args.rounds):
            for side, env in (("A", {"PYTHONPATH": args.ab}), ("B", {})):
                e = dict(os.environ, **env)
                got = subprocess.run(
                    [sys.executable, __file__, *base, "--json"], env=e, capture_output=True, text=True, check=True
                )
                report(json.loads(got.stdout), f"round {k} {side}: ", args.slowest)
        print(f"load average {os.getloadavg()}")
        return
    res = run(args)
    if args.json:
        print(json.dumps(res))
    else:
        print(f"load average {os.getloadavg()}")
        report(res, "", args.slowest)


if __name__ == "__main__":
    main()
