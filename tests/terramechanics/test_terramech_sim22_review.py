"""Boundary review of the terramechanics relations (sim22): values at and next to a limit."""

import numpy as np
import pytest

from terrain.terramechanics.slip import (ground_speed_from_slip, rim_speed_from_slip,
                                         sae_slip)


@pytest.mark.parametrize("q", [np.nextafter(-1.0, 0.0), -1.0 + 1e-15, -1.0 + 1e-13])
@pytest.mark.parametrize("rim", [1.0, -2.0])
def test_ground_speed_next_to_a_locked_wheel_is_the_inverse_not_a_floor(q, rim):
    """Just inside the domain, q = sign(omega r) s one ulp (or 1e-13) above -1, eq. 7.2 gives
    v = omega r / (1 + q). A 1e-12 floor on 1 + q (kept from before q = -1 was made NaN)
    returned omega r 1e12 there: at q = -1 + 1e-13 a tenth of the ground speed, at one ulp
    above -1 a ten-thousandth, and sae_slip of that speed was not the slip given."""
    slip = np.sign(rim) * q
    v = float(ground_speed_from_slip(rim, slip))
    assert v == pytest.approx(rim / (1.0 + q), rel=1e-12)
    assert float(sae_slip(rim, v, dead_band_m_s=0.0)) == pytest.approx(slip, abs=1e-15)
    # and it undoes rim_speed_from_slip there
    assert float(ground_speed_from_slip(rim_speed_from_slip(v, slip)[0], slip)) == \
        pytest.approx(v, rel=1e-9)
    assert np.isnan(ground_speed_from_slip(rim, np.sign(rim) * -1.0))


def test_ground_speed_of_a_nan_slip_stays_nan():
    got = ground_speed_from_slip(np.array([1.0, -1.0, 0.0]), np.array([np.nan] * 3))
    assert np.isnan(got).all()
