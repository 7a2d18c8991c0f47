"""IK benchmark: 1,000 random reachable Panda poses (FK of random configurations).

    python benches/ik.py [--n 1000] [--repeats 5]

Prints batch solves per second (all cores; wall time, and per CPU second of this process, which is what a
loaded machine still measures fairly: on an idle 2-core machine wall throughput is about twice the
per-CPU-second figure), single-solve latency (median), success rate and the largest position and rotation
errors (measured by ferrobot's FK, which the tests check against Pinocchio).
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import numpy as np

import ferrobot
from ferrobot.transforms import matrix_to_pose

SHARED = Path(__file__).resolve().parent.parent.parent / "shared"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--n", type=int, default=1000)
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    model = ferrobot.RobotModel.from_urdf(SHARED / "robots/panda/panda.urdf", srdf=SHARED / "robots/panda/panda.srdf")
    spheres = ferrobot.SphereModel.from_spherized_urdf(model, SHARED / "robots/panda/panda_spherized.urdf")
    planner = ferrobot.Planner(model, spheres=spheres)
    rng = np.random.default_rng(0)
    lo, hi = model.lower_limits, model.upper_limits
    qs = rng.uniform(lo, hi, size=(args.n, model.num_dof))
    poses = model.fk_batch(qs)
    rates, cpu_rates, res = [], [], None
    for _ in range(args.repeats):
        t, c = time.perf_counter(), time.process_time()
        res = planner.ik_batch(poses)
        rates.append(args.n / (time.perf_counter() - t))
        cpu_rates.append(args.n / (time.process_time() - c))
    single = []
    for pose in poses[:200]:
        t = time.perf_counter()
        planner.ik(pose)
        single.append(time.perf_counter() - t)
    idx = [model.dof_names.index(n) for n in planner.joint_names]
    errs_p, errs_r = [], []
    for q, pose in zip(res.q, poses, strict=True):
        full = planner.locked_positions.copy()
        full[idx] = q
        got = matrix_to_pose(model.fk(full)) if np.ndim(model.fk(full)) == 2 else model.fk(full)
        errs_p.append(np.linalg.norm(got[:3] - pose[:3]))
        dot = abs(np.dot(got[3:], pose[3:]))
        errs_r.append(2 * np.arccos(min(1.0, dot)))
    print(f"ferrobot {ferrobot.__version__}, {os.cpu_count()} cores, {args.n} poses")
    print(f"batch: median {np.median(rates):,.0f} solves/s (min {min(rates):,.0f}, max {max(rates):,.0f})")
    lo, hi = min(cpu_rates), max(cpu_rates)
    print(f"batch: median {np.median(cpu_rates):,.0f} solves per CPU-s (min {lo:,.0f}, max {hi:,.0f})")
    print(f"single: median {np.median(single) * 1e6:.1f} us per solve")
    print(
        f"success {res.success.mean() * 100:.1f}%, max position error {max(errs_p) * 1e3:.3f} mm, "
        f"max rotation error {max(errs_r):.4f} rad, median seeds {np.median(res.seeds_tried):.0f}"
    )


if __name__ == "__main__":
    main()
