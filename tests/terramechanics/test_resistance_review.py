"""Slope of Wong's compaction resistance; the lateral laws' slide speed (review tests)."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import ConfigError
from terrain.terramechanics.lateral import SOILS, soil_contact, soil_lateral_force_and_slope
from terrain.terramechanics.resistance import (compaction_resistance_n, lateral_force_and_slope,
                                               lateral_force_n)


def test_compaction_slope_is_the_pressure_sinkage_force_at_the_rut_depth():
    # d/dz of b (k_c/b + k_phi) z^(n+1) / (n+1) is b (k_c/b + k_phi) z^n: the Bekker pressure
    # times the width (Wong eq. 2.33 integrated over depth, eq. 2.54)
    soil = SOILS["SANDY_LOAM"]
    b = 0.11
    z = np.array([0.0, 0.002, 0.01, 0.05])
    r, dr_dz = compaction_resistance_n(z, b, soil.k_c, soil.k_phi, soil.n)
    np.testing.assert_allclose(dr_dz, b * (soil.k_c / b + soil.k_phi) * z ** soil.n, rtol=1e-12)
    h = 1e-7
    up = compaction_resistance_n(z[1:] + h, b, soil.k_c, soil.k_phi, soil.n)[0]
    down = compaction_resistance_n(z[1:] - h, b, soil.k_c, soil.k_phi, soil.n)[0]
    np.testing.assert_allclose(dr_dz[1:], (up - down) / (2 * h), rtol=1e-6)
    assert r[0] == 0.0 and np.all(np.diff(r) > 0.0)


@pytest.mark.parametrize("slide_speed", [0.0, -0.02, float("nan"), float("inf"), True])
def test_lateral_force_refuses_a_slide_speed_that_is_not_positive(slide_speed):
    # v_slide = 0 divided by zero (NaN force at v_lat = 0, NaN slope everywhere); a
    # negative one flipped the friction into a pushing force
    with pytest.raises(ConfigError, match="slide_speed_m_s"):
        lateral_force_and_slope(0.5, np.array([100.0]), np.array([0.0]), slide_speed)
    with pytest.raises(ConfigError, match="slide_speed_m_s"):
        lateral_force_n(0.5, np.array([100.0]), np.array([0.1]), slide_speed)
    contact = soil_contact(SOILS["SANDY_LOAM"], 0.11, 0.08, 0.1651, 400.0)
    with pytest.raises(ConfigError, match="slide_speed_m_s"):
        soil_lateral_force_and_slope(contact, np.array([100.0]), np.array([0.0]),
                                     np.array([0.3]), slide_speed)


def test_lateral_force_opposes_sliding_at_the_default_slide_speed():
    force, slope = lateral_force_and_slope(0.5, np.full(3, 100.0), np.array([-0.1, 0.0, 0.1]))
    assert force[0] > 0.0 and force[1] == 0.0 and force[2] < 0.0
    assert np.all(np.isfinite(slope)) and np.all(slope < 0.0)
