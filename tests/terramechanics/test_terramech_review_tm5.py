"""Review tests (tm5) of calibration, bearing capacity and their inputs."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from terrain.errors import ConfigError, DataWarning
from terrain.terramechanics import get_terrain, sae_slip, traction_peak
from terrain.terramechanics.calibration import husky_hysteresis_for_current, steady_slip
from terrain.terramechanics.inverse import slip_from_traction, stable_side
from terrain.terramechanics.lateral import (SOILS, SoilParams, bearing_capacity_factors,
                                            SlipCompactionResistance, contact_chord_m,
                                            longitudinal_curve, slip_sinkage_m,
                                            soil_lateral_force_and_slope,
                                            soil_contact, wheel_sinkage_m)
from terrain.terramechanics.resistance import bekker_sinkage_m, soil_resistance_coefficient
from terrain.terramechanics.traction import (CurveCoefficients, TractionAndResistance,
                                             patch_mobilisation, traction_coefficient)


@pytest.mark.parametrize("current", [float("nan"), float("inf"), -float("inf"), True, "3.9",
                                     None])
def test_hysteresis_calibration_refuses_a_current_that_is_not_a_finite_number(current):
    # NaN came out as hysteresis 0.0 (max(0.0, nan)), inf as inf and True as a 1 A target,
    # each without a word; a catalogue entry calibrated from a missing measurement
    with pytest.raises(ConfigError, match="current_a"):
        husky_hysteresis_for_current(get_terrain("SANDY_LOAM"), current, 0.45)


def test_hysteresis_calibration_refuses_a_boolean_speed():
    # True passed 'finite and > 0' as a 1 m/s speed
    with pytest.raises(ConfigError, match="speed_m_s"):
        husky_hysteresis_for_current(get_terrain("SANDY_LOAM"), 3.9, True)


def test_hysteresis_below_the_traction_current_is_zero_not_negative():
    # documented: >= 0 (a target below the no-load plus traction current buys no loss)
    with pytest.warns(DataWarning, match="current_a"):   # tm18: no longer without a word
        assert husky_hysteresis_for_current(get_terrain("SANDY_LOAM"), 0.0, 0.45) == 0.0


def test_bearing_capacity_factors_are_the_cited_closed_forms():
    # N_q = e^(pi tan phi) tan^2(45 + phi/2), N_c = (N_q - 1) cot phi, N_gamma = 2 (N_q + 1)
    # tan phi (Vesic 1973), as the docstring cites them; tabulated (Das, Principles of
    # Foundation Engineering, Vesic's table) at 29 deg: 27.86, 16.44, 19.34
    n_c, n_q, n_g = bearing_capacity_factors(29.0)
    assert (n_c, n_q, n_g) == pytest.approx((27.86, 16.44, 19.34), abs=0.01)


@pytest.mark.parametrize("phi", [0.0, -10.0, 90.0, 120.0, float("nan"), float("inf"), True,
                                 "29", None])
def test_bearing_capacity_factors_refuse_an_angle_outside_0_90(phi):
    # phi = 0 gave N_c = -inf (0 / tan 0 after rounding), a negative angle negative factors,
    # 90 infinite ones, NaN NaN, all without a word; True was 1 degree
    with pytest.raises(ConfigError, match="friction_angle_deg"):
        bearing_capacity_factors(phi)


@pytest.mark.parametrize("demand", [True, "0.1", None])
def test_steady_slip_refuses_a_demand_that_is_not_a_real_number(demand):
    # True was a demand of 1 (slip 1.0, full spin, on every terrain), '0.1' and None a bare
    # TypeError inside math.isfinite
    with pytest.raises(ConfigError, match="extra_demand"):
        steady_slip(get_terrain("SANDY_LOAM"), demand)


@pytest.mark.parametrize("load_n", [200.0, 300.0, 400.0])
def test_wheel_sinkage_is_the_fixed_point_on_a_soil_where_plain_iteration_oscillates(load_n):
    # with n = 0.5 (a clay-like exponent) on SNOW's moduli the map z -> bekker(W, b, l(z))
    # is steeper than 1 and the undamped iteration z_k+1 = bekker(l(z_k)) oscillates (at
    # 300 N it stops at z = 6.98 mm with bekker(l) = 11.4 mm); the damped one returns a pair
    # with z = bekker(W, b, l) and l = max(l_0, 2 sqrt(2 r z - z^2)) (8.96 mm, 0.107 m)
    soil = replace(SOILS["SNOW"], n=0.5)
    z, length = wheel_sinkage_m(load_n, 0.11, 0.08, 0.165, soil)
    assert 0.0 < z < 0.165
    assert z == pytest.approx(bekker_sinkage_m(load_n, 0.11, length, soil.k_c, soil.k_phi,
                                               soil.n), rel=1e-9)
    assert length == pytest.approx(float(contact_chord_m(z, 0.165, 0.08)), rel=1e-9)


def test_dead_band_zeroes_the_slip_only_below_its_speed():
    # seed 001 ch. 7.2.1: slip 0 when both speeds "fall below" 0.05 m/s; at exactly 0.05
    # m/s the slip is the formula's, (0.05 - 0.04) / 0.05 = 0.2
    assert float(sae_slip(0.05, 0.04)) == pytest.approx(0.2)
    assert float(sae_slip(0.0499, 0.04)) == 0.0
    assert float(sae_slip(0.04, 0.05)) == pytest.approx(-0.2)


class _RoundedPlateau:
    """A curve that saturates at s = 0.1 and then loses 1e-12 of its value by s = 1
    (rounding-level): flat, not an interior peak."""

    def coefficients(self, abs_slip, soil_resistance):
        s = np.asarray(abs_slip, dtype=float)
        mu = 0.6 * np.minimum(s / 0.1, 1.0) * (1.0 - 1e-12 * s)
        zero = np.zeros_like(s)
        return CurveCoefficients(mu, zero, zero, zero)


def test_traction_peak_reads_a_rounding_level_fall_as_a_flat_top():
    # a plateau that falls by 1e-12 is monotonic: the peak is the first slip reaching 95 %
    # of the maximum (0.095), not the start of the plateau as an interior maximum (0.1)
    peak = traction_peak(_RoundedPlateau())
    assert peak.monotonic
    assert peak.slip == pytest.approx(0.095, abs=1e-4)
    assert peak.mu_max == pytest.approx(0.6, rel=1e-9)


@pytest.mark.parametrize("max_load", [True, "300", None, float("inf")])
def test_soil_contact_refuses_a_largest_load_that_is_not_a_finite_number(max_load):
    # True tabulated the wheel up to 1 N without a word (every load clipped to 1 N: almost
    # no lateral force), '300' and None raised NumPy's bare 'isfinite not supported'
    with pytest.raises(ConfigError, match="max_load_n"):
        soil_contact(SOILS["SNOW"], 0.11, 0.08, 0.165, max_load)


def _taylor(coefficient, x, terms=25):
    """``sum_k coefficient(k) x^k`` for ``k = 1..terms`` (exact to rounding for x < 0.1)."""
    return math.fsum(coefficient(k) * x ** k for k in range(1, terms + 1))


@pytest.mark.parametrize("a", [2e-4, 1e-3, 3e-3, 9e-3])
def test_exponential_patch_mean_is_exact_between_the_series_and_the_curve(a):
    # g(a) = 1 - (1 - e^-a) / a = sum_k>=1 (-1)^(k+1) a^k / (k+1)!, g'(a) its derivative;
    # a second-order series used up to a = 1e-2 is 7e-6 off at 9e-3
    g_exact = _taylor(lambda k: (-1) ** (k + 1) / math.factorial(k + 1), a)
    dg_exact = _taylor(lambda k: (-1) ** k * (k + 1) / math.factorial(k + 2), a) + 0.5
    g, dg = patch_mobilisation(np.array([a]))
    assert g[0] == pytest.approx(g_exact, rel=1e-10)
    assert dg[0] == pytest.approx(dg_exact, rel=1e-10)


@pytest.mark.parametrize("kr", [0.4, 0.9])
@pytest.mark.parametrize("u_end", [2e-4, 1e-3, 5e-3])
def test_hump_patch_mean_is_exact_between_the_series_and_the_curve(kr, u_end):
    # Wong's hump curve f(u) = K_r (1 - e^-u) + K_r B e (e^-u - e^-2u); its patch mean
    # (1/U) int_0^U f by Taylor series: int (1 - e^-u) = sum_k>=2 (-1)^k U^k / k!,
    # int (e^-u - e^-2u) = sum_k>=1 (-1)^(k+1) (1 - 2^(k-1)) U^k / k!; at U of a few
    # 1e-3 a second-order series is 1e-6 off
    b = 1.0 / (kr * (1.0 - math.exp(-1.0))) - 1.0
    s0 = kr * (1.0 + b * math.e)
    first = _taylor(lambda k: 0.0 if k < 2 else (-1) ** k / math.factorial(k), u_end)
    second = _taylor(lambda k: (-1) ** (k + 1) * (1 - 2 ** (k - 1)) / math.factorial(k),
                     u_end)
    mean = kr * (first + b * math.e * second) / u_end
    f_end = kr * (1.0 + b * math.exp(1.0 - u_end)) * -math.expm1(-u_end)
    g, dg = patch_mobilisation(np.array([s0 * u_end]), kr)
    assert g[0] == pytest.approx(mean, rel=1e-10)
    assert dg[0] == pytest.approx((f_end - mean) / u_end / s0, rel=1e-7)


def test_soil_refuses_a_friction_angle_of_90_degrees():
    # tan 90 deg is infinite: Mohr-Coulomb has no strength and the bearing-capacity
    # factors are infinite (the docstring: phi in (0, 90))
    base = SOILS["SANDY_LOAM"]
    with pytest.raises(ConfigError, match="friction_angle_deg"):
        SoilParams("x", base.n, base.k_c, base.k_phi, base.cohesion_pa, 90.0,
                   base.shear_modulus_m, base.unit_weight_n_m3, "test")


@pytest.mark.parametrize("kr", [1.0, 0.0, 1.5])
def test_patch_mobilisation_refuses_a_residual_ratio_outside_0_1(kr):
    # K_r = 1 is no residual below the peak: f(1) = 1 and the curve then rises above its
    # peak strength (1.05 at u = 2); 0 and 1.5 are no ratio of a residual at all
    with pytest.raises(ConfigError, match="residual_ratio"):
        patch_mobilisation(np.array([0.5]), kr)


def test_inverse_of_a_curve_holding_arrays_is_the_inverse_not_a_hash_error():
    # physics v2's curve on a soil with slip compaction holds a SoilContact (NumPy arrays):
    # the memoised stable side hashed it and raised Python's bare 'unhashable type:
    # numpy.ndarray'; its traction is the soil's Janosi curve, so its inverse is that one's
    soil = replace(SOILS["SANDY_LOAM"], slip_sinkage_ratio=5.0, slip_compaction=True)
    contact = soil_contact(soil, 0.11, 0.08, 0.165, 400.0)
    janosi = longitudinal_curve(contact, 122.6)
    curve = TractionAndResistance(
        janosi, SlipCompactionResistance(get_terrain("SANDY_LOAM").curve, contact, 122.6))
    mu = np.array([0.1, -0.3, 0.5])
    got = slip_from_traction(curve, mu)
    want = slip_from_traction(janosi, mu)
    np.testing.assert_array_equal(got.slip, want.slip)
    np.testing.assert_array_equal(got.saturated, want.saturated)
    s_grid, mu_grid = stable_side(curve)
    assert not s_grid.flags.writeable and not mu_grid.flags.writeable
    np.testing.assert_allclose(traction_coefficient(curve, got.slip[:2]), mu[:2], rtol=1e-5)


def test_lateral_shear_of_a_softening_soil_follows_its_hump_curve():
    # module docstring: SNOW (K_r = 0.4) follows Wong's hump-type curve laterally too; far
    # past the peak (a about 140) the patch mean nears K_r, not the exponential's 0.99
    soil = SOILS["SNOW"]
    c = soil_contact(soil, 0.11, 0.08, 0.165, 500.0)
    load = 122.6
    strength = np.interp(load, c.load_grid_n, c.strength_grid_n)
    length = np.interp(load, c.load_grid_n, c.length_grid_m)
    v, wr = np.array([0.004, 0.5]), np.array([0.3, 0.02])
    a = length * np.abs(v) / (soil.shear_modulus_y_m * wr)
    g_hump = patch_mobilisation(a, soil.residual_ratio)[0]
    assert g_hump[1] < 0.6 * patch_mobilisation(a)[0][1]
    f = soil_lateral_force_and_slope(c, np.full(2, load), v, wr)[0]
    np.testing.assert_allclose(f, -np.tanh(v / 0.02) * strength * g_hump, rtol=1e-12)


def test_slip_sinkage_is_even_in_the_slip():
    # docstring: the sign of the slip ratio is ignored (a braking wheel digs in as a
    # driving one does, z = z_0 (1 + k_s |s|)); a signed s made braking lift the wheel
    soil = replace(SOILS["SANDY_LOAM"], slip_sinkage_ratio=5.0)
    c = soil_contact(soil, 0.11, 0.08, 0.165, 400.0)
    z_drive, dz_drive = slip_sinkage_m(c, 122.6, np.array([0.3]))
    z_brake, dz_brake = slip_sinkage_m(c, 122.6, np.array([-0.3]))
    z0 = np.interp(122.6, c.load_grid_n, c.sinkage_grid_m)
    assert z_brake[0] == z_drive[0] == pytest.approx(z0 * 2.5, rel=1e-12)
    assert dz_brake[0] == dz_drive[0]


def test_soil_resistance_clips_the_slip_to_one():
    # docstring: the slip is clipped to [-1, 1]; Brixius's 1/Bn + 0.5 |s| / sqrt(Bn) grew
    # without bound for |s| > 1 otherwise
    terrain = get_terrain("PLOUGHED")
    at_one = float(soil_resistance_coefficient(terrain, 1.0))
    assert float(soil_resistance_coefficient(terrain, 3.0)) == at_one
    assert float(soil_resistance_coefficient(terrain, -3.0)) == at_one
    assert at_one > float(soil_resistance_coefficient(terrain, 0.5))
