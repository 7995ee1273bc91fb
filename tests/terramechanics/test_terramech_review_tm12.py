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


@pytest.mark.parametrize("residual_ratio", [None, 0.4, 0.9])
def test_combined_shear_shares_give_the_resultant_shear_along_each_direction(residual_ratio):
    """Each direction's force is the patch mean of the resultant's shear curve projected on
    it, ``g(a) a_i / a`` (Wong eq. 2.56 along the resultant displacement), integrated here
    by quadrature: ``share_i g(a_i)`` must equal it (a long share of ``h_x / h_res``, the
    inverse, passed the existing tests)."""
    from scipy.integrate import quad

    from terrain.terramechanics.lateral import combined_shear_shares
    from terrain.terramechanics.traction import patch_mobilisation

    a_x = np.array([0.7, 2.0, 1e-3, 5.0])
    a_y = np.array([1.3, 0.5, 0.8, 0.0])
    share_x, share_y = combined_shear_shares(a_x, a_y, residual_ratio)
    for i in range(a_x.size):
        a = np.hypot(a_x[i], a_y[i])
        mean = quad(lambda t: _shear_curve(t, residual_ratio), 0.0, a)[0] / a
        for share, a_i in ((share_x[i], a_x[i]), (share_y[i], a_y[i])):
            if a_i == 0.0:
                assert share == pytest.approx((mean / a) / 0.5)  # h(0) = 1/2
                continue
            one_way = float(patch_mobilisation(np.array([a_i]), residual_ratio)[0][0])
            assert share * one_way == pytest.approx(mean * a_i / a, rel=1e-9)
    assert share_x[3] == pytest.approx(1.0)   # no lateral slip: the whole longitudinal shear


def _shear_curve(j, residual_ratio):
    """Wong's shear curve ``tau / tau_max`` at ``j / K`` (exponential, or hump-type with the
    stiffness-matched ``K_w``, :func:`terrain.terramechanics.traction.patch_mobilisation`)."""
    if residual_ratio is None:
        return 1.0 - np.exp(-j)
    kr = residual_ratio
    b = 1.0 / (kr * (1.0 - np.exp(-1.0))) - 1.0
    u = j / (kr * (1.0 + b * np.e))
    return kr * (1.0 + b * np.exp(1.0 - u)) * (1.0 - np.exp(-u))


@pytest.mark.parametrize("floor", [0.0, -0.01, np.inf, np.nan])
def test_velocity_slope_refuses_a_floor_that_is_not_positive_and_finite(floor):
    """Floor 0 divided 0 by 0 at a wheel at rest on a body at rest (NaN slip and slope)."""
    from terrain.errors import EstimationError
    with pytest.raises(EstimationError, match="speed_floor_m_s"):
        sae_slip_and_velocity_slope(np.zeros(2), np.array([0.0, 0.1]), floor)


@pytest.mark.parametrize("residual_ratio", [None, 0.05, 0.2, 0.4, 0.6, 0.9, 0.99])
def test_patch_mean_stays_below_one_and_shares_never_exceed_one(residual_ratio):
    """The hump curve itself rises a few per cent above its peak strength (1.016 at K_r
    0.4, 1.066 at 0.05), but its patch mean stays below 1, and ``h(u) = g(u) / u`` never
    rises (``f <= 2 g``), so neither combined-shear share exceeds 1 (the docstrings said
    "up to ~1.02" and "can give a share above 1")."""
    from terrain.terramechanics.lateral import combined_shear_shares, shear_mobilisation
    a = np.linspace(0.0, 60.0, 60001)
    assert shear_mobilisation(a, residual_ratio).max() < 1.0
    grid = np.geomspace(1e-6, 100.0, 120)
    ax, ay = np.meshgrid(grid, grid)
    share_x, share_y = combined_shear_shares(ax.ravel(), ay.ravel(), residual_ratio)
    assert share_x.max() <= 1.0 + 1e-12 and share_y.max() <= 1.0 + 1e-12
    assert share_x.min() > 0.0 and share_y.min() > 0.0


@pytest.mark.parametrize("name", ["ASPHALT", "ICE", "PACKED_SNOW", "SANDY_LOAM", "DIRT_ROAD"])
@pytest.mark.parametrize("fraction", [0.5, 0.95, 0.99])
def test_slip_at_peak_fraction_delivers_that_fraction_of_the_peak(name, fraction):
    """``mu(s) = fraction mu_peak`` on the stable side (a level of ``fraction^2 mu_peak``
    survived the existing tests)."""
    from terrain.terramechanics import get_terrain, traction_coefficient
    from terrain.terramechanics.inverse import slip_at_peak_fraction, stable_side_end
    curve = get_terrain(name).curve
    s_peak, mu_peak = stable_side_end(curve)
    s = slip_at_peak_fraction(curve, fraction)
    assert 0.0 < s < s_peak
    assert float(traction_coefficient(curve, s)) == pytest.approx(fraction * mu_peak,
                                                                  rel=1e-9)
