"""Terramechanics relations against hand-computed values of their source equations.

Each test pins a relation (Bekker, Wong, Brixius, Janosi-Hanamoto) to numbers worked out
here from the printed equation, or to an invariant the docstring states, so that a flipped
sign, a dropped term or a swapped exponent in the library changes a checked number.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from terrain.terramechanics import (BrixiusCurve, bekker_compaction_coefficient,
                                    bekker_sinkage_m, can_turn_in_place, get_terrain,
                                    grade_resistance_n, traction_curve_and_slope,
                                    traction_peak)
from terrain.terramechanics.lateral import (SOILS, SoilParams, bulldozing_force_n,
                                            combined_shear_shares, shear_mobilisation,
                                            shear_strength_n, soil_contact,
                                            soil_lateral_force_and_slope)
from terrain.terramechanics.traction import patch_mobilisation
from terrain.vehicles import HUSKY

W = 50.0 * 9.80665 / 4.0          # static Husky wheel load, N


def test_bekker_sinkage_is_the_pressure_over_the_plate_modulus_to_the_power_1_over_n():
    # Wong eq. 2.33, z = (p / (k_c / b + k_phi))^(1/n): a 0.5 x 1 m plate under 1 kN
    # (p = 2 kPa) on k_c = 10 kN/m^2, k_phi = 1 MN/m^3, n = 1 sinks
    # 2000 / (10e3 / 0.5 + 1e6) = 2000 / 1.02e6 m
    assert bekker_sinkage_m(1000.0, 0.5, 1.0, 10e3, 1e6, 1.0) == pytest.approx(
        2000.0 / 1.02e6, rel=1e-12)
    # a purely cohesive soil (k_phi = 0): z = p b / k_c, so a plate of the same pressure
    # twice as wide sinks twice as deep (n = 1), 2^(1/n) as deep in general
    narrow = bekker_sinkage_m(1000.0, 0.5, 1.0, 10e3, 0.0, 0.5)
    wide = bekker_sinkage_m(2000.0, 1.0, 1.0, 10e3, 0.0, 0.5)
    assert narrow == pytest.approx((2000.0 * 0.5 / 10e3) ** 2, rel=1e-12)
    assert wide == pytest.approx(4.0 * narrow, rel=1e-12)


def test_bekker_compaction_coefficient_is_wongs_compaction_over_the_load():
    # Wong eq. 2.54 with n = 1: R_c = b (k_c / b + k_phi) z^2 / 2 at the plate's sinkage
    # z = 2000 / 1.02e6 m (above): R_c / W = 0.5 * 1.02e6 * z^2 / 2 / 1000
    z = 2000.0 / 1.02e6
    assert bekker_compaction_coefficient(1000.0, 0.5, 1.0, 10e3, 1e6, 1.0) == pytest.approx(
        0.5 * 1.02e6 * z * z / 2.0 / 1000.0, rel=1e-12)


def test_grade_resistance_is_the_weight_times_the_sine_of_the_pitch():
    # seed 003 eq. 10: 50 kg on a 15 degree grade, 50 * 9.80665 * sin(15 deg) = 126.907 N
    assert grade_resistance_n(50.0, np.radians(15.0)) == pytest.approx(126.907, abs=1e-3)
    assert grade_resistance_n(50.0, -np.radians(15.0)) == pytest.approx(-126.907, abs=1e-3)


def _soil_30_degrees():
    return SoilParams("phi 30 test soil", n=1.0, k_c=1e3, k_phi=1e6, cohesion_pa=1000.0,
                      friction_angle_deg=30.0, shear_modulus_m=0.01,
                      unit_weight_n_m3=15000.0, source="hand-computed test values")


def test_bulldozing_is_wongs_passive_pressure_with_the_tabulated_factors():
    # Wong eq. 2.61, R_b = w (0.67 c z K_pc + 0.5 z^2 gamma K_pgamma), with Vesic's factors
    # at phi = 30 deg (Das, Table 3.3: N_c 30.14, N_gamma 22.40):
    # K_pc = (30.14 - tan 30) cos^2 30 = 22.172, K_pgamma = (2 * 22.40 / tan 30 + 1) cos^2 30
    # = 58.947; a wall 0.05 m deep and 0.2 m wide, c = 1 kPa, gamma = 15 kN/m^3:
    # 0.2 (0.67 * 1000 * 0.05 * 22.172 + 0.5 * 0.05^2 * 15000 * 58.947) = 369.6 N
    soil = _soil_30_degrees()
    k_pc = (30.14 - np.tan(np.radians(30.0))) * 0.75
    k_pg = (2.0 * 22.40 / np.tan(np.radians(30.0)) + 1.0) * 0.75
    cohesive = 0.2 * 0.67 * 1000.0 * 0.05 * k_pc
    frictional = 0.2 * 0.5 * 0.05 ** 2 * 15000.0 * k_pg
    assert cohesive + frictional == pytest.approx(369.6, abs=0.1)
    assert bulldozing_force_n(0.05, 0.2, soil) == pytest.approx(369.6, rel=2e-3)
    # each term on its own: linear in z without gamma, quadratic without cohesion
    assert bulldozing_force_n(0.05, 0.2, replace(soil, unit_weight_n_m3=0.0)) == (
        pytest.approx(cohesive, rel=2e-3))
    assert bulldozing_force_n(0.05, 0.2, replace(soil, cohesion_pa=0.0)) == (
        pytest.approx(frictional, rel=2e-3))


def test_exponential_patch_mobilisation_slope_is_continuous_at_zero_slip():
    # g(a) = 1 - (1 - e^-a) / a, g'(a) = 1/2 - a/3 + ... near 0: the series branch below
    # a = 1e-4 and the closed form above it are the same curve, so its slope (the initial
    # traction stiffness of every Janosi terrain) matches a finite difference on both sides
    a = np.array([1e-7, 3e-5, 9.9e-5, 1.01e-4, 5e-4])
    g, dg = patch_mobilisation(a)
    h = 1e-9
    fd = (patch_mobilisation(a + h)[0] - patch_mobilisation(a - h)[0]) / (2 * h)
    np.testing.assert_allclose(dg, fd, rtol=1e-4)
    np.testing.assert_allclose(dg, 0.5 - a / 3.0, rtol=1e-6)
    np.testing.assert_allclose(g, a / 2.0 - a * a / 6.0, rtol=1e-6)


def test_traction_slope_is_zero_where_the_slip_is_saturated():
    # the slip saturates at +-1 (seed 001 ch. 7.2): beyond it mu holds its value at +-1 and
    # its slope in s is 0 (traction_curve_and_slope's contract)
    curve = get_terrain("GRASS").curve
    mu, dmu = traction_curve_and_slope(curve, np.array([-2.0, -1.5, 1.5, 3.0]))
    mu_1, dmu_1 = traction_curve_and_slope(curve, np.array([-1.0, 1.0]))
    np.testing.assert_array_equal(dmu, 0.0)
    assert dmu_1[1] > 0
    np.testing.assert_allclose(mu, [mu_1[0], mu_1[0], mu_1[1], mu_1[1]])


def test_traction_peak_of_a_monotone_curve_is_its_95_percent_slip():
    # Brixius gross traction 0.88 (1 - e^-0.1Bn)(1 - e^-7.5 s) rises up to s = 1: its peak
    # slip is where it reaches 95 % of mu(1), 1 - e^-7.5 s = 0.95 (1 - e^-7.5),
    # s = -ln(0.05 + 0.95 e^-7.5) / 7.5 = 0.39804
    peak = traction_peak(BrixiusCurve(30.0))
    amp = 0.88 * (1.0 - np.exp(-3.0))
    assert peak.monotonic
    assert peak.mu_max == pytest.approx(amp * (1.0 - np.exp(-7.5)), rel=1e-9)
    assert peak.slip == pytest.approx(-np.log(0.05 + 0.95 * np.exp(-7.5)) / 7.5, abs=1e-4)
    assert peak.mu == pytest.approx(0.95 * peak.mu_max, rel=1e-3)


@pytest.mark.parametrize("name", ["ASPHALT", "PLOUGHED"])
def test_turning_in_place_is_the_moment_balance_of_the_contacts(name):
    # can_turn_in_place: drive sum N_i (mu_peak - f_soil(1)) |y_i| against the lateral
    # friction moment sum N_i mu_lat |x_i|; with the Husky's track the vehicle turns in
    # place while its half wheelbase is below x* = (mu_peak - f_soil(1)) |y| / mu_lat
    terrain = get_terrain(name)
    geo = HUSKY.contact_geometry()
    y = abs(geo.positions_m[0, 1])
    if name == "ASPHALT":        # Burckhardt: no soil resistance, peak 1.170 (Kiencke)
        net = traction_peak(terrain.curve).mu_max
    else:                        # Brixius: 0.88 (1 - e^-0.1Bn)(1 - e^-7.5) - 1/Bn - 0.5/sqrt Bn
        bn = terrain.curve.mobility_number
        net = (0.88 * (1 - np.exp(-0.1 * bn)) * (1 - np.exp(-7.5)) - 1 / bn
               - 0.5 / np.sqrt(bn))
    x_star = net * y / terrain.lateral_friction

    def with_half_wheelbase(x):
        pos = geo.positions_m.copy()
        pos[:, 0] = np.sign(pos[:, 0]) * x
        return replace(geo, positions_m=pos)

    assert can_turn_in_place(with_half_wheelbase(0.97 * x_star), terrain)
    assert not can_turn_in_place(with_half_wheelbase(1.03 * x_star), terrain)


def _exponential_loam():
    return replace(SOILS["SANDY_LOAM"], residual_ratio=None)


def test_lateral_force_is_the_janosi_shear_of_the_lateral_slip_angle_with_k_y():
    # module docstring: F = -tanh(v / v_slide) S g(a), a = l |v| / (K_y max(|omega r|,
    # v_slide)), g(a) = 1 - (1 - e^-a) / a; the sandy loam's K_y = 0.010 m, l = 0.08 m
    soil = _exponential_loam()
    c = soil_contact(soil, 0.11, 0.08, 0.1651, 4 * W)
    strength = np.interp(W, c.load_grid_n, c.strength_grid_n)
    v, wr = np.array([0.01, 0.05, -0.2]), np.array([0.3, 0.3, 0.5])
    a = 0.08 * np.abs(v) / (0.010 * wr)
    expected = -np.tanh(v / 0.02) * strength * (1 - (1 - np.exp(-a)) / a)
    f, _, _ = soil_lateral_force_and_slope(c, np.full(3, W), v, wr)
    np.testing.assert_allclose(f, expected, rtol=1e-9)
    # the longitudinal modulus K_x plays no part in the lateral shear
    c_x = soil_contact(replace(soil, shear_modulus_m=0.05), 0.11, 0.08, 0.1651, 4 * W)
    np.testing.assert_allclose(soil_lateral_force_and_slope(c_x, np.full(3, W), v, wr)[0],
                               f, rtol=1e-12)


def test_a_locked_wheel_shears_the_soil_as_one_rolling_at_the_slide_speed():
    # the rim speed is floored at the regularisation speed (docstring: a locked wheel
    # shears the soil fully, not infinitely): a wheel at omega r = 0 or 0.01 m/s pushed
    # sideways at 2 mm/s has a = 0.08 * 0.002 / (0.010 * 0.02) = 0.8, g = 0.3117
    c = soil_contact(_exponential_loam(), 0.11, 0.08, 0.1651, 4 * W)
    strength = np.interp(W, c.load_grid_n, c.strength_grid_n)
    v = np.full(3, 0.002)
    f, _, _ = soil_lateral_force_and_slope(c, np.full(3, W), v, np.array([0.0, 0.01, 0.02]))
    g = 1 - (1 - np.exp(-0.8)) / 0.8
    np.testing.assert_allclose(f, -np.tanh(0.1) * strength * g, rtol=1e-9)


@pytest.mark.parametrize("name", ["SANDY_LOAM", "SNOW", "PLOUGHED"])
def test_lateral_slope_is_the_secant_of_the_lateral_force(name):
    # documented: slope = F / v_lat, which keeps the implicit integrator stable
    c = soil_contact(SOILS[name], 0.11, 0.08, 0.1651, 4 * W)
    v = np.array([-0.4, -0.03, 0.001, 0.02, 0.25])
    f, k, _ = soil_lateral_force_and_slope(c, np.full(5, W), v, np.full(5, 0.3))
    np.testing.assert_allclose(k * v, f, rtol=1e-9)
    assert np.all(k < 0)


def test_combined_shear_leaves_the_lateral_shear_the_resultants_share():
    # with combined_shear the lateral strength is the bulldozing plus the Mohr-Coulomb shear
    # times the lateral share h(a) / h(a_y) (combined_shear_shares): a wheel that does not
    # slip along (a_x = 0) keeps the whole strength, one that does keeps
    # c b l + N tan phi times g(a) a_y / a over g(a_y)
    soil = replace(_exponential_loam(), combined_shear=True)
    c = soil_contact(soil, 0.11, 0.08, 0.1651, 4 * W)
    load, v, wr = np.full(2, W), np.full(2, 0.05), np.full(2, 0.3)
    alone, _, _ = soil_lateral_force_and_slope(c, load, v, wr)
    f, _, share_x = soil_lateral_force_and_slope(c, load, v, wr,
                                                 shear_long=np.array([0.0, 3.0]))
    assert f[0] == pytest.approx(alone[0], rel=1e-12)
    a_y = 0.08 * 0.05 / (0.010 * 0.3)
    a = np.hypot(3.0, a_y)
    shear = float(shear_strength_n(soil, 0.11, W, 0.08))
    bulldozing = np.interp(W, c.load_grid_n, c.strength_grid_n) - shear
    g_y = float(shear_mobilisation(a_y))
    g = float(shear_mobilisation(a))
    expected = -np.tanh(2.5) * (bulldozing * g_y + shear * g * a_y / a)
    assert f[1] == pytest.approx(expected, rel=1e-9)
    share_long = combined_shear_shares(np.array([3.0]), np.array([a_y]))[0]
    assert share_x[1] == pytest.approx(share_long[0])
