"""Pick-and-place throughput and success: `ferrobot demo`'s batch mode as a benchmark.

    python benches/pipeline.py [--episodes 100] [--seed 0] [--workers N] [--json FILE]
                               [--robot panda|ur5e] [--preshape-margin M] [--place-clearance C]

Runs randomised episodes (the bundled Panda, a table with 3-5 objects, camera -> grasp -> IK ->
plan -> execute -> verify) and prints the success rate, failures by stage, episodes per second of
wall time, CPU seconds per episode (all processes; steadier than wall time on a shared machine)
and the median time of every stage. Targets (2-core machine): >= 90% success over 100 episodes,
>= 1 episode per second of wall time.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import time
from pathlib import Path

import ferrobot
from ferrobot.pipeline import PickPlaceConfig
from ferrobot.pipeline.batch import run_batch


def cpu_seconds() -> float:
    own = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--episodes", type=int, default=100)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--json", type=Path)
    ap.add_argument("--robot", default="panda", choices=("panda", "ur5e"))
    ap.add_argument(
        "--preshape-margin",
        type=float,
        default=None,
        help="PickPlaceConfig.preshape_margin (m, in [0, 0.05]); default: approach fully open",
    )
    ap.add_argument(
        "--place-clearance", type=float, default=None, help="PickPlaceConfig.place_clearance (m); default: its default"
    )
    args = ap.parse_args()
    print(
        f"ferrobot {ferrobot.__version__}, {os.cpu_count()} cores, {args.workers} worker(s), robot {args.robot}, "
        f"preshape_margin {args.preshape_margin}, load {os.getloadavg()}"
    )
    c0, t0 = cpu_seconds(), time.perf_counter()
    config = PickPlaceConfig(preshape_margin=args.preshape_margin)
    if args.place_clearance is not None:
        config.place_clearance = args.place_clearance
    s = run_batch(args.episodes, seed=args.seed, workers=args.workers, progress=False, config=config, robot=args.robot)
    wall, cpu = time.perf_counter() - t0, cpu_seconds() - c0
    s["cpu_s_per_episode"] = cpu / args.episodes
    s["wall_incl_startup_s"] = wall
    print(
        f"success: {s['successes']}/{s['episodes']} ({100 * s['success_rate']:.1f}%), failures {s['failures_by_stage']}"
    )
    print(
        f"throughput: {s['episodes_per_second']:.2f} episodes/s wall ({s['episodes_per_hour']:.0f}/h), "
        f"{s['cpu_s_per_episode']:.3f} CPU s per episode, median episode {s['median_episode_wall_s']:.3f} s"
    )
    print("median stage times (ms): " + ", ".join(f"{k} {v:.1f}" for k, v in s["median_stage_ms"].items()))
    print(f"median place error: {s['median_place_error_mm']:.1f} mm; load after {os.getloadavg()}")
    if args.json:
        args.json.write_text(json.dumps(s, indent=2))


if __name__ == "__main__":
    main()
