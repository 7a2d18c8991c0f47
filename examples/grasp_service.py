"""The grasp service with two servers: a client spreads requests over both and fails over when one stops.

    python examples/grasp_service.py [--ports 5101 5102]

Starts two `ferrobot serve-grasp` processes on localhost (needs the `serve` extra: fastapi, uvicorn,
httpx), sends the saved RGB-D frame to them (binary `.npz` and the AnyGrasp-style JSON body), stops one
server and shows the client carrying on with the other.
"""

import argparse
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from ferrobot.grasp.client import GraspClient

ap = argparse.ArgumentParser()
ap.add_argument("--ports", type=int, nargs=2, default=[5101, 5102])
args = ap.parse_args()
frame = np.load(Path(__file__).parent / "data" / "table_rgbd.npz")
intr = {k: float(frame[k]) for k in ("fx", "fy", "cx", "cy", "scale")}
lims = [-0.6, 0.6, -0.5, 0.5, 0.2, 1.4]  # workspace in the camera frame
addresses = [f"http://127.0.0.1:{p}" for p in args.ports]
cmd = [sys.executable, "-m", "ferrobot.cli", "serve-grasp", "--host", "127.0.0.1", "--log-level", "warning"]
servers = [subprocess.Popen([*cmd, "--port", str(p)]) for p in args.ports]
try:
    client = GraspClient(addresses, timeout=10.0, retries=2, cooldown=30.0)
    deadline = time.time() + 60
    while True:  # wait until both answer /health
        try:
            up = [GraspClient(a, timeout=1.0, retries=0).health() for a in addresses]
            break
        except Exception:
            if time.time() > deadline:
                raise
            time.sleep(0.2)
    print(f"two servers up: {[u.get('status') for u in up]}")

    for binary in (True, False):
        t0 = time.perf_counter()
        gg = client.process(frame["depth"], colors=frame["rgb"], lims=lims, binary=binary, **intr)
        kind = "npz" if binary else "JSON"
        print(f"{kind:>4}: {len(gg)} grasps, best score {gg.scores[0]:.3f}, {1e3 * (time.perf_counter() - t0):.0f} ms")

    servers[0].terminate()
    servers[0].wait()
    print(f"stopped {addresses[0]}")
    for i in range(3):
        gg = client.process(frame["depth"], lims=lims, **intr)
        print(f"request {i}: {len(gg)} grasps (served by the remaining server)")
finally:
    for s in servers:
        s.terminate()
        s.wait()
