"""Two builds of ferrobot compared on the collision, planning and grasp workloads, interleaved, in CPU time.

    python benches/portable_vs_native.py NATIVE_DIR PORTABLE_DIR [--rounds 5] [--json FILE]

``NATIVE_DIR`` and ``PORTABLE_DIR`` each hold an unpacked wheel (``python -m zipfile -e x.whl DIR``): for
issue 22, one built with ``RUSTFLAGS="-C target-cpu=native"`` and the portable one (baseline target,
run-time SIMD dispatch). Every measurement runs in a fresh subprocess importing ferrobot from one of the
two folders, alternating A, B, A, B, ... for ``--rounds`` rounds, so that the machine's drift (20-30 % on
a shared VM) hits both builds alike. Times are process CPU time (``time.process_time``, all threads) of
the timed part only; the figure per workload is the median over rounds, and the ratio is portable / native.

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
c0 = time.process_time(); out = run(); c1 = time.process_time()
print(json.dumps({"cpu_s": c1 - c0, "file": ferrobot.__file__}))
"""


def measure(site: Path, workload: str) -> float:
    env = dict(os.environ, PYTHONPATH=str(site), RAYON_NUM_THREADS="1")
    out = subprocess.run(
        [sys.executable, "-c", CHILD, workload, str(SHARED), str(HERE.parent / "tests")],
        env=env,
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    r = json.loads(out.strip().splitlines()[-1])
    assert r["file"].startswith(str(site)), (r["file"], site)  # the build under test, not another install
    return r["cpu_s"]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("native", type=Path)
    ap.add_argument("portable", type=Path)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--only", nargs="*", default=WORKLOADS, choices=WORKLOADS)
    ap.add_argument("--json")
    args = ap.parse_args()
    times: dict[str, dict[str, list[float]]] = {w: {"native": [], "portable": []} for w in args.only}
    for r in range(args.rounds):
        for w in args.only:
            order = ("native", "portable") if r % 2 == 0 else ("portable", "native")
            for which in order:
                times[w][which].append(measure(getattr(args, which), w))
        print(f"round {r + 1}/{args.rounds}, load {os.getloadavg()[0]:.1f}", file=sys.stderr)
    print(f"{'workload':<18} {'native ms':>10} {'portable ms':>12} {'ratio':>7}")
    summary = {}
    for w, t in times.items():
        n, p = statistics.median(t["native"]), statistics.median(t["portable"])
        ratios = [b / a for a, b in zip(t["native"], t["portable"], strict=True)]
        summary[w] = {"native_ms": n * 1e3, "portable_ms": p * 1e3, "ratio": p / n, "ratio_per_round": ratios}
        print(f"{w:<18} {n * 1e3:10.1f} {p * 1e3:12.1f} {p / n:7.3f}")
    if args.json:
        Path(args.json).write_text(json.dumps(summary, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
