"""How far the automatic sphere model sticks out of each robot's links, and whether it covers them
(issue 17: protrusion at most 1 cm while covering every surface point within the 1 mm tolerance),
measured independently of the spherizer (tests/sphere_truth.py: exact distance functions for
primitives, trimesh-read meshes with a dense surface point set and scipy's KD-tree).

Per robot: sphere count, build CPU time (empty sphere cache), worst protrusion on the spheres'
union boundary and over whole spheres, worst link, coverage (fraction of 20,000 random surface
points per link within 1 mm of a sphere; the minimum over links) and the largest gap.

    python benches/sphere_fit.py [--robots panda ur5e shared_panda shared_ur5 erd_ur3 ...] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
import warnings
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "tests"))

import robots_in_env as env  # noqa: E402
import sphere_truth  # noqa: E402

import ferrobot  # noqa: E402

SHARED = HERE.parent.parent / "shared" / "robots"


def load(name: str) -> ferrobot.RobotModel:
    if name == "panda":
        return ferrobot.robots.panda()
    if name == "ur5e":
        return ferrobot.robots.ur5e()
    if name.startswith("shared_"):
        robot = name.removeprefix("shared_")
        return ferrobot.RobotModel.from_urdf(SHARED / robot / f"{robot}.urdf", srdf=SHARED / robot / f"{robot}.srdf")
    return env.load(name)


def bench(name: str) -> dict:
    model = load(name)
    t = time.process_time()
    spheres = ferrobot.SphereModel.automatic(model)
    build = time.process_time() - t
    fits = sphere_truth.measure_model(model, spheres)
    worst = max(fits, key=lambda f: f.max_protrusion)
    own = max((r.max_protrusion for r in spheres.report), default=0.0)
    return {
        "robot": name,
        "spheres": spheres.count,
        "build_cpu_s": build,
        "max_protrusion_mm": 1e3 * worst.max_protrusion,
        "worst_link": worst.link,
        "max_protrusion_any_mm": 1e3 * max(f.max_protrusion_any for f in fits),
        "own_report_mm": 1e3 * own,
        "min_coverage": min(f.coverage for f in fits),
        "max_gap_mm": 1e3 * max(f.worst_gap for f in fits),
        "links": [f.__dict__ for f in fits],
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    default = ["panda", "ur5e", "shared_panda", "shared_ur5", *env.available()]
    ap.add_argument("--robots", nargs="*", default=None, help=f"default: {' '.join(default)}")
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args()
    os.environ.setdefault("FERROBOT_CACHE_DIR", tempfile.mkdtemp(prefix="ferrobot-spherefit-"))
    rows = []
    head = f"{'robot':<16} {'spheres':>7} {'build s':>8} {'protr mm':>9} {'any mm':>7} {'own mm':>7}"
    print(f"{head} {'coverage':>9} {'gap mm':>7}  worst link")
    for name in args.robots or default:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            row = bench(name)
        rows.append(row)
        print(
            f"{name:<16} {row['spheres']:>7} {row['build_cpu_s']:>8.2f} {row['max_protrusion_mm']:>9.1f} "
            f"{row['max_protrusion_any_mm']:>7.1f} {row['own_report_mm']:>7.1f} {row['min_coverage']:>9.4f} "
            f"{row['max_gap_mm']:>7.2f}  {row['worst_link']}",
            flush=True,
        )
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
