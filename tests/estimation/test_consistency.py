"""NEES / NIS statistics and chi-square bounds."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal, stats

from terrain.errors import ConfigError, CovarianceError, ShapeError
from terrain.estimation.consistency import (chi2_test, effective_sample_size, mean_chi2_bounds,
                                            nees, rmse, state_errors)


def test_nees_of_gaussian_errors_has_mean_n():
    rng = np.random.default_rng(0)
    n, N = 4, 20000
    a = rng.standard_normal((n, n))
    P = a @ a.T + np.eye(n)
    e = rng.multivariate_normal(np.zeros(n), P, size=N)
    v = nees(e, np.broadcast_to(P, (N, n, n)))
    assert v.mean() == pytest.approx(n, rel=0.03)
    test = chi2_test(v, n)
    assert test.inside and test.fraction_in_pointwise == pytest.approx(0.95, abs=0.01)
    assert test.n_effective > 0.8 * N          # independent samples


def test_bounds_and_effective_sample_size():
    lo, hi = mean_chi2_bounds(12, 10)
    assert lo == pytest.approx(stats.chi2.ppf(0.025, 120) / 10)
    assert hi == pytest.approx(stats.chi2.ppf(0.975, 120) / 10)
    rng = np.random.default_rng(1)
    white = rng.standard_normal(5000)
    red = np.convolve(white, np.ones(50) / 50, mode="same")
    assert effective_sample_size(red) < 0.1 * effective_sample_size(white)
    # a known value: AR(1) with phi = 0.8 has tau = 1 + 2 sum phi^k = (1 + phi) / (1 - phi)
    # = 9 (8.6 summed to the 0.05 threshold); the ratio above also held with tau = 1 + sum
    ar = signal.lfilter([1.0], [1.0, -0.8], np.random.default_rng(5).standard_normal(20000))
    assert effective_sample_size(ar) == pytest.approx(20000 / 9.0, rel=0.15)


def test_biased_filter_fails_the_test():
    rng = np.random.default_rng(2)
    v = rng.chisquare(3, 3000) * 2.0          # covariance underestimated by 2
    assert not chi2_test(v, 3).inside


def test_pessimistic_filter_fails_the_test():
    # the lower bound: a covariance overestimated by 2 halves the NEES
    rng = np.random.default_rng(2)
    v = rng.chisquare(3, 3000) * 0.5
    test = chi2_test(v, 3)
    assert test.mean < test.bounds[0]
    assert not test.inside
    assert chi2_test(rng.chisquare(3, 3000), 3).inside      # a consistent one passes


def test_state_errors_wrap_angles_and_shapes():
    e = state_errors(np.array([[3.1, 1.0]]), np.array([[-3.1, 0.5]]), angle_columns=(0,))
    assert e[0, 0] == pytest.approx(6.2 - 2 * np.pi)
    with pytest.raises(ShapeError):
        nees(np.zeros((3, 2)), np.zeros((3, 3, 3)))


def test_rmse_known_value_and_nan_policy():
    assert rmse(np.array([3.0, -4.0])) == pytest.approx(np.sqrt(12.5))
    assert rmse(np.array([[1.0, 1.0], [-1.0, 1.0]])) == pytest.approx(1.0)
    assert np.isnan(rmse(np.array([1.0, np.nan])))              # NaN not dropped silently
    assert rmse(np.array([2.0, np.nan]), ignore_nan=True) == pytest.approx(2.0)
    # a diverged estimate is not a missing one: inf stays inf (est19: the docstring said
    # "finite errors only")
    assert rmse(np.array([2.0, np.nan, -np.inf]), ignore_nan=True) == np.inf


def test_nees_of_a_singular_covariance_names_the_step():
    # a state with zero variance at step 1 raised numpy's LinAlgError("Singular matrix")
    P = np.stack([np.eye(2), np.diag([1.0, 0.0]), np.eye(2)])
    with pytest.raises(CovarianceError, match="singular at step 1$"):
        nees(np.ones((3, 2)), P)


@pytest.mark.parametrize("probability", [0.0, 1.0, 1.5, 95, np.nan])
def test_a_coverage_outside_zero_one_is_refused(probability):
    # chi2_test(..., probability=1.5) returned bounds (nan, nan), inside False and
    # fraction_in_pointwise 0.0 as if the filter had failed the test
    with pytest.raises(ConfigError, match="probability"):
        chi2_test(np.full(10, 2.0), 2, probability)
    with pytest.raises(ConfigError, match="probability"):
        mean_chi2_bounds(2, 100, probability)


def test_arrays_of_other_shapes_are_refused_by_name():
    # a dof per step of another length was NumPy's bare "could not be broadcast" ValueError,
    # as was a truth of another number of steps; a 1-D error with an angle column was a bare
    # IndexError, and a truth of shape (n,) was broadcast over every step without a word
    with pytest.raises(ShapeError, match="dof"):
        chi2_test(np.full(100, 2.0), np.full(99, 2.0))
    with pytest.raises(ShapeError, match="truth"):
        state_errors(np.zeros((5, 3)), np.ones((4, 3)))
    with pytest.raises(ShapeError, match="truth"):
        state_errors(np.zeros((5, 3)), np.ones(3))
    with pytest.raises(ShapeError, match="estimates"):
        state_errors(np.zeros(5), np.ones(5), (0,))
    with pytest.raises(ShapeError, match="angle column 3"):
        state_errors(np.zeros((5, 3)), np.ones((5, 3)), (3,))
    assert chi2_test(np.full(4, 2.0), np.full(4, 2.0)).n_samples == 4


def test_nis_with_a_varying_number_of_rows_is_tested_against_the_mean_dof():
    """NIS of steps with different numbers of accepted rows: the expected mean is the mean
    dof (E[sum chi2(d_k)] / N), not its median; a step with no row (dof 0) carries no
    statistic and is left out even if a value was written for it."""
    rng = np.random.default_rng(6)
    dof = np.tile([1, 1, 4], 4000)
    values = rng.chisquare(dof).astype(float)
    test = chi2_test(values, dof)
    assert test.dof == pytest.approx(2.0)
    assert test.inside and test.mean == pytest.approx(2.0, rel=0.03)
    with_empty = chi2_test(np.r_[values, 50.0, 50.0], np.r_[dof, 0, 0])
    assert with_empty.n_samples == values.size
    assert with_empty.mean == pytest.approx(test.mean)


def test_bounds_of_fewer_than_one_effective_sample_are_those_of_one():
    assert mean_chi2_bounds(3, 0.4) == mean_chi2_bounds(3, 1)
    lo, hi = mean_chi2_bounds(3, 1)
    assert (lo, hi) == pytest.approx((stats.chi2.ppf(0.025, 3), stats.chi2.ppf(0.975, 3)))
