"""EKF core: pure predict/update, Joseph form, gating, streaming wrapper, bad input."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import (ConfigError, CovarianceError, EstimationError, NonFiniteInputError,
                            ShapeError, TimeStepError)
from terrain.estimation import ExtendedKalmanFilter, Gate, correct, predict, update


def _cv_model(dt_unused=None):
    """Constant-velocity 1-D target: x = [p, v], z = p."""
    f = lambda x, dt: np.array([x[0] + dt * x[1], x[1]])  # noqa: E731
    F = lambda x, dt: np.array([[1.0, dt], [0.0, 1.0]])  # noqa: E731
    h = lambda x: x[:1]  # noqa: E731
    H = lambda x: np.array([[1.0, 0.0]])  # noqa: E731
    Q = lambda dt: 0.1 * np.array([[dt ** 3 / 3, dt ** 2 / 2], [dt ** 2 / 2, dt]])  # noqa: E731
    return f, F, h, H, Q


def _random_spd(n, rng, scale=1.0):
    a = rng.standard_normal((n, n))
    return scale * (a @ a.T + n * np.eye(n))


def _is_psd(P, tol=1e-12):
    return np.allclose(P, P.T, atol=0, rtol=1e-12) and np.linalg.eigvalsh(P).min() > -tol


def test_linear_update_matches_textbook_kalman_filter():
    rng = np.random.default_rng(0)
    n, m = 4, 3
    x, P = rng.standard_normal(n), _random_spd(n, rng)
    Hm, R = rng.standard_normal((m, n)), _random_spd(m, rng, 0.1)
    z = rng.standard_normal(m)
    x1, P1, inn = correct(x, P, z - Hm @ x, Hm, R)
    S = Hm @ P @ Hm.T + R
    K = P @ Hm.T @ np.linalg.inv(S)
    np.testing.assert_allclose(x1, x + K @ (z - Hm @ x), rtol=1e-10)
    np.testing.assert_allclose(P1, (np.eye(n) - K @ Hm) @ P, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(inn.S, S, rtol=1e-12)
    y = z - Hm @ x
    assert inn.nis == pytest.approx(float(y @ np.linalg.solve(S, y)), rel=1e-10)
    assert inn.dof == m and inn.accepted.all()


def test_joseph_form_keeps_covariance_psd_under_bad_conditioning():
    rng = np.random.default_rng(1)
    n = 6
    P = np.diag(10.0 ** rng.uniform(-8, 4, n))
    for _ in range(200):
        Hm = rng.standard_normal((2, n))
        x, P, _ = correct(np.zeros(n), P, rng.standard_normal(2), Hm, np.array([1e-9, 1e-9]),
                          check=False)
        P = P + np.diag(np.full(n, 1e-12))
        assert _is_psd(P, tol=1e-10 * np.abs(P).max())


def test_pure_functions_do_not_modify_inputs_and_predict_matches_linear_propagation():
    f, F, h, H, Q = _cv_model()
    x = np.array([1.0, 2.0])
    P = np.diag([0.5, 0.2])
    xc, Pc = x.copy(), P.copy()
    x1, P1 = predict(x, P, 0.1, f, F, Q)
    np.testing.assert_array_equal(x, xc)
    np.testing.assert_array_equal(P, Pc)
    Fm = F(x, 0.1)
    np.testing.assert_allclose(x1, Fm @ x)
    np.testing.assert_allclose(P1, Fm @ P @ Fm.T + Q(0.1))
    x2, P2, inn = update(x1, P1, np.array([1.3]), h, H, np.array([0.01]))
    assert x2 is not x1 and inn.y.shape == (1,) and inn.S.shape == (1, 1)
    assert P2[0, 0] < P1[0, 0]


def test_streaming_wrapper_equals_pure_functions_and_rows_subset():
    f, F, h, H, Q = _cv_model()
    rng = np.random.default_rng(2)
    h2 = lambda x: np.array([x[0], x[1]])  # noqa: E731
    H2 = lambda x: np.eye(2)  # noqa: E731
    R = np.array([0.04, 0.09])
    ekf = ExtendedKalmanFilter(np.zeros(2), np.eye(2), f, F, h2, H2, Q, R)
    x, P = np.zeros(2), np.eye(2)
    for k in range(50):
        z = rng.standard_normal(2)
        ekf.predict(0.1)
        x, P = predict(x, P, 0.1, f, F, Q, check=False)
        if k % 3 == 0:    # only the position row arrives
            inn = ekf.update(z[:1], rows=[0])
            x, P, ref = correct(x, P, z[:1] - x[:1], np.array([[1.0, 0.0]]), R[:1])
        else:
            inn = ekf.update(z)
            x, P, ref = update(x, P, z, h2, H2, R)
        assert inn.nis == pytest.approx(ref.nis)
    np.testing.assert_allclose(ekf.x, x, rtol=1e-12)
    np.testing.assert_allclose(ekf.P, P, rtol=1e-12)


def test_nis_is_chi_square_distributed_for_a_consistent_linear_filter():
    f, F, h, H, Q = _cv_model()
    rng = np.random.default_rng(3)
    dt, r = 0.1, 0.05
    xt = np.array([0.0, 1.0])
    ekf = ExtendedKalmanFilter(xt + rng.normal(0, [1.0, 1.0]), np.eye(2), f, F, h, H, Q,
                               np.array([r]))
    nis = []
    chol = np.linalg.cholesky(Q(dt))
    for _ in range(3000):
        xt = F(xt, dt) @ xt + chol @ rng.standard_normal(2)
        ekf.predict(dt)
        nis.append(ekf.update(np.array([xt[0] + np.sqrt(r) * rng.standard_normal()])).nis)
    nis = np.asarray(nis[100:])
    assert 0.93 < nis.mean() < 1.07          # chi2(1) mean 1, 2900 samples: +-0.05 at 95 %


def test_gate_rejects_only_the_outlier_sensor():
    rng = np.random.default_rng(4)
    n = 3
    x, P = np.zeros(n), np.eye(n) * 0.01
    Hm = np.eye(n)
    R = np.full(n, 1e-4)
    groups = [np.array([0, 1]), np.array([2])]
    y = np.array([0.01, -0.01, 5.0])          # sensor 2 is an outlier (50 sigma)
    x1, P1, inn = correct(x, P, y, Hm, R, gate=Gate(0.999), groups=groups)
    assert inn.accepted.tolist() == [True, True, False]
    assert inn.dof == 2
    assert abs(x1[2]) < 1e-12 and P1[2, 2] == pytest.approx(P[2, 2])
    assert x1[0] == pytest.approx(0.01 * 0.01 / (0.01 + 1e-4))
    # without the gate the outlier moves the state by ~5
    x2, _, _ = correct(x, P, y, Hm, R)
    assert x2[2] > 4.0
    # all rows rejected: state and covariance unchanged, NIS NaN
    x3, P3, inn3 = correct(x, P, np.full(n, 10.0), Hm, R, gate=Gate(0.999), groups=groups)
    np.testing.assert_array_equal(x3, x)
    np.testing.assert_array_equal(P3, P)
    assert np.isnan(inn3.nis) and inn3.dof == 0
    del rng


@pytest.mark.parametrize("bad_dt", [0.0, -0.01, np.nan, np.inf, "a"])
def test_bad_time_step_raises(bad_dt):
    f, F, h, H, Q = _cv_model()
    with pytest.raises(TimeStepError):
        predict(np.zeros(2), np.eye(2), bad_dt, f, F, Q)
    ekf = ExtendedKalmanFilter(np.zeros(2), np.eye(2), f, F, h, H, Q, np.array([1.0]))
    with pytest.raises(TimeStepError):
        ekf.predict(bad_dt)


def test_bad_shapes_non_finite_and_covariances_raise_typed_errors():
    f, F, h, H, Q = _cv_model()
    x, P, R = np.zeros(2), np.eye(2), np.array([0.1])
    with pytest.raises(ShapeError, match=r"\(2, 1\)"):
        predict(np.zeros((2, 1)), P, 0.1, f, F, Q)
    with pytest.raises(ShapeError):
        predict(x, np.eye(3), 0.1, f, F, Q)
    with pytest.raises(NonFiniteInputError, match=r"\[1\]"):
        predict(np.array([0.0, np.nan]), P, 0.1, f, F, Q)
    with pytest.raises(CovarianceError, match="symmetric"):
        predict(x, np.array([[1.0, 0.5], [0.0, 1.0]]), 0.1, f, F, Q)
    with pytest.raises(CovarianceError, match="semi-definite"):
        predict(x, np.array([[1.0, 0.0], [0.0, -1.0]]), 0.1, f, F, Q)
    with pytest.raises(NonFiniteInputError):
        update(x, P, np.array([np.inf]), h, H, R)
    with pytest.raises(ShapeError):
        update(x, P, np.array([1.0, 2.0]), h, H, R)
    with pytest.raises(CovarianceError, match="positive definite"):
        update(x, P, np.array([1.0]), h, H, np.array([0.0]))
    with pytest.raises(CovarianceError):
        ExtendedKalmanFilter(x, -np.eye(2), f, F, h, H, Q, R)
    # a non-PD innovation covariance is caught even on the unchecked fast path
    with pytest.raises(CovarianceError):
        correct(x, np.zeros((2, 2)), np.array([1.0]), np.array([[1.0, 0.0]]),
                np.array([-1.0]), check=False)
    assert issubclass(CovarianceError, EstimationError)
    # the project's typed error (a bare ValueError passed), naming what is wrong
    with pytest.raises(ConfigError, match=r"gate probability must be in \(0, 1\)"):
        Gate(1.5)


# -- estimate projection onto bounds --------------------------------------------------------

def test_projection_leaves_an_estimate_inside_its_bounds_alone():
    from terrain.estimation.ekf import project_to_bounds
    rng = np.random.default_rng(0)
    P = _random_spd(4, rng)
    x = np.array([0.2, -0.1, 3.0, 0.0])
    xc, active = project_to_bounds(x, P, [-1, -1, -np.inf, -1], [1, 1, np.inf, 1])
    np.testing.assert_array_equal(xc, x)
    assert not active.any()
    xc[0] = 9.0
    assert x[0] == 0.2                     # a copy, the input untouched


def test_projection_moves_the_correlated_states_along_with_the_bounded_one():
    """Speed and slip anti-correlated as along the direction the wheels cannot see (the
    speed falls as the slip climbs, v (1 - s) = omega r): pushing the speed back onto its
    bound moves the slip by P_sv / P_vv times the speed's change (Simon & Chia 2002 eq. 13),
    where clipping would leave the slip where it ran off to."""
    from terrain.estimation.ekf import project_to_bounds
    P = np.array([[0.04, -0.018], [-0.018, 0.01]])         # correlation -0.9
    x = np.array([-3.3, 0.85])
    xc, active = project_to_bounds(x, P, [-1.1, -1.0], [1.1, 1.0])
    assert xc[0] == -1.1 and active.tolist() == [True, False]
    np.testing.assert_allclose(xc[1], 0.85 - 0.45 * 2.2)  # -0.14
    # correlated the other way the slip is pushed to 1.84, past its own bound: it joins
    # the active set and both are held
    xc, active = project_to_bounds(x, np.abs(P), [-1.1, -1.0], [1.1, 1.0])
    assert active.tolist() == [True, True] and xc.tolist() == [-1.1, 1.0]


@pytest.mark.parametrize("seed", range(5))
def test_projection_is_the_closest_point_on_the_active_bounds_in_the_covariance_metric(seed):
    """KKT of min (x_c - x)^T P^-1 (x_c - x) with the active states held at their bounds:
    the gradient P^-1 (x_c - x) vanishes on every free state, and the result is inside."""
    from terrain.estimation.ekf import project_to_bounds
    rng = np.random.default_rng(seed)
    n = 6
    P = _random_spd(n, rng)
    x = rng.normal(scale=3.0, size=n)
    lower, upper = np.full(n, -1.0), np.full(n, 1.0)
    lower[::3], upper[::3] = -np.inf, np.inf               # some states free
    xc, active = project_to_bounds(x, P, lower, upper)
    assert np.all(xc >= lower - 1e-12) and np.all(xc <= upper + 1e-12)
    assert active.any()
    grad = np.linalg.solve(P, xc - x)
    np.testing.assert_allclose(grad[~active], 0.0, atol=1e-9)
    assert np.all(np.isclose(xc[active], lower[active]) | np.isclose(xc[active], upper[active]))


@pytest.mark.parametrize("seed", range(5))
def test_a_projection_restricted_to_some_states_holds_the_others_and_is_closest(seed):
    """With ``movable`` the held states stay exactly where they were, the movable ones
    satisfy their bounds, and the result is the closest such point in the covariance
    metric: the gradient P^-1 (x_c - x) vanishes on every movable state not at a bound
    (KKT with the held states as equality constraints). Bounds of held states are not
    applied."""
    from terrain.estimation.ekf import project_to_bounds
    rng = np.random.default_rng(seed)
    n = 6
    P = _random_spd(n, rng)
    x = rng.normal(scale=3.0, size=n)
    x[0] = 4.0                                              # violates its bound
    movable = np.array([True, True, False, True, False, True])
    lower, upper = np.full(n, -1.0), np.full(n, 1.0)
    lower[3], upper[3] = -np.inf, np.inf
    xc, active = project_to_bounds(x, P, lower, upper, movable)
    np.testing.assert_array_equal(xc[~movable], x[~movable])
    assert not active[~movable].any() and active[0]
    m = movable
    assert np.all(xc[m] >= lower[m] - 1e-12) and np.all(xc[m] <= upper[m] + 1e-12)
    grad = np.linalg.solve(P, xc - x)
    np.testing.assert_allclose(grad[m & ~active], 0.0, atol=1e-9)
    # all states movable: the unrestricted projection
    full, _ = project_to_bounds(x, P, lower, upper)
    np.testing.assert_array_equal(project_to_bounds(x, P, lower, upper, np.ones(n, bool))[0],
                                  full)
    with pytest.raises(ShapeError, match="movable"):
        project_to_bounds(x, P, lower, upper, movable[:3])


def test_projection_refuses_crossed_bounds_and_a_wrong_covariance():
    from terrain.estimation.ekf import project_to_bounds
    with pytest.raises(ShapeError, match="above upper"):
        project_to_bounds(np.zeros(2), np.eye(2), [0.0, 1.0], [1.0, 0.0])
    with pytest.raises(ShapeError, match="shape"):
        project_to_bounds(np.zeros(2), np.eye(3), [-1.0, -1.0], [1.0, 1.0])


def test_update_with_its_own_noise_equals_a_filter_built_with_it():
    """``update(..., R=...)`` (a block-averaged or adaptively weighted row) is the update of
    a filter whose ``R`` holds that noise; the filter's own ``R`` is untouched, and a
    noise that is not positive definite is a typed error."""
    f, F, h, H, Q = _cv_model()
    rng = np.random.default_rng(5)
    own = ExtendedKalmanFilter(np.zeros(2), np.eye(2), f, F, h, H, Q, np.array([1.0]))
    ref = ExtendedKalmanFilter(np.zeros(2), np.eye(2), f, F, h, H, Q, np.array([0.04]))
    for _ in range(20):
        z = rng.standard_normal(1)
        own.predict(0.1)
        ref.predict(0.1)
        a = own.update(z, rows=[0], R=np.array([0.04]))
        b = ref.update(z)
        np.testing.assert_allclose(own.x, ref.x, rtol=1e-12)
        np.testing.assert_allclose(own.P, ref.P, rtol=1e-12)
        assert a.nis == pytest.approx(b.nis)
    assert own.update(np.zeros(1)).S[0, 0] > 1.0          # its own R (1.0) again
    with pytest.raises(CovarianceError):
        own.update(np.zeros(1), R=np.array([-0.1]))


def test_gate_threshold_outside_its_table_raises_a_config_error():
    # Gate(max_dof=2).threshold(0) returned the 2-dof quantile (index -1) and a 3-row group
    # raised a bare IndexError from inside correct()
    gate = Gate(0.99, max_dof=2)
    assert gate.threshold(2) == pytest.approx(9.2103, rel=1e-4)
    for dof in (0, 3):
        with pytest.raises(ConfigError, match="max_dof"):
            gate.threshold(dof)
    with pytest.raises(ConfigError, match="max_dof >= 3"):
        correct(np.zeros(3), np.eye(3), np.ones(3), np.eye(3), np.ones(3), gate=gate)


@pytest.mark.parametrize("rows", [[5], [-1], [0, 0], [0.5]])
def test_streaming_update_refuses_rows_outside_the_measurement(rows):
    # rows=[0, 0] used one sample twice as two independent ones (NIS 2.0, state pulled
    # twice as hard), [-1] updated the last row, [0.5] row 0, [5] raised a bare IndexError
    f, F, _, _, Q = _cv_model()
    h = lambda x: x  # noqa: E731
    H = lambda x: np.eye(2)  # noqa: E731
    ekf = ExtendedKalmanFilter(np.zeros(2), np.eye(2), f, F, h, H, Q, np.ones(2))
    with pytest.raises(ShapeError, match="rows"):
        ekf.update(np.ones(len(rows)), rows=rows)
    np.testing.assert_array_equal(ekf.x, np.zeros(2))


def test_streaming_filter_refuses_a_scalar_measurement_noise_by_shape():
    # R = 0.1 (a scalar) raised a bare IndexError on R.shape[0]
    from terrain.errors import ShapeError
    from terrain.estimation.ekf import ExtendedKalmanFilter
    with pytest.raises(ShapeError, match="R must have shape"):
        ExtendedKalmanFilter(np.zeros(1), np.ones(1), lambda x, dt: x, lambda x, dt: np.eye(1),
                             lambda x: x, lambda x: np.eye(1), np.ones(1), 0.1)


@pytest.mark.parametrize("bad_q, error, match", [
    (lambda dt: np.eye(3) * dt, ShapeError, r"\(2, 2\)"),       # was NumPy's broadcast error
    (lambda dt: 0.1 * dt, ShapeError, r"\(2, 2\)"),             # was a bare AttributeError
    (lambda dt: np.full((2, 2), np.nan), NonFiniteInputError, "Q"),   # P all NaN
    (lambda dt: np.array([[dt, 1.0], [0.0, dt]]), CovarianceError, "symmetric"),  # halved in
    (lambda dt: -np.eye(2), CovarianceError, "semi-definite"),  # P min eigenvalue -0.99
    (lambda dt: np.array([dt, np.inf]), NonFiniteInputError, "Q"),
    (lambda dt: np.array([dt, -dt]), CovarianceError, "semi-definite")])
def test_a_callable_process_noise_is_checked_at_each_predict(bad_q, error, match):
    f, F, h, H, _ = _cv_model()
    ekf = ExtendedKalmanFilter(np.zeros(2), np.eye(2), f, F, h, H, bad_q, np.array([1.0]))
    with pytest.raises(error, match=match):
        ekf.predict(0.1)
    np.testing.assert_array_equal(ekf.P, np.eye(2))      # nothing propagated


def test_a_callable_diagonal_process_noise_gives_what_its_matrix_gives():
    f, F, h, H, _ = _cv_model()
    for q in (lambda dt: np.array([0.0, 0.2 * dt]), lambda dt: np.diag([0.0, 0.2 * dt]),
              lambda dt: np.array([[1e-3, 1e-4], [1e-4, 0.2 * dt]])):
        ekf = ExtendedKalmanFilter(np.zeros(2), np.eye(2), f, F, h, H, q, np.array([1.0]))
        ekf.predict(0.1)
        ref = predict(np.zeros(2), np.eye(2), 0.1, f, F, q)[1]
        np.testing.assert_array_equal(ekf.P, ref)


def test_a_non_finite_control_input_is_refused_and_the_filter_keeps_its_state():
    # Was: a NaN control input made the state NaN without a word, and the next update
    # failed with a misleading "S is not positive definite (NIS nan)".
    f = lambda x, dt, u: x + dt * u  # noqa: E731
    F = lambda x, dt, u: np.eye(1)  # noqa: E731
    ekf = ExtendedKalmanFilter(np.zeros(1), np.eye(1), f, F, lambda x: x,
                               lambda x: np.eye(1), np.array([0.1]), np.ones(1))
    ekf.predict(0.1, np.array([2.0]))
    np.testing.assert_allclose(ekf.x, [0.2])
    with pytest.raises(NonFiniteInputError, match="non-finite state"):
        ekf.predict(0.1, np.array([np.nan]))
    np.testing.assert_allclose(ekf.x, [0.2])                 # nothing propagated
    np.testing.assert_allclose(ekf.P, [[1.1]])
    ekf.update(np.array([0.4]))                              # and the filter goes on
    assert np.isfinite(ekf.x).all()


def test_gate_thresholds_are_the_chi_square_quantile_of_each_group_size():
    # a table read at the wrong index (e.g. d instead of d - 1, clamped at the top) gave the
    # right value only for the largest group size
    from scipy import stats
    gate = Gate(0.999, max_dof=6)
    for dof in range(1, 7):
        assert gate.threshold(dof) == pytest.approx(stats.chi2.ppf(0.999, dof), rel=1e-12)
    assert gate.threshold(1) == pytest.approx(10.828, rel=1e-4)     # textbook table value


def test_streaming_update_of_some_rows_wraps_angles_and_gates_by_sensor():
    """``update(z, rows=...)`` with a residual: the residual sees ``z`` placed in its rows of
    a full vector (an angle row is wrapped by position), and the sensor groups of the gate are
    re-indexed to the positions of the rows present."""
    f = lambda x, dt: x  # noqa: E731
    F = lambda x, dt: np.eye(3)  # noqa: E731
    h = lambda x: x.copy()  # noqa: E731
    H = lambda x: np.eye(3)  # noqa: E731

    def wrap_row_2(z, hx):
        y = z - hx
        y[2] = (y[2] + np.pi) % (2 * np.pi) - np.pi
        return y

    x0, P0, R = np.array([0.0, 0.0, 3.1]), np.eye(3), np.full(3, 0.01)
    ekf = ExtendedKalmanFilter(x0, P0, f, F, h, H, np.zeros(3), R, residual=wrap_row_2)
    inn = ekf.update(np.array([0.5, -3.1]), rows=[0, 2])    # heading across +-pi
    y_heading = -3.1 - 3.1 + 2 * np.pi                      # +0.083 rad, not -6.2
    np.testing.assert_allclose(inn.y, [0.5, y_heading], atol=1e-12)
    ref_x, ref_P, _ = correct(x0, P0, np.array([0.5, y_heading]), np.eye(3)[[0, 2]], R[[0, 2]])
    np.testing.assert_allclose(ekf.x, ref_x, atol=1e-12)
    np.testing.assert_allclose(ekf.P, ref_P, atol=1e-12)
    # gate with sensors {0, 1} and {2}: given rows [1, 2], the outlier in row 2 is rejected
    # alone (its group is position 1 of the rows present, not row 2 of a full vector)
    gated = ExtendedKalmanFilter(np.zeros(3), np.eye(3) * 0.01, f, F, h, H, np.zeros(3),
                                 np.full(3, 1e-4), gate=Gate(0.999),
                                 groups=[np.array([0, 1]), np.array([2])])
    inn = gated.update(np.array([0.01, 5.0]), rows=[1, 2])
    assert inn.accepted.tolist() == [True, False]
    assert gated.x[1] == pytest.approx(0.01 * 0.01 / (0.01 + 1e-4))
    assert gated.x[2] == 0.0


def test_an_innovation_with_no_number_is_refused_on_the_unchecked_path():
    # correct(check=False) is the run loop's path; a NaN innovation (a model's h gone NaN)
    # must raise rather than return a NaN state, and say so: it read "S is not positive
    # definite (NIS nan)", sending the engineer after the covariances
    with pytest.raises(NonFiniteInputError, match="innovation y is not finite"):
        correct(np.zeros(2), np.eye(2), np.array([np.nan]), np.array([[1.0, 0.0]]),
                np.array([0.1]), check=False)
    # a non-positive-definite S is still named as such
    with pytest.raises(CovarianceError, match="not positive definite"):
        correct(np.zeros(2), np.zeros((2, 2)), np.array([1.0]), np.array([[1.0, 0.0]]),
                np.array([0.0]), check=False)


@pytest.mark.parametrize("eps, ok", [(1e-9, True), (1e-5, False)])
def test_covariance_checks_allow_round_off_and_refuse_more(eps, ok):
    """A covariance asymmetric by ``eps`` of its scale, or with a smallest eigenvalue of
    ``-eps / 2`` times its largest: round-off (1e-9, under SYMMETRY_RTOL 1e-6 and PSD_RTOL
    1e-9) passes, a real asymmetry or a negative variance (1e-5) is refused."""
    f, F, h, H, Q = _cv_model()
    asym = np.array([[100.0, 1.0 + 100.0 * eps], [1.0, 1.0]])
    indefinite = np.diag([100.0, -100.0 * eps / 2.0])
    for P, match in ((asym, "not symmetric"), (indefinite, "not positive semi-definite")):
        if ok:
            predict(np.zeros(2), P, 0.1, f, F, Q)
        else:
            with pytest.raises(CovarianceError, match=match):
                predict(np.zeros(2), P, 0.1, f, F, Q)


def test_normalised_innovation_is_y_over_the_innovation_std():
    """``Innovation.normalised`` = ``y_i / sqrt(S_ii)`` (a standard-normal value for a
    consistent filter), from a known update: P = diag(3, 8), H = I, R = diag(1, 1)."""
    x, P = np.zeros(2), np.diag([3.0, 8.0])
    _, _, inn = correct(x, P, np.array([4.0, -6.0]), np.eye(2), np.array([1.0, 1.0]))
    np.testing.assert_allclose(np.diag(inn.S), [4.0, 9.0])
    np.testing.assert_allclose(inn.normalised, [2.0, -2.0])
    assert inn.nis == pytest.approx(4.0 ** 2 / 4.0 + 6.0 ** 2 / 9.0)


def test_an_update_noise_that_is_not_a_covariance_is_refused_even_when_s_stays_positive():
    """A negative per-update ``R`` with a large prior (``S = H P H^T + R`` still > 0, so the
    solve alone would accept it and shrink ``P`` below the optimal posterior) and an ``R``
    of the wrong length are typed errors, and the filter keeps its state."""
    f, F, h, H, Q = _cv_model()
    kf = ExtendedKalmanFilter(np.zeros(2), 100.0 * np.eye(2), f, F, h, H, Q, np.array([1.0]))
    with pytest.raises(CovarianceError, match="R is not positive definite"):
        kf.update(np.ones(1), R=np.array([-0.1]))
    with pytest.raises(CovarianceError, match="R is not positive definite"):
        kf.update(np.ones(1), rows=[0], R=np.array([[-0.1]]))
    with pytest.raises(ShapeError, match=r"R must have shape \(1, 1\)"):
        kf.update(np.ones(1), R=np.array([0.1, 0.1]))
    np.testing.assert_array_equal(kf.x, np.zeros(2))
    np.testing.assert_array_equal(kf.P, 100.0 * np.eye(2))
    assert kf.last_innovation is None


def test_an_update_of_a_later_row_alone_uses_that_rows_noise():
    """``rows=[1]`` with a diagonal ``R`` (a vector) takes ``R[1]``, not the first entry: the
    posterior equals :func:`correct` with ``H = [0, 1]`` and ``R = [R_1]`` (the rows subset
    tests above only sent row 0, where ``R[:1]`` is the same number)."""
    R = np.array([1e-4, 0.25])
    ekf = ExtendedKalmanFilter(np.zeros(2), np.eye(2), lambda x, dt: x, lambda x, dt: np.eye(2),
                               lambda x: x, lambda x: np.eye(2), np.zeros(2), R)
    inn = ekf.update(np.array([1.0]), rows=[1])
    x, P, ref = correct(np.zeros(2), np.eye(2), np.array([1.0]), np.array([[0.0, 1.0]]),
                        R[1:])
    np.testing.assert_allclose(ekf.x, x, rtol=1e-12)
    np.testing.assert_allclose(ekf.P, P, rtol=1e-12)
    assert ekf.x[1] == pytest.approx(1.0 / 1.25)          # P / (P + R_1) of a unit innovation
    assert inn.nis == pytest.approx(ref.nis) and inn.nis == pytest.approx(1.0 / 1.25)


@pytest.mark.parametrize("flag", [True, np.True_])
def test_a_boolean_time_step_is_refused(flag):
    """float(True) is 1.0: predict(..., dt=True) propagated the state over one second without
    a word (a flag passed where the step belongs). It is a TimeStepError like any other step
    that is not a number of seconds, and the streaming filter keeps its state."""
    f, F, h, H, Q = _cv_model()
    with pytest.raises(TimeStepError, match="time step must be a number"):
        predict(np.array([0.0, 1.0]), np.eye(2), flag, f, F, Q)
    ekf = ExtendedKalmanFilter(np.array([0.0, 1.0]), np.eye(2), f, F, h, H, Q, np.array([1.0]))
    with pytest.raises(TimeStepError, match="time step must be a number"):
        ekf.predict(flag)
    np.testing.assert_array_equal(ekf.x, [0.0, 1.0])
