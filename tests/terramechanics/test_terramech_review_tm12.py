"""Review tm12 of the terramechanics: limits, slopes against finite differences, docstrings."""

import numpy as np
import pytest

from terrain.terramechanics.slip import sae_slip_and_velocity_slope


@pytest.mark.parametrize("floor", [1e-4, 5e-4, 0.02])
def test_velocity_slope_matches_finite_difference_below_one_mm_per_s(floor):
    """``d s / d v_long`` where the body speed sets the denominator is ``-w sign(v) / v^2``
    (seed 001 eq. 7.2 differentiated) for any floor > 0: the slope was clamped at
    ``v^2 >= 1e-6`` and came out -500 instead of -781 s/m at w = 0.5 mm/s, v = 0.8 mm/s
    (floor 0.1 mm/s)."""
    v = np.array([1.6, -1.6, 4.0, -3.0]) * floor          # body speed dominates
    rim = np.array([1.0, -1.2, 1.5, -2.0]) * floor        # same sign: |slip| < 1
    s, d = sae_slip_and_velocity_slope(rim, v, floor)
    assert np.all(np.abs(s) < 1.0)
    h = 1e-6 * np.abs(v)
    fd = (sae_slip_and_velocity_slope(rim, v + h, floor)[0]
          - sae_slip_and_velocity_slope(rim, v - h, floor)[0]) / (2 * h)
    assert np.allclose(d, fd, rtol=1e-5)
    assert np.allclose(d, -rim * np.sign(v) / v ** 2, rtol=1e-12)
