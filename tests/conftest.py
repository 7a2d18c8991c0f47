"""Shared fixtures: the robots in ../shared beside the checkout."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parent.parent
SHARED = ROOT.parent / "shared"
PANDA_URDF = SHARED / "robots" / "panda" / "panda.urdf"
PANDA_SRDF = SHARED / "robots" / "panda" / "panda.srdf"
UR5_URDF = SHARED / "robots" / "ur5" / "ur5.urdf"
UR5_SRDF = SHARED / "robots" / "ur5" / "ur5.srdf"


def pytest_configure(config):
    if not SHARED.is_dir():
        raise pytest.UsageError(f"the shared data folder {SHARED} is missing (clone beside ../shared)")


def random_configurations(model, n: int, seed: int = 0) -> np.ndarray:
    """Uniform samples within the joint limits (continuous joints in [-pi, pi])."""
    rng = np.random.default_rng(seed)
    lo = np.where(np.isfinite(model.lower_limits), model.lower_limits, -np.pi)
    hi = np.where(np.isfinite(model.upper_limits), model.upper_limits, np.pi)
    return rng.uniform(lo, hi, size=(n, model.num_dof))


@pytest.fixture(scope="session")
def mbm_panda():
    import ferrobot

    return ferrobot.RobotModel.from_urdf(PANDA_URDF, srdf=PANDA_SRDF)


@pytest.fixture(scope="session")
def ur5():
    import ferrobot

    return ferrobot.RobotModel.from_urdf(UR5_URDF, srdf=UR5_SRDF)


@pytest.fixture(scope="session")
def bundled_panda():
    import ferrobot

    return ferrobot.robots.panda()


MBM = SHARED / "bench" / "mbm"


def mbm_problem(scene: Path) -> tuple[dict[str, float], dict[str, float]]:
    """Start and goal joint values (by name) of a MotionBenchMaker problem, from its request file."""
    import yaml

    req = yaml.safe_load((scene.parent / scene.name.replace("scene", "request")).read_text())
    js = req["start_state"]["joint_state"]
    start = dict(zip(js["name"], js["position"], strict=True))
    goal = {c["joint_name"]: c["position"] for c in req["goal_constraints"][0]["joint_constraints"]}
    return start, goal
