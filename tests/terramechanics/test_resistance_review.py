"""Slope of Wong's compaction resistance (review tests)."""

from __future__ import annotations

import numpy as np

from terrain.terramechanics.lateral import SOILS
from terrain.terramechanics.resistance import compaction_resistance_n


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
