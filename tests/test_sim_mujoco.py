"""The bundled Panda against MuJoCo: the MJCF that benches/sim.py compares with is
generated from the same RobotModel; falling freely under gravity (no drives, no
gravity compensation) both simulators must move the same way."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import ferrobot

mujoco = pytest.importorskip("mujoco")
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benches"))
from mjcf_scene import Settings, build_ferrobot, build_mujoco  # noqa: E402


def test_mjcf_panda_has_the_models_masses_and_kinematics():
    model = ferrobot.robots.panda()
    q = np.array([0.3, -0.5, 0.2, -2.0, 0.4, 1.8, 0.5, 0.03])
    m, d, _ = build_mujoco(model, Settings(), q)
    for link in model.link_names:
        assert m.body(link).mass[0] == pytest.approx(model.inertial(link).mass, abs=1e-9)
        assert d.body(link).xpos == pytest.approx(model.fk(q, link)[:3, 3], abs=1e-9)
    # the mimic finger follows its driver
    assert d.joint("panda_finger_joint2").qpos[0] == pytest.approx(0.03)


def test_free_fall_of_the_arm_matches_mujoco():
    model = ferrobot.robots.panda()
    q0 = np.array([0.3, -0.5, 0.2, -2.0, 0.4, 1.8, 0.5, 0.03])
    s = Settings(gravity_compensation=False, stiffness=0.0, damping=0.0)
    w, r = build_ferrobot(model, s, q0)
    m, d, _ = build_mujoco(model, s, q0)
    for _ in range(20):  # 83 ms
        w.step()
        mujoco.mj_step(m, d)
    qf = r.joint_positions[:7]
    qm = np.array([d.joint(n).qpos[0] for n in model.dof_names[:7]])
    assert np.abs(qf - q0[:7]).max() > 0.1  # it moved
    # measured: 4.9 mrad apart (different integrators: Rapier's substeps, MuJoCo's implicitfast)
    assert np.abs(qf - qm).max() < 1e-2
