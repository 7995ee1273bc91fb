"""Catalogue values against their cited tables, and the definitions of the traction peak,
its inverse, the tractive efficiency and the slip's velocity slope.

Values are worked out here from the cited sources (Kiencke & Nielsen's table of
Burckhardt's coefficients, Wong's Table 2.3 through Mohr-Coulomb, Brixius's mobility
number and tractive efficiency), so that a changed catalogue number or a dropped term moves
a checked value.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from terrain.terramechanics import (BurckhardtCurve, JanosiCurve, TERRAINS, get_terrain,
                                    sae_slip, sae_slip_and_velocity_slope,
                                    traction_coefficient, traction_peak)
from terrain.terramechanics.efficiency import max_tractive_efficiency, tractive_efficiency
from terrain.terramechanics.inverse import slip_from_traction, stable_side_end
from terrain.terramechanics.lateral import (SOILS, combined_shear_shares, contact_chord_m,
                                            lateral_strength_n)
from terrain.terramechanics.resistance import (lateral_force_and_slope,
                                               soil_resistance_coefficient)
from terrain.terramechanics.traction import patch_mobilisation

W = 50.0 * 9.80665 / 4.0          # static Husky wheel load, N


@pytest.mark.parametrize("name, coefficients", [
    ("ASPHALT", (1.2801, 23.99, 0.52)), ("CONCRETE", (1.1973, 25.168, 0.5373)),
    ("FLOORING", (0.857, 33.822, 0.347)), ("TILES", (1.2801, 23.99, 0.52)),
    ("ICE", (0.05, 306.39, 0.0)), ("PACKED_SNOW", (0.1946, 94.129, 0.0646)),
])
def test_burckhardt_entries_are_the_tabulated_coefficients(name, coefficients):
    # Kiencke & Nielsen (2005): dry asphalt, dry concrete, wet asphalt, ice, snow
    curve = get_terrain(name).curve
    assert (curve.c1, curve.c2, curve.c3) == coefficients


@pytest.mark.parametrize("name, c_pa, phi_deg, area_m2, k_over_l", [
    ("SNOW", 1030.0, 19.7, 0.11 * 0.12, 0.04 / 0.12),
    ("SANDY_LOAM", 1720.0, 29.0, 0.11 * 0.08, 0.025 / 0.08),
])
def test_janosi_soils_are_mohr_coulomb_of_wong_table_2_3_on_a_quarter_husky(
        name, c_pa, phi_deg, area_m2, k_over_l):
    # mu_max = tan(phi) + c A / W with W the static Husky wheel load (quarter of 50 kg)
    curve = get_terrain(name).curve
    assert curve.mu_max == pytest.approx(np.tan(np.radians(phi_deg)) + c_pa * area_m2 / W,
                                         rel=1e-12)
    assert curve.shear_slip == pytest.approx(k_over_l, rel=1e-12)
    assert {"SNOW": 0.46896, "SANDY_LOAM": 0.67778}[name] == pytest.approx(curve.mu_max,
                                                                           abs=1e-5)


@pytest.mark.parametrize("name, cone_index_pa", [
    ("DIRT_ROAD", 1.5e6), ("UNPLOUGHED", 0.8e6), ("PLOUGHED", 0.1e6)])
def test_brixius_entries_use_the_husky_tyre_mobility_number(name, cone_index_pa):
    # Bn = (CI b d / W)(1 + 5 delta/h)/(1 + 3 b/d), b 0.11 m, d 0.33 m, delta/h 0.1:
    # (1 + 0.5) / (1 + 1) = 0.75
    assert get_terrain(name).curve.mobility_number == pytest.approx(
        cone_index_pa * 0.11 * 0.33 / W * 0.75, rel=1e-12)


def test_tractive_efficiency_with_brixius_hysteresis_is_brixius_te():
    # with h = 0.04 (Brixius's tyre term) eta = (NT / GT)(1 - s), GT and MR of Brixius (1987)
    terrain = replace(get_terrain("UNPLOUGHED"), hysteresis=0.04)
    bn = terrain.curve.mobility_number
    s = np.array([0.05, 0.1, 0.2, 0.4, 0.8])
    gt = 0.88 * (1.0 - np.exp(-0.1 * bn)) * (1.0 - np.exp(-7.5 * s)) + 0.04
    mr = 1.0 / bn + 0.04 + 0.5 * s / np.sqrt(bn)
    expected = (gt - mr) / gt * (1.0 - s)
    assert np.allclose(tractive_efficiency(terrain, s), expected, rtol=1e-12)
    assert np.allclose(tractive_efficiency(terrain, -s), expected, rtol=1e-12)


def test_tractive_efficiency_is_zero_without_net_pull_and_below_one():
    terrain = get_terrain("SNOW")
    s = np.linspace(0.0, 1.0, 201)
    eta = tractive_efficiency(terrain, s)
    assert eta[0] == 0.0 and eta[-1] == 0.0          # no pull at s = 0, no speed at s = 1
    assert np.all((eta >= 0.0) & (eta < 1.0 - s + 1e-15))


@pytest.mark.parametrize("points", range(3, 41))
def test_max_tractive_efficiency_is_found_between_any_grid_points(points):
    # the refinement brackets both neighbours of the best grid point
    terrain = get_terrain("DIRT_ROAD")
    slip, eta = max_tractive_efficiency(terrain, points)
    assert slip == pytest.approx(0.111651, abs=1e-5)
    assert eta == pytest.approx(float(tractive_efficiency(terrain, slip)))


@pytest.mark.parametrize("c3", [0.02, 0.1, 0.52])
def test_burckhardt_peak_is_the_closed_form_even_when_it_falls_little(c3):
    # d mu / ds = c1 c2 e^(-c2 s) - c3 = 0 at s* = ln(c1 c2 / c3) / c2
    c1, c2 = 1.2801, 23.99
    peak = traction_peak(BurckhardtCurve(c1, c2, c3))
    s_star = np.log(c1 * c2 / c3) / c2
    assert not peak.monotonic
    assert peak.slip == pytest.approx(s_star, abs=1e-6)
    assert peak.mu == pytest.approx(c1 * (1 - np.exp(-c2 * s_star)) - c3 * s_star, rel=1e-9)


def test_monotonic_peak_is_the_smallest_grid_slip_reaching_the_saturation():
    curve = JanosiCurve(0.5, 0.3)
    peak = traction_peak(curve, saturation=0.95)
    assert peak.monotonic and peak.mu_max == pytest.approx(float(traction_coefficient(curve, 1)))
    assert peak.mu >= 0.95 * peak.mu_max
    assert float(traction_coefficient(curve, peak.slip - 1.0 / 20000)) < 0.95 * peak.mu_max


def test_a_monotonic_curve_is_stable_up_to_full_slip():
    curve = JanosiCurve(0.5, 0.3)
    assert stable_side_end(curve) == (1.0, float(traction_coefficient(curve, 1.0)))


def test_inverse_is_odd_and_saturated_from_the_peak_on():
    curve = TERRAINS["ASPHALT"].curve
    s_peak, mu_peak = stable_side_end(curve)
    mu = np.array([0.3, 0.9, mu_peak, 2.0])
    pos, neg = slip_from_traction(curve, mu), slip_from_traction(curve, -mu)
    assert np.allclose(neg.slip, -pos.slip) and pos.slip[0] > 0.0
    assert list(pos.saturated) == [False, False, True, True] == list(neg.saturated)
    assert pos.slip[2] == pytest.approx(s_peak)


@pytest.mark.parametrize("rim, v", [(0.005, 0.01), (-0.005, -0.015), (0.01, 0.3),
                                    (0.3, 0.2), (-0.2, 0.01)])
def test_velocity_slope_of_the_slip_is_its_derivative(rim, v):
    # central difference of the floored slip at fixed rim speed, floor 0.02 m/s
    floor, h = 0.02, 1e-7
    slip, ds_dv = sae_slip_and_velocity_slope(np.array([rim]), np.array([v]), floor)
    fd = (sae_slip(rim, v + h, speed_floor_m_s=floor, dead_band_m_s=0.0)
          - sae_slip(rim, v - h, speed_floor_m_s=floor, dead_band_m_s=0.0)) / (2 * h)
    assert ds_dv[0] == pytest.approx(float(fd), rel=1e-5)


@pytest.mark.parametrize("rim, v, side", [(0.05, 0.0, 1.0), (-0.05, 0.0, -1.0),
                                          (0.3, 0.0, 1.0)])
def test_velocity_slope_at_saturation_is_the_unsaturated_sides(rim, v, side):
    # |slip| exactly 1 at a body at rest under a turning wheel: the slope is the one-sided
    # derivative from inside [-1, 1] (-1 / |rim|), not the saturated side's 0; the
    # simulator's implicit step needs it to hold a body started from rest behind its rims
    floor, h = 0.02, 1e-7
    slip, ds_dv = sae_slip_and_velocity_slope(np.array([rim]), np.array([v]), floor)
    assert abs(slip[0]) == 1.0
    inside = (sae_slip(rim, v + side * h, speed_floor_m_s=floor, dead_band_m_s=0.0)
              - slip[0]) / (side * h)
    assert ds_dv[0] != 0.0 and ds_dv[0] == pytest.approx(float(inside), rel=1e-5)
    # one step further out the slip stays saturated and its slope is 0
    beyond = sae_slip_and_velocity_slope(np.array([rim]), np.array([v - side * 0.01]), floor)
    assert abs(beyond[0][0]) == 1.0 and beyond[1][0] == 0.0


def test_velocity_slope_of_a_locked_wheel_is_zero():
    # rim 0 under a moving body: the slip is -sign(v) at every speed beyond the floor
    slip, ds_dv = sae_slip_and_velocity_slope(np.zeros(2), np.array([0.05, -0.05]), 0.02)
    np.testing.assert_array_equal(slip, [-1.0, 1.0])
    np.testing.assert_array_equal(np.abs(ds_dv), [0.0, 0.0])


def test_lateral_friction_opposes_the_slide_and_is_bounded_by_mu_n():
    # Coulomb -mu N sign(v) smoothed by tanh(v / v_slide); slope = secant F / v
    v = np.array([-0.5, -0.02, -1e-9, 0.0, 1e-9, 0.02, 0.5])
    normal = np.full(v.shape, 200.0)
    force, slope = lateral_force_and_slope(0.6, normal, v, slide_speed_m_s=0.02)
    assert np.all(force * v <= 0.0) and np.all(np.abs(force) <= 0.6 * 200.0)
    assert np.allclose(force, -force[::-1])                          # odd in v
    assert force[-1] == pytest.approx(-0.6 * 200.0 * np.tanh(25.0))
    assert force[-2] == pytest.approx(-0.6 * 200.0 * np.tanh(1.0))
    assert np.allclose(slope[v != 0], force[v != 0] / v[v != 0])
    assert slope[3] == pytest.approx(-0.6 * 200.0 / 0.02)          # the tangent at 0


def test_sunk_rim_chord_and_unloaded_strength():
    # chord of a rim of radius r sunk by z: 2 sqrt(2 r z - z^2); 2 r at z = r
    assert float(contact_chord_m(0.2, 0.2, 0.0)) == pytest.approx(0.4)
    assert float(contact_chord_m(0.02, 0.2, 0.0)) == pytest.approx(2 * np.sqrt(0.008 - 0.0004))
    assert float(contact_chord_m(0.001, 0.2, 0.1)) == pytest.approx(0.1)
    soil = SOILS["PLOUGHED"]
    strength = lateral_strength_n(soil, 0.11, np.array([0.0, 100.0]), np.array([0.02, 0.02]),
                                  np.array([0.1, 0.1]))
    assert strength[0] == 0.0 and strength[1] > 100.0 * np.tan(np.radians(
        soil.friction_angle_deg))


def test_combined_shear_shares_are_continuous_where_one_direction_stops():
    # h(u) = g(u) / u -> 1/2 as u -> 0: no jump when one displacement reaches 0
    at_zero = combined_shear_shares(np.array([0.0, 0.7]), np.array([0.7, 0.0]))
    near = combined_shear_shares(np.array([1e-9, 0.7]), np.array([0.7, 1e-9]))
    assert np.allclose(at_zero, near, atol=1e-7)
    assert at_zero[0][1] == pytest.approx(1.0) and at_zero[1][0] == pytest.approx(1.0)


@pytest.mark.parametrize("kr", [0.3, 0.5, 0.8])
def test_hump_shear_curve_peaks_near_one_and_falls_to_the_residual_ratio(kr):
    # point shear at the rear of the patch, f(a) = d(a g)/da = g + a g'; Wong's hump curve
    # is normalised to a peak of about 1 (1 at u = 1), tends to K_r, starts with slope 1
    a = np.linspace(1e-3, 30.0, 30001)
    g, dg = patch_mobilisation(a, kr)
    f = g + a * dg
    assert 1.0 <= f.max() < 1.03
    assert f[-1] == pytest.approx(kr, abs=2e-3)
    assert patch_mobilisation(np.array([0.0]), kr)[1][0] == pytest.approx(0.5)


def test_sae_slip_options_of_the_thesis_formula():
    # no floor: 0/0 is 0, the saturation bound applies, a NaN speed stays unknown
    assert float(sae_slip(0.0, 0.0, dead_band_m_s=0.0)) == 0.0
    assert float(sae_slip(1.0, 0.5, dead_band_m_s=0.0, saturation=0.3)) == pytest.approx(0.3)
    assert float(sae_slip(-1.0, 0.5, dead_band_m_s=0.0, saturation=0.3)) == pytest.approx(-0.3)
    assert np.isnan(sae_slip(np.nan, 1.0)) and np.isnan(sae_slip(1.0, np.nan))


@pytest.mark.parametrize("name", ["DIRT_ROAD", "PLOUGHED", "SNOW", "GRASS"])
def test_soil_resistance_is_even_in_the_slip(name):
    # resistance opposes rolling whichever way the wheel slips
    terrain = get_terrain(name)
    s = np.array([0.05, 0.3, 1.0])
    assert np.allclose(soil_resistance_coefficient(terrain, -s),
                       soil_resistance_coefficient(terrain, s))


def test_inverse_of_a_curve_with_a_flat_top_is_the_first_slip_reaching_it():
    # Burckhardt ice (c3 = 0) reaches c1 = 0.05 in floating point by s = 0.123 and stays
    curve = get_terrain("ICE").curve
    out = slip_from_traction(curve, 0.05)
    assert bool(out.saturated) and float(out.slip) < 0.13
