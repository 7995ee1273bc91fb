"""Second review pass of the online slip estimators (terrain.control.estimators): the
inputs the traction controller's enabling and stale-input guards read."""

from __future__ import annotations

import math

import numpy as np
import pytest
from control_helpers import observation

from terrain.control.estimators import (AgriMaRoVisualOdometryEKF, FusedSlipObserver,
                                        WheelImuObserver)
from terrain.sim.closed_loop import Observation


def test_the_wheel_imu_observer_hands_on_the_chassis_speed_as_a_magnitude_when_reversing():
    """chassis_speed_m_s is compared with the controller's enabling threshold (ch. 8.3.2,
    "magnitude of the overall chassis velocity"): reversing at -0.49 m/s (-1 m/s^2 over
    0.5 s at 100 Hz) hands on 0.49, while the side speeds keep their sign. A signed speed
    would keep the controller off for the whole reverse drive."""
    est = WheelImuObserver("husky")
    imu = np.array([[0.01 * k, -1.0, 0.0, 0.0] for k in range(50)])
    e = est.update(observation(0.5, np.zeros(2), imu=imu))
    assert e.chassis_speed_m_s == pytest.approx(0.49, abs=1e-12)
    np.testing.assert_allclose(e.v_long_m_s, [-0.49, -0.49], atol=1e-12)


def test_the_wheel_imu_observer_integrates_each_samples_own_acceleration():
    """``v <- v + dt a_x`` at every IMU sample, a_x that sample's: 0 m/s^2 at 0 s, then
    1 m/s^2 at 0.1 s gives 0.1 m/s and then 2 m/s^2 at 0.3 s 0.1 + 0.2 x 2 = 0.5 m/s (the
    previous sample's acceleration would give 0 and 0.2)."""
    est = WheelImuObserver("husky")
    imu = np.array([[0.0, 0.0, 0.0, 0.0], [0.1, 1.0, 0.0, 0.0]])
    assert est.update(observation(0.1, np.zeros(2), imu=imu)).chassis_speed_m_s == \
        pytest.approx(0.1)
    e = est.update(observation(0.3, np.zeros(2), imu=np.array([[0.3, 2.0, 0.0, 0.0]])))
    assert e.chassis_speed_m_s == pytest.approx(0.5)
    np.testing.assert_allclose(e.a_local_m_s2, [2.0, 2.0])


def test_the_agrimaro_estimate_age_runs_from_the_camera_samples_time():
    """The age the controller's stale-input guard reads is the time since the last camera
    sample the filter used, measured from that sample's stamp: a sample taken at 0.05 s and
    handed on in the call at 0.2 s is 0.15 s old then (beyond a 0.1 s max_input_age_s), not
    fresh; inf before the first."""
    est = AgriMaRoVisualOdometryEKF()

    def obs(t, cam):
        empty = np.zeros((0, 4))
        return Observation(t, np.zeros(3), empty, empty, empty, cam, empty, np.zeros((0, 7)))

    assert est.update(obs(0.02, np.zeros((0, 5)))).age_s == math.inf
    e = est.update(obs(0.2, np.array([[0.05, 0.0, 0.0, 0.0, 0.0]])))
    assert e.age_s == pytest.approx(0.15)


def test_the_fused_observer_skips_a_non_finite_wheel_sample():
    """A wheel sample holding NaN (an encoder dropout) is skipped: it neither enters the
    filter (whose state would turn NaN for good) nor becomes the latest encoder speed handed
    to the controller, and the estimate stays finite, also after the next good sample."""
    est = FusedSlipObserver("husky", None)
    e = est.update(observation(0.1, np.ones(2), wheels=np.array([[0.1, np.nan, 5.0]])))
    assert np.all(np.isfinite(est.x)) and np.all(np.isfinite(e.v_long_m_s))
    assert math.isfinite(e.chassis_speed_m_s)
    np.testing.assert_array_equal(e.omega_meas_rad_s, [0.0, 0.0])
    e = est.update(observation(0.2, np.ones(2), wheels=np.array([[0.2, 5.0, 5.0]])))
    np.testing.assert_array_equal(e.omega_meas_rad_s, [5.0, 5.0])
    assert np.all(np.isfinite(est.x)) and np.all(np.isfinite(e.v_long_m_s))
