"""The console command prints joints, limits, FK and timing of the bundled robot."""

from __future__ import annotations

import re
import subprocess
import sys

import ferrobot
from ferrobot.cli import main


def test_robot_command_prints_joints_limits_fk_and_timing(capsys):
    assert main(["robot", "panda", "--batch", "20000"]) == 0
    out = capsys.readouterr().out
    assert "robot panda: 8 DOF" in out
    assert "panda_joint4" in out and "-3.0718" in out and "-0.0698" in out
    assert re.search(r"panda_finger_joint2\s+mimics panda_finger_joint1", out)
    assert "named state 'ready'" in out
    # the printed FK is the model's FK of the ready state
    m = ferrobot.robots.panda()
    p = m.fk(m.named_state("ready"))[:3, 3]
    assert f"xyz = [{p[0]:+.4f}, {p[1]:+.4f}, {p[2]:+.4f}]" in out
    assert "single fk() call" in out and "M/s" in out


def test_robot_command_on_a_urdf_path_and_bad_path():
    from conftest import UR5_URDF

    run = subprocess.run(
        [sys.executable, "-m", "ferrobot.cli", "robot", str(UR5_URDF), "--batch", "1000"],
        capture_output=True,
        text=True,
    )
    assert run.returncode == 0, run.stderr
    assert "shoulder_pan_joint" in run.stdout
    run = subprocess.run(
        [sys.executable, "-m", "ferrobot.cli", "robot", "/no/such.urdf"], capture_output=True, text=True
    )
    assert run.returncode == 1
    assert "ferrobot: error:" in run.stderr and "cannot read" in run.stderr
    assert "Traceback" not in run.stderr


def test_version(capsys):
    assert main(["--version"]) == 0
    assert capsys.readouterr().out.strip() == f"ferrobot {ferrobot.__version__}"
    assert ferrobot.__version__.count(".") == 2
