"""World-sync time per pick-and-place episode: the planner's collision world kept in sync with the
simulation (``Planner.update_world(sim, ignore=...)`` before every IK goal set, motion and attach).

    python benches/scene_sync.py [--episodes 10] [--seed 0]
    python benches/scene_sync.py --compare OTHER_PYTHONPATH [--rounds 3] [--episodes 10]

Runs episodes in one process and prints, per episode, the CPU time spent in the pipeline's syncs
(``PickPlace._sync``), their number, the episode's CPU time and success. ``--compare`` runs this
script alternately against the installed ferrobot ("after") and the one found on ``OTHER_PYTHONPATH``
("before", e.g. a copy of ``main``'s ``python/ferrobot`` with its built extension), ``--rounds`` times
each, interleaved, and prints both medians: the before/after figure of BENCHMARKS.md. CPU time
(``time.process_time``) rather than wall time, since the machine is shared.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time


def run(episodes: int, seed: int) -> dict:
    import ferrobot
    from ferrobot.pipeline import PickPlace, random_scene

    pp = PickPlace()
    spent = {"sync_s": 0.0, "syncs": 0}
    inner = pp._sync

    def timed(ignore):
        t = time.process_time()
        inner(ignore)
        spent["sync_s"] += time.process_time() - t
        spent["syncs"] += 1

    pp._sync = timed
    rows = []
    for s in range(seed, seed + episodes):
        spent.update(sync_s=0.0, syncs=0)
        t = time.process_time()
        r = pp.run(random_scene(s))
        rows.append(
            {
                "seed": s,
                "success": bool(r.success),
                "sync_ms": 1e3 * spent["sync_s"],
                "syncs": spent["syncs"],
                "episode_cpu_s": time.process_time() - t,
            }
        )
    stats = getattr(pp.planner, "world_sync_stats", None)
    stats = stats.to_dict() if hasattr(stats, "to_dict") else stats  # a WorldSyncStats (a dict before issue 16)
    return {"ferrobot": os.path.dirname(ferrobot.__file__), "rows": rows, "world_sync_stats": stats}


def summary(rows: list[dict]) -> dict:
    return {
        "episodes": len(rows),
        "successes": sum(r["success"] for r in rows),
        "median_sync_ms_per_episode": statistics.median(r["sync_ms"] for r in rows),
        "mean_sync_ms_per_episode": statistics.fmean(r["sync_ms"] for r in rows),
        "median_syncs_per_episode": statistics.median(r["syncs"] for r in rows),
        "median_episode_cpu_s": statistics.median(r["episode_cpu_s"] for r in rows),
    }


def compare(other: str, rounds: int, episodes: int, seed: int) -> None:
    print(f"load {os.getloadavg()}")
    results: dict[str, list[dict]] = {"before": [], "after": []}
    for k in range(rounds):
        for label in ("before", "after"):
            env = dict(os.environ)
            if label == "before":
                env["PYTHONPATH"] = other + os.pathsep + env.get("PYTHONPATH", "")
            cmd = [sys.executable, __file__, "--episodes", str(episodes), "--seed", str(seed), "--json"]
            out = subprocess.run(cmd, env=env, check=True, capture_output=True, text=True).stdout
            data = json.loads(out.strip().splitlines()[-1])
            results[label] += data["rows"]
            print(f"round {k} {label:<6} ({data['ferrobot']}): {json.dumps(summary(data['rows']))}")
    for label, rows in results.items():
        print(f"{label}: {json.dumps(summary(rows))}")
    print(f"load {os.getloadavg()}")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--episodes", type=int, default=10)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--compare", metavar="OTHER_PYTHONPATH")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--json", action="store_true", help="print one JSON line (used by --compare)")
    args = ap.parse_args()
    if args.compare:
        compare(args.compare, args.rounds, args.episodes, args.seed)
        return
    data = run(args.episodes, args.seed)
    if args.json:
        print(json.dumps(data))
        return
    for r in data["rows"]:
        print(json.dumps(r))
    print(json.dumps(summary(data["rows"])))
    print("world_sync_stats:", data["world_sync_stats"])


if __name__ == "__main__":
    main()
