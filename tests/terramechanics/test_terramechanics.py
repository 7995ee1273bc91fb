import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from terrain.errors import ConfigError, DataFormatError, EstimationError, ShapeError
from terrain.sim.forces import contact_layout, contact_torque_nm
from terrain.terramechanics import (MEASURED_HUSKY_STRAIGHT, TERRAINS, BrixiusCurve,
                                    BurckhardtCurve,
                                    JanosiCurve, TractionAndResistance,
                                    bekker_compaction_coefficient, bekker_sinkage_m,
                                    brixius_mobility_number, brixius_motion_resistance,
                                    brixius_traction,
                                    calibrate_janosi, can_turn_in_place, get_terrain,
                                    husky_hysteresis_for_current, sae_slip, steady_slip,
                                    traction_coefficient, traction_curve_and_slope,
                                    traction_peak, turning_resistance_moment_nm)
from terrain.vehicles import HUSKY

REQUIRED = ["ASPHALT", "CONCRETE", "FLOORING", "ICE", "SNOW", "SANDY_LOAM", "DIRT_ROAD",
            "PLOUGHED", "UNPLOUGHED", "TILES", "GRASS", "GRAVEL"]


def test_catalogue_covers_required_terrains_with_sources():
    for name in REQUIRED:
        t = get_terrain(name)
        assert len(t.source) > 40 and t.curve is not None


def test_unknown_terrain_lists_choices():
    with pytest.raises(ConfigError, match="ASPHALT"):
        get_terrain("LAVA")


@pytest.mark.parametrize("name", list(TERRAINS))
def test_curve_odd_zero_and_slope_matches_finite_difference(name):
    curve = TERRAINS[name].curve
    s = np.linspace(-0.95, 0.95, 39)
    mu, dmu = traction_curve_and_slope(curve, s)
    assert np.allclose(mu, -mu[::-1])
    assert traction_coefficient(curve, 0.0) == pytest.approx(0.0)
    h = 1e-6
    pos = s[s > 0.01]
    fd = (traction_coefficient(curve, pos + h) - traction_coefficient(curve, pos - h)) / (2 * h)
    assert np.allclose(traction_curve_and_slope(curve, pos)[1], fd, rtol=1e-4, atol=1e-6)


@pytest.mark.parametrize("name", list(TERRAINS))
def test_traction_peak_is_curve_maximum(name):
    curve = TERRAINS[name].curve
    peak = traction_peak(curve)
    grid = np.linspace(0, 1, 5001)
    mu = traction_coefficient(curve, grid)
    assert 0.0 < peak.slip <= 1.0
    assert peak.mu_max == pytest.approx(mu.max(), rel=1e-4)
    assert peak.mu >= 0.95 * mu.max() - 1e-9


def test_burckhardt_dry_asphalt_peak_known_value():
    # c1 c2 e^{-c2 s} = c3  ->  s* = ln(c1 c2 / c3) / c2 ~ 0.17, mu ~ 1.17
    peak = traction_peak(BurckhardtCurve(1.2801, 23.99, 0.52))
    assert peak.slip == pytest.approx(0.170, abs=2e-3) and not peak.monotonic
    assert peak.mu == pytest.approx(1.17, abs=0.01)


def test_sae_slip_conditioning():
    assert sae_slip(1.0, 0.0) == 1.0
    assert sae_slip(0.0, 1.0) == -1.0
    assert sae_slip(1.0, 0.8) == pytest.approx(0.2)
    assert sae_slip(0.8, 1.0) == pytest.approx(-0.2)


def test_thesis_steady_slip_reproduced():
    assert steady_slip(get_terrain("TILES")) < 0.01
    assert 0.116 <= steady_slip(get_terrain("GRASS")) <= 0.135
    assert 0.122 <= steady_slip(get_terrain("GRAVEL")) <= 0.146


def test_steady_slip_refuses_a_non_finite_demand():
    # NaN made every comparison false and came out as 1.0 (full spin)
    for bad in (float("nan"), float("inf")):
        with pytest.raises(ConfigError, match="extra_demand must be finite"):
            steady_slip(get_terrain("SNOW"), bad)
    assert steady_slip(get_terrain("SNOW"), 10.0) == 1.0   # a finite demand beyond the peak


def test_calibrate_janosi_reproduces_catalogue_grass():
    c = calibrate_janosi(0.08, 0.1255, 0.339)
    g = get_terrain("GRASS").curve
    assert c.mu_max == pytest.approx(g.mu_max, abs=2e-3)
    assert c.shear_slip == pytest.approx(g.shear_slip, abs=2e-3)


def test_husky_hysteresis_reproduces_target_current():
    # rebuild the per-side current from the hysteresis by the simulator's contact torque law
    # and the motor law, independently of the calibration's algebra
    layout = contact_layout(HUSKY.contact_geometry(), HUSKY.mass_kg, 0.0, 1.0)
    for name, (cur, v) in MEASURED_HUSKY_STRAIGHT.items():
        t = get_terrain(name)
        h = husky_hysteresis_for_current(t, cur, v)
        assert h == pytest.approx(t.hysteresis)
        assert 0.0 < h < 0.4
        s = steady_slip(t)
        mu = np.full(len(layout.x_m), float(traction_coefficient(t.curve, s)))
        rim = np.full(len(layout.x_m), v / (1.0 - s))
        contact = contact_torque_nm(layout, dataclasses.replace(t, hysteresis=h), mu, rim)
        torque = np.bincount(layout.motor_of, weights=contact, minlength=layout.n_motors)
        omega = np.full(layout.n_motors, v / (1.0 - s) / layout.wheel_radius_m)
        side_current = HUSKY.motor.current_from_torque(torque, omega)
        assert side_current == pytest.approx(np.full(layout.n_motors, cur), rel=1e-6), name
    # a higher target needs more loss
    t = get_terrain("ASPHALT")
    assert husky_hysteresis_for_current(t, 3.0, 0.5) > husky_hysteresis_for_current(t, 2.0, 0.5)
    for speed in (0.0, -0.5, float("nan")):
        with pytest.raises(ConfigError, match="speed_m_s must be positive"):
            husky_hysteresis_for_current(t, 2.0, speed)


def test_dig_in_prediction():
    g = HUSKY.contact_geometry()
    assert can_turn_in_place(g, get_terrain("ASPHALT"))
    assert not can_turn_in_place(g, get_terrain("PLOUGHED"))
    assert turning_resistance_moment_nm(0.5, 100.0, 0.6) == pytest.approx(7.5)


def test_one_sae_slip_with_the_simulator_and_thesis_conditioning():
    from terrain.slip import sae_slip as slip_reexport
    from terrain.terramechanics.slip import sae_slip_and_velocity_slope

    assert slip_reexport is sae_slip
    # thesis defaults: 0.05 m/s dead band, saturation 1
    assert sae_slip(0.04, 0.0) == 0.0
    # simulator: no dead band, denominator floored at 0.02 m/s -> linear near standstill
    s = sae_slip(0.01, 0.0, speed_floor_m_s=0.02, dead_band_m_s=0.0)
    assert s == pytest.approx(0.5)
    wr = np.array([1.0, 1.0, 0.01, 0.5])
    v = np.array([0.8, 1.2, 0.0, -0.6])
    slip, dsdv = sae_slip_and_velocity_slope(wr, v, 0.02)
    np.testing.assert_allclose(slip, sae_slip(wr, v, speed_floor_m_s=0.02, dead_band_m_s=0.0))
    h = 1e-7
    fd = (sae_slip(wr, v + h, speed_floor_m_s=0.02, dead_band_m_s=0.0)
          - sae_slip(wr, v - h, speed_floor_m_s=0.02, dead_band_m_s=0.0)) / (2 * h)
    np.testing.assert_allclose(dsdv, fd, rtol=1e-5, atol=1e-6)


def test_sae_slip_denominator_is_the_slips_own():
    from terrain.terramechanics.slip import sae_slip_denominator

    wr = np.array([1.0, 1.0, 0.01, 0.5, 0.0])
    v = np.array([0.8, 1.2, 0.0, -0.6, 0.005])
    den = sae_slip_denominator(wr, v, 0.02)
    np.testing.assert_allclose(den, [1.0, 1.2, 0.02, 0.6, 0.02])
    # the slip is the speed difference over it (eqs. 7.1-7.2), saturated to [-1, 1]
    np.testing.assert_allclose(np.clip((wr - v) / den, -1.0, 1.0),
                               sae_slip(wr, v, speed_floor_m_s=0.02, dead_band_m_s=0.0))


def test_the_dead_band_is_where_sae_slip_is_zero_by_convention():
    from terrain.terramechanics.slip import in_dead_band

    wr = np.array([0.04, 0.04, 0.06, 0.0, -0.049, 0.3])
    v = np.array([0.0, 0.049, 0.0, -0.03, 0.01, 0.04])
    band = in_dead_band(wr, v, 0.05)
    np.testing.assert_array_equal(band, [True, True, False, True, True, False])
    # inside it sae_slip is 0 although the ratio is not; outside it is the ratio
    assert np.all(sae_slip(wr, v, dead_band_m_s=0.05)[band] == 0.0)
    np.testing.assert_allclose(sae_slip(wr, v, dead_band_m_s=0.05)[~band],
                               sae_slip(wr, v, dead_band_m_s=0.0)[~band])
    assert not in_dead_band(wr, v, 0.0).any()


@pytest.mark.parametrize("name", ["ASPHALT", "GRASS", "DIRT_ROAD"])
def test_curve_coefficients_slopes_match_finite_differences(name):
    terrain = TERRAINS[name]
    s = np.linspace(0.05, 0.95, 7)
    h = 1e-6
    c = terrain.curve.coefficients(s, terrain.soil_resistance)
    up = terrain.curve.coefficients(s + h, terrain.soil_resistance)
    dn = terrain.curve.coefficients(s - h, terrain.soil_resistance)
    np.testing.assert_allclose(c.dmu_ds, (up.mu - dn.mu) / (2 * h), rtol=1e-5, atol=1e-7)
    np.testing.assert_allclose(c.dresistance_ds, (up.resistance - dn.resistance) / (2 * h),
                               rtol=1e-5, atol=1e-7)


@pytest.mark.parametrize("rim, v, error", [
    ("fast", 1.0, DataFormatError), (None, 1.0, DataFormatError),
    (1.0, [1.0, "x"], DataFormatError),
    (np.ones(3), np.ones(4), ShapeError), (np.ones((2, 3)), np.ones(2), ShapeError)])
def test_sae_slip_refuses_non_numeric_or_unbroadcastable_speeds(rim, v, error):
    with pytest.raises(error, match="sae_slip"):
        sae_slip(rim, v)


@pytest.mark.parametrize("option", [{"saturation": "1"}, {"dead_band_m_s": float("nan")},
                                    {"speed_floor_m_s": None}])
def test_sae_slip_refuses_non_numeric_options(option):
    with pytest.raises(EstimationError, match="sae_slip"):
        sae_slip(1.0, 0.5, **option)


def test_sae_slip_broadcasts_compatible_shapes():
    s = sae_slip(np.array([[1.0], [0.5]]), np.array([0.5, 1.0, 0.25]))
    assert s.shape == (2, 3)
    assert s[0, 0] == pytest.approx(0.5) and s[1, 1] == pytest.approx(-0.5)


@settings(deadline=None)  # the first call compiles the numba kernel (~0.4 s)
@given(v=st.floats(-3.0, 3.0).filter(lambda v: abs(v) > 1e-3), s=st.floats(-0.95, 0.95))
def test_rim_and_ground_speed_from_slip_invert_sae_slip(v, s):
    # eqs. 7.1-7.2 solved for the rim speed, traction and braking, forward and reverse
    from terrain.terramechanics.slip import ground_speed_from_slip, rim_speed_from_slip
    rim, d_ground, d_slip = rim_speed_from_slip(v, s)
    assert float(sae_slip(rim, v, dead_band_m_s=0.0)) == pytest.approx(s, abs=1e-9)
    assert float(ground_speed_from_slip(rim, s)) == pytest.approx(v, rel=1e-9)
    h = 1e-7
    assert d_slip == pytest.approx((rim_speed_from_slip(v, s + h)[0]
                                    - rim_speed_from_slip(v, s - h)[0]) / (2 * h), rel=1e-5)
    assert d_ground == pytest.approx(rim / v, rel=1e-9)


def test_rim_speed_from_slip_braking_is_eq_7_2():
    from terrain.terramechanics.slip import rim_speed_from_slip
    assert rim_speed_from_slip(1.0, -0.2)[0] == pytest.approx(0.8)      # not 1 / 1.2
    assert rim_speed_from_slip(1.0, 0.2)[0] == pytest.approx(1.25)
    assert rim_speed_from_slip(-1.0, -0.2)[0] == pytest.approx(-1.25)   # reverse traction


def test_traction_and_resistance_takes_mu_from_one_curve_and_resistance_from_the_other():
    janosi = JanosiCurve(0.6, 0.1)
    brixius = get_terrain("PLOUGHED").curve
    s = np.linspace(0.0, 1.0, 21)
    both = TractionAndResistance(janosi, brixius).coefficients(s, 0.0)
    j, b = janosi.coefficients(s, 0.0), brixius.coefficients(s, 0.0)
    np.testing.assert_array_equal(both.mu, j.mu)
    np.testing.assert_array_equal(both.dmu_ds, j.dmu_ds)
    np.testing.assert_array_equal(both.resistance, b.resistance)
    np.testing.assert_array_equal(both.dresistance_ds, b.dresistance_ds)
    assert both.resistance[0] > 0.0                    # Brixius 1/Bn at zero slip
    # a constant-resistance curve passes the terrain's soil_resistance through
    back = TractionAndResistance(brixius, janosi).coefficients(s, 0.08)
    np.testing.assert_array_equal(back.resistance, np.full_like(s, 0.08))


@pytest.mark.parametrize("name", ["DIRT_ROAD", "UNPLOUGHED", "PLOUGHED"])
def test_brixius_net_traction_is_the_source_form_and_its_hysteresis_holds_the_0_04(name):
    # Brixius (1987): GT = 0.88 (1 - e^-0.1Bn)(1 - e^-7.5s) + 0.04,
    # MR = 1/Bn + 0.04 + 0.5 s / sqrt(Bn); the code drops the 0.04 from both
    terrain = get_terrain(name)
    bn = terrain.curve.mobility_number
    s = np.linspace(0.0, 1.0, 41)
    gt = 0.88 * (1 - np.exp(-0.1 * bn)) * (1 - np.exp(-7.5 * s)) + 0.04
    mr = 1 / bn + 0.04 + 0.5 * s / np.sqrt(bn)
    mu, _ = brixius_traction(s, bn)
    rho, _ = brixius_motion_resistance(s, bn)
    np.testing.assert_allclose(mu - rho, gt - mr, rtol=0, atol=1e-12)
    np.testing.assert_allclose(mu, gt - 0.04, rtol=0, atol=1e-12)
    # the torque-only loss the wheel torque adds back is at least Brixius's 0.04
    assert terrain.hysteresis >= 0.04


@pytest.mark.parametrize("name", ["SANDY_LOAM", "SNOW", "GRASS", "PLOUGHED", "ASPHALT"])
def test_curve_coefficients_of_an_integer_slip_equal_those_of_the_same_float_slip(name):
    # np.full_like took the dtype of an integer slip: the constant soil resistance 0.08 of
    # SANDY_LOAM came back as 0 at slip np.array([0, 1]) and Brixius's slope as 0
    terrain = get_terrain(name)
    as_int = terrain.curve.coefficients(np.array([0, 1]), terrain.soil_resistance)
    as_float = terrain.curve.coefficients(np.array([0.0, 1.0]), terrain.soil_resistance)
    for got, want in zip(as_int, as_float):
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-15)
        assert np.asarray(got).dtype == np.float64
    scalar = terrain.curve.coefficients(1, terrain.soil_resistance)
    np.testing.assert_allclose(scalar.resistance, as_float.resistance[1], rtol=0, atol=1e-15)


@pytest.mark.parametrize("load_n", [0.0, -5.0])
def test_bekker_sinkage_and_compaction_of_an_unloaded_plate_are_zero(load_n):
    # before: W = 0 raised ZeroDivisionError in bekker_compaction_coefficient and W < 0 a
    # TypeError (a negative pressure to the power 1/n is complex); the limit W -> 0 is 0
    soil = dict(width_m=0.11, length_m=0.08, k_c=5.27e3, k_phi=1515.04e3, n=0.7)
    assert bekker_sinkage_m(load_n, **soil) == 0.0
    assert bekker_compaction_coefficient(load_n, **soil) == 0.0
    assert bekker_sinkage_m(1e-6, **soil) < 1e-12            # continuous at 0
    assert bekker_compaction_coefficient(1e-6, **soil) < 1e-12


@pytest.mark.parametrize("mu_max, shear_slip, residual_ratio", [
    (0.6, -0.1, None),      # before: mu(0.5) = -4.0, traction against the slip, |mu| > mu_max
    (0.6, 0.0, None),       # before: mu(0.5) = 0.6 with a NaN slope
    (0.6, float("nan"), None),
    (-0.2, 0.1, None),
    (float("inf"), 0.1, None),
    (0.6, 0.1, 1.0),
])
def test_janosi_curve_refuses_parameters_with_no_physical_curve(
        mu_max, shear_slip, residual_ratio):
    with pytest.raises(ConfigError):
        JanosiCurve(mu_max, shear_slip, residual_ratio=residual_ratio)


@pytest.mark.parametrize("load_n", [0.0, -10.0])
def test_janosi_from_soil_refuses_a_contact_without_load(load_n):
    # before: ZeroDivisionError at W = 0, a negative mu_max below it (which the curve's own
    # mu_max check refused too: the load must be the field named)
    with pytest.raises(ConfigError, match="from_soil: load_n must be a finite load"):
        JanosiCurve.from_soil(1720.0, 29.0, 0.025, 0.11 * 0.08, 0.08, load_n)


@pytest.mark.parametrize("length_m", [0.0, -0.08, float("nan")])
def test_janosi_from_soil_refuses_a_contact_without_length(length_m):
    # before: ZeroDivisionError at L = 0, a negative or NaN shear slip K / L below it
    with pytest.raises(ConfigError, match="contact_length_m"):
        JanosiCurve.from_soil(1720.0, 29.0, 0.025, 0.11 * 0.08, length_m, 500.0)


@pytest.mark.parametrize("c1, c2, c3", [(0.0, 23.99, 0.52), (1.28, -1.0, 0.52),
                                        (1.28, 23.99, -0.1), (float("nan"), 23.99, 0.52),
                                        (1.28, float("inf"), 0.52), ("1.28", 23.99, 0.52)])
def test_burckhardt_curve_refuses_coefficients_outside_their_ranges(c1, c2, c3):
    # a negative c3 or c2 built a curve whose mu falls from s = 0 (NaN propagated, text
    # failed at the first evaluation)
    with pytest.raises(ConfigError, match="BurckhardtCurve"):
        BurckhardtCurve(c1, c2, c3)


@pytest.mark.parametrize("bn", [0.0, -3.0, float("nan"), float("inf"), None])
def test_brixius_curve_refuses_a_mobility_number_it_cannot_divide_by(bn):
    with pytest.raises(ConfigError, match="BrixiusCurve"):
        BrixiusCurve(bn)


@pytest.mark.parametrize("field, value", [
    ("load_n", 0.0),                  # before: ZeroDivisionError 'float division by zero'
    ("load_n", -400.0),               # before: a negative Bn
    ("diameter_m", 0.0),              # before: ZeroDivisionError
    ("section_width_m", -0.11),
    ("cone_index_pa", float("nan")),
    ("deflection_ratio", 1.5),        # a deflection larger than the section height
    ("load_n", "400"),                # before: TypeError
])
def test_brixius_mobility_number_refuses_an_unloaded_or_impossible_tyre(field, value):
    args = dict(cone_index_pa=1.5e6, section_width_m=0.11, diameter_m=0.33, load_n=400.0,
                deflection_ratio=0.1)
    assert brixius_mobility_number(**args) == pytest.approx(
        1.5e6 * 0.11 * 0.33 / 400.0 * 1.5 / (1.0 + 3.0 / 3.0))
    args[field] = value
    with pytest.raises(ConfigError, match=f"brixius_mobility_number.*{field}"):
        brixius_mobility_number(**args)


@pytest.mark.parametrize("field, change", [
    ("friction_angle_deg", dict(friction_angle_deg=90.0)),      # before: mu_max 1.6e16
    ("friction_angle_deg", dict(friction_angle_deg=100.0)),     # before: named mu_max
    ("friction_angle_deg", dict(friction_angle_deg=-5.0)),
    ("friction_angle_deg", dict(friction_angle_deg=float("nan"))),
    ("cohesion_pa", dict(cohesion_pa=-500.0)),                  # before: accepted, mu_max 0.53
    ("cohesion_pa", dict(cohesion_pa=float("inf"))),
    ("contact_area_m2", dict(contact_area_m2=-0.01)),           # before: accepted
    ("contact_area_m2", dict(contact_area_m2=0.0)),
    ("shear_modulus_m", dict(shear_modulus_m=-0.02)),           # before: named shear_slip
    ("shear_modulus_m", dict(shear_modulus_m=0.0)),
])
def test_janosi_from_soil_refuses_soil_values_naming_the_field(field, change):
    args = dict(cohesion_pa=1000.0, friction_angle_deg=30.0, shear_modulus_m=0.02,
                contact_area_m2=0.01, contact_length_m=0.1, load_n=100.0)
    args.update(change)
    with pytest.raises(ConfigError, match=f"JanosiCurve.from_soil: {field}"):
        JanosiCurve.from_soil(**args)


def test_janosi_from_soil_accepts_a_frictionless_or_cohesionless_soil():
    assert JanosiCurve.from_soil(0.0, 30.0, 0.02, 0.01, 0.1, 100.0).mu_max == pytest.approx(
        np.tan(np.radians(30.0)))
    assert JanosiCurve.from_soil(1000.0, 0.0, 0.02, 0.01, 0.1, 100.0).mu_max == pytest.approx(
        0.1)


@pytest.mark.parametrize("points", [2, 1, 0, -3, 2.5, "2001"])
def test_max_tractive_efficiency_refuses_a_grid_of_fewer_than_3_points(points):
    from terrain.terramechanics.efficiency import max_tractive_efficiency

    # before: points=1 returned (0.0, 0.0) on SNOW (true maximum 0.154 at slip 0.46),
    # points=0 raised NumPy's "argmax of an empty sequence"
    with pytest.raises(ConfigError, match="points"):
        max_tractive_efficiency(TERRAINS["SNOW"], points=points)


@pytest.mark.parametrize("points", [1, 0, -1, 3.5])
def test_stable_side_refuses_a_grid_of_fewer_than_2_points(points):
    from terrain.terramechanics.inverse import slip_from_traction, stable_side

    # before: points=1 tabulated only (0, 0), so slip_from_traction(ASPHALT, 0.5) said
    # slip 0, saturated; points=0 raised an IndexError
    curve = TERRAINS["ASPHALT"].curve
    with pytest.raises(ConfigError, match="points"):
        stable_side(curve, points)
    with pytest.raises(ConfigError, match="points"):
        slip_from_traction(curve, 0.5, points)


@pytest.mark.parametrize("fraction", [0.0, 1.5, -0.2, float("nan")])
def test_slip_at_peak_fraction_refuses_a_fraction_outside_0_1_with_a_config_error(fraction):
    from terrain.terramechanics.inverse import slip_at_peak_fraction

    with pytest.raises(ConfigError, match="fraction"):
        slip_at_peak_fraction(TERRAINS["ASPHALT"].curve, fraction)


@pytest.mark.parametrize("field, args", [
    ("k_c / width_m \\+ k_phi", (100.0, 0.1, 0.1, -5e3, 10.0, 0.7)),   # before: TypeError
    ("k_c / width_m \\+ k_phi", (100.0, 0.1, 0.1, 0.0, 0.0, 0.7)),     # ZeroDivisionError
    ("width_m", (100.0, 0.0, 0.1, 5.27e3, 1515.04e3, 0.7)),            # ZeroDivisionError
    ("length_m", (100.0, 0.1, -0.1, 5.27e3, 1515.04e3, 0.7)),          # NaN sinkage
    ("n", (100.0, 0.1, 0.1, 5.27e3, 1515.04e3, 0.0)),
])
def test_bekker_sinkage_refuses_a_plate_or_soil_with_no_sinkage(field, args):
    with pytest.raises(ConfigError, match=rf"bekker_sinkage_m(\.|: ){field}"):
        bekker_sinkage_m(*args)
    with pytest.raises(ConfigError, match=rf"bekker_compaction_coefficient(\.|: ){field}"):
        bekker_compaction_coefficient(*args)     # (errx: named by the function called)


@pytest.mark.parametrize("args, field", [
    ((0.0, 0.1255, 0.339), "soil_resistance"),      # before: ZeroDivisionError
    ((-0.08, 0.1255, 0.339), "soil_resistance"),
    ((0.08, 0.0, 0.339), "slip_steady"),
    ((0.08, 0.1255, 1.5), "slip_accel"),
    ((0.08, 0.339, 0.1255), "no Janosi-Hanamoto curve"),   # before: brentq's sign message
    ((0.08, 0.1255, 0.339, 0.0), "accel_m_s2"),
])
def test_calibrate_janosi_refuses_data_with_no_curve_naming_why(args, field):
    with pytest.raises(ConfigError, match=rf"calibrate_janosi(\.|: ){field}"):
        calibrate_janosi(*args)


@pytest.mark.parametrize("c1, c2, c3", [(0.05, 0.5, 1.0), (1.0, 0.5, 0.5)])
def test_burckhardt_curve_refuses_a_curve_that_does_not_rise_from_zero(c1, c2, c3):
    # mu'(0) = c1 c2 - c3 <= 0: mu falls (or stays flat) from s = 0, no stable side; before:
    # accepted, and traction_peak failed with scipy's bare 'The lower bound exceeds the
    # upper bound' (its refinement took the grid's last point as the lower bound)
    with pytest.raises(ConfigError, match="BurckhardtCurve.*c1 c2 > c3"):
        BurckhardtCurve(c1, c2, c3)


@pytest.mark.parametrize("args", [(0.3, 0.005, 0.05, 0.1), (0.08, 1e-4, 0.5)])
def test_calibrate_janosi_solves_data_whose_k_lies_outside_1e3(args):
    # a firm soil (f = 0.3) with slips 0.005 / 0.05 at 0.1 m/s^2 has its K/L near 1e-4:
    # before, brentq's fixed bracket [1e-3, 1e3] gave 'f(a) and f(b) must have different
    # signs' for data the docstring accepts
    f, s_ss, s_acc = args[:3]
    accel = args[3] if len(args) > 3 else 1.0
    curve = calibrate_janosi(*args)
    assert float(traction_coefficient(curve, s_ss)) == pytest.approx(f, rel=1e-6)
    assert float(traction_coefficient(curve, s_acc)) == pytest.approx(f + accel / 9.80665,
                                                                      rel=1e-6)


@pytest.mark.parametrize("args, field", [(("0.5", 0.3), "mu_max"), ((0.5, None), "shear_slip"),
                                         ((True, 0.3), "mu_max"),
                                         ((0.5, 0.3, "", "0.4"), "residual_ratio")])
def test_janosi_curve_refuses_a_value_that_is_not_a_number(args, field):
    # before: numpy's bare TypeError ('ufunc isfinite not supported'), Python's for the
    # residual ratio, and mu_max=True built a curve of mu_max 1
    with pytest.raises(ConfigError, match=rf"JanosiCurve\.{field}"):
        JanosiCurve(*args)
