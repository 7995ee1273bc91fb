"""Review tests of the online slip estimators (terrain.control.estimators)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from control_helpers import observation

from terrain.control.estimators import FusedSlipObserver, WheelImuObserver


def test_the_fused_observer_hands_on_the_chassis_speed_as_a_magnitude_when_reversing():
    """chassis_speed_m_s is the magnitude the controller compares with its enabling
    threshold; a signed speed (-0.5 m/s reversing) would keep the controller off for the
    whole reverse drive."""
    est = FusedSlipObserver("husky", None)
    est.x[0] = -0.5                                    # v_bx: reversing at 0.5 m/s
    e = est.update(observation(1.0, np.zeros(2)))
    assert e.chassis_speed_m_s == pytest.approx(0.5)


def test_the_wheel_imu_observer_age_is_that_of_its_last_wheel_sample():
    """No wheel sample yet: age inf (the controller's safe output); after a sample at 1.0 s,
    a call at 1.3 s hands on 0.3 s (IMU samples alone do not renew it)."""
    est = WheelImuObserver("husky")
    imu = np.array([[0.5, 0.1, 0.0, 0.0]])
    assert est.update(observation(0.5, np.ones(2), imu=imu)).age_s == math.inf
    est.update(observation(1.0, np.ones(2), wheels=np.array([[1.0, 1.0, 1.0]])))
    imu = np.array([[1.3, 0.1, 0.0, 0.0]])
    assert est.update(observation(1.3, np.ones(2), imu=imu)).age_s == pytest.approx(0.3)
