"""Self-collision verdicts against the collision meshes (issue 17 item 6, tighter exact stage):
random configurations within the joint limits of each robot, ferrobot's `CollisionChecker`
(automatic spheres, then the exact stage) against coal's mesh-mesh distance on the same link
pairs (tests/mesh_truth.py: Pinocchio's geometry loader, meshes as triangle BVHs, Pinocchio's
FK). Prints, per robot: the fraction flagged by ferrobot, the fraction whose meshes touch
(coal), misses (meshes touch, ferrobot free: must be 0) and the flagged configurations whose
meshes are apart, by distance band. Run it with another build's `python/` first on PYTHONPATH to
compare builds.

    python benches/self_collision_meshes.py [--robots erd_ur3 erd_ur10] [--samples 2000] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np

import ferrobot

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
import robots_in_env as env  # noqa: E402
from mesh_truth import MeshTruth  # noqa: E402


def run(name: str, samples: int, seed: int) -> dict:
    model = env.load(name)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        checker = ferrobot.CollisionChecker(model)
    truth = MeshTruth(name, model, checker)
    rng = np.random.default_rng(seed)
    lo = np.where(np.isfinite(model.lower_limits), model.lower_limits, -np.pi)
    hi = np.where(np.isfinite(model.upper_limits), model.upper_limits, np.pi)
    qs = rng.uniform(lo, hi, size=(samples, model.num_dof))
    t = time.process_time()
    ours = checker.in_collision_batch(qs)
    cpu = time.process_time() - t
    dist = np.array([truth.min_distance(q)[0] for q in qs])
    touch = dist <= 0.0
    apart = ~touch
    bands = {
        f"{a * 1e3:.0f}-{b * 1e3:.0f} mm": int(np.sum(ours & (dist > a) & (dist <= b)))
        for a, b in [(0, 0.002), (0.002, 0.005), (0.005, 0.01), (0.01, 0.02), (0.02, np.inf)]
    }
    return {
        "robot": name,
        "samples": samples,
        "ferrobot_flagged": float(ours.mean()),
        "meshes_touch": float(touch.mean()),
        "misses": int(np.sum(touch & ~ours)),
        "flagged_but_apart": float((ours & apart).mean()),
        "flagged_apart_by_distance": bands,
        "batch_cpu_us_per_q": 1e6 * cpu / samples,
        "ferrobot": ferrobot.__file__,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robots", nargs="*", default=["erd_ur3", "erd_ur10"])
    ap.add_argument("--samples", type=int, default=2000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json")
    args = ap.parse_args()
    rows = []
    for name in args.robots:
        row = run(name, args.samples, args.seed)
        rows.append(row)
        print(json.dumps(row))
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
