"""The scripts in examples/ run to completion (so they never rot) and print what they promise."""

from __future__ import annotations

import socket
import subprocess
import sys

import pytest

from conftest import ROOT

EXAMPLES = ROOT / "examples"


def run(script: str, *args: str, cwd=None, timeout: float = 300) -> str:
    p = subprocess.run(
        [sys.executable, str(EXAMPLES / script), *args],
        capture_output=True,
        text=True,
        timeout=timeout,
        cwd=cwd or ROOT,
    )
    assert p.returncode == 0, f"{script} failed:\n{p.stdout}\n{p.stderr}"
    return p.stdout


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_ik_example():
    out = run("ik.py")
    assert "ik: success=True" in out and "batch: 100.0% solved" in out


def test_plan_moveit_scene_example():
    out = run("plan_moveit_scene.py")
    assert "-> solved" in out and "every sample collision-free: True" in out


def test_pick_and_place_example():
    out = run("pick_and_place.py", "--seed", "3")
    assert "rests" in out and "mm from the place location" in out
    err_mm = float(out.rsplit("rests ", 1)[1].split(" mm")[0])
    assert err_mm < 30.0


def test_grasp_from_rgbd_example(tmp_path):
    out = run("grasp_from_rgbd.py", "--out", str(tmp_path / "g.png"))
    assert "grasps; best 5" in out and (tmp_path / "g.png").read_bytes()[:4] == b"\x89PNG"


def test_grasp_service_example():
    pytest.importorskip("uvicorn")
    out = run("grasp_service.py", "--ports", str(free_port()), str(free_port()), timeout=180)
    assert "two servers up" in out
    assert out.count("(served by the remaining server)") == 3
