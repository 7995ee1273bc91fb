"""Review veh3: the motor law's no-load term as MotorParams documents it."""

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
