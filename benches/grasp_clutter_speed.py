"""Grasp detection time per 640 x 480 frame, single objects and clutter, for one or more builds, interleaved.

    python benches/grasp_clutter_speed.py [--rounds 5] [--runs 10] [--build NAME=PYTHONPATH ...] [--json FILE]

Frames (analytic scenes of ``tests/grasp_scenes.py``, ray-cast in numpy, 600 px pinhole camera, depth in
metres, segmentation as the mask):

- ``box``: a 5 x 7 x 10 cm box alone on the table, its id as ``object_id``;
- ``cylinder``: a 3 cm radius, 12 cm tall cylinder alone, its id as ``object_id``;
- ``clutter``: seven boxes and cylinders 1-3 cm apart, grasps sought on the middle one (``object_id=1``);
- ``clutter-all``: the same, grasps sought on every object (mask without ``object_id``);
- ``bin``: the clutter in a 32 x 32 x 12 cm bin, ``object_id=1``;
- ``mesh``: a mesh object, ``pybullet_data/random_urdfs/000`` (its convex hull, as ``benches/grasp_eval.py``
  simulates it), settled on a table in a ferrobot ``World`` and rendered by its ``Camera`` (525 px, 0.6 m away,
  50 degrees down), its id as ``object_id``.

Each ``--build`` (default: the installed ferrobot, named ``current``) runs in its own worker process with
``PYTHONPATH`` set to the given folder (a copy of another build's ``python/`` tree holding its
``ferrobot`` package and extension). The builds take turns, ``--rounds`` times, each turn timing
``--runs`` detections per frame after one warm-up; printed per build and frame: the median over all
runs of the wall time and of the CPU time of the worker process (all threads), and the number of
grasps; and whether the grasp arrays (float64, every value, in order) of all builds and rounds are
identical per frame (a SHA-1 of each worker's last detection). Target: <= 30 ms per frame on 2 cores for
single objects (issue 18); ``benches/grasp_wall_time.py`` times the wall clock on an idle machine.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from grasp_scenes import CX, CY, FX, FY, Box, Cylinder, Scene, clutter_scene, look_at, render  # noqa: E402

FRAMES = ("box", "cylinder", "mesh", "clutter", "clutter-all", "bin")
MESH = "random_urdfs/000/000.urdf"


def frames() -> dict:
    cam = look_at(eye=(-0.4, -0.25, 0.5), target=(0.0, 0.0, 0.05))
    out = {}
    for name, obj in (
        ("box", Box(size=(0.05, 0.07, 0.10), yaw=0.35, label=1)),
        ("cylinder", Cylinder(radius=0.03, height=0.12, label=1)),
    ):
        depth, labels = render(Scene(objects=[obj]), cam)
        out[name] = (depth, labels, 1, (FX, FY, CX, CY))
    out["mesh"] = mesh_frame()
    for name, with_bin in (("clutter", False), ("bin", True)):
        scene, ccam = clutter_scene(with_bin)
        depth, labels = render(scene, ccam)
        out[name] = (depth, labels, 1, (FX, FY, CX, CY))
        if not with_bin:
            out["clutter-all"] = (depth, labels, None, (FX, FY, CX, CY))
    return out


def mesh_frame():
    """The ``mesh`` frame: ``grasp_eval.py``'s scene (table, settled object, camera) for one fixed mesh."""
    import random

    import grasp_eval as ge
    import numpy as np
    import pybullet_data

    spec = ge.make_spec(Path(pybullet_data.getDataPath()) / MESH)
    scene = ge.Scene(spec, random.Random(0))
    frame = scene.camera.render(rgb=False)
    depth = np.where(np.isfinite(frame.depth), frame.depth, 0.0)
    return depth, frame.segmentation, scene.object_id, (ge.F, ge.F, ge.CX, ge.CY)


def worker(runs: int) -> int:
    import hashlib

    import numpy as np

    import ferrobot.grasp as fg

    res = {}
    for name, (depth, labels, oid, (fx, fy, cx, cy)) in frames().items():
        kw = {"mask": labels} if oid is None else {"mask": labels, "object_id": oid}
        fg.detect_from_rgbd(depth, fx, fy, cx, cy, 1.0, **kw)  # warm-up
        wall, cpu = [], []
        for _ in range(runs):
            t0, c0 = time.perf_counter(), time.process_time()
            gg = fg.detect_from_rgbd(depth, fx, fy, cx, cy, 1.0, **kw)
            wall.append(time.perf_counter() - t0)
            cpu.append(time.process_time() - c0)
        digest = hashlib.sha1(np.ascontiguousarray(gg.grasp_group_array, dtype=np.float64).tobytes()).hexdigest()
        res[name] = {"wall": wall, "cpu": cpu, "grasps": len(gg), "sha1": digest}
    print(json.dumps(res))
    return 0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--runs", type=int, default=10)
    ap.add_argument("--build", action="append", default=[], metavar="NAME=PYTHONPATH")
    ap.add_argument("--json", type=Path)
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.worker:
        return worker(args.runs)
    builds = [tuple(b.split("=", 1)) for b in args.build] or [("current", "")]
    load0 = os.getloadavg()
    acc = {name: {f: {"wall": [], "cpu": [], "grasps": 0, "sha1": set()} for f in FRAMES} for name, _ in builds}
    for r in range(args.rounds):
        for name, path in builds:
            env = dict(os.environ)
            if path:
                env["PYTHONPATH"] = path
            out = subprocess.run(
                [sys.executable, __file__, "--worker", "--runs", str(args.runs)],
                env=env,
                check=True,
                capture_output=True,
                text=True,
            ).stdout
            for f, v in json.loads(out.strip().splitlines()[-1]).items():
                acc[name][f]["wall"] += v["wall"]
                acc[name][f]["cpu"] += v["cpu"]
                acc[name][f]["grasps"] = v["grasps"]
                acc[name][f]["sha1"].add(v["sha1"])
        print(f"round {r + 1}/{args.rounds} done, load {os.getloadavg()[0]:.2f}", file=sys.stderr)
    load1 = os.getloadavg()
    print(f"cores {os.cpu_count()}, load {load0[0]:.2f} -> {load1[0]:.2f}")
    print(f"{'frame':12s} " + " ".join(f"{name + ' wall/cpu ms, grasps':>34s}" for name, _ in builds))
    summary = {}
    for f in FRAMES:
        cells = []
        for name, _ in builds:
            a = acc[name][f]
            w, c = statistics.median(a["wall"]) * 1e3, statistics.median(a["cpu"]) * 1e3
            summary.setdefault(name, {})[f] = {"median_wall_ms": w, "median_cpu_ms": c, "grasps": a["grasps"]}
            cells.append(f"{w:10.1f} / {c:6.1f}  {a['grasps']:4d}")
        digests = set().union(*(acc[name][f]["sha1"] for name, _ in builds))
        same = "identical" if len(digests) == 1 else f"DIFFER ({len(digests)} distinct)"
        print(f"{f:12s} " + " ".join(f"{c:>34s}" for c in cells) + f"   grasp arrays: {same}")
    if args.json:
        for name, _ in builds:
            for f in FRAMES:
                acc[name][f]["sha1"] = sorted(acc[name][f]["sha1"])
        args.json.write_text(json.dumps({"load": [load0, load1], "summary": summary, "raw": acc}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
