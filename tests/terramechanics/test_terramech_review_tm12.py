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


def _fd(fun, v, h=1e-7):
    return (fun(v + h) - fun(v - h)) / (2 * h)


def test_coulomb_lateral_slope_is_the_secant_never_shallower_than_the_tangent():
    """``tanh(x) / x >= 1 / cosh^2(x)``: the docstring said "never steeper", the reverse."""
    from terrain.terramechanics.resistance import lateral_force_and_slope
    load = np.full(6, 100.0)
    v = np.array([-0.3, -0.02, -1e-3, 1e-3, 0.02, 0.3])
    force, slope = lateral_force_and_slope(0.5, load, v)
    assert np.allclose(slope, force / v)
    tangent = _fd(lambda x: lateral_force_and_slope(0.5, load, x)[0], v)
    assert np.all(slope <= 0.0) and np.all(np.abs(slope) >= np.abs(tangent) - 1e-6)


def test_soil_lateral_slope_is_the_secant_and_never_positive():
    """The soil law's secant is shallower than its tangent near 0 (``F ~ v^2``) and steeper
    once the strength is reached; it is ``F / v``, never positive, 0 at ``v = 0``."""
    from terrain.terramechanics.lateral import SOILS, soil_contact, soil_lateral_force_and_slope
    for name in SOILS:
        contact = soil_contact(SOILS[name], 0.11, 0.08, 0.165, 400.0)
        v = np.array([-0.5, -0.05, -1e-3, 0.0, 1e-3, 0.05, 0.5, 2.0])
        load, rim = np.full(v.size, 120.0), np.full(v.size, 0.5)
        force, slope, _ = soil_lateral_force_and_slope(contact, load, v, rim)
        nz = v != 0
        assert np.allclose(slope[nz], force[nz] / v[nz])
        assert np.all(slope <= 0.0) and slope[~nz] == 0.0
        tangent = _fd(lambda x: soil_lateral_force_and_slope(contact, load, x, rim)[0], v)
        assert abs(slope[4]) < abs(tangent[4])       # mobilising: shallower
        assert abs(slope[-1]) > abs(tangent[-1])     # saturated: steeper
