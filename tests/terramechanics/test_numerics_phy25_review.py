"""Review tests (phy25): numerical robustness of the terramechanics relations on valid input
(fixed points, domains of sqrt/exp, references computed another way)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import quad

from terrain.terramechanics.catalogue import TERRAINS
from terrain.terramechanics.combined_slip import combined_slip_coefficients
from terrain.terramechanics.lateral import SOILS, contact_chord_m, wheel_sinkage_m
from terrain.terramechanics.resistance import bekker_sinkage_m
from terrain.terramechanics.slip import ground_speed_from_slip, rim_speed_from_slip, sae_slip
from terrain.terramechanics.traction import brixius_traction, patch_mobilisation

#: Wong, Theory of Ground Vehicles, 4th ed., Table 2.3: heavy clay, 40 % moisture
#: (n = 0.11, k_c = 1.84 kN/m^(n+1), k_phi = 103.27 kN/m^(n+2), c = 20.69 kPa, phi = 6 deg).
HEAVY_CLAY = replace(SOILS["PLOUGHED"], name="heavy clay, 40 % moisture", n=0.11, k_c=1.84e3,
                     k_phi=103.27e3, cohesion_pa=20.69e3, friction_angle_deg=6.0)


def _assert_fixed_point(load_n, width_m, footprint_m, radius_m, soil, z, length):
    assert 0.0 <= z <= radius_m
    assert length == pytest.approx(float(contact_chord_m(z, radius_m, footprint_m)), rel=1e-9)
    expected = min(bekker_sinkage_m(load_n, width_m, length, soil.k_c, soil.k_phi, soil.n),
                   radius_m)
    assert z == pytest.approx(expected, rel=1e-9)


@pytest.mark.parametrize("load_n", [700.0, 1000.0, 1500.0, 3000.0, 4000.0])
def test_wheel_sinkage_is_the_fixed_point_on_a_heavy_clay_whatever_the_iteration_count(load_n):
    # with n = 0.11 the damped map of the contact length, l -> (l + l(z(l))) / 2, has the
    # slope 1/2 - 1/(4n) = -1.77 and oscillates: at 1000 N the sinkage was 16.7 mm after 30
    # iterations, 6.5 mm after 31 and 19.3 mm after 200, none of them Bekker's sinkage on
    # its own chord (6.5, 29.2 and 4.9 mm)
    results = [wheel_sinkage_m(load_n, 0.11, 0.08, 0.1651, HEAVY_CLAY, iterations=it)
               for it in (30, 31, 200)]
    for z, length in results:
        _assert_fixed_point(load_n, 0.11, 0.08, 0.1651, HEAVY_CLAY, z, length)
    assert results[0] == pytest.approx(results[1], rel=1e-9)
    assert results[0] == pytest.approx(results[2], rel=1e-9)


@settings(max_examples=80, deadline=None)
@given(n=st.floats(0.05, 2.0), load_n=st.floats(10.0, 5000.0),
       k_phi=st.floats(2e4, 5e6), width_m=st.floats(0.05, 0.5), radius_m=st.floats(0.1, 0.8))
def test_wheel_sinkage_is_bekkers_sinkage_on_its_own_chord_for_any_exponent(
        n, load_n, k_phi, width_m, radius_m):
    soil = replace(HEAVY_CLAY, n=n, k_phi=k_phi)
    z, length = wheel_sinkage_m(load_n, width_m, 0.08, radius_m, soil)
    _assert_fixed_point(load_n, width_m, 0.08, radius_m, soil, z, length)


@pytest.mark.parametrize("terrain_name", sorted(TERRAINS))
def test_combined_slip_secant_is_continuous_where_it_switches_to_the_slope_at_zero(
        terrain_name):
    # the friction ellipse takes d mu / ds at 0 below a resultant slip of 1e-12 and
    # mu(s) / s above it: Brixius's 1 - exp(-7.5 s) written out lost its digits there, so
    # the secant jumped by 8e-8 of itself (48 % at s = 1e-17 in mu itself)
    curve = TERRAINS[terrain_name].curve
    below, above = np.array([0.999e-12]), np.array([1.001e-12])
    zero = np.zeros(1)
    at_zero = combined_slip_coefficients(curve, below, zero, 1.0).secant[0]
    past = combined_slip_coefficients(curve, above, zero, 1.0).secant[0]
    assert past == pytest.approx(at_zero, rel=1e-9)    # ICE: c2 s / 2 = 1.5e-10


@settings(max_examples=60, deadline=None)
@given(slip=st.floats(1e-18, 1e-3), mobility=st.floats(0.5, 200.0))
def test_brixius_traction_keeps_its_digits_at_small_slip(slip, mobility):
    # reference: 1 - exp(-x) from its series, exact to the last bits for x <= 7.5e-3
    x = 7.5 * slip
    one_minus_e = x * (1.0 - x / 2.0 * (1.0 - x / 3.0 * (1.0 - x / 4.0 * (1.0 - x / 5.0))))
    amp = 0.88 * -math.expm1(-0.1 * mobility)
    mu = brixius_traction(np.array([slip]), mobility)[0][0]
    assert mu == pytest.approx(amp * one_minus_e, rel=1e-13, abs=0.0)


def _hump_shear(u, residual_ratio):
    """Wong's hump-type shear curve f(u) (ch. 2.4), written from its definition."""
    b = 1.0 / (residual_ratio * (1.0 - math.exp(-1.0))) - 1.0
    return residual_ratio * (1.0 + b * math.exp(1.0 - u)) * -math.expm1(-u)


@settings(max_examples=60, deadline=None)
@given(log_a=st.floats(-9.0, 2.5), residual_ratio=st.one_of(st.none(), st.floats(0.05, 0.95)))
def test_patch_mobilisation_is_the_patch_mean_of_the_shear_curve_by_quadrature(
        log_a, residual_ratio):
    # the closed forms and their series (below 1e-4) against the patch integral itself,
    # (1 / a) int_0^a tau(j) / tau_max d(j / K), by adaptive quadrature
    a = 10.0 ** log_a
    if residual_ratio is None:
        def curve(x):
            return -math.expm1(-x)
    else:
        kr = residual_ratio
        s0 = kr * (1.0 + (1.0 / (kr * (1.0 - math.exp(-1.0))) - 1.0) * math.e)   # f'(0)

        def curve(x):
            return _hump_shear(x / s0, kr)
    reference = quad(curve, 0.0, a, epsabs=0.0, epsrel=1e-13, limit=200)[0] / a
    g = patch_mobilisation(np.array([a]), residual_ratio)[0][0]
    assert g == pytest.approx(reference, rel=1e-8, abs=0.0)


@settings(max_examples=200, deadline=None)
@given(log_speed=st.floats(-9.0, 6.0), backwards=st.booleans(),
       slip=st.floats(-0.999, 0.999))
def test_rim_speed_from_slip_is_undone_by_sae_slip_at_any_speed_magnitude(
        log_speed, backwards, slip):
    # 1 nm/s to 1000 km/s: the inverse pair keeps the slip to a few ulps (no floor, no
    # dead band), in both directions of travel
    v = (-1.0 if backwards else 1.0) * 10.0 ** log_speed
    rim = rim_speed_from_slip(v, slip)[0]
    assert float(sae_slip(rim, v, dead_band_m_s=0.0)) == pytest.approx(slip, abs=1e-14)
    assert float(ground_speed_from_slip(rim, slip)) == pytest.approx(v, rel=1e-12)
