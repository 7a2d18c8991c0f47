"""The robots the environment's packages ship (PyPI `pybullet`'s `pybullet_data` and PyPI
`example-robot-data`), with how to load each: shared by tests/test_robots_in_env.py and
benches/robots.py."""

from __future__ import annotations

import sys
import sysconfig
import warnings
from pathlib import Path

import ferrobot


def _pybullet_data() -> Path | None:
    try:
        import pybullet_data
    except ImportError:
        return None
    return Path(pybullet_data.getDataPath())


def _erd() -> Path | None:
    # cmeel installs into site-packages' `cmeel.prefix`; a venv made with
    # --system-site-packages may hold it in the base interpreter's site-packages.
    roots = [sysconfig.get_paths()["purelib"], *sys.path]
    for root in roots:
        p = Path(root) / "cmeel.prefix/share/example-robot-data/robots"
        if p.is_dir():
            return p
    return None


PB = _pybullet_data()
ERD = _erd()

# name: (package root, URDF, SRDF or None, load options)
ROBOTS: dict[str, tuple[Path | None, str, str | None, dict]] = {
    "pb_kuka_iiwa": (PB, "kuka_iiwa/model.urdf", None, {}),
    "pb_xarm6": (PB, "xarm/xarm6_robot.urdf", None, {}),
    "pb_franka_panda": (PB, "franka_panda/panda.urdf", None, {}),
    "erd_ur3": (ERD, "ur_description/urdf/ur3_robot.urdf", None, {}),
    "erd_ur5": (ERD, "ur_description/urdf/ur5_robot.urdf", "ur_description/srdf/ur5.srdf", {}),
    "erd_ur10": (ERD, "ur_description/urdf/ur10_robot.urdf", None, {}),
    "erd_kinova": (ERD, "kinova_description/robots/kinova.urdf", "kinova_description/srdf/kinova.srdf", {}),
    "erd_panda": (ERD, "panda_description/urdf/panda.urdf", "panda_description/srdf/panda.srdf", {}),
    "erd_xarm7": (ERD, "xarm_description/urdf/xarm7.urdf", "xarm_description/srdf/xarm7.srdf", {}),
    "erd_z1": (ERD, "z1_description/urdf/z1.urdf", "z1_description/srdf/z1.srdf", {}),
    "erd_so101": (ERD, "so_arm_description/urdf/so101.urdf", None, {}),
    "erd_tiago": (ERD, "tiago_description/robots/tiago.urdf", None, {"ee_link": "arm_tool_link"}),
    "erd_baxter": (
        ERD,
        "baxter_description/urdf/baxter.urdf",
        "baxter_description/srdf/baxter_manipulation.srdf",
        {"ee_link": "left_gripper"},
    ),
}


def available() -> list[str]:
    return [k for k, (root, urdf, _, _) in ROBOTS.items() if root is not None and (root / urdf).is_file()]


def urdf_path(name: str) -> Path:
    root, urdf, _, _ = ROBOTS[name]
    assert root is not None
    return root / urdf


def load(name: str) -> ferrobot.RobotModel:
    """The robot as a new user loads it (stale SRDF entries skipped with their warning)."""
    root, urdf, srdf, opts = ROBOTS[name]
    assert root is not None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ferrobot.errors.SrdfWarning)
        return ferrobot.RobotModel.from_urdf(root / urdf, srdf=None if srdf is None else root / srdf, **opts)
