"""Batch runs for data generation: many randomised episodes, results per episode in ``episodes.jsonl``
and a summary in ``summary.json`` (episodes, successes, success rate, episodes per hour, failures by
stage, time per stage), with a progress bar."""

from __future__ import annotations

import collections
import json
import statistics
import sys
import time
from pathlib import Path

from .pick_place import STAGES, PickPlace, PickPlaceConfig
from .scene import random_scene

__all__ = ["run_batch", "Progress", "summarize"]


class Progress:
    """A text progress bar on a stream (stderr by default); on a non-terminal, a line every 10%."""

    def __init__(self, total: int, stream=None, width: int = 30):
        self.total, self.width = total, width
        self.stream = sys.stderr if stream is None else stream
        self.tty = hasattr(self.stream, "isatty") and self.stream.isatty()
        self.t0 = time.perf_counter()
        self._last_decile = -1

    def update(self, done: int, successes: int) -> None:
        el = time.perf_counter() - self.t0
        rate = done / el if el > 0 else 0.0
        eta = (self.total - done) / rate if rate > 0 else 0.0
        fill = int(self.width * done / self.total) if self.total else self.width
        text = (
            f"[{'#' * fill}{'.' * (self.width - fill)}] {done}/{self.total} "
            f"ok {successes} ({100.0 * successes / max(done, 1):.1f}%) {rate:.2f} ep/s eta {eta:.0f} s"
        )
        if self.tty:
            self.stream.write("\r" + text + ("\n" if done == self.total else ""))
            self.stream.flush()
        else:
            decile = 10 * done // max(self.total, 1)
            if decile != self._last_decile or done == self.total:
                self._last_decile = decile
                print(text, file=self.stream, flush=True)


def summarize(records: list[dict], wall_time_s: float) -> dict:
    """The summary of episode records (the dicts written to ``episodes.jsonl``)."""
    n = len(records)
    ok = sum(1 for r in records if r["success"])
    fails = collections.Counter(r["failed_stage"] for r in records if not r["success"])
    stage_ms = {}
    for name in STAGES:
        ts = [1e3 * s["time_s"] for r in records for s in r["stages"] if s["name"] == name and s["ok"]]
        if ts:
            stage_ms[name] = round(statistics.median(ts), 2)
    errs = [r["place_error_m"] for r in records if r["success"] and r["place_error_m"] is not None]
    return {
        "episodes": n,
        "successes": ok,
        "success_rate": ok / n if n else 0.0,
        "failures_by_stage": dict(sorted(fails.items())),
        "wall_time_s": wall_time_s,
        "episodes_per_second": n / wall_time_s if wall_time_s > 0 else 0.0,
        "episodes_per_hour": 3600.0 * n / wall_time_s if wall_time_s > 0 else 0.0,
        "median_episode_wall_s": statistics.median(r["wall_time_s"] for r in records) if n else 0.0,
        "median_stage_ms": stage_ms,
        "median_place_error_mm": 1e3 * statistics.median(errs) if errs else None,
    }


def run_batch(
    episodes: int,
    seed: int = 0,
    out: Path | None = None,
    config: PickPlaceConfig | None = None,
    num_objects: int | None = None,
    progress: bool = True,
) -> dict:
    """Runs ``episodes`` episodes on random scenes seeded ``seed, seed + 1, ...``; writes
    ``out/episodes.jsonl`` (one JSON object per episode, written as it finishes) and ``out/summary.json``
    when ``out`` is given; returns the summary."""
    pp = PickPlace(config)
    bar = Progress(episodes) if progress else None
    records = []
    jsonl = None
    if out is not None:
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        jsonl = (out / "episodes.jsonl").open("w")
    t0 = time.perf_counter()
    try:
        for i in range(episodes):
            spec = random_scene(seed + i, num_objects)
            rec = pp.run(spec).to_dict()
            rec["episode"] = i
            rec["objects"] = [o.kind for o in spec.objects]
            records.append(rec)
            if jsonl is not None:
                jsonl.write(json.dumps(rec) + "\n")
                jsonl.flush()
            if bar is not None:
                bar.update(i + 1, sum(r["success"] for r in records))
    finally:
        if jsonl is not None:
            jsonl.close()
    summary = summarize(records, time.perf_counter() - t0)
    summary["seed"] = seed
    if out is not None:
        (out / "summary.json").write_text(json.dumps(summary, indent=2))
    return summary
