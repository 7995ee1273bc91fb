"""Review veh3: the motor law's no-load term as MotorParams documents it, and the direction
of chi_from_truth's regression."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.vehicles import AGRIMARO, HUSKY, TRACKED


@pytest.mark.parametrize("vehicle", [HUSKY, TRACKED, AGRIMARO], ids=lambda v: v.name)
def test_no_load_current_is_the_smoothed_sign_of_the_wheel_speed(vehicle):
    m = vehicle.motor
    omega = np.array([0.0, 0.05, -0.05, 5.0])
    got = m.current_from_torque(np.zeros(4), omega)
    np.testing.assert_allclose(got, m.no_load_current_a * np.tanh(omega / 0.05), rtol=1e-15)
    assert got[0] == 0.0                                   # standstill: no no-load current
    assert got[1] == pytest.approx(0.7616 * m.no_load_current_a, rel=1e-4)
    assert got[3] == pytest.approx(m.no_load_current_a, rel=1e-12)
    # the torque term adds T / (G k_t eta) whatever the speed
    torque = m.current_from_torque(10.0, 5.0) - got[3]
    assert torque == pytest.approx(10.0 / (m.gear_ratio * m.torque_constant_nm_per_a
                                           * m.efficiency), rel=1e-12)


def test_chi_from_truth_regresses_the_side_speed_difference_on_the_yaw_rate():
    from terrain.vehicles.icr import chi_from_truth

    # d = v_R - v_L regressed on B w through the origin: sum(d B w) / sum((B w)^2) =
    # (0.3 * 0.2 + 0.5 * 0.4) / (0.2^2 + 0.4^2) = 1.3 with B = 1 (the reverse regression,
    # w on d, inverted, gives 0.34 / 0.26 = 1.3077); the standing sample (w = 0.05 below the
    # 0.1 rad/s threshold) is left out
    left = np.array([0.0, 0.0, 0.0])
    right = np.array([0.3, 0.5, 2.0])
    w = np.array([0.2, 0.4, 0.05])
    assert chi_from_truth(left, right, w, 1.0) == pytest.approx(1.3, rel=1e-12)
    assert chi_from_truth(left, 2.0 * right, w, 2.0) == pytest.approx(1.3, rel=1e-12)
