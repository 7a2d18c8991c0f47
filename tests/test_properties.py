"""Property-based tests (hypothesis) over the public API, issue 15.

For random shapes, memory layouts (C, Fortran, transposed view, strided slice, negative strides),
dtypes (float64, float32, int64) and values, every call answers exactly what the C-ordered float64
call answers, or raises a ``ferrobot.errors`` exception (never anything else, never a crash). The
reference is the same call on ``np.ascontiguousarray(x, dtype=np.float64)``: numpy's own
conversion, independent of ferrobot's array reader. Crash-prone cases (the simulator under extreme
values) run in a subprocess. Examples are bounded and derandomised for CI.
"""

from __future__ import annotations

import subprocess
import sys
import textwrap

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import ferrobot
from ferrobot import errors, transforms

SETTINGS = settings(
    max_examples=25,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)

PANDA = ferrobot.robots.panda()
N = PANDA.num_dof
LO = PANDA.lower_limits
HI = PANDA.upper_limits

LAYOUTS = ("C", "F", "transposed", "strided", "reversed")
DTYPES = ("float64", "float32", "int64")


def in_layout(a: np.ndarray, layout: str) -> np.ndarray:
    """The same logical values as `a` in another memory layout."""
    if layout == "F":
        return np.asfortranarray(a)
    if layout == "transposed":
        return np.ascontiguousarray(a.T).T
    if layout == "strided":
        big = np.zeros((a.shape[0] * 3,) + a.shape[1:], dtype=a.dtype)
        big[::3] = a
        return big[::3]
    if layout == "reversed":
        return np.ascontiguousarray(a[::-1])[::-1]
    return np.ascontiguousarray(a)


def exact_in(a: np.ndarray, dtype: str) -> np.ndarray:
    """`a` rounded so that it is exactly representable in `dtype`, stored as `dtype`."""
    if dtype == "float32":
        return a.astype(np.float32)
    if dtype == "int64":
        return np.round(a).astype(np.int64)
    return a.astype(np.float64)


@st.composite
def variants(draw, base: np.ndarray):
    """(the array in some dtype and layout, its C-ordered float64 reference)."""
    dtype = draw(st.sampled_from(DTYPES))
    layout = draw(st.sampled_from(LAYOUTS))
    typed = exact_in(base, dtype)
    return in_layout(typed, layout), np.ascontiguousarray(typed, dtype=np.float64)


@st.composite
def configs(draw, rows: int | None = None):
    n = rows if rows is not None else draw(st.integers(1, 12))
    seed = draw(st.integers(0, 2**32 - 1))
    q = np.random.default_rng(seed).uniform(LO, HI, (n, N))
    return draw(variants(q))


def same_or_ferrobot_error(f, x, ref):
    """f(x) equals f(ref) exactly, or both raise the same ferrobot error."""
    try:
        want = f(ref)
    except errors.FerrobotError as e:
        with pytest.raises(type(e)):
            f(x)
        return
    got = f(x)
    if isinstance(want, dict):
        for k in want:
            np.testing.assert_array_equal(np.asarray(got[k]), np.asarray(want[k]), err_msg=k)
    else:
        np.testing.assert_array_equal(np.asarray(got), np.asarray(want))


WORLD = ferrobot.CollisionWorld()
WORLD.add_box("table", [0.8, 1.2, 0.05], [0.55, 0.0, 0.0, 1, 0, 0, 0])
WORLD.add_sphere("ball", 0.12, [0.45, 0.2, 0.5, 1, 0, 0, 0])
CHECKER = ferrobot.CollisionChecker(PANDA, WORLD)
PLANNER = ferrobot.Planner(PANDA, WORLD)


@SETTINGS
@given(configs())
def test_fk_fk_batch_jacobian(v):
    x, ref = v
    same_or_ferrobot_error(PANDA.fk_batch, x, ref)
    same_or_ferrobot_error(lambda a: PANDA.fk(a[0]), x, ref)
    same_or_ferrobot_error(lambda a: PANDA.jacobian(a[0]), x, ref)
    same_or_ferrobot_error(lambda a: PANDA.fk_all(a[0]), x, ref)


@SETTINGS
@given(configs())
def test_collision_queries(v):
    x, ref = v
    same_or_ferrobot_error(CHECKER.in_collision_batch, x, ref)
    same_or_ferrobot_error(lambda a: CHECKER.in_collision(a[0]), x, ref)
    same_or_ferrobot_error(lambda a: CHECKER.motion_valid(a[0], a[-1], 0.01), x, ref)
    same_or_ferrobot_error(lambda a: CHECKER.distance(a[0]).to_dict(), x, ref)


@SETTINGS
@given(st.integers(1, 40), st.integers(0, 2**32 - 1), st.data())
def test_signed_distance(n, seed, data):
    pts = np.random.default_rng(seed).uniform(-1.5, 1.5, (n, 3))
    x, ref = data.draw(variants(pts))
    same_or_ferrobot_error(WORLD.signed_distance, x, ref)


@SETTINGS
@given(st.floats(-np.pi, np.pi), st.floats(-np.pi, np.pi), st.floats(-np.pi, np.pi), st.data())
def test_world_object_poses(a, b, c, data):
    from scipy.spatial.transform import Rotation

    t = np.eye(4)
    t[:3, :3] = Rotation.from_euler("xyz", [a, b, c]).as_matrix()
    t[:3, 3] = [0.3, -0.2, 0.5]
    layout = data.draw(st.sampled_from(LAYOUTS))
    w = ferrobot.CollisionWorld()
    w.add_box("b", [0.1, 0.2, 0.3], in_layout(t, layout))
    np.testing.assert_allclose(w.get_pose("b"), t, atol=1e-12)


@SETTINGS
@given(st.lists(st.floats(allow_nan=True, allow_infinity=True, width=64), min_size=N, max_size=N))
def test_hostile_values_give_answers_or_ferrobot_errors(values):
    q = np.array(values)
    for f in (PANDA.fk, CHECKER.in_collision, lambda a: CHECKER.motion_valid(a, a, 0.01)):
        try:
            f(q)
        except errors.FerrobotError:
            pass
    with pytest.raises(errors.FerrobotError) if not np.all(np.isfinite(q)) else _nothing():
        PANDA.fk(q)


class _nothing:
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


@SETTINGS
@given(st.floats(allow_nan=True, allow_infinity=True), st.floats(allow_nan=True, allow_infinity=True))
def test_numeric_options_are_bounded(resolution, dt):
    q0 = PANDA.named_state("ready")
    try:
        CHECKER.motion_valid(q0, q0 + 0.1, resolution)
    except errors.InvalidArgumentError:
        assert not (1e-6 <= resolution <= 1.0)
    else:
        assert 1e-6 <= resolution <= 1.0


@SETTINGS
@given(st.integers(0, 2**32 - 1), st.data())
def test_ik_and_plan_inputs(seed, data):
    rng = np.random.default_rng(seed)
    q = rng.uniform(LO, HI)
    pose = PANDA.fk(q)
    x, ref = data.draw(variants(pose))
    # (float32 or integer poses are rarely rotations any more: both raise then.)
    same_or_ferrobot_error(lambda a: PLANNER.ik(a, num_seeds=4, seed=1).q, x, ref)
    start = PANDA.named_state("ready")
    pair = np.stack([start, start + 0.05])
    xs, refs = data.draw(variants(pair))
    try:
        a = PLANNER.plan(refs[0], goal_q=refs[1], seed=2)
    except errors.FerrobotError as e:
        with pytest.raises(type(e)):
            PLANNER.plan(xs[0], goal_q=xs[1], seed=2)
        return
    b = PLANNER.plan(xs[0], goal_q=xs[1], seed=2)
    assert a.status == b.status
    np.testing.assert_array_equal(a.path, b.path)


@SETTINGS
@given(st.integers(2, 12), st.integers(2, 12), st.integers(0, 2**32 - 1), st.data())
def test_camera_back_projection(h, w, seed, data):
    rng = np.random.default_rng(seed)
    depth = rng.uniform(0.2, 3.0, (h, w))
    depth[rng.random((h, w)) < 0.2] = 0.0
    x, ref = data.draw(variants(depth))
    f = lambda d: ferrobot._core.depth_to_points(d, 50.0, 50.0, w / 2, h / 2)  # noqa: E731
    got, want = f(x), f(ref)
    np.testing.assert_array_equal(got[0], want[0])
    np.testing.assert_array_equal(got[1], want[1])


@SETTINGS
@given(st.lists(st.floats(allow_nan=True, allow_infinity=True), min_size=9, max_size=9))
def test_transforms_matrix_to_quat(values):
    m = np.array(values).reshape(3, 3)
    try:
        q = transforms.matrix_to_quat(m)
    except errors.FerrobotError:
        return
    # Accepted: a rotation within the documented tolerance, and the quaternion maps back to it.
    np.testing.assert_allclose(transforms.quat_to_matrix(q), m, atol=1e-5)


def test_sim_setters_under_layouts_and_extreme_values_in_a_subprocess():
    code = textwrap.dedent(
        """
        import numpy as np, ferrobot
        from ferrobot import errors
        from hypothesis import given, settings, strategies as st
        p = ferrobot.robots.panda()
        n = p.num_dof
        w = ferrobot.World()
        robot = w.add_robot(p, q=p.named_state("ready"))
        w.mark_initial_state()

        floats = st.floats(allow_nan=True, allow_infinity=True)

        @settings(max_examples=60, deadline=None, derandomize=True)
        @given(st.lists(floats, min_size=n, max_size=n), st.sampled_from(["C", "F", "strided"]),
               st.sampled_from(["efforts", "velocities", "positions", "targets", "gains"]))
        def run(values, layout, what):
            a = np.array(values)
            if layout == "F":
                a = np.asfortranarray(a[None, :])[0]
            elif layout == "strided":
                big = np.zeros(2 * n); big[::2] = a; a = big[::2]
            setter = {
                "efforts": robot.set_joint_efforts,
                "velocities": robot.set_joint_velocities,
                "positions": robot.set_joint_positions,
                "targets": robot.set_joint_position_targets,
                "gains": lambda v: robot.set_drive_gains(np.abs(v), np.abs(v)),
            }[what]
            try:
                setter(a)
                w.step(2)
            except errors.FerrobotError:
                pass
            w.reset()
            assert np.all(np.isfinite(robot.joint_positions))

        run()
        print("ok")
        """
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr[-3000:]
    assert r.stdout.strip().endswith("ok"), r.stdout + r.stderr
