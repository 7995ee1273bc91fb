"""Review of the simulator core: the attitude the truth stream and the IMU report agrees with
the gravity the dynamics apply on the inclined plane."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.sim.dynamics import slope_attitude
from terrain.sim.forces import gravity_force, specific_force_m_s2
from terrain.sim.sensors import gravity_specific_force


def test_facing_along_the_contour_the_uphill_side_is_the_right_one():
    # the plane rises along world +x; facing world +y (yaw pi/2) the right side (body -y)
    # points to world +x, uphill: right side up is a negative roll, and no pitch
    slope = np.radians(15.0)
    pitch, roll = slope_attitude(slope, 0.5 * np.pi)
    assert pitch == pytest.approx(0.0, abs=1e-12)
    assert roll == pytest.approx(-slope, rel=1e-12)
    pitch, roll = slope_attitude(slope, -0.5 * np.pi)
    assert roll == pytest.approx(slope, rel=1e-12)


@pytest.mark.parametrize("yaw", [0.0, 0.4, 1.2, 0.5 * np.pi, 2.5, np.pi, -0.7, -2.0])
def test_the_imu_gravity_is_the_specific_force_of_the_dynamics_gravity(yaw):
    # what the IMU adds for gravity at the reported pitch and roll is what the dynamics'
    # gravity along the plane gives as specific force at rest, -F_g / m, on both axes
    slope, mass = np.radians(15.0), 50.0
    pitch, roll = slope_attitude(slope, yaw)
    g_x, g_y, g_z = gravity_specific_force(np.array([pitch]), np.array([roll]))
    f = specific_force_m_s2(np.zeros(2), gravity_force(mass, slope, yaw), mass)
    np.testing.assert_allclose([g_x[0], g_y[0]], f, atol=1e-12)
    assert g_z[0] == pytest.approx(9.80665 * np.cos(slope), rel=1e-12)
