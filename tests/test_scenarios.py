"""Fault scenarios (each passes its stated bounds), the noise models against
their stated statistics (confidence bounds from scipy), the arbitration rule,
the latency helpers, and argument validation."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from ferrobot import _core, scenarios
from ferrobot.errors import InvalidArgumentError, NonFiniteError, ShapeError, UnknownNameError


@pytest.mark.parametrize("name", ["payload_change", "stream_interruption", "sensor_noise", "conflicting_targets"])
def test_scenario_passes(name):
    res = getattr(scenarios, name)()
    assert res.passed, str(res)


def test_scenario_fails_a_tight_bound():
    # The bounds are real: an impossible one fails (and says which).
    res = scenarios.conflicting_targets(tolerance=1e-12)
    assert not res.passed and any("teleop_error" in f for f in res.failures)


def _ci_std(sample_std, n, sigma, alpha=1e-4):
    """True when sigma lies in the chi-square confidence interval of the sample std."""
    lo = np.sqrt((n - 1) * sample_std**2 / stats.chi2.ppf(1 - alpha / 2, n - 1))
    hi = np.sqrt((n - 1) * sample_std**2 / stats.chi2.ppf(alpha / 2, n - 1))
    return lo <= sigma <= hi


def test_depth_noise_statistics():
    noise = scenarios.DepthNoise(dropout=0.03, edge_dropout=0.6, seed=1)
    # Two flat regions at 0.8 m and 2.0 m (a step between them is the only discontinuity).
    depth = np.full((200, 300), 0.8)
    depth[:, 150:] = 2.0
    edges = noise.edges(depth)
    assert edges.sum() == 2 * 200 and edges[:, 149].all() and edges[:, 150].all()
    out, missing = noise.apply(depth)
    for z, cols in ((0.8, slice(0, 149)), (2.0, slice(151, 300))):
        keep = ~missing[:, cols]
        err = out[:, cols][keep] - z
        sigma = 0.0012 + 0.0019 * (z - 0.4) ** 2
        assert abs(err.mean()) <= 4 * sigma / np.sqrt(err.size)
        assert _ci_std(err.std(ddof=1), err.size, sigma)
    interior = ~edges
    k, n = int(missing[interior].sum()), int(interior.sum())
    ci = stats.binomtest(k, n).proportion_ci(confidence_level=0.9999)
    assert ci.low <= 0.03 <= ci.high
    k, n = int(missing[edges].sum()), int(edges.sum())
    ci = stats.binomtest(k, n).proportion_ci(confidence_level=0.9999)
    assert ci.low <= 0.03 + 0.97 * 0.6 <= ci.high
    assert np.all(out[missing] == 0.0)
    # No reading stays missing.
    d2 = depth.copy()
    d2[10, 10] = np.inf
    out2, miss2 = scenarios.DepthNoise(dropout=0.0, edge_dropout=0.0).apply(d2)
    assert miss2[10, 10] and out2[10, 10] == 0.0 and miss2.sum() == 1


def test_encoder_noise_statistics():
    enc = scenarios.EncoderNoise([1e-3, 2e-3], seed=3)
    samples = np.array([enc.apply([0.5, -1.0]) for _ in range(20000)])
    for j, sigma in enumerate((1e-3, 2e-3)):
        s = samples[:, j] - [0.5, -1.0][j]
        assert abs(s.mean()) <= 4 * sigma / np.sqrt(len(s))
        assert _ci_std(s.std(ddof=1), len(s), sigma)
    q = scenarios.EncoderNoise(0.0, resolution=0.01).apply([0.123])
    assert q[0] == pytest.approx(0.12)


def test_arbiter_priority_then_latest():
    arb = scenarios.Arbiter(3, timeout=0.1)
    arb.add_source("a", 0)
    arb.add_source("b", 1)
    arb.add_source("c", 0)
    arb.command("a", 0.0, [0, 1], [1.0, 1.0])
    arb.command("c", 0.01, [1, 2], [2.0, 2.0])
    arb.command("b", 0.0, [0], [3.0])
    v, w = arb.resolve(0.02)
    assert list(v) == [3.0, 2.0, 2.0] and w == ["b", "c", "c"]
    assert {c.joint for c in arb.conflicts} == {0, 1}
    v, w = arb.resolve(0.5)  # all stale
    assert np.all(np.isnan(v)) and w == [None] * 3
    with pytest.raises(UnknownNameError):
        arb.command("zz", 0.0, [0], [1.0])
    with pytest.raises(UnknownNameError):
        arb.command("a", 0.0, [5], [1.0])
    with pytest.raises(ShapeError):
        arb.command("a", 0.0, [0, 1], [1.0])
    with pytest.raises(InvalidArgumentError):
        arb.command("a", 0.0, [0], [np.nan])
    with pytest.raises(InvalidArgumentError):
        arb.add_source("a", 2)


def test_latency_helpers():
    buf = _core.CommandDelay(0.05, 2)
    buf.push(0.0, [1.0, 2.0])
    assert buf.pop_due(0.049) is None
    np.testing.assert_array_equal(buf.pop_due(0.05), [1.0, 2.0])
    pred = _core.LinearPredictor(0.1)
    pred.update(0.0, [0.0])
    np.testing.assert_allclose(pred.update(0.01, [0.01]), [0.11])  # 0.01 + slope 1 x 0.1 s
    traj = np.array([[0.0], [1.0], [2.0]])
    assert _core.trajectory_sample(traj, 0.1, 0.15)[0] == pytest.approx(1.5)
    assert _core.trajectory_sample(traj, 0.1, 9.0)[0] == 2.0
    g = _core.StreamGuard(0.05, [1.0])
    assert g.update(0.0, [0.0], [0.0]).step == 0.0
    assert g.update(0.2, None, [0.0]).holding
    out = g.update(0.21, [1.0], [0.0])
    assert out.command[0] == pytest.approx(0.01) and out.catching_up
    with pytest.raises(InvalidArgumentError, match="delay"):
        _core.CommandDelay(-0.1, 2)
    with pytest.raises(ShapeError):
        buf.push(0.1, [1.0])
    with pytest.raises(InvalidArgumentError, match="order"):
        buf.push(-1.0, [1.0, 2.0])
    with pytest.raises(NonFiniteError):
        buf.push(np.nan, [1.0, 2.0])
    with pytest.raises(InvalidArgumentError, match="max_velocity"):
        _core.StreamGuard(0.05, [0.0])
    with pytest.raises(InvalidArgumentError, match="timeout"):
        _core.StreamGuard(0.0, [1.0])
    with pytest.raises(InvalidArgumentError, match="increase"):
        pred.update(0.0, [0.0])


def test_noise_model_validation():
    with pytest.raises(InvalidArgumentError, match="dropout"):
        scenarios.DepthNoise(dropout=1.5)
    with pytest.raises(InvalidArgumentError, match="sigma0"):
        scenarios.DepthNoise(sigma0=-1)
    with pytest.raises(ShapeError, match="depth"):
        scenarios.DepthNoise().apply(np.zeros(5))
    with pytest.raises(InvalidArgumentError, match="sigma"):
        scenarios.EncoderNoise(-1.0)
