"""Review tests (cnt10): the closed loop's estimators count the samples they skip for a NaN
or infinite value (``nonfinite_count``, ``estimator_nonfinite_samples`` of the metrics)."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.control.estimators import (AgriMaRoVisualOdometryEKF, FusedSlipObserver,
                                        WheelImuObserver)
from terrain.sim.closed_loop import Observation

NAN = np.nan


def _husky_obs(t, imu=None, imu_full=None, wheels=None, currents=None):
    imu = np.array([[t - 0.01, 0.0, 0.0, 0.0]]) if imu is None else imu
    full = np.array([[t - 0.01, 0.0, 0.0, 0.0, 0.0, 0.0, 9.81]]) if imu_full is None \
        else imu_full
    wheels = np.array([[t - 0.005, 1.0, 1.0]]) if wheels is None else wheels
    currents = np.array([[t - 0.005, 2.0, 2.0]]) if currents is None else currents
    return Observation(t, np.zeros(2), imu, wheels, np.zeros((0, 3)), np.zeros((0, 5)),
                       currents, full)


def test_fused_observer_counts_each_skipped_sample():
    # before: a NaN gyro, wheel or current sample was skipped without a trace
    est = FusedSlipObserver("husky", lambda t: ("SNOW", 1.0))
    est.update(_husky_obs(0.02))
    assert est.nonfinite_count == 0
    est.update(_husky_obs(0.04, imu_full=np.array([[0.031, 0.0, 0.0, NAN, 0.0, 0.0, 9.81]]),
                          wheels=np.array([[0.035, np.inf, 1.0]]),
                          currents=np.array([[0.035, NAN, 2.0]])))
    assert est.nonfinite_count == 3
    # the simplified IMU is not what the default (full-gyro) view reads: not counted
    est.update(_husky_obs(0.06, imu=np.array([[0.051, NAN, 0.0, 0.0]])))
    assert est.nonfinite_count == 3


def test_wheel_imu_observer_counts_each_skipped_sample():
    est = WheelImuObserver("husky")
    est.update(_husky_obs(0.02))
    est.update(_husky_obs(0.04, imu=np.array([[0.031, NAN, 0.0, 0.0]]),
                          wheels=np.array([[0.035, NAN, 1.0]]),
                          imu_full=np.array([[0.031, 0.0, 0.0, NAN, 0.0, 0.0, 9.81]]),
                          currents=np.array([[0.035, NAN, 2.0]])))
    assert est.nonfinite_count == 2          # the full IMU and the currents are not read
    assert np.isfinite(est.v)


def _agrimaro_obs(t, imu_full, wheels, cam):
    return Observation(t, np.zeros(3), np.zeros((0, 4)), wheels, np.zeros((0, 4)), cam,
                       np.zeros((0, 4)), imu_full)


@pytest.mark.parametrize("view, expect", [("full-gyro", 3), ("full-averaged", 4)])
def test_agrimaro_ekf_counts_the_samples_it_skips_of_what_its_view_reads(view, expect):
    est = AgriMaRoVisualOdometryEKF(imu=view)
    imu_full = np.array([[0.01, 0.0, 0.0, NAN, 0.0, 0.0, 9.81],     # gyro NaN: counted
                         [0.02, 0.0, 0.0, 0.0, NAN, 0.0, 9.81],     # ax NaN: read when averaged
                         [0.03, 0.0, 0.0, 0.0, 0.0, 0.0, 9.81]])
    wheels = np.array([[0.015, NAN, 1.0, 1.0], [0.025, 1.0, 1.0, 1.0]])
    cam = np.array([[0.02, NAN, 0.0, 0.0, 0.0],                      # v_cx NaN: counted
                    [0.03, 0.0, 0.0, 0.0, NAN]])                     # yaw_c is not read
    est.update(_agrimaro_obs(0.04, imu_full, wheels, cam))
    assert est.nonfinite_count == expect
    assert np.all(np.isfinite(est.ekf.x))


def test_the_closed_loop_metrics_carry_the_count():
    from terrain.control.closed_loop import run_closed_loop

    _, _, m = run_closed_loop("husky", "ICE", "straight_accel", True, 3, duration_s=0.3)
    assert m["estimator_nonfinite_samples"] == 0      # the simulated sensors give no NaN
