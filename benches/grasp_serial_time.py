"""CPU time of one ``grasp_clutter_speed.py`` frame's detection, optionally without the hand search.

    python benches/grasp_serial_time.py FRAME [RUNS] [NUM_SEEDS]

``FRAME`` is one of ``grasp_clutter_speed.FRAMES``; ``NUM_SEEDS=0`` times everything but the parallel hand
search (back-projection, voxel grid, support plane, kd-trees, hidden volume): the serial part of a frame.
Prints the median ``time.process_time`` per call over ``RUNS`` calls after one warm-up. Set
``RAYON_NUM_THREADS=1`` for the single-thread work. Run it for two builds in turn (``PYTHONPATH``) to compare.
"""

from __future__ import annotations

import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import grasp_clutter_speed as gcs  # noqa: E402


def main() -> int:
    import ferrobot.grasp as fg

    name = sys.argv[1]
    runs = int(sys.argv[2]) if len(sys.argv) > 2 else 15
    seeds = int(sys.argv[3]) if len(sys.argv) > 3 else 0
    depth, labels, oid, (fx, fy, cx, cy) = gcs.frames()[name]
    kw = {"mask": labels} if oid is None else {"mask": labels, "object_id": oid}
    fg.detect_from_rgbd(depth, fx, fy, cx, cy, 1.0, num_seeds=seeds, **kw)
    cpu = []
    for _ in range(runs):
        c0 = time.process_time()
        fg.detect_from_rgbd(depth, fx, fy, cx, cy, 1.0, num_seeds=seeds, **kw)
        cpu.append(time.process_time() - c0)
    print(f"{name} num_seeds {seeds}: median CPU {1e3 * statistics.median(cpu):.2f} ms")
    return 0


if __name__ == "__main__":
    sys.exit(main())
