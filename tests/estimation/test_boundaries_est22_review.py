"""Boundary review (est22): values exactly at the thresholds, limits and edges of the
estimation package."""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from terrain.estimation.observer import eta_from_truth


@settings(max_examples=60, deadline=None)
@given(v=st.floats(-2.0, 2.0), w=st.floats(-1.0, 1.0), other=st.floats(0.05, 2.0))
def test_eta_from_truth_is_undefined_at_a_zero_rim_speed_even_with_no_speed_floor(v, w, other):
    # min_speed_m_s = 0 is allowed (>= 0): a rim speed of 0 is not below it, but eta = g / 0
    # is no efficiency (it was inf, or NaN for 0 / 0)
    eta = eta_from_truth(np.array([v, v]), np.array([w, w]), np.array([0.0, other]),
                         np.array([other, -0.0]), 0.25, min_speed_m_s=0.0)
    assert np.isnan(eta[0, 0]) and np.isnan(eta[1, 1])
    assert np.isfinite(eta[0, 1]) and np.isfinite(eta[1, 0])


def test_eta_from_truth_speed_floor_is_inclusive_one_ulp_either_side():
    floor = 0.1
    rims = np.array([np.nextafter(floor, 0.0), floor, np.nextafter(floor, 1.0)])
    eta = eta_from_truth(np.full(3, 0.1), np.zeros(3), rims, -rims, 0.25,
                         min_speed_m_s=floor)
    assert np.isnan(eta[0]).all()                # below the floor: undefined
    assert np.isfinite(eta[1:]).all()            # at it and above: defined
    np.testing.assert_allclose(eta[1], [1.0, -1.0])


# -- the last sample of a run on a clock far from 0 -----------------------------------------

#: Clocks from 0 and since boot (17 min .. 12 days), whose unit in the last place is below the
#: placement rule's 1e-9 s; an epoch clock (1.7e9 s, 2.4e-7 s) is not (make_grid says so).
CLOCKS = (0.0, 1e3, 8.64e4, 1e6)
EPOCH_S = 1.7e9


@settings(max_examples=80, deadline=None)
@given(t0=st.sampled_from(CLOCKS), rate=st.sampled_from((6.5, 15.0, 50.0, 100.0, 200.0)),
       n=st.integers(2, 3000))
def test_a_grid_at_the_rate_read_off_a_stream_keeps_its_last_sample(t0, rate, n):
    # the default filter rate is 1 / median step of the stream's own clock, off by up to one
    # unit in the last place of its timestamps; a grid from it fell short of the last
    # sample (the grid one step short, or its last step a hair before the sample): the last
    # sample of the run was counted as outside
    from terrain.estimation.runner import make_grid, sample_steps, samples_inside
    t = t0 + np.arange(n) / rate
    if n * np.spacing(t[-1]) > 0.1 / rate:      # an epoch clock over a long run: out of reach
        return
    grid = make_grid(t[0], t[-1], 1.0 / np.median(np.diff(t)))
    assert grid.size == n
    assert grid[0] == t[0] and abs(grid[-1] - t[-1]) <= 1e-9    # (the placement rule's)
    assert samples_inside(grid, t).all()
    np.testing.assert_array_equal(sample_steps(grid, t), np.arange(n))


@settings(max_examples=40, deadline=None)
@given(rate=st.sampled_from((6.5, 15.0, 50.0, 100.0, 200.0)), n=st.integers(2, 1000))
def test_on_an_epoch_clock_the_grid_still_ends_on_the_last_sample(rate, n):
    from terrain.estimation.runner import make_grid, samples_inside
    t = EPOCH_S + np.arange(n) / rate
    grid = make_grid(t[0], t[-1], 1.0 / np.median(np.diff(t)))
    assert grid.size == n and grid[-1] == t[-1]
    assert samples_inside(grid, t).all()


@pytest.mark.parametrize("t0", CLOCKS + (EPOCH_S,))
def test_skid_steer_estimate_uses_the_last_gyro_and_wheel_samples_on_any_clock(t0):
    import pandas as pd
    from terrain.estimation.skid_steer import estimate_skid_steer
    from terrain.run import Run
    tw = t0 + np.arange(101) / 10.0
    ti = t0 + np.arange(1001) / 100.0
    run = Run("sim/TEST/05", "sim", "ASPHALT",
              {"wheels": pd.DataFrame({"t_s": tw, "vel_l": 0.5, "vel_r": 0.6}),
               "imu": pd.DataFrame({"t_s": ti, "wz": 0.2})})
    res = estimate_skid_steer(run)
    assert res.counts["gyro"]["outside"] == 0 and res.counts["wheels"]["outside"] == 0
    assert res.t_s.size == 1001 and abs(res.t_s[-1] - ti[-1]) <= 1e-9
    if t0 != EPOCH_S:     # (on an epoch clock samples round off their steps: make_grid)
        assert res.counts["gyro"]["used"] == 1001 and res.counts["wheels"]["used"] == 101


def test_the_shipped_wheel_only_run_keeps_its_last_wheel_sample():
    # BorealTC ICE/01 has no IMU: its 6.5 Hz wheel clock (9358 samples over 1439.5 s) sets the
    # grid, whose rate 1 / median step (6.499999999998522 Hz) made it 9357 steps long: the
    # run's last wheel sample was outside the grid
    from pathlib import Path

    import pandas as pd
    from terrain.estimation.runner import make_grid, sample_steps, samples_inside
    path = Path(__file__).resolve().parents[2] / "data" / "borealtc" / "wheels.parquet"
    wheels = pd.read_parquet(path, columns=["run_id", "t_s"])
    t = wheels.loc[wheels["run_id"] == "borealtc/ICE/01", "t_s"].to_numpy(float)
    grid = make_grid(t[0], t[-1], 1.0 / np.median(np.diff(t)))
    assert grid.size == t.size == 9358
    assert samples_inside(grid, t).all()
    np.testing.assert_array_equal(sample_steps(grid, t), np.arange(t.size))


# -- the hold window of the speed bound: (t - hold_s, t] -------------------------------------

@pytest.mark.slow
@settings(max_examples=80, deadline=None)
@given(t0=st.sampled_from(CLOCKS), rate=st.sampled_from((15.0, 30.0, 50.0, 100.0, 1000.0 / 3)),
       k=st.integers(1, 12), j=st.integers(0, 40))
def test_a_rim_spike_widens_the_speed_bound_over_exactly_hold_s(t0, rate, k, j):
    # hold_s = k steps: the window (t - hold_s, t] of a step holds it and the k - 1 before
    # it; the step exactly hold_s back is outside it (at 30 Hz with hold_s = 0.1 s it was
    # taken on some steps, the rounding of the clock deciding: the spike held 3 or 4 steps)
    from terrain.estimation.runner import SensorSamples, make_grid
    from terrain.estimation.skid_steer_slip import speed_bounds_m_s
    grid = make_grid(t0, t0 + 3.0, rate)
    j = min(k + j, grid.size - k)      # the spike and its hold inside the grid
    rim = np.full((grid.size, 2), 0.2)
    rim[j] = 1.0
    lower, upper = speed_bounds_m_s(grid, SensorSamples(grid, rim), -0.5, 0.0, hold_s=k / rate)
    widened = np.flatnonzero(upper > upper[k:].min() + 1e-12)
    np.testing.assert_array_equal(widened[widened >= k], np.arange(j, j + k))


# -- a pseudo-measurement on the first grid step: a first segment of one step ---------------

def test_a_pseudo_slip_on_the_first_step_keeps_the_samples_before_the_grid_outside():
    # the grid's first step takes the samples of (t_0 - dt, t_0]; a slip window placed on
    # t_0 made run_with_pseudo_slip's first segment one step long, and a grid of one step
    # took the samples of the second before it: a wheel sample 0.2 s before a 100 Hz grid
    # was used (and one at -0.5 s superseded) where the whole run counts both as outside
    from terrain.estimation import SensorSamples, run_filter
    from terrain.estimation.skid_steer_slip import (SPEED_BOUND_MOVABLE, SkidSteerSlipModel,
                                                    SkidSteerSlipSettings, _speed_bounds,
                                                    run_with_pseudo_slip)
    grid = np.arange(301) * 0.01
    tw = np.r_[-0.5, -0.2, -0.004, np.arange(1, 300) * 0.01 + 0.003]
    wheels = SensorSamples(tw, np.column_stack([np.full(tw.size, 1.0), np.full(tw.size, 1.2)]))
    s = SkidSteerSlipSettings()
    tp = np.array([0.0, 1.0, 2.0])
    sp = np.column_stack([np.full(3, 0.1), np.full(3, 0.12)])
    seg = run_with_pseudo_slip(grid, {"wheels": wheels}, s, tp, sp, np.full(3, s.slip_std))
    whole = run_filter(SkidSteerSlipModel(s), grid,
                       {"wheels": wheels, "slip_model": SensorSamples(tp, sp)},
                       store_covariance=True, engine="numpy",
                       step_bounds=_speed_bounds(grid, wheels, s),
                       step_bound_movable=SPEED_BOUND_MOVABLE)
    assert seg.counts == whole.counts
    assert whole.counts["wheels"]["outside"] == 2 and whole.counts["wheels"]["used"] == 300
    np.testing.assert_allclose(seg.x, whole.x, rtol=0, atol=1e-12)
    np.testing.assert_allclose(seg.P, whole.P, rtol=0, atol=1e-12)


# -- the lag window of the autocorrelation time: lags 1 .. max_lag - 1 ----------------------

def test_the_autocorrelation_window_sums_lags_below_max_lag_and_one_sums_none():
    from terrain.estimation.consistency import (effective_sample_size,
                                                integrated_autocorrelation_time)
    x = np.repeat(np.random.default_rng(3).standard_normal(60), 5)    # correlated over 5
    n = x.size
    d = x - x.mean()
    acf = np.array([d[:n - k] @ d[k:] for k in range(n)]) / (d @ d)
    for max_lag in (1, 2, 3, 5):
        # every lag below 5 is above the 0.05 threshold: the sum is lags 1 .. max_lag - 1
        want = 1.0 + 2.0 * acf[1:max_lag].sum()
        assert float(integrated_autocorrelation_time(x, max_lag)) == pytest.approx(want)
    assert float(integrated_autocorrelation_time(x, 1)) == 1.0        # no lag: independent
    assert effective_sample_size(x, 1) == n
    # the window as long as the series: every lag, the same as any longer one
    assert float(integrated_autocorrelation_time(x, n)) == float(
        integrated_autocorrelation_time(x, 10 * n))


@pytest.mark.parametrize("max_lag", [2.5, 1.5, np.float64(3.7)])
def test_a_lag_window_that_is_not_a_whole_number_of_lags_is_refused_by_name(max_lag):
    from terrain.errors import ConfigError
    from terrain.estimation.consistency import (effective_sample_size,
                                                integrated_autocorrelation_time)
    x = np.random.default_rng(0).standard_normal(100)
    with pytest.raises(ConfigError, match="max_lag must be an integer"):
        integrated_autocorrelation_time(x, max_lag=max_lag)
    with pytest.raises(ConfigError, match="max_lag must be an integer"):
        effective_sample_size(x, max_lag=max_lag)


# -- robust_noise_std: the window in samples and a column exactly as long as it ---------------

@pytest.mark.parametrize("window_s, rate_hz, w", [
    (0.5, 100.0, 51), (0.5, 50.0, 25), (0.5, 6.5, 3), (0.01, 100.0, 3), (0.2, 30.0, 7),
    (1.0, 15.0, 15)])
def test_robust_noise_std_needs_as_many_finite_samples_as_its_odd_window(window_s, rate_hz, w):
    from terrain.estimation.prefilter import robust_noise_std
    x = np.random.default_rng(1).standard_normal(w)
    assert np.isfinite(robust_noise_std(x, rate_hz, window_s))           # exactly w
    assert np.isnan(robust_noise_std(x[:-1], rate_hz, window_s))         # one fewer
    # a non-finite sample does not count
    assert np.isnan(robust_noise_std(np.r_[x[:-1], np.nan], rate_hz, window_s))


# -- the chi-square gate and the consistency bounds: exactly at the threshold ----------------

def test_a_group_whose_nis_equals_the_gate_threshold_is_accepted_one_ulp_above_rejected():
    # Gate: rejected when the NIS *exceeds* the quantile; S = 1 makes the NIS y^2 exactly
    from terrain.estimation.ekf import Gate, correct
    gate = Gate(0.999)
    thr = gate.threshold(1)
    y = np.sqrt(thr)
    assert y * y == thr                      # (this quantile is a square in floats)
    above = np.nextafter(y, np.inf)
    assert above * above > thr
    P, H, R = np.array([[0.5]]), np.array([[1.0]]), np.array([0.5])
    for value, ok in ((y, True), (-y, True), (above, False)):
        _, _, inn = correct(np.zeros(1), P, np.array([value]), H, R, gate=gate)
        assert bool(inn.accepted[0]) is ok
        assert (inn.nis == thr) if ok else np.isnan(inn.nis)


def test_a_mean_nis_on_a_bound_of_its_interval_is_inside_it():
    from terrain.estimation.consistency import ChiSquareTest
    lo, hi = 0.8, 1.25
    for mean, inside in ((lo, True), (hi, True), (np.nextafter(lo, 0.0), False),
                         (np.nextafter(hi, 2.0), False)):
        test = ChiSquareTest(float(mean), 1.0, 100, 100.0, (lo, hi), (lo, hi), 1.0)
        assert test.inside is inside
        assert test.as_dict("nis")["nis_inside"] == float(inside)


def test_values_on_the_pointwise_chi_square_quantiles_count_as_inside():
    from scipy import stats
    from terrain.estimation.consistency import chi2_test
    a = (1.0 - 0.95) / 2.0       # (0.025000000000000022: the tail of the float 0.95)
    lo, hi = stats.chi2.ppf([a, 1.0 - a], 2)
    assert chi2_test(np.array([lo, hi, lo, hi]), 2).fraction_in_pointwise == 1.0
    out = np.array([np.nextafter(lo, 0.0), hi, lo, np.nextafter(hi, np.inf)])
    assert chi2_test(out, 2).fraction_in_pointwise == 0.5


# -- the ICR factor's yaw-rate threshold: corrected from |yaw_rate| = threshold on -----------

@pytest.mark.parametrize("slip_model", [False, True])
def test_chi_is_corrected_from_a_yaw_rate_exactly_at_its_threshold(slip_model):
    if slip_model:
        from terrain.estimation.skid_steer_slip import (STATE_NAMES, SkidSteerSlipModel as M,
                                                        SkidSteerSlipSettings as S)
    else:
        from terrain.estimation.skid_steer import (STATE_NAMES, SkidSteerModel as M,
                                                   SkidSteerSettings as S)
    model = M(S())
    limit = S().chi_min_yaw_rate_rad_s
    w, chi = STATE_NAMES.index("yaw_rate"), STATE_NAMES.index("log_icr_chi")
    for yaw_rate, corrected in ((limit, True), (-limit, True),
                                (np.nextafter(limit, 0.0), False),
                                (np.nextafter(-limit, 0.0), False)):
        x = np.array(model.x0, dtype=float)
        x[0], x[w] = 1.0, yaw_rate
        _, H = model.observation(x)
        assert bool(np.any(H[:2, chi] != 0.0)) is corrected


# -- an update with no measurement row (count 0) ---------------------------------------------

@pytest.mark.parametrize("check", [True, False])
def test_a_correction_with_no_row_leaves_the_state_and_has_no_nis(check):
    # (NumPy's bare 'zero-size array to reduction operation maximum' / LAPACK's 'unexpected
    # array size' before)
    from terrain.estimation.ekf import Gate, correct
    x, P = np.array([1.0, 2.0]), np.diag([0.5, 0.25])
    for gate in (None, Gate(0.99)):
        x1, P1, inn = correct(x, P, np.zeros(0), np.zeros((0, 2)), np.zeros(0), gate=gate,
                              check=check)
        np.testing.assert_array_equal(x1, x)
        np.testing.assert_array_equal(P1, P)
        assert np.isnan(inn.nis) and inn.dof == 0 and inn.accepted.shape == (0,)
        assert inn.S.shape == (0, 0)


def test_a_streaming_update_of_no_rows_is_a_no_op():
    from terrain.estimation.ekf import ExtendedKalmanFilter
    ekf = ExtendedKalmanFilter(np.zeros(2), np.eye(2), lambda x, dt: x, lambda x, dt: np.eye(2),
                               lambda x: x.copy(), lambda x: np.eye(2), 0.1 * np.eye(2),
                               np.ones(2))
    inn = ekf.update(np.zeros(0), rows=[])
    assert np.isnan(inn.nis) and inn.dof == 0
    np.testing.assert_array_equal(ekf.x, np.zeros(2))
    np.testing.assert_array_equal(ekf.P, np.eye(2))


# -- the adaptive observer: a step of exactly twice the median is no time gap -----------------

@pytest.mark.parametrize("factor, gap", [(2.0, False), (2.0 + 2.0 ** -10, True)])
def test_an_observer_step_of_exactly_twice_the_median_is_corrected_over_its_length(factor, gap):
    # 'a step longer than twice the median step' is a gap (corrected over one median step,
    # predicted over the rest); one of exactly twice is corrected over its whole length
    from terrain.estimation.observer import AdaptiveObserverSettings, run_adaptive_observer
    from terrain.vehicles.skid_steer import body_rates
    h = 0.125                                     # (binary-exact times)
    t = np.r_[0.0, h, 2 * h, 2 * h + factor * h, 3 * h + factor * h, 4 * h + factor * h]
    theta = np.array([0.0, 0.01, 0.03, 0.02, 0.05, 0.04])
    pose = np.column_stack([np.zeros(6), np.zeros(6), theta])
    vr, vl = np.full(6, 0.6), np.full(6, 0.4)
    s = AdaptiveObserverSettings(use_position=False)
    res = run_adaptive_observer(t, pose, vr, vl, s)
    er, el = res.eta[2]
    _, w = body_rates(vl[2] * el, vr[2] * er, 2.0 * s.half_track_m, 1.0)
    step = t[3] - t[2]
    corrected_over = h if gap else step
    # yaw: corrected (l3 e) over corrected_over, predicted (e = 0) over the rest; the rest's
    # rate uses the etas after the correction, equal to before up to the adaptation
    th = res.pose_hat[2, 2] + corrected_over * (w + s.l_gains[2] * res.error[2, 2])
    if gap:
        er2, el2 = res.eta[3]
        _, w2 = body_rates(vl[2] * el2, vr[2] * er2, 2.0 * s.half_track_m, 1.0)
        th += (step - h) * w2
    assert res.pose_hat[3, 2] == pytest.approx(th, abs=1e-12)
