"""Review tests (ctl12): a sensor sample whose *time* is NaN or infinite is skipped and
counted in ``nonfinite_count``, as one with a non-finite value is; it neither poisons the
estimate nor reorders the other samples of its observation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from terrain.control.estimators import (AgriMaRoVisualOdometryEKF, FusedSlipObserver,
                                        WheelImuObserver, _merged)
from terrain.sim.closed_loop import Observation

NAN = np.nan


def _husky_obs(t, imu=None, wheels=None):
    imu = np.array([[t - 0.01, 0.5, 0.0, 0.0]]) if imu is None else imu
    full = np.array([[t - 0.01, 0.0, 0.0, 0.0, 0.5, 0.0, 9.81]])
    wheels = np.array([[t - 0.005, 1.0, 1.0]]) if wheels is None else wheels
    return Observation(t, np.ones(2), imu, wheels, np.zeros((0, 3)), np.zeros((0, 5)),
                       np.array([[t - 0.005, 2.0, 2.0]]), full)


@pytest.mark.parametrize("bad_t", [NAN, np.inf])
def test_wheel_imu_observer_skips_and_counts_an_imu_sample_of_unknown_time(bad_t):
    # before: v += (nan - t_imu) a made the speed NaN for good (the controller's safe
    # output at every later step, the age still fresh) and nothing was counted
    est = WheelImuObserver("husky")
    est.update(_husky_obs(0.02))
    est.update(_husky_obs(0.04, imu=np.array([[bad_t, 0.5, 0.0, 0.0]])))
    for k in range(3, 10):
        out = est.update(_husky_obs(0.02 * k))
    assert est.nonfinite_count == 1
    assert np.all(np.isfinite(out.v_long_m_s)) and math.isfinite(out.chassis_speed_m_s)


def test_fused_observer_skips_and_counts_a_sample_of_unknown_time():
    est = FusedSlipObserver("husky", lambda t: ("SNOW", 1.0))
    est.update(_husky_obs(0.02))
    est.update(_husky_obs(0.04, wheels=np.array([[np.inf, 1.0, 1.0]])))
    assert est.nonfinite_count == 1
    assert math.isfinite(est.t) and est.t <= 0.04      # before: inf, no predict ever again
    out = est.update(_husky_obs(0.06))
    assert np.all(np.isfinite(est.x)) and np.all(np.isfinite(out.v_long_m_s))


def test_agrimaro_ekf_skips_and_counts_a_camera_sample_of_unknown_time():
    est = AgriMaRoVisualOdometryEKF()
    cam = np.array([[NAN, 0.5, 0.0, 0.0, 0.0]])
    wheels = np.array([[0.015, 1.0, 1.0, 1.0]])
    full = np.array([[0.01, 0.0, 0.0, 0.0, 0.0, 0.0, 9.81]])
    out = est.update(Observation(0.04, np.zeros(3), np.zeros((0, 4)), wheels,
                                 np.zeros((0, 4)), cam, np.zeros((0, 4)), full))
    assert est.nonfinite_count == 1
    assert out.age_s == math.inf                  # no camera sample of known time yet


def test_merged_keeps_the_finite_times_in_order_around_a_nan_time():
    # list.sort with a NaN key left [0.03, nan, 0.01] as it was: out of order
    obs = _husky_obs(0.04, imu=np.array([[0.03, 0.0, 0.0, 0.0], [NAN, 0.0, 0.0, 0.0],
                                         [0.01, 0.0, 0.0, 0.0]]),
                     wheels=np.zeros((0, 3)))
    times = [t for t, _, _ in _merged(obs)]
    finite = [t for t in times if math.isfinite(t)]
    assert finite == sorted(finite)
    assert not math.isfinite(times[-1])


def _agrimaro_call(t, ts=None):
    ts = t if ts is None else ts
    return Observation(t, np.full(3, 3.0), np.zeros((0, 4)),
                       np.array([[ts - 0.005, 3.0, 3.0, 3.0]]), np.zeros((0, 4)),
                       np.array([[ts - 0.005, 0.5, 0.0, 0.0, 0.0]]), np.zeros((0, 4)),
                       np.array([[ts - 0.01, 0.0, 0.0, 0.0, 0.0, 0.0, 9.81]]))


def test_agrimaro_speed_slope_survives_a_call_of_unknown_time():
    """The full-gyro view's speed window took the call time as it came: a NaN time stayed
    at the window's head for good (nan < t is never true, so it was never dropped), and the
    next least-squares slope raised numpy's bare LinAlgError ("SVD did not converge"),
    which stopped the closed loop that promises its safe output at such a call."""
    est = AgriMaRoVisualOdometryEKF()
    for k in range(1, 30):
        est.update(_agrimaro_call(0.02 * k))
    out = est.update(Observation(NAN, np.full(3, 3.0), np.zeros((0, 4)), np.zeros((0, 4)),
                                 np.zeros((0, 4)), np.zeros((0, 5)), np.zeros((0, 4)),
                                 np.zeros((0, 7))))
    assert not math.isfinite(out.age_s)            # the controller's safe output
    for k in range(31, 80):
        out = est.update(_agrimaro_call(0.02 * k))
    assert np.all(np.isfinite(out.a_local_m_s2)) and math.isfinite(out.age_s)
    assert all(math.isfinite(t) for t, _ in est._speeds)
    assert len(est._speeds) <= 0.5 / 0.02 + 2


def test_the_closed_loop_on_the_agrimaro_ekf_gives_its_safe_output_at_a_nan_call_time():
    from terrain.control import build_slip_table, config_for_vehicle
    from terrain.control.closed_loop import TractionLoop

    cfg, n = config_for_vehicle("agrimaro", kp=5.0)
    loop = TractionLoop(cfg, n, AgriMaRoVisualOdometryEKF(), build_slip_table(["GRASS"]),
                        lambda t: ("GRASS", 1.0))
    for k in range(1, 30):
        loop(_agrimaro_call(0.02 * k))
    c = loop(_agrimaro_call(NAN, ts=0.6))
    assert loop.log[-1]["safe"].all() and np.all(c == 0.0)
    for k in range(31, 60):
        loop(_agrimaro_call(0.02 * k))
    assert not loop.log[-1]["safe"].any()
