"""MotionBenchMaker planning benchmark (Panda, spherized model).

    python benches/mbm.py ../shared/bench/mbm/table_pick_panda ../shared/bench/mbm/bookshelf_small_panda \
        [--robot URDF] [--spheres SPHERIZED_URDF] [--srdf SRDF] [--pose-goals] [--out results.json]

Each problem is planned once; its path and its trajectory are then re-checked densely by a separate
CollisionChecker (no joint moves more than 5 mrad between checked configurations): a plan that only passes at
the planner's own resolution counts as a failure. Problems whose start or goal collides are invalid and skipped.
Prints per scene: valid / solved, median, mean and 95th-percentile planning time, simplification time, time to
the finished time-parametrised trajectory, path length.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

import numpy as np
import yaml

import ferrobot

HERE = Path(__file__).resolve().parent
SHARED = HERE.parent.parent / "shared"
ARM = [f"panda_joint{i}" for i in range(1, 8)]
RESOLUTION = 0.005


def load_request(scene: Path) -> tuple[dict, dict]:
    req = yaml.safe_load((scene.parent / scene.name.replace("scene", "request")).read_text())
    js = req["start_state"]["joint_state"]
    start = dict(zip(js["name"], js["position"], strict=True))
    goal = {c["joint_name"]: c["position"] for c in req["goal_constraints"][0]["joint_constraints"]}
    return start, goal


def dense_ok(checker, planner, configs: np.ndarray) -> bool:
    full = np.tile(planner.locked_positions, (len(configs), 1))
    idx = [planner.dof_names.index(n) for n in planner.joint_names]
    full[:, idx] = configs
    return not checker.in_collision_batch(full).any()


def densify(path: np.ndarray) -> np.ndarray:
    """Every edge of a path at <= RESOLUTION per joint (end points included)."""
    out = [path[:1]]
    for a, b in zip(path[:-1], path[1:], strict=True):
        n = max(1, int(np.ceil(np.abs(b - a).max() / RESOLUTION)))
        t = np.arange(1, n + 1)[:, None] / n
        out.append(a + (b - a) * t)
    return np.concatenate(out)


def run(args) -> dict:
    model = ferrobot.RobotModel.from_urdf(args.robot, srdf=args.srdf)
    spheres = ferrobot.SphereModel.from_spherized_urdf(model, args.spheres)
    planner = ferrobot.Planner(model, spheres=spheres)
    checker = ferrobot.CollisionChecker(model, spheres=spheres)
    vmax = planner.limits.velocity.max()
    problems = []
    scenes = [s for d in args.dirs for s in sorted(Path(d).glob("scene*.yaml"))]
    for k, scene in enumerate(scenes):
        world = ferrobot.CollisionWorld.from_moveit_scene(scene)
        planner.update_world(world)
        checker.update_world(world)
        start_d, goal_d = load_request(scene)
        start = np.array([start_d[n] for n in planner.joint_names])
        goal = np.array([goal_d[n] for n in planner.joint_names])
        row = {"scene": scene.parent.name, "id": scene.stem[5:], "valid": True, "solved": False}
        if args.pose_goals:
            full_goal = planner.locked_positions.copy()
            full_goal[[planner.dof_names.index(n) for n in planner.joint_names]] = goal
            if planner.in_collision(start) or planner.in_collision(goal):
                row["valid"] = False
                problems.append(row)
                continue
            r = planner.plan(start, goal_pose=model.fk(full_goal, "panda_hand"), seed=k)
        else:
            r = planner.plan(start, goal_q=goal, seed=k)
        if r.status in ("start_in_collision", "goal_in_collision"):
            row["valid"] = False
            problems.append(row)
            continue
        if r.success:
            traj = r.interpolated(dt=0.8 * RESOLUTION / vmax)
            ok = dense_ok(checker, planner, densify(r.path)) and dense_ok(checker, planner, traj.positions)
            ok = ok and np.abs(np.diff(traj.positions, axis=0)).max() <= RESOLUTION
            row.update(
                solved=bool(ok),
                status=r.status if ok else "failed_dense_recheck",
                plan_time_s=r.times.ik + r.times.planning,
                simplify_time_s=r.times.simplify,
                trajectory_time_s=r.times.total,
                path_length=r.path_length,
                path=r.path.tolist(),
                trajectory={"dt": 0.01, "positions": r.interpolated(0.01).positions.tolist()},
            )
        else:
            row["status"] = r.status
        problems.append(row)
        if sys.stderr.isatty():
            print(f"\r{k + 1}/{len(scenes)}", end="", file=sys.stderr)
    if sys.stderr.isatty():
        print(file=sys.stderr)
    return {"problems": problems}


def report(results: dict) -> None:
    by_scene: dict[str, list] = {}
    for p in results["problems"]:
        by_scene.setdefault(p["scene"], []).append(p)
    for scene, rows in by_scene.items():
        valid = [r for r in rows if r["valid"]]
        solved = [r for r in valid if r["solved"]]
        print(f"{scene}: {len(solved)}/{len(valid)} valid problems solved ({len(rows)} problems)")
        for r in valid:
            if not r["solved"]:
                print(f"  {r['id']}: {r.get('status')}")
        if not solved:
            continue
        for key, label in [
            ("plan_time_s", "planning"),
            ("plan+simplify", "planning + simplification"),
            ("trajectory_time_s", "finished trajectory"),
        ]:
            if key == "plan+simplify":
                v = np.array([r["plan_time_s"] + r["simplify_time_s"] for r in solved]) * 1e6
            else:
                v = np.array([r[key] for r in solved]) * 1e6
            print(
                f"  {label:28s} median {np.median(v):8.1f} us  mean {v.mean():8.1f} us  "
                f"p95 {np.percentile(v, 95):8.1f} us"
            )
        lengths = np.array([r["path_length"] for r in solved])
        print(f"  {'path length':28s} median {np.median(lengths):8.3f} rad")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("dirs", nargs="+", help="MotionBenchMaker problem folders")
    ap.add_argument("--robot", default=str(SHARED / "robots/panda/panda.urdf"))
    ap.add_argument("--spheres", default=str(SHARED / "robots/panda/panda_spherized.urdf"))
    ap.add_argument("--srdf", default=str(SHARED / "robots/panda/panda.srdf"))
    ap.add_argument("--pose-goals", action="store_true", help="goal = FK pose of panda_hand at the goal")
    ap.add_argument("--out", help="write per-problem JSON here")
    args = ap.parse_args()
    print(f"ferrobot {ferrobot.__version__}, {os.cpu_count()} cores, mode {'pose' if args.pose_goals else 'joint'}")
    results = run(args)
    report(results)
    if args.out:
        Path(args.out).write_text(json.dumps(results))


if __name__ == "__main__":
    main()
