"""Grasp detection latency on a rendered 640 x 480 RGB-D frame, and the HTTP round trip (JSON vs binary).

    python benches/grasp.py [--runs 20] [--http-runs 10] [--no-http]

The frame: a 5 x 7 x 10 cm box and a 3 cm radius, 12 cm cylinder on a 0.8 m table, seen by a
600 px pinhole camera from 0.7 m at 45 degrees (the analytic scene of tests/grasp_scenes.py,
ray-cast in numpy), as a uint16 millimetre depth image. Prints the median (and min) latency of
``detect_from_rgbd`` with default options, with a segmentation mask, with a workspace crop, and
with a faster preset; then starts ``ferrobot serve-grasp`` on a free port and times
``GraspClient.process`` through ``POST /process`` (nested JSON lists, AnyGrasp's protocol) and
``POST /process_npz`` (binary), with request sizes. Target: tens of ms per frame on 2 cores.
"""

from __future__ import annotations

import argparse
import io
import json
import os
import socket
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from grasp_scenes import CX, CY, FX, FY, default_scene, render  # noqa: E402

import ferrobot.grasp as fg  # noqa: E402
from ferrobot.errors import ServiceError  # noqa: E402
from ferrobot.grasp.client import GraspClient  # noqa: E402


def timed(f, runs: int):
    """Median and min wall time (ms), median CPU time of this process (ms, all threads), last result."""
    f()  # warm-up
    ts, cs = [], []
    for _ in range(runs):
        t0, c0 = time.perf_counter(), time.process_time()
        out = f()
        ts.append(time.perf_counter() - t0)
        cs.append(time.process_time() - c0)
    return statistics.median(ts) * 1e3, min(ts) * 1e3, statistics.median(cs) * 1e3, out


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=20)
    ap.add_argument("--http-runs", type=int, default=10)
    ap.add_argument("--no-http", action="store_true")
    args = ap.parse_args()

    scene, cam = default_scene()
    depth, labels = render(scene, cam)
    mm = np.round(depth * 1000).astype(np.uint16)
    colors = np.zeros(mm.shape + (3,), dtype=np.uint8)
    print(f"frame {mm.shape[1]}x{mm.shape[0]}, {np.count_nonzero(mm)} valid depth pixels, cores {os.cpu_count()}")

    cases = [
        ("backproject only", lambda: fg.backproject(mm, FX, FY, CX, CY, 1000.0)[0]),
        ("detect_from_rgbd, defaults", lambda: fg.detect_from_rgbd(mm, FX, FY, CX, CY, 1000.0)),
        ("detect_from_rgbd, mask", lambda: fg.detect_from_rgbd(mm, FX, FY, CX, CY, 1000.0, mask=labels)),
        (
            "detect_from_rgbd, workspace crop",
            lambda: fg.detect_from_rgbd(mm, FX, FY, CX, CY, 1000.0, workspace=[-0.25, 0.35, -0.25, 0.25, 0.3, 0.9]),
        ),
        (
            "detect_from_rgbd, fast (64 seeds, no tilt)",
            lambda: fg.detect_from_rgbd(mm, FX, FY, CX, CY, 1000.0, num_seeds=64, approach_tilts=[0.0]),
        ),
    ]
    for name, f in cases:
        med, lo, cpu, out = timed(f, args.runs)
        what = "points" if "back" in name else "grasps"
        print(f"{name:<46} median {med:7.1f} ms  min {lo:7.1f} ms  cpu {cpu:7.1f} ms  ({len(out)} {what})")

    if args.no_http:
        return 0
    port = free_port()
    proc = subprocess.Popen(
        [sys.executable, "-m", "ferrobot.cli", "serve-grasp", "--port", str(port), "--log-level", "warning"],
        stdout=subprocess.DEVNULL,
    )
    try:
        client = GraspClient([f"http://127.0.0.1:{port}"], timeout=60.0, retries=0)
        deadline = time.monotonic() + 30
        while True:
            try:
                client.health()
                break
            except ServiceError:
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.2)
        body = {"depths": mm.tolist(), "colors": colors.tolist(), "fx": FX, "fy": FY, "cx": CX, "cy": CY, "scale": 1e3}
        json_bytes = len(json.dumps(body).encode())
        buf = io.BytesIO()
        np.savez(buf, depths=mm, colors=colors, fx=FX, fy=FY, cx=CX, cy=CY, scale=1000.0)
        npz_bytes = len(buf.getvalue())
        for name, binary, size in (
            ("HTTP JSON /process", False, json_bytes),
            ("HTTP binary /process_npz", True, npz_bytes),
        ):
            med, lo, _, out = timed(
                lambda b=binary: client.process(mm, FX, FY, CX, CY, 1000.0, colors=colors, binary=b), args.http_runs
            )
            print(
                f"{name:<46} median {med:8.1f} ms   min {lo:8.1f} ms   ({len(out)} grasps, request {size / 1e6:.2f} MB)"
            )
        client.close()
    finally:
        proc.terminate()
        proc.wait(timeout=10)
    return 0


if __name__ == "__main__":
    sys.exit(main())
