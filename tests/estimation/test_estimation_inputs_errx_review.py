"""Estimation leftovers (errx review): the box projection, NEES, the finite-difference
Jacobian, the streaming and pure updates with a residual of the wrong length, and the RMSE of
nothing, each refusing bad input with a typed error naming it where NumPy answered bare or
with a number."""

import warnings

import numpy as np
import pytest

from terrain.errors import (ConfigError, CovarianceError, DataWarning, EstimationError,
                            NonFiniteInputError, ShapeError)
from terrain.estimation.consistency import nees, rmse
from terrain.estimation.ekf import ExtendedKalmanFilter, project_to_bounds, update
from terrain.estimation.model import finite_difference_jacobian

LO, UP = np.zeros(2), np.ones(2)


@pytest.mark.parametrize("x, error, said", [
    (None, ShapeError, r"x must have shape \(n,\), got \(\)"),       # IndexError before
    ("ab", EstimationError, "x must hold real numbers, got text"),    # bare ValueError
    (np.zeros((2, 2)), ShapeError, r"x must have shape \(n,\), got \(2, 2\)"),
    ([0.5, True], EstimationError, "x must hold numbers, got booleans"),
    (np.array([np.nan, 2.0]), NonFiniteInputError, r"x has non-finite entries at indices \[0\]"),
    (np.array([0.5, np.inf]), NonFiniteInputError, r"at indices \[1\]"),
    (np.array([-np.inf, 0.5]), NonFiniteInputError, r"at indices \[0\]")])
@pytest.mark.filterwarnings("ignore::RuntimeWarning")     # (NumPy's, on the way to the error)
def test_project_to_bounds_refuses_an_estimate_that_is_not_a_real_vector(x, error, said):
    with pytest.raises(error, match=said):      # (a NaN came back as NaN, "held")
        project_to_bounds(x, np.eye(2), LO, UP)


@pytest.mark.parametrize("movable", [[0.5, 0], np.array([1, 0]), np.array([0, 1]), "01"])
def test_project_to_bounds_refuses_a_movable_that_is_not_a_boolean_mask(movable):
    # [0.5, 0] was read as [True, False], and state indices [0, 1] as the mask [False, True]
    with pytest.raises(EstimationError, match="movable must be a boolean mask"):
        project_to_bounds(np.array([0.5, 2.0]), np.eye(2), LO, UP, movable)


@pytest.mark.parametrize("movable", [None, np.array([True, True, False])])
def test_project_to_bounds_refuses_a_nan_covariance_where_it_uses_it(movable):
    P = np.eye(3)
    P[2, 2] = np.nan       # (with a held state: a bare LinAlgError of NumPy's least squares)
    P[1, 2] = P[2, 1] = np.nan
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        with pytest.raises(NonFiniteInputError, match="P has non-finite entries"):
            project_to_bounds(np.array([0.5, 2.0, 0.0]), P, np.zeros(3), np.ones(3), movable)


def test_project_to_bounds_refuses_boolean_or_text_bounds_and_covariance():
    x = np.array([0.5, 2.0])
    with pytest.raises(EstimationError, match="upper must hold numbers, got booleans"):
        project_to_bounds(x, np.eye(2), LO, [True, True])
    with pytest.raises(EstimationError, match="lower must hold real numbers"):
        project_to_bounds(x, np.eye(2), "0", UP)
    with pytest.raises(EstimationError, match="P must hold numbers, got booleans"):
        project_to_bounds(x, np.eye(2, dtype=bool), LO, UP)


def test_project_to_bounds_of_valid_input_is_unchanged():
    P = np.array([[2.0, 0.5], [0.5, 1.0]])
    xc, active = project_to_bounds(np.array([0.5, 2.0]), P, LO, UP, np.array([True, True]))
    np.testing.assert_array_equal(active, [False, True])
    np.testing.assert_allclose(xc, [0.5 - 0.5 * 1.0, 1.0])    # x - P D^T (D P D^T)^-1 (Dx - d)
    # a list of booleans is a mask, and a float32 estimate is converted as before
    xl, _ = project_to_bounds(np.array([0.5, 2.0], np.float32), P, LO, UP, [True, True])
    np.testing.assert_array_equal(xl, xc)


def test_nees_refuses_an_asymmetric_covariance_naming_the_step():
    P = np.stack([np.eye(2), [[1.0, 0.5], [0.0, 1.0]]])     # NEES 1.5 of step 1 before
    with pytest.raises(CovarianceError, match=r"not symmetric .* at step 1"):
        nees(np.ones((2, 2)), P)
    np.testing.assert_allclose(nees(np.ones((1, 2)), np.eye(2)[None]), [2.0])


@pytest.mark.parametrize("eps", [0, 0.0, -1e-6, np.nan, np.inf, True, "1e-6", None])
def test_finite_difference_jacobian_refuses_a_step_that_is_not_positive(eps):
    with warnings.catch_warnings():
        warnings.simplefilter("error")       # (0 gave a Jacobian of NaN and a RuntimeWarning)
        with pytest.raises(ConfigError, match="finite_difference_jacobian.eps"):
            finite_difference_jacobian(np.sin, np.array([1.0, 2.0]), eps=eps)


def test_finite_difference_jacobian_refuses_a_step_too_small_to_move_x():
    with pytest.raises(ConfigError, match=r"too small to move x\[0\]"):    # zeros before
        finite_difference_jacobian(np.sin, np.array([1.0, 2.0]), eps=1e-300)


@pytest.mark.parametrize("x, error", [(None, ShapeError), (np.ones((2, 2)), ShapeError),
                                      ([1.0, np.nan], NonFiniteInputError)])
def test_finite_difference_jacobian_names_a_bad_point(x, error):
    with pytest.raises(error, match="x "):
        finite_difference_jacobian(np.sin, x)


def test_finite_difference_jacobian_of_valid_input():
    J = finite_difference_jacobian(np.sin, np.array([0.3, 1.2]))
    np.testing.assert_allclose(J, np.diag(np.cos([0.3, 1.2])), rtol=1e-8)


def _h(x):
    return np.r_[x, x[0]]


def _H(x):
    return np.vstack([np.eye(2), [1.0, 0.0]])


def _short_residual(z, hx):
    return (z - hx)[:2]


def test_the_streaming_update_names_a_residual_of_the_wrong_length():
    kf = ExtendedKalmanFilter(np.zeros(2), np.eye(2), lambda x, dt: x,
                              lambda x, dt: np.eye(2), _h, _H, np.eye(2), np.ones(3),
                              residual=_short_residual)
    x, P = kf.x.copy(), kf.P.copy()
    with pytest.raises(ShapeError, match=r"residual\(z, h\(x\)\) must have shape \(3,\), "
                                         r"got \(2,\)"):     # NumPy's concatenation error
        kf.update(np.zeros(3))
    with pytest.raises(ShapeError, match=r"residual\(z, h\(x\)\) must have shape \(3,\)"):
        kf.update(np.zeros(2), rows=[0, 2])
    np.testing.assert_array_equal(kf.x, x)           # nothing changed
    np.testing.assert_array_equal(kf.P, P)


def test_the_pure_update_names_the_residual_not_H():
    with pytest.raises(ShapeError, match=r"residual\(z, h\(x\)\) must have shape \(3,\)"):
        update(np.zeros(2), np.eye(2), np.zeros(3), _h, _H, np.ones(3),   # "H must have
               residual=_short_residual)                                   # shape (2, 2)"


def test_a_good_residual_updates_as_without_one():
    kw = dict(residual=lambda z, hx: z - hx)
    a = ExtendedKalmanFilter(np.zeros(2), np.eye(2), lambda x, dt: x, lambda x, dt: np.eye(2),
                             _h, _H, np.eye(2), np.ones(3), **kw)
    b = ExtendedKalmanFilter(np.zeros(2), np.eye(2), lambda x, dt: x, lambda x, dt: np.eye(2),
                             _h, _H, np.eye(2), np.ones(3))
    for kf in (a, b):
        kf.update(np.array([0.1, 0.2, 0.3]))
        kf.update(np.array([0.4, 0.5]), rows=[0, 2])
    np.testing.assert_array_equal(a.x, b.x)
    np.testing.assert_array_equal(a.P, b.P)


@pytest.mark.parametrize("errors, kw, said", [
    ([], {}, "no errors"), (np.zeros((0, 3)), {}, "no errors"),
    ([np.nan, np.nan], {"ignore_nan": True}, "every one of the 2 errors NaN")])
def test_the_rmse_of_nothing_is_nan_with_a_data_warning(errors, kw, said):
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)   # (NumPy's "Mean of empty slice")
        with pytest.warns(DataWarning, match=f"rmse: {said}, nothing to average"):
            assert np.isnan(rmse(errors, **kw))


def test_the_rmse_of_errors_is_unchanged():
    assert rmse([3.0, 4.0]) == np.sqrt(12.5)
    assert rmse([3.0, np.nan, 4.0], ignore_nan=True) == np.sqrt(12.5)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert np.isnan(rmse([3.0, np.nan]))            # a NaN error: NaN, no warning
