"""State, aliasing and reuse of the estimation layer (review est23)."""

from __future__ import annotations

import copy

import numpy as np
from hypothesis import given, settings, strategies as st

from terrain.estimation.ekf import ExtendedKalmanFilter, correct, predict, update


def _linear(n: int = 2):
    A = np.array([[1.0, 0.1], [0.0, 1.0]])
    f = (lambda x, dt: A @ x)
    F = (lambda x, dt: A)
    h = (lambda x: x[:1].copy())
    H = (lambda x: np.array([[1.0, 0.0]]))
    return f, F, h, H


def test_filter_does_not_alias_the_callers_initial_arrays():
    """Changing x0, P0, Q or R after construction must not change the filter."""
    f, F, h, H = _linear()
    x0 = np.array([1.0, 2.0])
    P0 = np.eye(2)
    Q = np.eye(2) * 0.01
    R = np.array([0.5])
    ekf = ExtendedKalmanFilter(x0, P0, f, F, h, H, Q, R)
    ref = ExtendedKalmanFilter(x0.copy(), P0.copy(), f, F, h, H, Q.copy(), R.copy())
    x0[:] = 99.0        # the caller reuses its buffers for the next filter
    P0[:] = 7.0 * np.eye(2)
    Q[:] = 3.0 * np.eye(2)
    R[:] = 1e-6
    np.testing.assert_array_equal(ekf.x, ref.x)
    np.testing.assert_array_equal(ekf.P, ref.P)
    for e in (ekf, ref):
        e.predict(0.1)
        e.update(np.array([1.5]))
    np.testing.assert_array_equal(ekf.x, ref.x)
    np.testing.assert_array_equal(ekf.P, ref.P)


def test_filter_2d_R_not_aliased():
    f, F, h, H = _linear()
    R = np.array([[0.5]])
    ekf = ExtendedKalmanFilter(np.zeros(2), np.eye(2), f, F, h, H, np.eye(2) * 0.01, R)
    R[0, 0] = 1e-9
    inn = ekf.update(np.array([1.0]))
    assert inn.S[0, 0] == 1.0 + 0.5


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(-10, 10), min_size=2, max_size=2),
       st.floats(0.1, 5.0), st.floats(0.01, 2.0), st.floats(-5, 5))
def test_pure_functions_leave_their_inputs_alone(x, p, r, z):
    """predict / update / correct are pure: no input is written."""
    f, F, h, H = _linear()
    x = np.array(x)
    P = np.array([[p, 0.1], [0.1, p]])
    Q = np.eye(2) * 0.01
    R = np.array([r])
    zz = np.array([z])
    keep = copy.deepcopy((x, P, Q, R, zz))
    xp, Pp = predict(x, P, 0.1, f, F, Q)
    xu, Pu, inn = update(xp, Pp, zz, h, H, R)
    y = zz - h(x)
    y_keep = y.copy()
    Hm = H(x)
    xc, Pc, _ = correct(x, P, y, Hm, R)
    for a, b in zip((x, P, Q, R, zz), keep):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(y, y_keep)
    for out in (xp, Pp, xu, Pu, xc, Pc):
        for inp in (x, P, Q, R, zz, y):
            assert not np.shares_memory(out, inp)


def _skid_steer_samples(n: int = 60):
    from terrain.estimation.runner import SensorSamples
    t = np.arange(n) * 0.02
    wheels = SensorSamples(t, np.column_stack([np.full(n, 0.5), np.full(n, 0.6)]))
    gyro = SensorSamples(t, np.full((n, 1), 0.1))
    return t, {"wheels": wheels, "gyro": gyro}


def test_run_filter_result_does_not_alias_the_grid_or_x0():
    """Shifting a result's times in place (to absolute time) must not move the grid that
    the next run is filtered on."""
    from terrain.estimation.runner import run_filter
    from terrain.estimation.skid_steer import SkidSteerModel, SkidSteerSettings
    model = SkidSteerModel(SkidSteerSettings())
    t, samples = _skid_steer_samples()
    grid = t.copy()
    x0 = np.asarray(model.x0, dtype=float).copy()
    keep = (grid.copy(), x0.copy())
    for engine in ("numpy", "auto"):
        res = run_filter(model, grid, samples, x0=x0, engine=engine)
        assert not np.shares_memory(res.t_s, grid)
        res.t_s += 100.0
        np.testing.assert_array_equal(grid, keep[0])
        np.testing.assert_array_equal(x0, keep[1])
    again = run_filter(model, grid, samples, x0=x0, engine="numpy")
    first = run_filter(model, keep[0], samples, x0=keep[1], engine="numpy")
    np.testing.assert_array_equal(again.x, first.x)


def test_run_filter_leaves_the_samples_alone():
    from terrain.estimation.runner import run_filter
    from terrain.estimation.skid_steer import SkidSteerModel, SkidSteerSettings
    t, samples = _skid_steer_samples()
    samples["wheels"].values[5, 0] = np.nan
    keep = {k: (v.t_s.copy(), v.values.copy()) for k, v in samples.items()}
    res = run_filter(SkidSteerModel(SkidSteerSettings()), t, samples, engine="numpy")
    for k, (ts, vs) in keep.items():
        np.testing.assert_array_equal(samples[k].t_s, ts)
        np.testing.assert_array_equal(samples[k].values, vs)
        assert not np.shares_memory(res.t_s, samples[k].t_s)


def test_observer_result_does_not_alias_the_callers_times():
    from terrain.estimation.observer import run_adaptive_observer
    t = np.arange(50) * 0.1
    pose = np.column_stack([0.5 * t, np.zeros_like(t), np.zeros_like(t)])
    v = np.full(t.size, 0.5)
    keep = copy.deepcopy((t, pose, v))
    res = run_adaptive_observer(t, pose, v, v.copy())
    assert not np.shares_memory(res.t_s, t)
    res.t_s[:] = 0.0
    np.testing.assert_array_equal(t, keep[0])
    np.testing.assert_array_equal(pose, keep[1])
    np.testing.assert_array_equal(v, keep[2])


def _frozen_after_mutation(make, field: str, values: np.ndarray, bad: float):
    """Build with ``values`` as a NumPy array, then overwrite the caller's array: the
    validated settings must not follow it."""
    arr = np.array(values, dtype=float)
    obj = make(arr)
    arr[:] = bad
    held = getattr(obj, field)
    assert not isinstance(held, np.ndarray)
    np.testing.assert_array_equal(np.asarray(held, dtype=float), values)
    assert obj == make(np.array(values, dtype=float))
    return obj


def test_settings_keep_their_own_copy_of_array_fields():
    """A frozen settings object built from the caller's arrays kept them: refilling the
    array afterwards changed a validated, 'frozen' noise (to negative variances here)."""
    from terrain.estimation.agrimaro import (THESIS_P0, THESIS_Q, THESIS_R, AgriMaRoEKFSettings,
                                             AgriMaRoModel)
    from terrain.estimation.observer import AdaptiveObserverSettings
    from terrain.estimation.slip_state import THESIS_Q_CH4, SlipStateModel
    for field, values in (("q_diag", THESIS_Q), ("p0_diag", THESIS_P0), ("r_diag", THESIS_R)):
        s = _frozen_after_mutation(lambda a: AgriMaRoEKFSettings(**{field: a}), field,
                                   np.array(values), -1.0)
    model = AgriMaRoModel(settings=s)
    assert (np.diag(model.Q(0.01)) >= 0).all()
    for field in ("q_diag", "p0_diag"):
        m = _frozen_after_mutation(lambda a: SlipStateModel(**{field: a}), field,
                                   np.array(THESIS_Q_CH4), -1.0)
    assert (np.diag(m.Q(0.01)) >= 0).all()
    for field, values in (("l_gains", (2.0, 2.0, 10.0)), ("lambda_gains", (50.0, 50.0)),
                          ("eta0", (1.0, 1.0)), ("eta_bounds", (0.02, 2.0))):
        _frozen_after_mutation(lambda a: AdaptiveObserverSettings(**{field: a}), field,
                               np.array(values), -5.0)


def test_sensor_samples_keep_their_own_checked_arrays():
    """SensorSamples checks its times once; it kept the caller's arrays, so a caller reusing
    its buffer (here writing an earlier time) gave a filter samples out of order unchecked."""
    from terrain.estimation.runner import SensorSamples
    t = np.arange(5) * 0.1
    v = np.ones((5, 2))
    s = SensorSamples(t, v)
    assert not np.shares_memory(s.t_s, t) and not np.shares_memory(s.values, v)
    t[3] = 0.0
    v[:] = np.nan
    np.testing.assert_array_equal(s.t_s, np.arange(5) * 0.1)
    np.testing.assert_array_equal(s.values, np.ones((5, 2)))


def test_agrimaro_settings_keep_their_own_ema_pairs():
    """ema_alpha given as a list of [sensor, alpha] lists stayed the caller's: an alpha
    written afterwards (1.5, refused by the check) reached the EMA filter."""
    from terrain.estimation.agrimaro import AgriMaRoEKFSettings
    pairs = [["cam", 0.2], ["imu", 0.1]]
    s = AgriMaRoEKFSettings(ema_alpha=pairs)
    pairs[0][1] = 1.5
    pairs.append(["steer", 0.9])
    assert s.ema_alpha == (("cam", 0.2), ("imu", 0.1))
    assert s.alpha("cam") == 0.2 and s.alpha("steer") == 0.0
    assert s == AgriMaRoEKFSettings(ema_alpha=(("cam", 0.2), ("imu", 0.1)))
