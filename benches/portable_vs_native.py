"""Two builds of ferrobot compared on the collision, planning and grasp workloads, interleaved, in CPU time.

    python benches/portable_vs_native.py NATIVE_DIR PORTABLE_DIR [--rounds 5] [--forced LEVEL ...] [--json FILE]

``NATIVE_DIR`` and ``PORTABLE_DIR`` each hold an unpacked wheel (``python -m zipfile -e x.whl DIR``): for
issue 22, one built with ``RUSTFLAGS="-C target-cpu=native"`` and the portable one (baseline target,
run-time SIMD dispatch). Every measurement runs in a fresh subprocess importing ferrobot from one of the
two folders, alternating A, B, A, B, ... for ``--rounds`` rounds, so that the machine's drift (20-30 % on
a shared VM) hits both builds alike. Times are process CPU time (``time.process_time``, all threads) of
the timed part only (each subprocess times ``--reps`` runs after a warm-up run and reports their median);
the figure per workload is the median over rounds, and the ratio is portable / native.

Since issue 22's per-level wheels (``scripts/build_wheel.py``), ``PORTABLE_DIR`` holds every level's build and
loads the best one the CPU supports; ``--forced baseline`` (any ``FERROBOT_SIMD`` level, repeatable) adds an
arm running the same portable folder with ``FERROBOT_SIMD`` set, interleaved with the others, to show what
the loader's choice is worth. Each child reports ``ferrobot.simd_level()`` (printed once per arm).

Workloads (one thread, ``RAYON_NUM_THREADS=1``, so CPU time is not inflated by idle spinning):
- ``collision_batch``: ``in_collision_batch`` of 100,000 random Panda configurations in the
  MotionBenchMaker scene ``table_pick_panda/scene0001`` (59 spheres);
- ``collision_single``: 20,000 ``in_collision`` calls, one configuration each;
- ``collision_motion``: 2,000 ``motion_valid`` calls (random motions up to 0.3 rad per joint, 5 mrad);
- ``planning``: ``Planner.plan`` (joint goal) on the first 8 ``table_pick_panda`` problems, seeds fixed;
- ``grasp``: ``detect_from_rgbd`` with default options on the 640 x 480 frame of ``benches/grasp.py``.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
SHARED = HERE.parents[1] / "shared"
WORKLOADS = ["collision_batch", "collision_single", "collision_motion", "planning", "grasp"]

CHILD = r"""
import json, sys, time
import numpy as np
import ferrobot
from pathlib import Path
SHARED = Path(sys.argv[2]); which = sys.argv[1]
def panda():
    m = ferrobot.RobotModel.from_urdf(SHARED / "robots/panda/panda.urdf", srdf=SHARED / "robots/panda/panda.srdf",
                                      ee_link="panda_hand")
    return m, ferrobot.SphereModel.from_spherized_urdf(m, SHARED / "robots/panda/panda_spherized.urdf")
scene = SHARED / "bench/mbm/table_pick_panda/scene0001.yaml"
if which.startswith("collision"):
    model, spheres = panda()
    checker = ferrobot.CollisionChecker(model, ferrobot.CollisionWorld.from_moveit_scene(scene), spheres)
    rng = np.random.default_rng(0)
    qs = rng.uniform(model.lower_limits, model.upper_limits, size=(100_000, model.num_dof))
    checker.in_collision_batch(qs[:1000])
    if which == "collision_batch":
        run = lambda: checker.in_collision_batch(qs)
    elif which == "collision_single":
        run = lambda: [checker.in_collision(q) for q in qs[:20000]]
    else:
        ends = qs[:2000] + rng.uniform(-0.3, 0.3, size=(2000, model.num_dof))
        run = lambda: [checker.motion_valid(a, b, 0.005) for a, b in zip(qs[:2000], ends)]
elif which == "planning":
    import yaml
    model, spheres = panda()
    planner = ferrobot.Planner(model, spheres=spheres)
    probs = []
    for k in range(1, 9):
        s = SHARED / f"bench/mbm/table_pick_panda/scene{k:04d}.yaml"
        req = yaml.safe_load(s.with_name(s.name.replace("scene", "request")).read_text())
        js = dict(zip(req["start_state"]["joint_state"]["name"], req["start_state"]["joint_state"]["position"]))
        goal = {c["joint_name"]: c["position"] for c in req["goal_constraints"][0]["joint_constraints"]}
        probs.append((ferrobot.CollisionWorld.from_moveit_scene(s), np.array([js[n] for n in planner.joint_names]),
                      np.array([goal[n] for n in planner.joint_names])))
    def run():
        out = []
        for k, (w, a, b) in enumerate(probs):
            planner.update_world(w)
            out.append(planner.plan(a, goal_q=b, seed=k).success)
        return out
else:
    sys.path.insert(0, sys.argv[3])
    from grasp_scenes import CX, CY, FX, FY, default_scene, render
    import ferrobot.grasp as fg
    sc, cam = default_scene()
    depth, _ = render(sc, cam)
    mm = np.round(depth * 1000).astype(np.uint16)
    run = lambda: fg.detect_from_rgbd(mm, FX, FY, CX, CY, 1000.0)
run()
cpu = []
for _ in range(int(sys.argv[4])):
    c0 = time.process_time(); out = run(); c1 = time.process_time(); cpu.append(c1 - c0)
level = ferrobot.simd_level() if hasattr(ferrobot, "simd_level") else "?"
print(json.dumps({"cpu_s": sorted(cpu)[len(cpu) // 2], "file": ferrobot.__file__, "level": level}))
"""


def measure(site: Path, workload: str, forced: str | None = None, reps: int = 5) -> tuple[float, str]:
    env = dict(os.environ, PYTHONPATH=str(site), RAYON_NUM_THREADS="1")
    env.pop("FERROBOT_SIMD", None)
    if forced is not None:
        env["FERROBOT_SIMD"] = forced
    out = subprocess.run(
        [sys.executable, "-c", CHILD, workload, str(SHARED), str(HERE.parent / "tests"), str(reps)],
        env=env,
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    r = json.loads(out.strip().splitlines()[-1])
    assert r["file"].startswith(str(site)), (r["file"], site)  # the build under test, not another install
    return r["cpu_s"], r["level"]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("native", type=Path)
    ap.add_argument("portable", type=Path)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--only", nargs="*", default=WORKLOADS, choices=WORKLOADS)
    ap.add_argument("--forced", nargs="*", default=[], help="FERROBOT_SIMD levels to run the portable folder at too")
    ap.add_argument("--reps", type=int, default=5, help="timed runs per subprocess; its figure is their median")
    ap.add_argument("--json")
    args = ap.parse_args()
    arms: dict[str, tuple[Path, str | None]] = {"native": (args.native, None), "portable": (args.portable, None)}
    for lv in args.forced:
        arms[f"portable@{lv}"] = (args.portable, lv)
    times: dict[str, dict[str, list[float]]] = {w: {a: [] for a in arms} for w in args.only}
    levels: dict[str, str] = {}
    names = list(arms)
    for r in range(args.rounds):
        for w in args.only:
            order = names if r % 2 == 0 else names[::-1]
            for arm in order:
                site, forced = arms[arm]
                cpu_s, level = measure(site, w, forced, args.reps)
                times[w][arm].append(cpu_s)
                if levels.setdefault(arm, level) != level:
                    raise SystemExit(f"{arm}: loaded {level}, earlier {levels[arm]}")
        print(f"round {r + 1}/{args.rounds}, load {os.getloadavg()[0]:.1f}", file=sys.stderr)
    print("levels loaded: " + ", ".join(f"{a} = {lv}" for a, lv in levels.items()))
    head = f"{'workload':<18} " + " ".join(f"{a + ' ms':>20}" for a in names)
    head += " " + " ".join(f"{a + '/native':>26}" for a in names[1:])
    print(head)
    summary: dict[str, dict[str, object]] = {}
    for w, t in times.items():
        med = {a: statistics.median(t[a]) for a in names}
        row = f"{w:<18} " + " ".join(f"{med[a] * 1e3:20.1f}" for a in names)
        entry: dict[str, object] = {f"{a}_ms": med[a] * 1e3 for a in names}
        entry["per_round_ms"] = {a: [x * 1e3 for x in t[a]] for a in names}
        for a in names[1:]:
            ratios = [b / n for n, b in zip(t["native"], t[a], strict=True)]
            entry[f"{a}_ratio"] = med[a] / med["native"]
            entry[f"{a}_ratio_per_round"] = ratios
            row += f" {med[a] / med['native']:10.3f} ({', '.join(f'{x:.2f}' for x in ratios)})"
        summary[w] = entry
        print(row)
    if args.json:
        Path(args.json).write_text(json.dumps({"levels": levels, "workloads": summary}, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
