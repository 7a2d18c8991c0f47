"""The loader that picks one of a wheel's per-level builds of ``ferrobot._core`` (issue 22, ``_builds.py``).

What runs depends on the install, and every case is checked, none skipped:

* A wheel from ``scripts/build_wheel.py`` (``ferrobot/_simd/<level>/`` present): the loader picked the highest
  level the CPU supports among the four builds; each build the CPU can run, forced with ``FERROBOT_SIMD`` in
  its own subprocess, loads that very file and gives bit-identical answers (collision flags of a batch,
  signed distances, FK poses of a batch) to the baseline build's.
* A source install (one build, compiled for its machine, as CI has): the single-build path: the loaded
  build reports the level it was compiled for, forcing that level loads it and gives the same answers as
  the default import, and forcing any other level the CPU has raises the clear error (a source install
  cannot honour it).

In both, the choice rules are checked as a pure function for CPUs other than this one (a level above the
CPU's, unknown names, aliases), and a level the CPU lacks or an unknown name fails ``import ferrobot`` with
:class:`ferrobot.errors.InvalidArgumentError` in a subprocess.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

import ferrobot
from ferrobot import _builds
from ferrobot.errors import InvalidArgumentError

SHARED = Path(__file__).resolve().parents[2] / "shared"
LEVELS = _builds.LEVELS

CHILD = r"""
import json, sys
import numpy as np
import ferrobot
from pathlib import Path
shared = Path(sys.argv[1])
model = ferrobot.RobotModel.from_urdf(shared / "robots/panda/panda.urdf", srdf=shared / "robots/panda/panda.srdf",
                                      ee_link="panda_hand")
spheres = ferrobot.SphereModel.from_spherized_urdf(model, shared / "robots/panda/panda_spherized.urdf")
world = ferrobot.CollisionWorld.from_moveit_scene(shared / "bench/mbm/table_pick_panda/scene0001.yaml")
checker = ferrobot.CollisionChecker(model, world, spheres)
qs = np.random.default_rng(7).uniform(model.lower_limits, model.upper_limits, size=(4000, model.num_dof))
flags = checker.in_collision_batch(qs)
dist = [checker.distance(q).distance for q in qs[:200]]
fk = model.fk_batch(qs)
print(json.dumps({
    "level": ferrobot.simd_level(), "file": ferrobot._core.__file__, "info": ferrobot.simd_info(),
    "built": ferrobot._core._simd_support()[1],
    "flags": flags.astype(int).tolist(), "dist": [float(d).hex() for d in dist],
    "fk": [float(x).hex() for x in np.asarray(fk).ravel()],
}))
"""

FAIL_CHILD = r"""
import sys
try:
    import ferrobot
except Exception as e:
    print(type(e).__module__ + "." + type(e).__name__ + ": " + str(e))
    sys.exit(3)
print("imported " + ferrobot.simd_level())
"""


def _env(level: str | None) -> dict[str, str]:
    env = dict(os.environ, RAYON_NUM_THREADS="1")
    env.pop("FERROBOT_SIMD", None)
    if level is not None:
        env["FERROBOT_SIMD"] = level
    return env


def _run(level: str | None) -> dict:
    out = subprocess.run(
        [sys.executable, "-c", CHILD, str(SHARED)], env=_env(level), capture_output=True, text=True, timeout=300
    )
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout.strip().splitlines()[-1])


def _fail(level: str) -> str:
    out = subprocess.run(
        [sys.executable, "-c", FAIL_CHILD], env=_env(level), capture_output=True, text=True, timeout=120
    )
    assert out.returncode == 3, (out.stdout, out.stderr)
    return out.stdout


def test_choice_rules_for_other_cpus():
    four = list(LEVELS)
    assert _builds.choose_level(None, "x86-64-v4", four) == "x86-64-v4"
    assert _builds.choose_level(None, "x86-64-v3", four) == "x86-64-v3"  # never above the CPU
    assert _builds.choose_level(None, "baseline", four) == "baseline"
    assert _builds.choose_level(None, "x86-64-v4", ["baseline", "x86-64-v2"]) == "x86-64-v2"  # best available
    assert _builds.choose_level("v2", "x86-64-v4", four) == "x86-64-v2"  # forced, aliases accepted
    assert _builds.choose_level(" X86-64-V3 ", "x86-64-v4", four) == "x86-64-v3"
    assert _builds.choose_level("baseline", "x86-64-v4", four) == "baseline"
    with pytest.raises(InvalidArgumentError, match=r"FERROBOT_SIMD='x86-64-v4'.*does not support x86-64-v4"):
        _builds.choose_level("x86-64-v4", "x86-64-v3", four)
    with pytest.raises(InvalidArgumentError, match="does not support x86-64-v2"):
        _builds.choose_level("v2", "baseline", ["baseline"])  # e.g. aarch64: baseline only
    with pytest.raises(InvalidArgumentError, match="FERROBOT_SIMD='avx9' is not an instruction-set level"):
        _builds.choose_level("avx9", "x86-64-v4", four)
    with pytest.raises(InvalidArgumentError, match="no build for x86-64-v3"):
        _builds.choose_level("x86-64-v3", "x86-64-v4", ["baseline", "x86-64-v4"])
    # one build (a source install): its own level only
    assert _builds.choose_level(None, "x86-64-v4", ["x86-64-v4"], single_build="x86-64-v4") == "x86-64-v4"
    assert _builds.choose_level("v4", "x86-64-v4", ["x86-64-v4"], single_build="x86-64-v4") == "x86-64-v4"
    with pytest.raises(InvalidArgumentError, match="single build of the extension, compiled for x86-64-v4"):
        _builds.choose_level("baseline", "x86-64-v4", ["x86-64-v4"], single_build="x86-64-v4")


def test_loaded_build_is_the_best_the_cpu_supports():
    info = ferrobot.simd_info()
    cpu, built = ferrobot._core._simd_support()
    assert info["cpu"] == cpu
    forced = info["forced"]
    assert os.environ.get("FERROBOT_SIMD") == (None if forced is None else _builds.canonical_level(str(forced)))
    assert sys.modules["ferrobot._core"] is ferrobot._core
    assert Path(info["path"]) == Path(ferrobot._core.__file__)
    assert ferrobot.simd_level() == built  # the module loaded is compiled for the level the loader reports
    if info["forced"] is None:
        wheel_dir = Path(ferrobot.__file__).parent / _builds.SIMD_DIR
        if wheel_dir.is_dir():  # a per-level wheel: every x86-64 level present, the best one the CPU has chosen
            assert info["builds"] == list(LEVELS)
            assert ferrobot.simd_level() == cpu
        else:  # a source install: its one build
            assert info["builds"] == [built]


def test_every_build_gives_identical_answers():
    default = _run(None)
    builds = default["info"]["builds"]
    cpu = default["info"]["cpu"]
    runnable = [b for b in builds if LEVELS.index(b) <= LEVELS.index(cpu)]
    assert default["level"] in runnable
    assert 0 < sum(default["flags"]) < len(default["flags"])  # the batch has colliding and free configurations
    files = set()
    for level in runnable:
        r = _run(level)
        assert r["level"] == level and r["built"] == level, (level, r["level"], r["built"])
        assert r["info"]["forced"] == level
        files.add(r["file"])
        assert r["flags"] == default["flags"], level
        assert r["dist"] == default["dist"], level  # bit for bit
        assert r["fk"] == default["fk"], level
    assert len(files) == len(runnable)  # each level is its own file


def test_forcing_a_level_this_install_or_cpu_cannot_run_fails_the_import():
    assert "ferrobot.errors.InvalidArgumentError: FERROBOT_SIMD='sse9'" in _fail("sse9")
    info = ferrobot.simd_info()
    cpu = info["cpu"]
    above = [lv for lv in LEVELS if LEVELS.index(lv) > LEVELS.index(cpu)]
    if above:  # not on an AVX-512 CPU: forcing AVX-512 must fail
        assert f"this CPU does not support {above[-1]}" in _fail(above[-1])
    else:  # the rule for CPUs below x86-64-v4 is checked in test_choice_rules_for_other_cpus
        assert cpu == "x86-64-v4"
    if len(info["builds"]) == 1 and info["builds"][0] != "baseline":  # a source install: only its own level
        assert "single build of the extension" in _fail("baseline")
