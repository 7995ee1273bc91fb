"""Review sim20: the slip (and traction) arguments of the terramechanics relations are numbers,
as :func:`terrain.terramechanics.traction.traction_coefficient` already demands: a boolean was
taken as full slip, text parsed, None a silent NaN."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from terrain.errors import DataFormatError
from terrain.terramechanics import (TERRAIN_NAMES, BrixiusCurve, BurckhardtCurve, JanosiCurve,
                                    TractionAndResistance, get_terrain,
                                    soil_resistance_coefficient, traction_coefficient)
from terrain.terramechanics.efficiency import tractive_efficiency
from terrain.terramechanics.inverse import slip_from_traction

NOT_NUMBERS = (True, False, np.array([True, False]), "0.1", ["0.1", "0.2"], None,
               np.array([0.1, None], dtype=object))
RELATIONS = {
    "soil_resistance_coefficient": lambda x: soil_resistance_coefficient(
        get_terrain("PLOUGHED"), x),
    "tractive_efficiency": lambda x: tractive_efficiency(get_terrain("SNOW"), x),
    "slip_from_traction": lambda x: slip_from_traction(get_terrain("ASPHALT").curve, x),
    "traction_coefficient": lambda x: traction_coefficient(get_terrain("ASPHALT").curve, x),
}


@pytest.mark.parametrize("relation", sorted(RELATIONS))
@pytest.mark.parametrize("bad", NOT_NUMBERS, ids=repr)
def test_a_slip_or_traction_that_is_not_numbers_is_refused(relation, bad):
    # True was full slip (efficiency 0, the resistance at s = 1), '0.1' was parsed, None NaN
    with pytest.raises(DataFormatError, match=r"must be a number or a numeric array"):
        RELATIONS[relation](bad)


@settings(max_examples=40, deadline=None)
@given(name=st.sampled_from(TERRAIN_NAMES),
       s=st.lists(st.floats(-1.0, 1.0), min_size=0, max_size=5),
       as_int=st.booleans())
def test_numbers_of_any_numeric_dtype_give_the_float_answer(name, s, as_int):
    terrain = get_terrain(name)
    x = np.round(s).astype(int) if as_int else np.asarray(s, dtype=float)
    xf = x.astype(float)
    np.testing.assert_array_equal(soil_resistance_coefficient(terrain, x),
                                  soil_resistance_coefficient(terrain, xf))
    np.testing.assert_array_equal(tractive_efficiency(terrain, x), tractive_efficiency(terrain, xf))
    np.testing.assert_array_equal(slip_from_traction(terrain.curve, x).slip,
                                  slip_from_traction(terrain.curve, xf).slip)
    for one in (0, 0.3, np.float32(0.3), -1):
        assert np.isfinite(soil_resistance_coefficient(terrain, one))
        assert np.isfinite(tractive_efficiency(terrain, one))


@settings(max_examples=40, deadline=None)
@given(a_long=st.floats(0.0, 50.0), a_lat=st.lists(st.floats(0.0, 50.0), min_size=1, max_size=4),
       kr=st.sampled_from((None, 0.4, 0.9)))
def test_combined_shear_shares_broadcast_a_single_displacement_over_the_contacts(
        a_long, a_lat, kr):
    # a scalar longitudinal displacement with one lateral per contact was a bare ValueError
    # ('all the input arrays must have same number of dimensions')
    from terrain.terramechanics.lateral import combined_shear_shares
    lat = np.asarray(a_lat)
    got = combined_shear_shares(a_long, lat, kr)
    want = combined_shear_shares(np.full_like(lat, a_long), lat, kr)
    for g, w in zip(got, want):
        assert g.shape == lat.shape
        np.testing.assert_array_equal(g, w)
    one = combined_shear_shares(a_long, a_lat[0], kr)
    assert np.shape(one[0]) == () and one[0] == got[0][0]


def test_combined_shear_shares_of_shapes_that_do_not_broadcast_is_a_shape_error():
    from terrain.errors import ShapeError
    from terrain.terramechanics.lateral import combined_shear_shares
    with pytest.raises(ShapeError, match=r"combined_shear_shares.*\(2,\).*\(3,\)"):
        combined_shear_shares(np.zeros(2), np.zeros(3))


SOIL_BAD = {"n": -1.0, "k_c": float("nan"), "k_phi": float("inf"), "cohesion_pa": -1.0,
            "friction_angle_deg": 0.0, "shear_modulus_m": 0.0, "unit_weight_n_m3": True,
            "lateral_shear_modulus_m": -0.01, "layer_depth_m": 0.0, "residual_ratio": 1.0,
            "slip_sinkage_ratio": float("nan"), "rate_weakening_speed_m_s": 0.0,
            "combined_shear": 1, "slip_compaction": "no"}


@pytest.mark.parametrize("field", sorted(SOIL_BAD))
def test_soil_params_refusals_name_the_class_field_and_the_soil(field):
    # the messages began with the soil's name ('snow (U.S., Harrison): k_c must be ...'),
    # naming neither SoilParams nor, for config_* checks, the field as Class.field
    from dataclasses import replace

    from terrain.errors import ConfigError
    from terrain.terramechanics.lateral import SOILS
    with pytest.raises(ConfigError, match=rf"SoilParams\.{field} .*\(soil 'snow \(U\.S\., "
                                          rf"Harrison\)'\)"):
        replace(SOILS["SNOW"], **{field: SOIL_BAD[field]})


@pytest.mark.parametrize("field, value", [("c1", float("nan")), ("c2", -1.0), ("c3", -0.1),
                                          ("c1", float("inf"))])
def test_burckhardt_refusals_name_the_coefficient(field, value):
    from dataclasses import replace

    from terrain.errors import ConfigError
    with pytest.raises(ConfigError, match=rf"BurckhardtCurve\.{field}"):
        replace(get_terrain("ASPHALT").curve, **{field: value})


ASPHALT_CURVE = get_terrain("ASPHALT").curve


@pytest.mark.parametrize("make, field", [
    (lambda: JanosiCurve(float("nan"), 0.1), "mu_max"),
    (lambda: JanosiCurve(0.5, 0.0), "shear_slip"),
    (lambda: JanosiCurve(0.5, 0.1, residual_ratio=1.0), "residual_ratio"),
    (lambda: BrixiusCurve(-3.0), "mobility_number"),
    (lambda: TractionAndResistance("ASPHALT", ASPHALT_CURVE), "traction"),
    (lambda: TractionAndResistance(ASPHALT_CURVE, None), "resistance"),
])
def test_curve_refusals_name_class_and_field(make, field):
    # 'JanosiCurve: mu_max must be ...'; TractionAndResistance took a name or None and failed
    # at its first use with an AttributeError naming no field
    from terrain.errors import ConfigError
    with pytest.raises(ConfigError, match=rf"(JanosiCurve|BrixiusCurve|TractionAndResistance)"
                                          rf"\.{field}"):
        make()


# any valid curve of the three families, the hump-type Janosi curve included (the catalogue's
# entries are a handful of points of this space)
CURVES = st.one_of(
    st.builds(lambda c1, c2, f: BurckhardtCurve(c1, c2, f * c1 * -np.expm1(-c2)),
              st.floats(0.05, 1.5), st.floats(1.0, 300.0), st.floats(0.0, 0.9)),
    st.builds(lambda m, k, r: JanosiCurve(m, k, residual_ratio=r), st.floats(0.05, 1.2),
              st.floats(0.005, 1.0), st.one_of(st.none(), st.floats(0.2, 0.95))),
    st.builds(BrixiusCurve, st.floats(5.0, 100.0)))


@pytest.mark.slow
@settings(max_examples=60, deadline=None)
@example(curve=BurckhardtCurve(1.0, 1.0, 0.0), soil=2.1914474387390497e-11, hyst=0.0,
         demand=0.0, frac=0.5)
@given(curve=CURVES, soil=st.floats(0.0, 0.2), hyst=st.floats(0.0, 0.3),
       demand=st.floats(-0.1, 0.5), frac=st.floats(0.01, 0.999))
def test_efficiency_steady_slip_and_inverses_hold_for_any_valid_curve(curve, soil, hyst,
                                                                      demand, frac):
    from terrain.terramechanics import TerrainParams, steady_slip, traction_peak
    from terrain.terramechanics.inverse import slip_at_peak_fraction, stable_side_end
    terrain = TerrainParams("X", curve, soil, hyst, 0.5, 0.1, 0.1, 0.5, "test")
    s = np.linspace(0.0, 1.0, 501)
    # Wong ch. 4.2: drawbar over drive power, never above 1, never negative
    eta = tractive_efficiency(terrain, s)
    assert np.all((eta >= 0.0) & (eta < 1.0))
    mu = traction_coefficient(curve, s)
    assert traction_peak(curve).mu_max >= mu.max() - 1e-12
    # the exact and the tabulated inverses of the stable side land on the asked traction
    _, mu_end = stable_side_end(curve)
    target = frac * mu_end
    np.testing.assert_allclose(float(traction_coefficient(curve, slip_at_peak_fraction(
        curve, frac))), target, rtol=0, atol=1e-8)
    back = float(slip_from_traction(curve, target).slip)
    assert abs(float(traction_coefficient(curve, back)) - target) <= 2e-3 * mu_end + 1e-12
    # the steady slip balances traction against soil resistance plus the demand
    ss = steady_slip(terrain, demand)
    net = mu - soil_resistance_coefficient(terrain, s) - demand
    if ss == 0.0:       # (brentq's xtol 1e-10: a root at 2e-11 comes back as 0.0)
        assert float(traction_coefficient(curve, 1e-8)
                     - soil_resistance_coefficient(terrain, 1e-8)) - demand >= 0.0
    elif ss == 1.0:
        assert net.max() < 1e-9
    else:
        assert abs(float(traction_coefficient(curve, ss)
                         - soil_resistance_coefficient(terrain, ss)) - demand) < 1e-6
        assert np.all(net[s < ss - 1e-6] < 1e-9)     # the first slip meeting the demand


@pytest.mark.parametrize("name", ("snow", "Snow", " SNOW", "", None, 3, True))
def test_a_terrain_name_that_is_not_an_upper_case_label_is_refused(name):
    # the simulator finds a terrain's soil (physics v2), tyre friction factor and desired
    # slip by its upper-case name: replace(SNOW, name='snow') ran v2 without the snow soil,
    # on the Coulomb lateral law, without a word
    from dataclasses import replace

    from terrain.errors import ConfigError
    with pytest.raises(ConfigError, match=r"TerrainParams\.name"):
        replace(get_terrain("SNOW"), name=name)


@settings(max_examples=30, deadline=None)
@given(st.text(alphabet="ABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_", min_size=1, max_size=12))
def test_an_upper_case_terrain_label_is_kept(name):
    from dataclasses import replace
    assert replace(get_terrain("ASPHALT"), name=name).name == name
