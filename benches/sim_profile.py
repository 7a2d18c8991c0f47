"""Steps one of ``benches/sim.py``'s scenes for a profiler, nothing else timed.

    perf record -F 2000 -g python benches/sim_profile.py [alone|table] [steps]

The Panda holds the same pose as in ``benches/sim.py`` (hand 15 cm above the
table's box), after one untimed second to settle; then ``World.step(steps)``
once (default 150,000 steps), so the profile is the simulation step only.
Prints CPU microseconds per step.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

import ferrobot

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent))
from _sim_helpers import PANDA_Q0, ik, pose_at  # noqa: E402
from mjcf_scene import Settings, build_ferrobot  # noqa: E402
from sim import TABLE_TOP, TCP, table_objects  # noqa: E402


def main() -> None:
    scene = sys.argv[1] if len(sys.argv) > 1 else "alone"
    steps = int(sys.argv[2]) if len(sys.argv) > 2 else 150_000
    if scene not in ("alone", "table"):
        raise SystemExit("scene must be 'alone' or 'table'")
    model = ferrobot.robots.panda()
    q = np.r_[ik(model, PANDA_Q0, pose_at([0.5, 0.0, TABLE_TOP + 0.15]), TCP)[:7], 0.04]
    objects = table_objects() if scene == "table" else []
    w, _ = build_ferrobot(model, Settings(objects=objects), q)
    w.step(240)
    t = time.process_time()
    w.step(steps)
    cpu = time.process_time() - t
    print(f"{scene}: {steps} steps, {1e6 * cpu / steps:.2f} CPU us/step")


if __name__ == "__main__":
    main()
