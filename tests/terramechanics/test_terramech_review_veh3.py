"""Review veh3: the slopes of the slip-sinkage, slip-compaction, rate-weakening and
combined-slip laws against finite differences and their formulas (hand mutants of each
slope survived the targeted tests)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from terrain.errors import ConfigError
from terrain.terramechanics.catalogue import TERRAINS
from terrain.terramechanics.lateral import (SOILS, SlipCompactionResistance,
                                            rate_weakening_factor, slip_sinkage_m,
                                            soil_contact)

HUSKY_LOAD_N = 50.0 * 9.80665 / 4.0


def _contact(ratio=3.0):
    soil = replace(SOILS["SANDY_LOAM"], slip_sinkage_ratio=ratio)
    return soil_contact(soil, 0.11, 0.08, 0.1651, 4.0 * HUSKY_LOAD_N)


def test_slip_sinkage_is_linear_in_the_slip_with_the_slope_it_reports():
    contact = _contact(3.0)
    z0 = float(np.interp(HUSKY_LOAD_N, contact.load_grid_n, contact.sinkage_grid_m))
    s = np.array([0.0, 0.2, 0.5, 0.9])
    z, dz = slip_sinkage_m(contact, HUSKY_LOAD_N, s)
    np.testing.assert_allclose(z, z0 * (1.0 + 3.0 * s), rtol=1e-12)
    np.testing.assert_allclose(dz, np.full(4, 3.0 * z0), rtol=1e-12)
    h = 1e-6
    fd = (slip_sinkage_m(contact, HUSKY_LOAD_N, s + h)[0]
          - slip_sinkage_m(contact, HUSKY_LOAD_N, s)[0]) / h
    np.testing.assert_allclose(dz, fd, rtol=1e-6)


def test_slip_sinkage_slope_is_zero_where_the_sinkage_is_capped():
    contact = _contact(1e4)          # any slip above 1e-3 sinks the wheel to its radius
    z, dz = slip_sinkage_m(contact, HUSKY_LOAD_N, np.array([0.5]))
    assert z[0] == pytest.approx(0.1651)
    assert dz[0] == 0.0


def test_slip_compaction_slope_is_the_derivative_of_its_resistance():
    contact = _contact(3.0)
    base = TERRAINS["SANDY_LOAM"].curve
    curve = SlipCompactionResistance(base, contact, HUSKY_LOAD_N)
    s = np.array([0.05, 0.2, 0.6])
    c = curve.coefficients(s, 0.08)
    h = 1e-6
    fd = (curve.coefficients(s + h, 0.08).resistance - c.resistance) / h
    np.testing.assert_allclose(c.dresistance_ds, fd, rtol=1e-4)
    # at rest the rut is the static one: the base curve's resistance, no more
    assert curve.coefficients(np.array([0.0]), 0.08).resistance[0] == pytest.approx(0.08)
    # the deeper rut of a slipping wheel resists more
    assert np.all(np.diff(c.resistance) > 0.0)


def test_rate_weakening_halves_the_strength_at_its_speed_with_the_slope_it_reports():
    soil = replace(SOILS["SNOW"], rate_weakening_speed_m_s=0.2)
    u = np.array([0.0, 0.1, 0.2, 1.0])
    f, df = rate_weakening_factor(u, soil)
    np.testing.assert_allclose(f, 1.0 / (1.0 + u / 0.2), rtol=1e-15)
    assert f[2] == 0.5
    h = 1e-7
    fd = (rate_weakening_factor(u + h, soil)[0] - f) / h
    np.testing.assert_allclose(df, fd, rtol=1e-5)
    # a soil without it keeps the whole strength
    f1, df1 = rate_weakening_factor(u, SOILS["SNOW"])
    assert np.all(f1 == 1.0) and np.all(df1 == 0.0)


def test_combined_slip_tangent_at_exactly_the_hold_slip_is_the_curve_slope():
    from terrain.terramechanics.combined_slip import combined_slip_coefficients

    curve = TERRAINS["SANDY_LOAM"].curve        # rising up to s = 1: a nonzero slope there
    out = combined_slip_coefficients(curve, np.array([1.0, 0.6]), np.array([0.0, 0.8]), 0.6)
    slope = curve.coefficients(np.array([1.0]), 0.0).dmu_ds[0]
    assert slope > 0.0
    np.testing.assert_allclose(out.tangent, [slope, slope], rtol=1e-12)   # s_res = 1 both
    beyond = combined_slip_coefficients(curve, np.array([0.9]), np.array([0.9]), 0.6)
    assert beyond.tangent[0] == 0.0


@pytest.mark.parametrize("load_n", [float("nan"), float("inf"), True, "100", None])
def test_bekker_plate_refuses_a_load_that_is_not_a_finite_number(load_n):
    # before: NaN gave a NaN sinkage and inf an infinite one without a word, True a 1 N
    # load, '100' and None Python's bare TypeError on the comparison with 0
    from terrain.terramechanics.resistance import (bekker_compaction_coefficient,
                                                   bekker_sinkage_m)

    plate = dict(width_m=0.11, length_m=0.08, k_c=5.27e3, k_phi=1515.04e3, n=0.7)
    with pytest.raises(ConfigError, match=r"bekker_sinkage_m\.load_n"):
        bekker_sinkage_m(load_n, **plate)
    with pytest.raises(ConfigError, match=r"bekker_compaction_coefficient\.load_n"):
        bekker_compaction_coefficient(load_n, **plate)     # (errx: the function called)


@pytest.mark.parametrize("field, value", [("k_c", "5270"), ("k_phi", None)])
def test_bekker_plate_refuses_moduli_that_are_not_real_numbers(field, value):
    # before: Python's bare TypeError on '5270' / 0.11 and None + 5270 / 0.11
    from terrain.terramechanics.resistance import bekker_sinkage_m

    plate = dict(width_m=0.11, length_m=0.08, k_c=5.27e3, k_phi=1515.04e3, n=0.7)
    with pytest.raises(ConfigError, match=rf"bekker_sinkage_m\.{field}"):
        bekker_sinkage_m(100.0, **{**plate, field: value})


@pytest.mark.parametrize("field, value", [
    ("friction_angle_deg", True),        # before: a soil with phi = 1 degree
    ("friction_angle_deg", "29"),        # before: bare TypeError on 0.0 < '29'
    ("k_c", "5270"),                     # before: bare TypeError from np.isfinite
    ("k_phi", None),                     # before: bare TypeError from np.isfinite
    ("layer_depth_m", True),             # before: a 1 m layer
    ("slip_sinkage_ratio", True),        # before: k_s = 1
    ("rate_weakening_speed_m_s", True),  # before: u_c = 1 m/s
    ("residual_ratio", "0.5"),           # before: bare TypeError on 0.0 < '0.5'
    ("lateral_shear_modulus_m", True),   # (refused before too, by config_positive)
])
def test_soil_params_refuse_values_that_are_not_real_numbers(field, value):
    with pytest.raises(ConfigError, match=rf"\.{field} must be a real number"):
        replace(SOILS["SANDY_LOAM"], **{field: value})


def test_soil_params_keep_the_shipped_rows_and_the_optional_none():
    for soil in SOILS.values():
        assert replace(soil) == soil
    bare = replace(SOILS["SANDY_LOAM"], lateral_shear_modulus_m=None, layer_depth_m=None,
                   residual_ratio=None, slip_sinkage_ratio=None,
                   rate_weakening_speed_m_s=None)
    assert bare.shear_modulus_y_m == bare.shear_modulus_m


@pytest.mark.parametrize("load_n", [0.0, -5.0, float("nan"), float("inf"), True])
def test_slip_compaction_refuses_a_load_that_is_not_a_finite_positive_one(load_n):
    # before: 0 and NaN gave a NaN resistance and slope at every slip (0/0), -5 N silently
    # the base resistance, True a 1 N wheel
    with pytest.raises(ConfigError, match=r"SlipCompactionResistance\.load_n"):
        SlipCompactionResistance(TERRAINS["SANDY_LOAM"].curve, _contact(3.0), load_n)


def test_slip_compaction_refuses_a_soil_without_slip_sinkage():
    # before: Python's bare TypeError (None * float) at the first coefficients() call
    contact = soil_contact(SOILS["SANDY_LOAM"], 0.11, 0.08, 0.1651, 4.0 * HUSKY_LOAD_N)
    with pytest.raises(ConfigError, match="slip_sinkage_ratio"):
        SlipCompactionResistance(TERRAINS["SANDY_LOAM"].curve, contact, HUSKY_LOAD_N)


@pytest.mark.parametrize("iterations", [0, -3, 2.5, True])
def test_wheel_sinkage_refuses_an_iteration_count_that_is_not_a_positive_integer(iterations):
    # before: 0 (or -3) returned (0.0, footprint) as the wheel's sinkage without a word, a
    # Husky wheel on SNOW that sinks 73 mm; 2.5 raised range()'s bare TypeError; True ran one
    from terrain.terramechanics.lateral import wheel_sinkage_m

    with pytest.raises(ConfigError, match="iterations"):
        wheel_sinkage_m(HUSKY_LOAD_N, 0.11, 0.08, 0.1651, SOILS["SNOW"], iterations=iterations)


def test_wheel_sinkage_is_the_fixed_point_of_bekker_on_the_sunk_chord():
    from terrain.terramechanics.lateral import contact_chord_m, wheel_sinkage_m
    from terrain.terramechanics.resistance import bekker_sinkage_m

    soil = SOILS["SNOW"]
    z, length = wheel_sinkage_m(HUSKY_LOAD_N, 0.11, 0.08, 0.1651, soil)
    assert z == pytest.approx(0.0730, abs=5e-4)          # docs/physics_v2.md: 73 mm
    assert length == pytest.approx(float(contact_chord_m(z, 0.1651, 0.08)), rel=1e-9)
    assert z == pytest.approx(bekker_sinkage_m(HUSKY_LOAD_N, 0.11, length, soil.k_c,
                                               soil.k_phi, soil.n), rel=1e-9)


def test_lateral_strength_is_cohesion_friction_and_the_bulldozed_wall_of_the_chord():
    from terrain.terramechanics.lateral import bulldozing_force_n, lateral_strength_n

    soil = SOILS["SNOW"]
    width, load, z, chord = 0.11, np.array([123.0]), np.array([0.073]), np.array([0.274])
    want = (soil.cohesion_pa * width * chord + load * np.tan(np.radians(23.2))
            + bulldozing_force_n(z, chord, soil))       # the wall is as wide as the chord
    np.testing.assert_allclose(lateral_strength_n(soil, width, load, z, chord), want,
                               rtol=1e-12)
    assert bulldozing_force_n(z, chord, soil)[0] > 2.0 * bulldozing_force_n(z, width, soil)[0]
