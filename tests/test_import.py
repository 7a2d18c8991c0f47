"""The extension coexists with other native libraries imported after it.

The extension's allocator (mimalloc) must not take the static TLS space that libraries loaded
later need: built with the initial-exec TLS model it made ``import pinocchio`` (whose libgomp
needs static TLS) fail with "cannot allocate memory in static TLS block" after ``import ferrobot``.
"""

import subprocess
import sys


def test_native_libraries_import_after_ferrobot():
    code = "import ferrobot, pinocchio, scipy.spatial, pybullet, mujoco; print('ok')"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip().endswith("ok")
