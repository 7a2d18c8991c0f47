"""Batch runs for data generation: many randomised episodes, results per episode in ``episodes.jsonl``
and a summary in ``summary.json`` (episodes, successes, success rate, episodes per hour, failures by
stage, time per stage), with a progress bar."""

from __future__ import annotations

import collections
import json
import multiprocessing
import os
import statistics
import sys
import time
from pathlib import Path

from ..errors import InvalidArgumentError
from .pick_place import STAGES, PickPlace, PickPlaceConfig
from .scene import place_camera, random_scene

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


_WORKER: dict = {}


def _worker_init(config: PickPlaceConfig | None, threads: int, robot: dict | None = None) -> None:
    # Each worker process gets its share of the cores for the Rust thread pools (set before first use).
    os.environ.setdefault("RAYON_NUM_THREADS", str(threads))
    _WORKER["pp"] = PickPlace(config, **(robot or {}))


def _worker_run(job: tuple[int, int, int | None]) -> dict:
    i, seed, num_objects = job
    return _episode(_WORKER["pp"], i, seed, num_objects)


def _episode(pp: PickPlace, i: int, seed: int, num_objects: int | None) -> dict:
    spec = place_camera(random_scene(seed, num_objects), pp.model, pp.gripper)
    rec = pp.run(spec).to_dict()
    rec["episode"] = i
    rec["objects"] = [o.kind for o in spec.objects]
    return rec


def run_batch(
    episodes: int,
    seed: int = 0,
    out: Path | None = None,
    config: PickPlaceConfig | None = None,
    num_objects: int | None = None,
    progress: bool = True,
    workers: int = 1,
    robot=None,
    srdf=None,
    gripper=None,
) -> dict:
    """Runs ``episodes`` episodes on random scenes seeded ``seed, seed + 1, ...``; writes
    ``out/episodes.jsonl`` (one JSON object per episode, in episode order, written as they finish) and
    ``out/summary.json`` when ``out`` is given; returns the summary. ``workers`` > 1 runs episodes in that
    many processes (each episode depends only on its seed, so the records are the same). ``robot``, ``srdf``
    and ``gripper`` are :class:`PickPlace`'s (names or paths when ``workers`` > 1: they are sent to the
    worker processes)."""
    robot_args = {"robot": robot, "srdf": srdf, "gripper": gripper}
    if workers < 1:
        raise InvalidArgumentError(f"workers: expected >= 1, got {workers}")
    bar = Progress(episodes) if progress else None
    records = []
    jsonl = None
    if out is not None:
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        jsonl = (out / "episodes.jsonl").open("w")
    jobs = [(i, seed + i, num_objects) for i in range(episodes)]
    t0 = time.perf_counter()
    pool = None
    try:
        if workers == 1:
            pp = PickPlace(config, **robot_args)
            results = (_episode(pp, *job) for job in jobs)
        else:
            threads = max(1, (os.cpu_count() or 1) // workers)
            ctx = multiprocessing.get_context("spawn")  # no fork of a process whose Rust threads run
            pool = ctx.Pool(workers, initializer=_worker_init, initargs=(config, threads, robot_args))
            results = pool.imap(_worker_run, jobs)
        for rec in results:
            records.append(rec)
            if jsonl is not None:
                jsonl.write(json.dumps(rec) + "\n")
                jsonl.flush()
            if bar is not None:
                bar.update(len(records), sum(r["success"] for r in records))
    finally:
        if pool is not None:
            pool.terminate()
        if jsonl is not None:
            jsonl.close()
    summary = summarize(records, time.perf_counter() - t0)
    summary["seed"] = seed
    summary["workers"] = workers
    summary["robot"] = str(robot or "panda")
    if out is not None:
        (out / "summary.json").write_text(json.dumps(summary, indent=2))
    return summary
