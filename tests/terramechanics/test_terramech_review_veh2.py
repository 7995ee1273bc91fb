"""Review tests (hand mutants) of resistance, combined slip, calibration and the catalogue."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from terrain.terramechanics import get_terrain
from terrain.terramechanics.calibration import husky_hysteresis_for_current, steady_slip
from terrain.terramechanics.catalogue import TERRAINS
from terrain.terramechanics.combined_slip import combined_slip_coefficients
from terrain.terramechanics.lateral import SOILS
from terrain.terramechanics.resistance import (G_M_S2, HYSTERESIS_SPEED_M_S,
                                               compaction_resistance_n, is_deformable)
from terrain.terramechanics.traction import traction_coefficient
from terrain.vehicles import HUSKY


def test_secant_at_zero_slip_is_the_slope_of_the_curve_there():
    # mu(s_res) / s_res -> d mu / ds at 0: the documented value at s_res = 0 is that limit,
    # not 0 (a 0 there gave a linearised contact no stiffness at rest)
    curve = get_terrain("ASPHALT").curve
    slope0 = float(curve.coefficients(np.array(0.0), 0.0).dmu_ds)
    assert slope0 > 1.0
    at_rest = combined_slip_coefficients(curve, np.array([0.0]), np.array([0.0]), 0.7)
    tiny = combined_slip_coefficients(curve, np.array([1e-9]), np.array([0.0]), 0.7)
    assert at_rest.secant[0] == pytest.approx(slope0, rel=1e-12)
    assert at_rest.secant[0] == pytest.approx(tiny.secant[0], rel=1e-6)
    assert at_rest.mu_long[0] == 0.0 and at_rest.mu_side[0] == 0.0


def test_compaction_of_a_rut_above_the_surface_is_zero_not_nan():
    # a negative depth (the contact lifts off) has no compaction; z^(n+1) of a negative z
    # with a fractional n would be NaN
    soil = SOILS["SANDY_LOAM"]
    assert soil.n != round(soil.n)
    r, dr = compaction_resistance_n(np.array([-0.01, -1e-6, 0.0]), 0.11, soil.k_c,
                                    soil.k_phi, soil.n)
    np.testing.assert_array_equal(r, 0.0)
    np.testing.assert_array_equal(dr, 0.0)


@dataclasses.dataclass(frozen=True)
class _RisingResistance:
    """Asphalt traction with a resistance 0 at rest, rising with slip (a slip-sinkage soil)."""

    base: object

    def coefficients(self, abs_slip, soil_resistance):
        """Coefficients of ``base`` with resistance ``0.1 |s|``."""
        s = np.asarray(abs_slip, dtype=float)
        c = self.base.coefficients(s, soil_resistance)
        return c._replace(resistance=0.1 * s, dresistance_ds=np.full_like(s, 0.1))


def test_a_soil_with_resistance_only_under_slip_is_deformable():
    # "slip-producing soil resistance anywhere on [0, 1]": none at rest is still a soil
    asphalt = get_terrain("ASPHALT")
    assert not is_deformable(asphalt)
    soil = dataclasses.replace(asphalt, curve=_RisingResistance(asphalt.curve))
    assert is_deformable(soil)


@pytest.mark.parametrize("name", ["SANDY_LOAM", "GRASS", "ASPHALT"])
def test_steady_slip_downhill_is_zero(name):
    # a downhill grade (sin(pitch) < 0) that outweighs the soil resistance needs no
    # traction: slip 0 (documented range [0, 1]), not a root-finding error
    terrain = get_terrain(name)
    assert steady_slip(terrain, -0.3) == 0.0
    assert steady_slip(terrain, -0.3) <= steady_slip(terrain, -0.05) <= steady_slip(terrain, 0.05)


def _side_current(terrain, husky, hysteresis, speed_m_s):
    """Per-side current of ``husky`` driving straight: the contact torque law
    ``r (W/2)(mu(s) + h tanh(omega r / v0))`` at the steady slip, then the motor law."""
    s = steady_slip(terrain)
    mu = float(traction_coefficient(terrain.curve, s))
    rim = speed_m_s / (1.0 - s)
    torque = (husky.wheel_radius_m * husky.mass_kg * G_M_S2 / 2.0
              * (mu + hysteresis * math.tanh(rim / HYSTERESIS_SPEED_M_S)))
    return float(husky.motor.current_from_torque(torque, rim / husky.wheel_radius_m))


@pytest.mark.parametrize("husky, speed_m_s", [
    (HUSKY, 0.45),
    (dataclasses.replace(HUSKY, mass_kg=80.0), 0.45),     # a loaded Husky: its own weight
    (HUSKY, 0.004),          # no-load current only partly signed: tanh(omega / 0.05) ~ 0.46
])
def test_calibrated_hysteresis_reproduces_the_current_of_the_vehicle_given(husky, speed_m_s):
    terrain = get_terrain("SANDY_LOAM")
    h = husky_hysteresis_for_current(terrain, 4.5, speed_m_s, husky=husky)
    assert h > 0.0
    assert _side_current(terrain, husky, h, speed_m_s) == pytest.approx(4.5, rel=1e-9)


def test_catalogue_vibration_levels_are_the_measured_ones_in_their_fields():
    # accelerometer std in m/s^2, roll/pitch gyro std in rad/s, at the speed given
    asphalt, snow = TERRAINS["ASPHALT"], TERRAINS["SNOW"]
    assert (asphalt.vib_accel_m_s2, asphalt.vib_gyro_rad_s, asphalt.vib_speed_m_s) == (
        1.59, 0.038, 0.45)
    assert (snow.vib_accel_m_s2, snow.vib_gyro_rad_s, snow.vib_speed_m_s) == (2.76, 0.088, 0.23)
    for t in TERRAINS.values():
        assert t.vib_accel_m_s2 > t.vib_gyro_rad_s > 0.0, t.name


def test_terrain_lookup_is_case_insensitive():
    assert get_terrain("sandy_loam") is TERRAINS["SANDY_LOAM"]
    assert get_terrain("Asphalt") is TERRAINS["ASPHALT"]


@pytest.mark.parametrize("field, value", [
    ("hysteresis", -0.5),            # before: accepted, tractive efficiency 1.64 at slip 0.1
    ("soil_resistance", float("nan")),   # before: accepted, is_deformable False (rigid)
    ("soil_resistance", -0.08),
    ("lateral_friction", -0.5),      # before: accepted, sideways friction pushing the slide
    ("lateral_friction", float("inf")),
    ("vib_accel_m_s2", -1.0),
    ("vib_gyro_rad_s", float("nan")),
    ("vib_speed_m_s", 0.0),          # before: accepted, sqrt(v / 0) vibration scaling
    ("hysteresis", "0.015"),
])
def test_terrain_params_refuse_impossible_values(field, value):
    from terrain.errors import ConfigError
    with pytest.raises(ConfigError, match=f"TerrainParams.{field}"):
        dataclasses.replace(TERRAINS["ASPHALT"], **{field: value})


def test_the_catalogue_passes_its_own_terrain_checks():
    for terrain in TERRAINS.values():
        assert dataclasses.replace(terrain) == terrain
    # a rigid surface with no rolling loss: allowed (0 = none)
    assert dataclasses.replace(TERRAINS["ASPHALT"], hysteresis=0.0).hysteresis == 0.0


def test_bekker_sinkage_uses_the_pressure_over_the_whole_plate():
    # p = W / (b l): a 0.5 x 2 m plate under 2 kN bears the 2 kPa of a 0.5 x 1 m plate under
    # 1 kN and sinks as deep, 2000 / (10e3 / 0.5 + 1e6) m (Wong eq. 2.33, n = 1)
    from terrain.terramechanics.resistance import bekker_sinkage_m
    long_plate = bekker_sinkage_m(2000.0, 0.5, 2.0, 10e3, 1e6, 1.0)
    assert long_plate == pytest.approx(2000.0 / 1.02e6, rel=1e-12)
    assert long_plate == pytest.approx(bekker_sinkage_m(1000.0, 0.5, 1.0, 10e3, 1e6, 1.0),
                                       rel=1e-12)
    # a longer plate under the same load presses less and sinks less
    assert bekker_sinkage_m(1000.0, 0.5, 2.0, 10e3, 1e6, 1.0) == pytest.approx(
        1000.0 / 1.02e6, rel=1e-12)


@pytest.mark.parametrize("slip, k", [(0.5, 2.0), (-0.5, 0.5), (0.0, 1.0)])
def test_rim_speed_from_slip_at_standstill_takes_sign_0_as_forward(slip, k):
    # documented sign(0) = +1: at v = 0 the slope d(omega r)/dv is that of a vehicle about
    # to move forward, 1 / (1 - s) in traction, 1 + s in braking (the limit v -> 0+)
    from terrain.terramechanics.slip import rim_speed_from_slip
    rim, d_ground, d_slip = rim_speed_from_slip(0.0, slip)
    assert (rim, d_slip) == (0.0, 0.0)
    assert d_ground == pytest.approx(k, rel=1e-12)
    assert d_ground == pytest.approx(rim_speed_from_slip(1e-12, slip)[1], rel=1e-9)


def test_brixius_mobility_number_edges_of_the_deflection_ratio():
    # [0, 1): an undeflected tyre is allowed, a tyre flattened to its rim (delta = h) is not;
    # Bn = CI b d / W (1 + 5 delta/h) / (1 + 3 b/d)
    from terrain.errors import ConfigError
    from terrain.terramechanics.traction import brixius_mobility_number
    assert brixius_mobility_number(1e6, 0.11, 0.33, 123.0, 0.0) == pytest.approx(
        1e6 * 0.11 * 0.33 / 123.0 / 2.0, rel=1e-12)
    with pytest.raises(ConfigError, match="deflection_ratio"):
        brixius_mobility_number(1e6, 0.11, 0.33, 123.0, 1.0)


def test_longitudinal_curve_is_janosi_on_the_sunk_patch():
    # JanosiCurve.from_soil with A = b l(N), L = l(N): mu_max = tan(phi) + c b l / W and
    # k = K / l, with l(N) the contact's tabulated sunk length at that load
    from terrain.terramechanics.lateral import longitudinal_curve, soil_contact
    soil = SOILS["SANDY_LOAM"]
    width, load = 0.11, 150.0
    contact = soil_contact(soil, width, 0.08, 0.1651, 4 * 123.0)
    length = float(np.interp(load, contact.load_grid_n, contact.length_grid_m))
    assert length != pytest.approx(width)
    curve = longitudinal_curve(contact, load)
    assert curve.shear_slip == pytest.approx(soil.shear_modulus_m / length, rel=1e-12)
    assert curve.mu_max == pytest.approx(
        math.tan(math.radians(soil.friction_angle_deg)) + soil.cohesion_pa * width * length
        / load, rel=1e-12)


def test_steady_slip_near_a_narrow_peak_is_found_on_the_stable_side():
    # dry asphalt peaks (mu 1.170) at slip 0.17 and falls below 1.147 by slip 0.25: a demand
    # of 1.16 is met at a stable slip below the peak, not read as a full spin (slip 1)
    from terrain.terramechanics.inverse import stable_side_end
    asphalt = get_terrain("ASPHALT")
    s_peak, mu_peak = stable_side_end(asphalt.curve)
    assert 1.16 < mu_peak
    s = steady_slip(asphalt, 1.16)
    assert 0.0 < s < s_peak
    assert float(traction_coefficient(asphalt.curve, s)) == pytest.approx(1.16, abs=1e-8)


@pytest.mark.parametrize("name", ["FLOORING", "PACKED_SNOW", "ASPHALT"])
def test_steady_slip_just_below_a_peak_between_grid_points_is_not_a_full_spin(name):
    # FLOORING peaks at slip 0.13084, between the 0.0025-spaced search points 0.13 and
    # 0.1325, both about 4e-6 below the peak: a demand 2e-6 below the peak came out as 1.0
    # (full spin) although the curve meets it on its stable side
    from terrain.terramechanics.inverse import stable_side_end
    terrain = get_terrain(name)
    s_peak, mu_peak = stable_side_end(terrain.curve)
    demand = mu_peak - 2e-6
    s = steady_slip(terrain, demand)
    assert 0.0 < s <= s_peak
    assert float(traction_coefficient(terrain.curve, s)) == pytest.approx(demand, abs=1e-9)
    assert steady_slip(terrain, mu_peak + 1e-6) == 1.0      # beyond the peak: full spin


def test_combined_slip_at_small_slips_is_on_the_curve():
    # s_res small but not 0: mu_L = mu(s) along the slip, the secant, not the tangent there
    curve = get_terrain("ASPHALT").curve
    s = np.array([1e-9, 1e-6, 5e-4, 2e-3])
    c = combined_slip_coefficients(curve, s, np.zeros_like(s), 0.7)
    np.testing.assert_allclose(c.mu_long, traction_coefficient(curve, s), rtol=1e-9)
    c = combined_slip_coefficients(curve, np.zeros_like(s), s, 0.7)
    np.testing.assert_allclose(c.mu_side, -0.7 * traction_coefficient(curve, s), rtol=1e-9)


def test_max_tractive_efficiency_is_searched_up_to_full_slip():
    # a soil whose traction builds up slowly (K/L = 5) over a small resistance works best at
    # a large slip: the search covers [0, 1], and agrees with a dense scan
    from terrain.terramechanics.efficiency import max_tractive_efficiency, tractive_efficiency
    from terrain.terramechanics.traction import JanosiCurve
    terrain = dataclasses.replace(get_terrain("GRASS"), curve=JanosiCurve(1.0, 5.0),
                                  soil_resistance=0.04, hysteresis=0.0)
    s_best, eta_best = max_tractive_efficiency(terrain)
    scan = np.linspace(0.0, 1.0, 100001)
    eta = tractive_efficiency(terrain, scan)
    assert s_best > 0.6                   # 0.641
    assert s_best == pytest.approx(scan[np.argmax(eta)], abs=1e-4)
    assert eta_best == pytest.approx(eta.max(), rel=1e-6)
