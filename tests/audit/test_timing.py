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


def test_the_parabola_refines_a_lag_between_grid_points():
    # on a 0.1 s grid, lags of 0.33 s and 0.37 s lie between the points 0.3 and 0.4: the
    # parabola through the best three R^2 values brings the estimate within 0.01 s of
    # them (the grid point alone is 0.03 s off)
    for lag in (0.33, 0.37):
        t_w, x, t_imu, wz = _signals(lambda t: np.full_like(t, lag))
        m = t_w < 60.0
        found = best_lag(t_w[m], x[m], t_imu, wz, LagSettings(lag_step_s=0.1))[0]
        assert found == pytest.approx(lag, abs=0.01)


def test_samples_whose_imu_time_leaves_the_record_are_not_used():
    # a wheel sample whose IMU time t - lag falls outside the IMU record for some candidate
    # lag would read the record's end value held: such samples are left out, so the result
    # is exactly that of the stretch trimmed to the samples inside for every lag
    t_w, x, t_imu, wz = _signals(lambda t: np.full_like(t, 0.4))
    s = LagSettings()
    m = (t_w > 5.0) & (t_w < 35.0)
    keep = (t_imu > 8.0) & (t_imu < 30.0)
    ti, wi = t_imu[keep], wz[keep]
    inside = (t_w[m] - s.max_lag_s >= ti[0]) & (t_w[m] + s.max_lag_s <= ti[-1])
    assert 0 < inside.sum() < m.sum()
    full = best_lag(t_w[m], x[m], ti, wi, s)
    assert full == best_lag(t_w[m][inside], x[m][inside], ti, wi, s)
    assert full[0] == pytest.approx(0.4, abs=0.03)


def test_windows_need_excitation_and_a_fit_that_explains_the_gyro():
    t_w, x, t_imu, wz = _signals(lambda t: np.full_like(t, 0.3))
    assert estimate_lag_track(t_w, x, t_imu, wz).identifiable
    # the same clean turns, scaled down to a commanded std of 0.03 rad/s (below 0.05)
    k = 0.03 / np.std(x)
    assert not estimate_lag_track(t_w, k * x, t_imu, k * wz).identifiable
    # a gyro so noisy that no lag explains half its variance (R^2 < min_r2 = 0.5)
    noisy = wz + 0.5 * np.random.default_rng(5).standard_normal(wz.size)
    assert best_lag(t_w[:200], x[:200], t_imu, noisy)[1] < 0.5
    assert not estimate_lag_track(t_w, x, t_imu, noisy).identifiable


def test_the_replayed_yaw_rate_sets_the_lag_where_it_explains_the_gyro_better():
    # the robot follows the commands with a 1 s first-order response; the wheel stream is
    # 0.3 s late. Against the command the best shift mixes the response time into the lag
    # (the gyro's delay reads as an early wheel stream: about -0.37 s); the replayed yaw
    # rate, which includes the response, explains the gyro exactly at the true 0.3 s and
    # wins every window
    t_w, x_now, t_imu, _ = _signals(lambda t: np.zeros_like(t))
    lag = 0.3
    x_imu = np.interp(t_imu, t_w, x_now)
    slow = np.empty_like(x_imu)
    slow[0] = x_imu[0]
    a = 0.01 / 1.0
    for k in range(1, slow.size):
        slow[k] = slow[k - 1] + a * (x_imu[k] - slow[k - 1])
    gyro = slow / 1.5
    x = np.interp(t_w - lag, t_imu, x_imu)
    replayed = np.interp(t_w - lag, t_imu, slow)
    track = estimate_lag_track(t_w, x, t_imu, gyro, alternative=replayed)
    assert track.identifiable and np.allclose(track.lags_s, lag, atol=0.01)
    assert np.all(track.r2 > 0.999)
    command_only = estimate_lag_track(t_w, x, t_imu, gyro)
    assert np.all(command_only.lags_s < lag - 0.5)


def test_track_summary_and_median_of_a_known_track():
    from terrain.audit.timing import LagTrack
    c = np.array([15.0, 30.0, 45.0, 60.0])
    track = LagTrack(c, np.array([0.1, 0.2, 0.25, 1.0]), np.ones(4), 5)
    assert track.median_s == pytest.approx(0.225)             # the median, not the mean 0.39
    s = track.summary()
    assert (s["lag_s"], s["lag_start_s"], s["lag_end_s"]) == (0.225, 0.1, 1.0)
    assert (s["lag_min_s"], s["lag_max_s"]) == (0.1, 1.0)
    assert (s["n_windows_used"], s["n_windows"], s["identifiable"]) == (4, 5, True)
    # between centres the lag is interpolated, beyond them held
    np.testing.assert_allclose(track.at(np.array([0.0, 22.5, 70.0])), [0.1, 0.15, 1.0])


def test_every_window_examined_spans_at_least_half_its_length():
    # 100 s at window = step = 30 s: windows start at 0, 30 and 60; one starting at 90 s
    # would hold 10 s of data only, and is not examined; the last 10 s are in a full window
    # ending on the last sample instead, [70, 100] (aud23: they were in none)
    t_w, x, t_imu, wz = _signals(lambda t: np.full_like(t, 0.2), duration_s=100.0)
    track = estimate_lag_track(t_w, x, t_imu, wz, LagSettings(window_s=30.0, step_s=30.0))
    assert track.n_windows == 4


@pytest.mark.parametrize("kwargs", [dict(lag_step_s=2.0), dict(lag_step_s=0.0),
                                    dict(step_s=31.0), dict(step_s=0.0)])
def test_lag_settings_refuse_a_step_outside_its_range(kwargs):
    from terrain.errors import ConfigError
    with pytest.raises(ConfigError):
        LagSettings(**kwargs)


@pytest.mark.parametrize("kwargs, field", [
    (dict(min_r2=float("nan")), "min_r2"),                   # no window's R^2 passed
    (dict(min_excitation_rad_s=float("nan")), "min_excitation_rad_s"),   # every window did
    (dict(min_r2=-0.1), "min_r2"), (dict(min_r2=1.5), "min_r2"),
    (dict(max_lag_s=float("inf")), "max_lag_s"), (dict(window_s=float("inf")), "window_s"),
    (dict(min_r2="0.5"), "min_r2")])
def test_lag_settings_refuse_thresholds_that_are_not_finite_numbers_in_range(kwargs, field):
    from terrain.errors import ConfigError
    with pytest.raises(ConfigError, match=rf"LagSettings\.{field} must be"):
        LagSettings(**kwargs)
    LagSettings(min_r2=0.0, min_excitation_rad_s=0.0)      # both limits off: valid
