"""Soak test of the grasp service (loopback only): ``benches/grasp_service_soak.py`` for 20 s of concurrent valid
and hostile requests (the full minute is in BENCHMARKS.md). Every valid request must get a 200 with grasps,
``/health`` must answer 200 throughout, no hostile request may get a 5xx or stay open, and the server's RSS must
stay under 512 MiB."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("fastapi")

SCRIPT = Path(__file__).resolve().parents[1] / "benches" / "grasp_service_soak.py"
DURATION = os.environ.get("FERROBOT_SOAK_SECONDS", "20")


def test_service_soak(tmp_path):
    out = tmp_path / "soak.json"
    cmd = [sys.executable, str(SCRIPT), "--duration", DURATION, "--json", str(out), "--rss-limit-mb", "512"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=float(DURATION) + 240)
    assert out.exists(), proc.stderr[-3000:]
    s = json.loads(out.read_text())
    assert s["server_alive"] and s["failures"] == [], s["failures"]
    assert s["valid_lost"] == 0 and s["valid_npz"] > 0 and s["valid_json"] > 0
    assert s["valid_ok"] == s["valid_npz"] + s["valid_json"]
    assert s["health_failed"] == 0 and s["health_ok"] > 0
    assert s["rss_max_mb"] <= 512
    # every attack was tried and answered 4xx or by closing the connection
    assert len(s["hostile_statuses"]) == 13
    for name, statuses in s["hostile_statuses"].items():
        assert all(k.startswith("4") or k == "closed" for k in statuses), (name, statuses)
    assert proc.returncode == 0, proc.stdout[-3000:]
