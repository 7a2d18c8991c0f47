"""Why thin and flat objects get no grasp: per object, grasps found with the default options and with one
check relaxed at a time, in ``benches/grasp_eval.py``'s table scene (one object in the open).

    python benches/grasp_thin.py [--objects DIR] [--per-kind N] [--json FILE]

DIR: a folder of object URDFs (default: ``benches/thin_objects.py``'s set, written to a temporary folder).
Per object it prints its height above the table (from the settled mesh), the number of grasps with each
variant and, for the default's top grasp, its depth, width, approach angle from vertical and fingertip
height above the table. Variants (detection options, ``ferrobot.grasp.OPTIONS``):

- ``default``; ``no body`` (``body_collision`` off); ``no plane`` (``support_plane`` off: no hidden-volume
  completion, the table's points are still obstacles); ``voxel 3 mm``; ``no single`` (``single_object`` off);
  ``no occlusion``; ``shallow`` (depths down to 5 mm); ``all off`` (every one of these at once).
"""

from __future__ import annotations

import argparse
import json
import random
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import grasp_eval as ge  # noqa: E402
import thin_objects  # noqa: E402

import ferrobot.grasp as fg  # noqa: E402

VARIANTS = {
    "default": {},
    "no body": {"body_collision": False},
    "no plane": {"support_plane": False},
    "voxel 3 mm": {"voxel_size": 0.003},
    "no single": {"single_object": False},
    "no occlusion": {"occlusion": False},
    "shallow": {"depths": [0.04, 0.03, 0.02, 0.015, 0.01, 0.005]},
    "all off": {
        "body_collision": False,
        "support_plane": False,
        "single_object": False,
        "occlusion": False,
        "depths": [0.04, 0.03, 0.02, 0.015, 0.01, 0.005],
    },
}


def diagnose(paths: list[Path], seed: int = 0) -> list[dict]:
    rng = random.Random(seed)
    rows = []
    for path in paths:
        spec = ge.make_spec(path)
        scene = ge.Scene(spec, rng)
        pose = scene.settled
        pts = spec.points @ pose[:3, :3].T + pose[:3, 3]
        height = float(pts[:, 2].max() - ge.TABLE_TOP)
        down = tuple(scene.cam_pose[:3, :3].T @ np.array([0.0, 0.0, -1.0]))
        row = {"object": path.stem, "height_mm": round(height * 1e3, 1), "grasps": {}}
        for name, opts in VARIANTS.items():
            gg, _, _ = scene.detect(approach_direction=down, **opts)
            row["grasps"][name] = len(gg)
            if name == "default" and len(gg):
                top = gg[:1].transform(fg.camera_to_world(scene.cam_pose, "opencv"))
                r = top.rotation_matrices[0]
                tip = top.translations[0] + r[:, 0] * top.depths[0]
                row["top"] = {
                    "depth_mm": round(float(top.depths[0]) * 1e3, 1),
                    "width_mm": round(float(top.widths[0]) * 1e3, 1),
                    "tilt_deg": round(float(np.degrees(np.arccos(-r[2, 0]))), 1),
                    "tip_above_table_mm": round(float(tip[2] - ge.TABLE_TOP) * 1e3, 1),
                }
        rows.append(row)
        print(row, flush=True)
    return rows


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--objects", type=Path, default=None)
    ap.add_argument("--per-kind", type=int, default=3)
    ap.add_argument("--seed", type=int, default=7, help="the thin set's seed (without --objects)")
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        if args.objects:
            paths = ge.find_objects(args.objects)
        else:
            paths = thin_objects.generate(Path(tmp), args.per_kind, args.seed)
        rows = diagnose(paths)
    names = list(VARIANTS)
    print("object".ljust(14) + "h mm".rjust(6) + "".join(n.rjust(13) for n in names))
    for r in rows:
        print(r["object"].ljust(14) + f"{r['height_mm']:6.1f}" + "".join(f"{r['grasps'][n]:13d}" for n in names))
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
