"""Clock-offset estimation (``wheel_lag``) on synthetic signals with a known lag."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.audit.timing import LagSettings, best_lag, estimate_lag_track


def _signals(lag_of_t, duration_s=120.0, chi=1.5, bias=0.0, seed=0, constant=False):
    """Wheel stamps (6.5 Hz) with x(t - lag(t)) and a 100 Hz gyro seeing x(t) / chi + bias."""
    rng = np.random.default_rng(seed)
    knots = np.cumsum(rng.uniform(2.0, 6.0, 60))
    levels = np.where(rng.random(60) < 0.6, rng.uniform(-0.6, 0.6, 60), 0.0)

    # piecewise-constant commands with 0.3 s ramps (a rate-limited joystick)
    tk = np.r_[0.0, np.ravel(np.column_stack([knots, knots + 0.3]))]
    vk = np.r_[0.0, np.ravel(np.column_stack([np.r_[0.0, levels[:-1]], levels]))]
    if constant:
        vk[:] = 0.4

    def x_true(t):
        return np.interp(t, tk, vk)
    t_imu = np.arange(0.0, duration_s, 0.01)
    wz = x_true(t_imu) / chi + bias + 0.01 * rng.standard_normal(t_imu.size)
    t_w = np.arange(0.0, duration_s, 1.0 / 6.5)
    x = x_true(t_w - lag_of_t(t_w))                  # wheel sample stamped t shows t - lag
    return t_w, x, t_imu, wz


@pytest.mark.parametrize("lag", [0.5, -0.7, 0.0])
def test_constant_lag_recovered(lag):
    t_w, x, t_imu, wz = _signals(lambda t: np.full_like(t, lag))
    track = estimate_lag_track(t_w, x, t_imu, wz)
    assert track.identifiable and len(track.lags_s) >= 5
    assert track.median_s == pytest.approx(lag, abs=0.05)
    assert np.all(np.abs(track.lags_s - lag) < 0.1)


def test_lag_does_not_depend_on_chi_or_bias():
    lag = 0.3
    for chi, bias in ((1.0, 0.0), (3.0, 0.05)):
        t_w, x, t_imu, wz = _signals(lambda t: np.full_like(t, lag), chi=chi, bias=bias)
        assert best_lag(t_w, x, t_imu, wz)[0] == pytest.approx(lag, abs=0.04)


def test_drifting_lag_is_followed():
    def drift(t):
        return 0.2 + 0.8 * t / 120.0                 # 0.2 s -> 1.0 s over the run
    t_w, x, t_imu, wz = _signals(drift, seed=3)
    track = estimate_lag_track(t_w, x, t_imu, wz)
    assert np.allclose(track.lags_s, drift(track.centres_s), atol=0.12)
    assert track.drift_s_per_min() == pytest.approx(0.4, abs=0.12)
    assert track.at(np.array([0.0]))[0] == pytest.approx(track.lags_s[0])


def test_constant_command_has_no_identifiable_lag():
    t_w, x, t_imu, wz = _signals(lambda t: np.full_like(t, 0.4), constant=True)
    track = estimate_lag_track(t_w, x, t_imu, wz)
    assert not track.identifiable
    assert np.isnan(track.median_s)
    assert np.all(track.at(t_w) == 0.0)
    assert track.summary()["identifiable"] is False


def test_lag_beyond_search_range_is_not_reported():
    t_w, x, t_imu, wz = _signals(lambda t: np.full_like(t, 2.5))
    track = estimate_lag_track(t_w, x, t_imu, wz, LagSettings(max_lag_s=1.0))
    assert not np.any(np.abs(track.lags_s) >= 0.95)


def test_an_inverted_gyro_is_no_match_and_drift_is_per_minute():
    from terrain.audit.timing import LagTrack
    t_w, x, t_imu, wz = _signals(lambda t: np.full_like(t, 0.3))
    m = t_w < 40.0
    lag, r2, slope = best_lag(t_w[m], x[m], t_imu, wz)
    assert lag == pytest.approx(0.3, abs=0.05) and r2 > 0.9 and slope > 0
    # the same gyro mounted upside down: no lag explains it with a positive slope
    lag, r2, slope = best_lag(t_w[m], x[m], t_imu, -wz)
    assert r2 == 0.0
    # a lag growing by 0.01 s every second drifts 0.6 s per minute
    c = np.arange(0.0, 61.0, 15.0)
    track = LagTrack(c, 0.1 + 0.01 * c, np.ones(c.size), c.size)
    assert track.drift_s_per_min() == pytest.approx(0.6)
    assert track.summary()["drift_s_per_min"] == pytest.approx(0.6)
    assert np.isnan(LagTrack(c[:3], c[:3], np.ones(3), 3).drift_s_per_min())   # 30 s span
