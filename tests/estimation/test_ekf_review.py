"""Review tests of the EKF core: gate degrees of freedom and boundary, chi-square bounds with
the effective sample count, the windowed autocorrelation time."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal, stats

from terrain.estimation import Gate, correct
from terrain.estimation.consistency import (chi2_test, effective_sample_size,
                                            integrated_autocorrelation_time, mean_chi2_bounds)


def test_each_group_is_gated_on_the_quantile_of_its_own_size():
    # three independent unit-variance rows (P = 0, R = 1: S = I), groups of 2 and 1 rows;
    # NIS 13 of the 1-row group is over chi2(1) 0.999 = 10.83 (under chi2(3) = 16.27), NIS
    # 15 of the 2-row group over chi2(2) = 13.82: both groups are rejected
    gate = Gate(0.999)
    groups = [np.array([0, 1]), np.array([2])]
    y = np.array([np.sqrt(7.5), np.sqrt(7.5), np.sqrt(13.0)])
    _, _, inn = correct(np.zeros(3), np.zeros((3, 3)), y, np.eye(3), np.ones(3), gate=gate,
                        groups=groups)
    assert inn.accepted.tolist() == [False, False, False]
    # just under their own thresholds both are accepted
    y = np.array([np.sqrt(6.5), np.sqrt(6.5), np.sqrt(10.5)])
    _, _, inn = correct(np.zeros(3), np.zeros((3, 3)), y, np.eye(3), np.ones(3), gate=gate,
                        groups=groups)
    assert inn.accepted.all() and inn.nis == pytest.approx(23.5) and inn.dof == 3


def test_a_group_exactly_at_its_threshold_is_accepted():
    # the gate rejects a NIS that *exceeds* the quantile (the compiled loop tests the same)
    t = Gate(0.999).threshold(1)
    y = np.array([np.sqrt(t)])
    assert y[0] * y[0] == t                    # exact in float64 for this quantile
    _, _, inn = correct(np.zeros(1), np.zeros((1, 1)), y, np.eye(1), np.ones(1),
                        gate=Gate(0.999))
    assert inn.accepted.tolist() == [True] and inn.nis == t
    _, _, inn = correct(np.zeros(1), np.zeros((1, 1)), np.nextafter(y, 10.0), np.eye(1),
                        np.ones(1), gate=Gate(0.999))
    assert inn.accepted.tolist() == [False] and np.isnan(inn.nis)


def test_chi2_test_bounds_use_the_effective_sample_count():
    # correlated chi-square(1) values: squares of an AR(1) with unit variance (tau ~ 1.5)
    e = signal.lfilter([np.sqrt(1 - 0.9 ** 2)], [1.0, -0.9],
                       np.random.default_rng(3).standard_normal(4000))
    v = e ** 2
    test = chi2_test(v, 1.0)
    n_eff = effective_sample_size(v)
    assert n_eff < 0.8 * v.size
    assert test.n_effective == n_eff
    assert test.bounds == mean_chi2_bounds(1.0, n_eff)
    assert test.bounds_iid == mean_chi2_bounds(1.0, v.size)
    assert test.bounds[0] < test.bounds_iid[0] and test.bounds[1] > test.bounds_iid[1]


def _tau_by_definition(x, max_lag, threshold):
    """Sokal's windowed tau from the biased sample autocorrelation, one lag at a time."""
    d = x - x.mean()
    n = x.size
    var = d @ d / n
    tau = 1.0
    for k in range(1, min(n, max_lag)):
        rho = (d[:-k] @ d[k:]) / n / var
        if rho < threshold:
            break
        tau += 2.0 * rho
    return tau


def test_autocorrelation_time_stops_at_the_first_lag_below_the_threshold():
    # a noisy oscillation: its autocorrelation drops below 0.05 near lag 12 and comes back
    # above it near lag 38, which the window must not count
    rng = np.random.default_rng(8)
    t = np.arange(3000)
    x = np.sin(2 * np.pi * t / 50.0) + 0.5 * rng.standard_normal(t.size)
    want = _tau_by_definition(x, 2000, 0.05)
    assert float(integrated_autocorrelation_time(x)) == pytest.approx(want, rel=1e-9)
    assert 1.0 < want < 15.0
    # rows of a 2-D array each get their own
    ar = signal.lfilter([1.0], [1.0, -0.7], rng.standard_normal(3000))
    both = integrated_autocorrelation_time(np.stack([x, ar]))
    assert both[1] == pytest.approx(_tau_by_definition(ar, 2000, 0.05), rel=1e-9)


def test_effective_sample_size_drops_non_finite_values():
    rng = np.random.default_rng(9)
    ar = signal.lfilter([1.0], [1.0, -0.8], rng.standard_normal(3000))
    holed = ar.copy()
    holed[::10] = np.nan
    holed[5] = np.inf
    finite = holed[np.isfinite(holed)]
    assert effective_sample_size(holed) == effective_sample_size(finite)
    assert effective_sample_size(holed) < finite.size / 5.0      # tau of about 9


def test_chi_square_quantiles_behind_the_bounds():
    # N = 1 bounds are the two-sided quantiles of one chi-square value
    lo, hi = mean_chi2_bounds(2, 1, probability=0.9)
    assert (lo, hi) == pytest.approx((stats.chi2.ppf(0.05, 2), stats.chi2.ppf(0.95, 2)))


def _gate_at(value):
    """A gate whose threshold is ``value`` for every group size."""
    class _Fixed(Gate):
        def threshold(self, dof):
            return value
    return _Fixed(0.999)


def test_the_compiled_gate_accepts_a_nis_exactly_at_its_threshold():
    # one gyro sample: the only gated group of the run; its marginal NIS is the step's NIS,
    # computed by the same Cholesky solve in the compiled loop
    from terrain.estimation.runner import SensorSamples, make_grid, run_filter
    from terrain.estimation.skid_steer import SkidSteerModel

    grid = make_grid(0.0, 0.05, 100.0)
    samples = {"gyro": SensorSamples(np.array([0.013]), np.array([[0.2]]))}
    free = run_filter(SkidSteerModel(), grid, samples, engine="numba")
    d2 = free.nis[2]
    assert d2 > 0.0 and free.accepted[2, 2]
    at = run_filter(SkidSteerModel(), grid, samples, engine="numba", gate=_gate_at(d2))
    assert at.accepted[2, 2] and at.nis[2] == d2
    np.testing.assert_array_equal(at.x, free.x)
    below = run_filter(SkidSteerModel(), grid, samples, engine="numba",
                       gate=_gate_at(np.nextafter(d2, 0.0)))
    assert not below.accepted[2, 2] and below.counts["gyro"]["rejected"] == 1


def test_with_step_bounds_the_state_bounds_also_hold_at_steps_without_a_sample():
    # run_filter: after each step's update, or prediction at a step with no sample, the
    # estimate is projected onto step_bounds, *then* clipped into the model's state_bounds
    from terrain.estimation.runner import SensorSamples, run_filter
    from terrain.estimation.skid_steer_slip import SkidSteerSlipModel

    model = SkidSteerSlipModel()
    t = np.arange(0.0, 1.0, 0.01)
    wheels = {"wheels": SensorSamples(t[5::10], np.full((t[5::10].size, 2), 0.3))}
    x0 = model.x0
    x0[4] = 1.4                                  # slip_1 outside [-1, 1]
    free = np.full((t.size, model.n_states), np.inf)
    res = run_filter(model, t, wheels, engine="numpy", x0=x0, step_bounds=(-free, free))
    assert res.x[0, 4] == 1.0                    # step 0 has no sample: clipped all the same
    assert np.abs(res.x[:, 4:6]).max() <= 1.0
    assert res.meta["state_bounds_clipped"] >= 1 and res.meta["step_bounds_active"] == 0


def test_one_precise_update_of_a_badly_scaled_covariance_stays_positive_semi_definite():
    # states of scales 1e-3 .. 1e4 observed by rows with noise down to 1e-14: the short form
    # (I - K H) P of eq. 4.12 reaches eigenvalues of -3e-5 times the largest on these
    # draws; the Joseph form stays within round-off of PSD. Round-off here is relative to the
    # prior (eps |P0|, up to 1e8), not to the posterior: the stored P1 of draw 204 has an
    # exact eigenvalue of -2.8e-12 times its largest with one OpenBLAS kernel (-1e-12 was
    # met with another), five orders below the short form's -5e-5 on the same draws
    rng = np.random.default_rng(0)
    n = 4
    worst = 0.0
    for _ in range(300):
        a = rng.standard_normal((n, n)) * 10.0 ** rng.uniform(-3, 4, n)
        H = rng.standard_normal((2, n))
        R = np.full(2, 10.0 ** rng.uniform(-14, -6))
        _, P1, _ = correct(np.zeros(n), a @ a.T, np.zeros(2), H, R, check=False)
        eig = np.linalg.eigvalsh(P1)
        worst = min(worst, eig[0] / eig[-1])
        np.testing.assert_array_equal(P1, P1.T)
    assert worst > -1e-10


def test_the_streaming_filter_gates_a_sensor_after_an_absent_one():
    # groups [0] and [1]; an update of row 1 alone leaves group 0 empty: group 1 is still
    # gated (an outlier of 100 sigma is rejected, the filter unchanged)
    from terrain.estimation import ExtendedKalmanFilter

    ekf = ExtendedKalmanFilter(np.zeros(2), np.eye(2) * 0.01, lambda x, dt: x,
                               lambda x, dt: np.eye(2), lambda x: x, lambda x: np.eye(2),
                               np.eye(2) * 1e-4, np.array([1e-4, 1e-4]), gate=Gate(0.999),
                               groups=[np.array([0]), np.array([1])])
    inn = ekf.update(np.array([10.0]), rows=[1])
    assert inn.accepted.tolist() == [False] and inn.dof == 0
    np.testing.assert_array_equal(ekf.x, np.zeros(2))
    inn = ekf.update(np.array([0.01]), rows=[1])          # a good sample is used
    assert inn.accepted.tolist() == [True] and ekf.x[1] > 0.0


def test_a_grid_whose_span_rounds_below_a_whole_number_of_steps_keeps_its_last_step():
    # (0.3 - 0.1) * 10 is 1.9999999999999998 in float64: the grid still has 3 steps
    from terrain.estimation.runner import make_grid

    grid = make_grid(0.1, 0.3, 10.0)
    assert grid.size == 3 and grid[-1] == pytest.approx(0.3)
