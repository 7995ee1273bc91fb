"""Residual statistics of the audit: RMSE, bias and a correlation that means something."""

import numpy as np
import pandas as pd
import pytest

from terrain.audit.core import CONSTANT_SPREAD_TOL, residual_statistics


def _table(measured, replay):
    n = len(measured)
    return pd.DataFrame({"run_id": ["r1"] * n, "terrain": ["SNOW"] * n,
                         "manoeuvre": ["spin"] * n, "signal": ["ax"] * n,
                         "measured": measured, "replay": replay})


def test_a_replay_constant_up_to_float_noise_has_no_correlation():
    # a spin in place: the replayed body acceleration is zero up to 1e-19 of integrator noise;
    # two noise draws of that size must not give two different correlations
    rng = np.random.default_rng(0)
    measured = rng.normal(0.0, 0.4, 300)
    out = []
    for seed in (1, 2):
        noise = np.random.default_rng(seed).normal(0.0, 1e-19, 300)
        stats = residual_statistics(_table(measured, noise), "SNOW")
        out.append(stats)
        assert stats["corr"].isna().all()
    # RMSE and bias are unaffected by the noise
    assert out[0]["rmse"].iloc[0] == pytest.approx(np.sqrt(np.mean(measured ** 2)))
    assert out[0]["bias"].iloc[0] == pytest.approx(np.mean(measured))


def test_a_replay_that_varies_keeps_its_pearson_correlation():
    rng = np.random.default_rng(3)
    replay = rng.normal(0.0, 0.3, 200)
    measured = 0.8 * replay + rng.normal(0.0, 0.1, 200)
    stats = residual_statistics(_table(measured, replay), "SNOW")
    expected = np.corrcoef(measured, replay)[0, 1]
    assert len(stats) == 3  # pooled, per run, per manoeuvre
    assert np.allclose(stats["corr"], expected)
    assert expected > 0.9


def test_the_tolerance_lies_far_below_sensor_resolution():
    # a replay varying by a micro-unit (1e-6 m/s^2, far below an IMU's 1e-3) still counts
    rng = np.random.default_rng(4)
    replay = 1e-6 * rng.normal(size=100)
    measured = replay * 1e5 + rng.normal(0.0, 0.01, 100)
    stats = residual_statistics(_table(measured, replay), "SNOW")
    assert CONSTANT_SPREAD_TOL < 1e-6
    assert stats["corr"].notna().all()
