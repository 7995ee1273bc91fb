"""Boundaries of the lag search (terrain.audit.timing), review aud23: the lag grid's ends and
zero, windows' edges and the last sample of a run."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.audit.replay import LOWPASS_MIN_SAMPLES, lowpass
from terrain.audit.timing import (LagSettings, LagTrack, best_lag, estimate_lag_track,
                                  lag_grid)

DT_S = 0.02


def _commanded(seed: int = 0, duration_s: float = 40.0):
    """A smooth random commanded yaw rate on a 50 Hz clock: (t_s, x)."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, duration_s, DT_S)
    x = 3.0 * np.convolve(rng.normal(size=t.size), np.ones(25) / 25, "same")
    return t, x


@pytest.mark.parametrize("max_lag_s, lag_step_s", [(1.0, 0.3), (1.0, 0.4), (0.5, 0.15)])
@pytest.mark.parametrize("k", [-2, -1, 0, 1, 2])
def test_a_lag_on_a_whole_number_of_steps_is_found_when_the_step_does_not_divide_the_range(
        max_lag_s, lag_step_s, k):
    """The grid is symmetric about 0 and holds every whole step inside [-max_lag_s,
    max_lag_s]: it was built from -max_lag_s upward, so with a step that does not divide the
    range 0 was not on it (max 1.0, step 0.3: ..., -0.1, 0.2, ...; an unlagged gyro came out
    -0.042 s) and a wheel stream 0.1 s early (-0.1 on the grid) and 0.1 s late (off it) were
    found as -0.0996 and +0.143 s."""
    t, x = _commanded()
    lag = k * lag_step_s
    wz = np.interp(t + lag, t, x)                 # x(t) = wz(t - lag): wheel data late by lag
    found, r2, slope = best_lag(t, x, t, wz,
                                LagSettings(max_lag_s=max_lag_s, lag_step_s=lag_step_s,
                                            window_s=60.0, step_s=30.0))
    assert found == pytest.approx(lag, abs=0.02 * lag_step_s)
    assert r2 > 0.99 and slope > 0


@pytest.mark.parametrize("max_lag_s, lag_step_s", [(2.0, 0.02), (1.0, 0.3), (1.0, 0.4),
                                                   (0.3, 0.1), (0.5, 0.15), (2.0, 1.5)])
def test_lag_grid_is_symmetric_about_zero_and_inside_the_range(max_lag_s, lag_step_s):
    """Whole steps -n..n (0 on the grid, both ends inside [-max_lag_s, max_lag_s], the last
    step within one step of max_lag_s); a step that divides the range keeps the grid built
    before, bit for bit (the documented audit reports use 2.0 s in 0.02 s steps)."""
    grid = lag_grid(LagSettings(max_lag_s=max_lag_s, lag_step_s=lag_step_s))
    n = len(grid) // 2
    assert len(grid) == 2 * n + 1 and abs(grid[n]) < 1e-12
    np.testing.assert_allclose(grid, -grid[::-1], atol=1e-12)
    np.testing.assert_allclose(np.diff(grid), lag_step_s, rtol=1e-9)
    assert grid[-1] <= max_lag_s + 1e-9 and grid[-1] > max_lag_s - lag_step_s
    if max_lag_s == 2.0 and lag_step_s == 0.02:
        assert np.array_equal(grid, np.arange(-2.0, 2.0 + 1e-9, 0.02))


@pytest.mark.parametrize("window_s, step_s, moving_from_s", [
    (30.0, 30.0, 60.5), (30.0, 20.0, 60.5), (20.0, 15.0, 65.5)])
def test_the_last_samples_of_a_run_are_in_a_window_whatever_the_hop(window_s, step_s,
                                                                    moving_from_s):
    """Every sample is in a window: with a hop longer than half a window the window that
    would cover a run's tail (centre past the last sample) was dropped, so a run of 70 s in
    30 s windows every 30 s examined [0, 30] and [30, 60] only, and a lag whose only
    excitation lies in the last 10 s was not identifiable (20 s every 15 s: 65-70 s in no
    window); the last window now ends on the last sample."""
    t, x = _commanded(duration_s=70.0)
    x = np.where(t >= moving_from_s, x, 0.0)      # the commands move at the end only
    lag = 0.1
    wz = np.interp(t + lag, t, x)
    track = estimate_lag_track(t, x, t, wz, LagSettings(
        max_lag_s=1.0, lag_step_s=0.02, window_s=window_s, step_s=step_s,
        min_excitation_rad_s=0.01))
    assert track.identifiable
    assert track.median_s == pytest.approx(lag, abs=0.005)


def test_default_windows_are_unchanged_and_already_reach_the_last_sample():
    """With the default hop (half a window) the windows already reached the last sample:
    70 s gives [0, 30], [15, 45], [30, 60], [45, 75] as before (4 windows)."""
    t, x = _commanded(duration_s=70.0)
    track = estimate_lag_track(t, x, t, x, LagSettings(max_lag_s=1.0))
    assert track.n_windows == 4


@pytest.mark.parametrize("n, usable", [(7, False), (8, True)])
def test_best_lag_needs_eight_samples_inside_the_imu_record_ends_included(n, usable):
    """8 wheel samples whose every candidate IMU time lies inside the IMU record give a lag,
    7 do not; a sample exactly max_lag_s from the IMU record's ends counts (the two outside,
    0.5 s from them, do not)."""
    t_imu = np.linspace(0.0, 20.0, 1001)
    t = np.r_[0.5, np.linspace(1.0, 19.0, n), 19.5]
    lag, r2, slope = best_lag(t, np.sin(t), t_imu, np.sin(t_imu),
                              LagSettings(max_lag_s=1.0, lag_step_s=0.1))
    assert np.isfinite(lag) == usable
    if usable:
        assert lag == pytest.approx(0.0, abs=0.01) and r2 > 0.99


def test_drift_is_reported_over_exactly_min_span_s_and_not_one_ulp_short():
    """Two windows exactly ``min_span_s`` apart span it (drift given); a span one ulp short
    of it gives NaN."""
    track = LagTrack(np.array([0.0, 45.0]), np.array([0.1, 0.4]), np.ones(2), 2)
    assert track.drift_s_per_min(45.0) == pytest.approx(0.4)
    assert np.isnan(track.drift_s_per_min(float(np.nextafter(45.0, 46.0))))


def test_lowpass_filters_from_exactly_its_minimum_sample_count():
    """LOWPASS_MIN_SAMPLES samples are filtered (scipy needs more than its 15-sample end
    padding), one fewer come back unchanged (the IMU count prepare_frame requires)."""
    for n, unchanged in ((LOWPASS_MIN_SAMPLES - 1, True), (LOWPASS_MIN_SAMPLES, False)):
        v = np.sin(0.7 * np.arange(n))
        assert np.array_equal(lowpass(v, 50.0, 2.0), v) == unchanged


@pytest.mark.parametrize("lag, identifiable", [(0.8, True), (-0.8, True), (0.84, True),
                                               (0.86, False), (0.9, False), (-0.9, False)])
def test_a_window_whose_lag_lies_within_one_and_a_half_steps_of_the_range_end_is_not_used(
        lag, identifiable):
    """max_lag_s 1.0 in 0.1 s steps: a lag of 0.8 or 0.84 s is used, one from 0.85 s on
    (the outermost grid point, or refined towards it) is at the edge of the search range
    and gives no usable window, on either side."""
    t, x = _commanded()
    track = estimate_lag_track(t, x, t, np.interp(t + lag, t, x),
                               LagSettings(max_lag_s=1.0, lag_step_s=0.1))
    assert track.identifiable == identifiable
    if identifiable:
        np.testing.assert_allclose(track.lags_s, lag, atol=0.012)


def test_windows_are_closed_a_sample_on_the_shared_edge_is_in_both():
    """Windows are closed at both ends (module docstring): with the hop equal to the window
    (60 s in 30 s windows) the sample at 30 s is in [0, 30] and in [30, 60], so the centres
    are 15 and 45 s (14.75 s for a window open at its end)."""
    t = np.arange(0.0, 60.0 + 0.25, 0.25)
    rng = np.random.default_rng(1)
    x = 3.0 * np.convolve(rng.normal(size=t.size), np.ones(9) / 9, "same")
    track = estimate_lag_track(t, x, t, x, LagSettings(max_lag_s=1.0, lag_step_s=0.25,
                                                       window_s=30.0, step_s=30.0))
    assert track.n_windows == 2
    np.testing.assert_array_equal(track.centres_s, [15.0, 45.0])
