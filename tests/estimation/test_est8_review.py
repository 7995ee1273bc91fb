"""Review est8: EKF core inputs that were silently accepted, and missing tests (mutants)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from terrain.errors import ConfigError, EstimationError, ShapeError
from terrain.estimation.consistency import (chi2_test, integrated_autocorrelation_time,
                                            mean_chi2_bounds)
from terrain.estimation.ekf import (ExtendedKalmanFilter, Gate, as_covariance, as_vector,
                                    correct)
from terrain.estimation.result import EKFResult


def _three_rows():
    """Two states, three rows: rows 0 and 1 see a state each, row 2 their sum."""
    H = np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
    return np.zeros(2), np.eye(2), H, np.full(3, 0.01)


@pytest.mark.parametrize("groups,match", [
    ([[0, 1]], r"row\(s\) \[2\] in no group"),
    ([[0, 1], [2, 3]], r"outside 0\.\.2"),
    ([[0, 1, 1], [2]], r"row\(s\) \[1\] in more than one group"),
    ([[0, 1], [1, 2]], r"row\(s\) \[1\] in more than one group"),
    ([[0.5], [1, 2]], "integer row numbers")])
def test_gate_groups_that_are_not_a_partition_of_the_rows_are_refused(groups, match):
    # groups=[[0, 1]] for 3 rows left row 2 ungated: a 50-sigma outlier on it was accepted
    # and moved the state by 16.6; [2, 3] was a bare IndexError, a repeated row a false
    # "S is singular"
    x, P, H, R = _three_rows()
    y = np.array([0.1, 0.1, 50.0])
    with pytest.raises(ShapeError, match=match):
        correct(x, P, y, H, R, gate=Gate(), groups=[np.asarray(g) for g in groups])
    with pytest.raises(ShapeError, match=match):
        ExtendedKalmanFilter(x, P, lambda v, dt: v, lambda v, dt: np.eye(2), lambda v: H @ v,
                             lambda v: H, np.eye(2) * 0.1, R, gate=Gate(), groups=groups)


def test_a_partition_gates_the_outlier_row_and_keeps_the_others():
    x, P, H, R = _three_rows()
    y = np.array([0.1, 0.1, 50.0])
    xn, _, inn = correct(x, P, y, H, R, gate=Gate(), groups=[np.array([0, 1]), np.array([2])])
    assert inn.accepted.tolist() == [True, True, False] and inn.dof == 2
    assert np.all(np.abs(xn) < 0.2)
    ekf = ExtendedKalmanFilter(x, P, lambda v, dt: v, lambda v, dt: np.eye(2), lambda v: H @ v,
                               lambda v: H, np.eye(2) * 0.1, R, gate=Gate(),
                               groups=[[0, 1], [2]])
    assert ekf.update(H @ x + y).accepted.tolist() == [True, True, False]


def test_default_gate_is_the_documented_0_999_quantile_of_the_group_size():
    # Gate's docstring: probability 0.999, a consistent filter rejects 0.1 % of good samples;
    # dof = rows of the group (mutants: default 0.99, or the table shifted by one dof, passed
    # every test but one that only checks the table's end)
    gate = Gate()
    assert gate.probability == 0.999
    assert gate.threshold(1) == pytest.approx(10.828, abs=1e-3)      # chi2.ppf(0.999, 1)
    assert gate.threshold(2) == pytest.approx(13.816, abs=1e-3)
    assert gate.threshold(4) == pytest.approx(18.467, abs=1e-3)
    x, P, H, R = _three_rows()
    # one row of NIS 10.0 passes, 11.0 fails: S = P + R = 1.01 on row 0
    for nis, ok in ((10.0, True), (11.0, False)):
        y = np.array([np.sqrt(nis * 1.01), 0.0, 0.0])
        _, _, inn = correct(x, P, y, H, R, gate=gate,
                            groups=[np.array([0]), np.array([1]), np.array([2])])
        assert inn.accepted[0] == ok


@pytest.mark.parametrize("n_samples", [0, -5])
def test_chi_square_bounds_of_a_mean_of_no_sample_are_refused(n_samples):
    # mean_chi2_bounds(2, 0) and (2, -5) gave the bounds of one sample, (0.0506, 7.38),
    # for an average of no value (a fraction of an effective sample is still taken as 1)
    with pytest.raises(ConfigError, match="n_samples"):
        mean_chi2_bounds(2, n_samples)
    assert mean_chi2_bounds(2, 0.5) == mean_chi2_bounds(2, 1)
    lo, hi = mean_chi2_bounds(2, 1)
    assert (lo, hi) == pytest.approx((stats.chi2.ppf(0.025, 2), stats.chi2.ppf(0.975, 2)))


@pytest.mark.parametrize("bad", [-1.0, np.nan])
def test_chi2_test_refuses_a_negative_or_nan_dof_instead_of_dropping_its_value(bad):
    # chi2_test([1, 2, 3], [1, -1, nan]) dropped the last two values silently and tested
    # the first alone (n_samples 1)
    with pytest.raises(ConfigError, match=r"dof .*index 1"):
        chi2_test(np.array([1.0, 2.0, 3.0]), np.array([1.0, bad, 2.0]))
    # dof 0 (a step with no accepted row, NIS NaN) is still left out of n_samples
    test = chi2_test(np.array([1.0, np.nan, 3.0]), np.array([1, 0, 3]))
    assert test.n_samples == 2 and test.dof == 2.0 and test.mean == 2.0


def test_autocorrelation_time_of_a_row_with_a_non_finite_value_is_nan_not_one():
    # a NaN sample made the variance NaN and the row was given tau = 1 (independent
    # samples); the other rows keep their value
    rng = np.random.default_rng(0)
    x = np.cumsum(rng.standard_normal((2, 400)), axis=1)      # strongly correlated rows
    clean = integrated_autocorrelation_time(x)
    x[1, 7] = np.nan
    tau = integrated_autocorrelation_time(x)
    assert clean[1] > 5.0 and np.isnan(tau[1]) and tau[0] == clean[0]
    assert integrated_autocorrelation_time(np.ones(10)) == 1.0             # constant row


def test_an_unknown_state_or_sensor_of_a_result_is_named():
    # state('vx') and std('vx') were a bare "tuple.index(x): x not in tuple", sensor_nis('cam')
    # a bare KeyError 'cam'
    res = EKFResult(t_s=np.arange(2.0), x=np.array([[1.0], [2.0]]), P_diag=np.full((2, 1), 4.0),
                    P=None, y=np.array([[1.0], [np.nan]]), S_diag=np.array([[2.0], [np.nan]]),
                    accepted=np.array([[True], [False]]), nis=np.array([0.5, np.nan]),
                    dof=np.array([1, 0]), state_names=("v_bx",), measurement_names=("wz",),
                    sensor_rows={"gyro": (0,)}, counts={})
    for call, name in ((res.state, "vx"), (res.std, "vx"), (res.sensor_nis, "cam")):
        with pytest.raises(EstimationError, match=f"unknown (state|sensor) '{name}'.*"
                                                  f"(v_bx|gyro)"):
            call(name)
    assert res.state("v_bx").tolist() == [1.0, 2.0] and res.std("v_bx").tolist() == [2.0, 2.0]
    np.testing.assert_array_equal(res.sensor_nis("gyro"), [0.5, np.nan])


def test_the_speed_bound_widens_each_rim_by_three_wheel_noise_stds():
    """The bound on v_bx allows each rim speed 3 wheel-noise stds (two-sided 99.7 %) and
    the deepest braking slip: rims at 1 m/s with 0.03 m/s noise and s_b = -0.3 bound the
    speed to [0, (1 + 0.09) / 0.7] = [0, 1.557] m/s (mutant: 2 stds, 1.471, passed every
    test)."""
    from terrain.estimation.runner import SensorSamples
    from terrain.estimation.skid_steer_slip import (SkidSteerSlipSettings, _speed_bounds,
                                                    rim_speed_range_m_s)
    settings = SkidSteerSlipSettings(wheel_std_m_s=0.03, speed_bound_braking_slip=-0.3,
                                     speed_bound_hold_s=0.0)
    assert settings.speed_bound_rim_margin_m_s == pytest.approx(0.09)
    t = np.arange(5) * 0.1
    lower, upper = _speed_bounds(t, SensorSamples(t, np.ones((5, 2))), settings)
    np.testing.assert_allclose(upper[:, 0], 1.09 / 0.7)
    np.testing.assert_allclose(lower[:, 0], 0.0)
    assert np.isinf(upper[:, 1:]).all() and np.isinf(lower[:, 1:]).all()   # v_bx only
    # a spot turn's rims (+-0.05 m/s): the margin lets the body move either way
    lo, up = rim_speed_range_m_s(np.array([[0.05, -0.05]]), -0.3, 0.09)
    np.testing.assert_allclose([lo[0], up[0]], [-0.18 / 2 / 0.7, 0.18 / 2 / 0.7])


def test_boolean_states_measurements_and_covariances_are_refused():
    # a mask passed as a measurement was read as 0 and 1 (update(z=[True, False]) corrected
    # the state towards 1 and 0), np.eye(2, dtype=bool) was a unit covariance
    with pytest.raises(EstimationError, match="z must hold numbers, got booleans"):
        as_vector(np.array([True, False]), "z")
    with pytest.raises(EstimationError, match="booleans"):
        as_vector([True, False], "x0")
    with pytest.raises(EstimationError, match="P0 must hold numbers"):
        as_covariance(np.eye(2, dtype=bool), 2, "P0")
    x, P, H, R = _three_rows()
    ekf = ExtendedKalmanFilter(x, P, lambda v, dt: v, lambda v, dt: np.eye(2), lambda v: H @ v,
                               lambda v: H, np.eye(2) * 0.1, R)
    with pytest.raises(EstimationError, match="booleans"):
        ekf.update(np.array([True, False, True]))
    assert np.array_equal(ekf.x, x)                         # nothing changed
    np.testing.assert_array_equal(as_vector([1, 0.5], "z"), [1.0, 0.5])    # numbers pass
