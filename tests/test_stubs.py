"""The stubs of the extension module (``python/ferrobot/_core.pyi``) cannot drift from it (issue 16):
``mypy.stubtest`` compares every class, function, signature and property of ``ferrobot._core`` at run time
with the stubs. ``tests/stubtest_allowlist.txt`` lists only what stubtest cannot express (each entry says
why)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("mypy")

HERE = Path(__file__).parent


def test_core_stubs_match_the_extension_module():
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "mypy.stubtest",
            "ferrobot._core",
            "--allowlist",
            str(HERE / "stubtest_allowlist.txt"),
            "--mypy-config-file",
            str(HERE / "stubtest_mypy.ini"),
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stdout[-8000:] + proc.stderr[-2000:]
