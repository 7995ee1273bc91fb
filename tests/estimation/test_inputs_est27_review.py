"""est27 review: the EKF core and the consistency statistics refuse inputs that are not real
numbers (text, complex, booleans through a conversion), callables that return arrays of the
wrong shape and gates that are not gates, with a typed error naming the argument; valid
inputs give the values they gave before."""

import numpy as np
import pytest

from terrain.errors import ConfigError, EstimationError, NonFiniteInputError, ShapeError
from terrain.errors import TimeStepError
from terrain.estimation import consistency as C
from terrain.estimation import ekf


def _f(x, dt):
    return x + dt


def _F(x, dt):
    return np.eye(x.size)


def _h(x):
    return x[:1]


def _H(x):
    return np.eye(1, x.size)


def _filter(**kw):
    args = dict(x0=np.zeros(2), P0=np.eye(2), f=_f, F=_F, h=_h, H=_H, Q=np.eye(2), R=[1.0])
    args.update(kw)
    return ekf.ExtendedKalmanFilter(**args)


@pytest.mark.parametrize("call, name", [
    (lambda: ekf.predict("ab", np.eye(2), 0.1, _f, _F, np.eye(2)), "x"),
    (lambda: ekf.predict(np.zeros(2), "ab", 0.1, _f, _F, np.eye(2)), "P"),
    (lambda: ekf.predict(np.zeros(2), np.eye(2), 0.1, _f, _F, "a"), "Q"),
    (lambda: ekf.predict(np.zeros(2), np.eye(2), 0.1, _f, _F, np.array(["1", "1"])), "Q"),
    (lambda: ekf.update(np.zeros(2), np.eye(2), "a", _h, _H, [1.0]), "z"),
    (lambda: ekf.update(np.zeros(2), np.eye(2), ["1.5"], _h, _H, [1.0]), "z"),
    (lambda: ekf.update(np.zeros(2), np.eye(2), [1.0], _h, _H, "a"), "R"),
    (lambda: ekf.correct(np.zeros(2), np.eye(2), "a", np.zeros((1, 2)), [1.0]), "innovation y"),
    (lambda: ekf.correct(np.zeros(2), np.eye(2), [1.0], "ab", [1.0]), "H"),
    (lambda: ekf.as_vector([1j], "v"), "v"),
    (lambda: ekf.as_vector(np.array([1 + 2j, 0]), "v"), "v"),
    (lambda: ekf.checked_process_noise("a", 1), "Q"),
    (lambda: _filter(R="ab"), "R"),
    (lambda: _filter().update([1.0], R="a"), "R"),
])
def test_text_and_complex_are_refused_naming_the_argument(call, name):
    # main: a bare ValueError/TypeError naming nothing, numeric text parsed, the imaginary
    # part of a complex array dropped (a warning only)
    with pytest.raises(EstimationError, match=f"{name} must hold real numbers"):
        call()


@pytest.mark.parametrize("call, name", [
    (lambda: ekf.predict(np.zeros(2), np.eye(2), 0.1, _f, _F, np.eye(2, dtype=bool)), "Q"),
    (lambda: ekf.correct(np.zeros(2), np.eye(2), [1.0], np.ones((1, 2), bool), [1.0]), "H"),
    (lambda: ekf.checked_process_noise(np.eye(2, dtype=bool), 2), "Q"),
    (lambda: _filter(R=[True]), "R"),
    (lambda: _filter().update([1.0], R=[True]), "R"),
])
def test_booleans_converted_before_the_refusal_are_now_refused(call, name):
    # main: a unit covariance / a 0-1 Jacobian (the conversion to float came first)
    with pytest.raises(EstimationError, match=f"{name} must hold numbers, got booleans"):
        call()


def test_a_time_step_of_text_is_refused():
    # main: "0.1" was a 0.1 s step
    with pytest.raises(TimeStepError, match="time step must be a number"):
        ekf.predict(np.zeros(2), np.eye(2), "0.1", _f, _F, np.eye(2))
    with pytest.raises(TimeStepError):
        _filter().predict("0.1")


@pytest.mark.parametrize("gate", ["x", 0.99])
def test_a_gate_that_is_not_a_gate_is_a_config_error(gate):
    # main: a bare AttributeError ('float' object has no attribute 'threshold')
    with pytest.raises(ConfigError, match="gate must be a Gate"):
        ekf.update(np.zeros(2), np.eye(2), [1.0], _h, _H, [1.0], gate=gate)
    with pytest.raises(ConfigError, match="gate must be a Gate"):
        _filter(gate=gate)


@pytest.mark.parametrize("dof", ["a", None, float("nan"), 1.5, True])
def test_gate_threshold_takes_integer_degrees_of_freedom_only(dof):
    # main: 1.5 and True gave the 1-dof quantile, the rest bare ValueError/TypeError
    with pytest.raises(ConfigError, match="dof must be an integer"):
        ekf.Gate().threshold(dof)
    assert ekf.Gate().threshold(np.int64(2)) == ekf.Gate().threshold(2)


def test_correct_refuses_a_state_that_is_not_an_array():
    # main: x.shape before the checks, a bare AttributeError
    with pytest.raises(ShapeError, match="x must have shape"):
        ekf.correct(None, np.eye(2), [1.0], np.zeros((1, 2)), [1.0])


def test_predict_refuses_f_and_F_of_the_wrong_shape_in_every_path():
    # main: with check=False (the streaming filter) an f of 3 values became the state and
    # an F of shape (n,) made a "covariance" by broadcasting; F of (3, 3) a bare ValueError
    for check in (True, False):
        with pytest.raises(ShapeError, match=r"f\(x, dt\) must have shape \(2,\)"):
            ekf.predict(np.zeros(2), np.eye(2), 0.1, lambda x, dt: np.zeros(3), _F, np.eye(2),
                        check=check)
        for bad in (np.ones(2), np.eye(3)):
            with pytest.raises(ShapeError, match=r"F\(x, dt\) must have shape \(2, 2\)"):
                ekf.predict(np.zeros(2), np.eye(2), 0.1, _f, lambda x, dt, b=bad: b,
                            np.eye(2), check=check)
    kf = _filter(f=lambda x, dt: np.zeros(3))
    with pytest.raises(ShapeError):
        kf.predict(0.1)
    assert kf.x.shape == (2,)       # nothing changed


def test_the_streaming_update_refuses_h_and_H_of_the_wrong_shape():
    # main: an h of 3 rows for m = 1 was cut to its first row; an H of 3 columns a bare
    # ValueError of NumPy's dot
    with pytest.raises(ShapeError, match=r"h\(x\) must have shape \(1,\)"):
        _filter(h=lambda x: np.zeros(3)).update([1.0])
    with pytest.raises(ShapeError, match=r"H\(x\) must have shape \(1, 2\)"):
        _filter(H=lambda x: np.zeros((1, 3))).update([1.0])


def test_valid_inputs_give_the_same_numbers_as_lists_and_as_arrays():
    x0, P0 = [0.5, -1.0], [[2.0, 0.3], [0.3, 1.0]]
    a = ekf.update(*ekf.predict(x0, P0, 0.1, _f, _F, [0.1, 0.2]), [1.0], _h, _H, [0.5])
    b = ekf.update(*ekf.predict(np.array(x0), np.array(P0), 0.1, _f, _F, np.array([0.1, 0.2]),
                                check=False), np.array([1.0]), _h, _H, np.array([0.5]))
    np.testing.assert_array_equal(a[0], b[0])
    np.testing.assert_array_equal(a[1], b[1])
    assert a[2].nis == b[2].nis
    kf = _filter(R=[0.5], Q=[0.1, 0.2], x0=x0, P0=P0)
    kf.predict(0.1)
    inn = kf.update([1.0])
    np.testing.assert_array_equal(kf.x, a[0])
    assert inn.nis == a[2].nis


@pytest.mark.parametrize("call, error, match", [
    (lambda: C.nees([[1.0]], np.full((1, 1, 1), np.inf)), NonFiniteInputError,
     "covariance is not finite at step 0"),
    (lambda: C.nees([[1.0], [1.0]], [[[1.0]], [[np.nan]]]), NonFiniteInputError,
     "covariance is not finite at step 1"),
    (lambda: C.nees("a", "b"), EstimationError, "errors must hold real numbers"),
    (lambda: C.state_errors("a", "b"), EstimationError, "estimates must hold real numbers"),
    (lambda: C.state_errors(np.zeros((2, 2)), np.zeros((2, 2)), None), ShapeError,
     "angle_columns"),
    (lambda: C.state_errors(np.zeros((2, 2)), np.zeros((2, 2)), 1), ShapeError,
     "angle_columns"),
    (lambda: C.rmse(None), EstimationError, "got None"),
    (lambda: C.rmse(["1.0"]), EstimationError, "errors must hold real numbers"),
    (lambda: C.rmse([1.0], ignore_nan="no"), ConfigError, "ignore_nan"),
    (lambda: C.mean_chi2_bounds(1, 10, "0.95"), ConfigError, "probability"),
    (lambda: C.chi2_test([1.0, 2.0], 1, "0.95"), ConfigError, "probability"),
    (lambda: C.integrated_autocorrelation_time(None), ShapeError, "series"),
    (lambda: C.integrated_autocorrelation_time(3.0), ShapeError, "series"),
    (lambda: C.integrated_autocorrelation_time(["1", "2", "3"]), EstimationError, "series"),
    (lambda: C.effective_sample_size(["1", "2", "3", "4"]), EstimationError, "series"),
    (lambda: C.chi2_test(["1", "2"], 1), EstimationError, "values"),
    (lambda: C.chi2_test([1.0, 2.0], "1"), EstimationError, "dof"),
])
def test_consistency_statistics_refuse_what_is_not_a_number(call, error, match):
    # main: a NEES of 0 for an infinite covariance, NaN for a NaN one, an RMSE of NaN for
    # None, numeric text parsed, "no" taken as True, bare TypeError/IndexError
    with pytest.raises(error, match=match):
        call()


def test_consistency_values_unchanged_for_valid_input():
    rng = np.random.default_rng(27)
    e = rng.normal(size=(50, 3))
    L = rng.normal(size=(50, 3, 3))
    P = L @ np.swapaxes(L, 1, 2) + 0.1 * np.eye(3)
    want = np.einsum("ij,ij->i", e, np.linalg.solve(P, e[..., None])[..., 0])
    np.testing.assert_array_equal(C.nees(e, P), want)
    e[3, 1] = np.nan                         # a step without truth: NaN there, nothing else
    out = C.nees(e, P)
    assert np.isnan(out[3]) and np.isfinite(np.delete(out, 3)).all()
    assert C.rmse([3.0, 4.0]) == np.sqrt(12.5)
    assert C.rmse([3.0, np.nan], ignore_nan=np.True_) == 3.0


def test_diagonal_process_noise_refuses_an_unknown_unit_and_a_bad_step():
    from terrain.estimation.model import diagonal_process_noise
    # main: "Step" (any text but "step") was per second, a negative step negative variances
    with pytest.raises(ConfigError, match="q_per"):
        diagonal_process_noise((1.0, 2.0), "Step", 0.1)
    for dt in (-0.1, 0.0, float("nan"), True):
        with pytest.raises(TimeStepError):
            diagonal_process_noise((1.0, 2.0), "second", dt)
    np.testing.assert_array_equal(diagonal_process_noise((1.0, 2.0), "second", 0.1),
                                  np.diag([0.1, 0.2]))
    np.testing.assert_array_equal(diagonal_process_noise((1.0, 2.0), "step", -1.0),
                                  np.diag([1.0, 2.0]))
