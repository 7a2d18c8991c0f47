"""Piles of mesh objects at rest, and the step cost of a heap of convex decompositions (issue 18).

    python benches/pile_rest.py [--sets made,pybullet,heldout] [--seeds 1,2,3] [--steps 10000]
                                [--before PKG_DIR] [--rounds 2] [--json FILE]

Rest: per object set and seed, ``clutter.random_clutter`` drops 6-12 objects on a table box
(``clutter.add_clutter``, then :func:`clutter.settle` up to 6 s more); the pile counts as settled when
every object moved slower than 2 mm/s and 2 mrad/s over 0.25 s. Then ``--steps`` steps: the largest
displacement and rotation of any object, and the CPU time of those steps (``getrusage``, this process).
Sets: ``made`` (``benches/make_objects.py``: superellipsoids, bent tubes, L shapes, rings, dumbbells),
``pybullet`` (PyPI ``pybullet``'s ``pybullet_data``: ``random_urdfs`` and ``objects``), ``heldout``
(``benches/heldout_objects.py``: rods, hammers, mugs, bowls, ladles...).

Heap cost: 8 convex decompositions (the ``made`` meshes, 4 cm, 0.1 kg) dropped in one heap, 1 s after
the last drop, then 2,400 steps timed (CPU), for ``--heaps`` seeds; a heap 1 s after the drops is still
moving, so its cost depends on how it moves (an object rolling away keeps its pairs awake): compare sums
over several seeds, with the count of objects still moving at the end.

``--before PKG_DIR``: a copy of another build's ``python/ferrobot`` package (e.g. ``main``'s); every case
then also runs with it on ``PYTHONPATH``, in a subprocess, interleaved with this build's run of the same
case, ``--rounds`` times (CPU medians).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))


def _cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def _objects(name: str, tmp: Path):
    if name == "pybullet":
        return None
    d = tmp / name
    if not d.exists():
        d.mkdir(parents=True)
        if name == "made":
            import make_objects

            rng = np.random.default_rng(7)
            for i in range(10):
                kind = make_objects.KINDS[i % len(make_objects.KINDS)]
                v, f = kind(rng)
                make_objects.write_obj(d / f"{i:02d}_{kind.__name__}.obj", v, f)
        elif name == "heldout":
            import heldout_objects

            heldout_objects.generate(d, per_kind=3)
        else:
            raise SystemExit(f"--sets: unknown object set {name!r}")
    return d


def rest_case(set_name: str, seed: int, n: int, steps: int, tmp: Path) -> dict:
    import ferrobot
    from ferrobot.pipeline import clutter

    spec = clutter.random_clutter(seed, n, _objects(set_name, tmp), center=(0.0, 0.0))
    w = ferrobot.World(dt=1 / 240)
    w.add_box("table", [1.0, 1.0, spec.table_top], [0.0, 0.0, spec.table_top / 2, 1, 0, 0, 0], fixed=True)
    names = clutter.add_clutter(w, spec)
    extra = clutter.settle(w, names, max_seconds=6.0)
    settled = extra < 6.0
    before = {nm: w.get_object_pose(nm) for nm in names}
    t0 = _cpu()
    w.step(steps)
    cpu = _cpu() - t0
    disp, rot = 0.0, 0.0
    for nm in names:
        a = w.get_object_pose(nm)
        disp = max(disp, float(np.linalg.norm(a[:3, 3] - before[nm][:3, 3])))
        c = (np.trace(before[nm][:3, :3].T @ a[:3, :3]) - 1) / 2
        rot = max(rot, float(np.degrees(np.arccos(np.clip(c, -1, 1)))))
    return {
        "case": f"{set_name} seed {seed} x{n}",
        "settled": settled,
        "max_disp_mm": disp * 1e3,
        "max_rot_deg": rot,
        "cpu_s": cpu,
    }


def heap_case(seed: int, steps: int = 2400) -> dict:
    import make_objects

    import ferrobot

    rng = np.random.default_rng(seed)
    w = ferrobot.World(dt=1 / 240)
    w.add_box("table", [1.0, 1.0, 0.4], [0, 0, 0.2, 1, 0, 0, 0], fixed=True)
    kinds = [make_objects.superellipsoid, make_objects.dumbbell, make_objects.ring, make_objects.bent_tube]
    for i in range(8):
        v, f = kinds[i % 4](rng)
        v = (v - v.mean(axis=0)) * (0.04 / np.ptp(v, axis=0).max())
        xy = rng.uniform(-0.02, 0.02, size=2)
        w.add_mesh(f"o{i}", v, f, [*xy, 0.45 + 0.03 * i, 1, 0, 0, 0], approximation="convex_decomposition", mass=0.1)
        w.step(24)
    w.step(240)
    t0 = _cpu()
    w.step(steps)
    cpu = _cpu() - t0
    moving = sum(
        float(np.linalg.norm(w.get_object_velocity(f"o{i}")[0])) > 2e-3
        or float(np.linalg.norm(w.get_object_velocity(f"o{i}")[1])) > 2e-3
        for i in range(8)
    )
    return {"case": f"heap of 8 decompositions seed {seed}", "cpu_s": cpu, "steps": steps, "moving_at_end": moving}


def _run_sub(pkg: str | None, args: list[str]) -> dict:
    env = dict(os.environ)
    if pkg:
        env["PYTHONPATH"] = pkg + os.pathsep + env.get("PYTHONPATH", "")
    out = subprocess.run(
        [sys.executable, __file__, "--one", *args], env=env, capture_output=True, text=True, check=True
    ).stdout
    return json.loads(out.strip().splitlines()[-1])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sets", default="made,pybullet,heldout")
    ap.add_argument("--seeds", default="1,2,3")
    ap.add_argument("--steps", type=int, default=10_000)
    ap.add_argument("--before", help="another build's python/ferrobot package directory, run interleaved")
    ap.add_argument("--rounds", type=int, default=1)
    ap.add_argument("--heaps", type=int, default=4, help="heaps of decompositions timed (seeds 1..N)")
    ap.add_argument("--json", type=Path)
    ap.add_argument("--one", nargs="+", help=argparse.SUPPRESS)
    a = ap.parse_args()
    tmp = Path(tempfile.gettempdir()) / "ferrobot_pile_rest_objects"
    if a.one:
        if a.one[0] == "heap":
            print(json.dumps(heap_case(int(a.one[1]))))
        else:
            s, seed, n, steps = a.one
            print(json.dumps(rest_case(s, int(seed), int(n), int(steps), tmp)))
        return 0
    counts = {"made": 6, "pybullet": 8, "heldout": 8}
    cases = [["heap", str(h)] for h in range(1, a.heaps + 1)] + [
        [s, seed, str(counts.get(s, 8)), str(a.steps)] for s in a.sets.split(",") for seed in a.seeds.split(",")
    ]
    builds = [("this", None)] + ([("before", str(Path(a.before).resolve().parent))] if a.before else [])
    rows = []
    for case in cases:
        per = {}
        for _ in range(a.rounds):
            for label, pkg in builds:
                per.setdefault(label, []).append(_run_sub(pkg, case))
        row = {"case": per["this"][0]["case"]}
        for label, runs in per.items():
            r = runs[-1]
            row[label] = {k: v for k, v in r.items() if k != "case"}
            row[label]["cpu_s"] = statistics.median(x["cpu_s"] for x in runs)
        rows.append(row)
        print(json.dumps(row), flush=True)
    print(f"load average {os.getloadavg()}")
    if a.json:
        a.json.write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
