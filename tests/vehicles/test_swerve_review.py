"""Boundary of the swerve inverse kinematics' minimum speed (review tests)."""

from __future__ import annotations

import numpy as np

from terrain.vehicles import AGRIMARO, swerve_inverse


def test_a_unit_at_the_minimum_speed_steers_and_one_below_it_keeps_its_angle():
    # every unit of a pure translation at 0.5 m/s moves at exactly 0.5 m/s
    twist = np.array([0.0, 0.5, 0.0])
    prev = np.full(3, 0.3)
    delta, omega = swerve_inverse(twist, delta_prev_rad=prev, min_speed_m_s=0.5)
    np.testing.assert_allclose(delta, 0.0, atol=1e-15)            # not below: it steers
    np.testing.assert_allclose(omega, 0.5 / AGRIMARO.wheel_radius_m)
    delta, omega = swerve_inverse(twist, delta_prev_rad=prev,
                                  min_speed_m_s=float(np.nextafter(0.5, 1.0)))
    np.testing.assert_array_equal(delta, prev)                     # below: keeps its angle
    np.testing.assert_array_equal(omega, 0.0)
