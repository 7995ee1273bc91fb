"""Review tm18 of terrain.terramechanics: inputs refused by name, inverse slip outside its
domain, and Hypothesis properties of the traction curves, their peaks and the calibrations."""

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from terrain.errors import ConfigError, DataFormatError, DataWarning
from terrain.terramechanics import (G_M_S2, TERRAIN_NAMES, BurckhardtCurve, JanosiCurve,
                                    TerrainParams, calibrate_janosi, get_terrain,
                                    husky_hysteresis_for_current, sae_slip,
                                    soil_resistance_coefficient, steady_slip,
                                    traction_coefficient, traction_curve_and_slope,
                                    traction_peak)
from terrain.terramechanics.resistance import grade_resistance_n, lateral_force_and_slope
from terrain.terramechanics.slip import ground_speed_from_slip, rim_speed_from_slip


@pytest.mark.parametrize("v, s", [(1.0, 1.0), (0.0, 1.0), (-1.0, -1.0), (1.0, 1.5),
                                  (1.0, -1.5), (-1.0, 1.5)])
def test_rim_speed_from_slip_is_nan_where_no_rim_speed_gives_the_slip(v, s):
    # q = sign(v) s >= 1 divided by zero (ZeroDivisionError) or gave a rim running against
    # the ground (v 1, s 1.5: -2 m/s, whose slip is 1, not 1.5); q < -1 likewise
    assert all(math.isnan(x) for x in rim_speed_from_slip(v, s))


def test_rim_speed_from_slip_keeps_the_locked_wheel():
    # q = -1: a locked wheel on a moving body, rim speed 0 (eq. 7.2)
    rim = rim_speed_from_slip(2.0, -1.0)[0]
    assert rim == 0.0
    assert float(sae_slip(rim, 2.0, dead_band_m_s=0.0)) == -1.0
    assert float(ground_speed_from_slip(rim_speed_from_slip(2.0, 0.5)[0], 0.5)) == 2.0


@pytest.mark.parametrize("current_a", [0.0, -5.0, 0.5])
def test_husky_hysteresis_warns_of_a_current_below_what_the_traction_alone_draws(current_a):
    # it came out as hysteresis 0 without a word (tm5 keeps the 0), a terrain that then
    # draws more than the target
    with pytest.warns(DataWarning, match=r"current_a .* below the 2\.\d+ A"):
        assert husky_hysteresis_for_current(get_terrain("SNOW"), current_a, 0.5) == 0.0


def test_husky_hysteresis_round_trips_the_catalogue_calibration():
    snow = get_terrain("SNOW")
    assert husky_hysteresis_for_current(snow, 5.2, 0.37) == pytest.approx(snow.hysteresis)


@pytest.mark.parametrize("curve", [None, 0.5, "ASPHALT", (1.28, 23.99, 0.52)])
def test_terrain_params_refuses_a_curve_that_is_no_traction_curve(curve):
    # accepted, then an AttributeError ('NoneType' object has no attribute 'coefficients')
    # at the first traction or resistance asked of it, naming no field
    with pytest.raises(ConfigError, match="curve"):
        TerrainParams("X", curve, 0.1, 0.0, 0.5, 0.0, 0.0, 1.0, "test")


# --- Hypothesis properties -------------------------------------------------------------

FINE = np.linspace(0.0, 1.0, 4001)


def _curves():
    janosi = st.builds(JanosiCurve, mu_max=st.floats(0.05, 1.5), shear_slip=st.floats(0.005, 2.0),
                       residual_ratio=st.one_of(st.none(), st.floats(0.05, 0.95)))
    burck = st.builds(BurckhardtCurve, c1=st.floats(0.3, 1.5), c2=st.floats(5.0, 300.0),
                      c3=st.floats(0.0, 0.25))
    return st.one_of(janosi, burck, st.sampled_from([get_terrain(n).curve
                                                     for n in TERRAIN_NAMES]))


@settings(max_examples=60, deadline=None)
@given(curve=_curves(), saturation=st.floats(0.5, 1.0))
def test_traction_peak_is_a_true_maximum(curve, saturation):
    peak = traction_peak(curve, saturation)
    mu = traction_coefficient(curve, FINE)
    assert mu.max() <= peak.mu_max * (1 + 1e-9) + 1e-12
    assert float(traction_coefficient(curve, peak.slip)) == pytest.approx(peak.mu, rel=1e-9)
    if peak.monotonic:
        # the smallest slip (on the 1/20000 grid) reaching saturation x the maximum
        assert peak.mu >= saturation * peak.mu_max * (1 - 1e-12)
        assert float(traction_coefficient(curve, peak.slip - 5e-5)) < saturation * peak.mu_max
    else:
        assert peak.mu == peak.mu_max
        for ds in (1e-4, 1e-3, 1e-2):
            for s in (peak.slip - ds, peak.slip + ds):
                if 0.0 <= s <= 1.0:
                    assert float(traction_coefficient(curve, s)) <= peak.mu * (1 + 1e-12)


@settings(max_examples=60, deadline=None)
@given(curve=_curves(), s=st.floats(0.0, 1.0), s2=st.floats(0.0, 1.0))
def test_traction_is_bounded_by_its_strength_and_its_slope_even(curve, s, s2):
    mu, slope = traction_curve_and_slope(curve, np.array([s, -s]))
    bound = curve.c1 if isinstance(curve, BurckhardtCurve) else (
        curve.mu_max if isinstance(curve, JanosiCurve) else 0.88)
    assert 0.0 <= mu[0] <= bound and mu[1] == -mu[0]
    assert slope[1] == slope[0]
    peak = traction_peak(curve)
    lo, hi = sorted((s, s2))
    if hi <= peak.slip:      # monotone up to the peak
        assert (float(traction_coefficient(curve, lo))
                <= float(traction_coefficient(curve, hi)) * (1 + 1e-12) + 1e-15)


@settings(max_examples=60, deadline=None)
@given(c=st.floats(0.0, 20e3), phi=st.floats(0.0, 45.0), k=st.floats(0.005, 0.1),
       w1=st.floats(10.0, 2000.0), w2=st.floats(10.0, 2000.0), s=st.floats(0.0, 1.0))
def test_janosi_force_is_affine_in_the_normal_load(c, phi, k, w1, w2, s):
    # F = mu W = (W tan phi + c A) g(s / k): Mohr-Coulomb, the strength grows with the load
    # by tan phi and the cohesion adds a load-independent c A
    area, length = 0.11 * 0.1, 0.1

    def force(w):
        return w * float(traction_coefficient(
            JanosiCurve.from_soil(c, phi, k, area, length, w), s))

    g = float(traction_coefficient(JanosiCurve(1.0, k / length), s))
    for w in (w1, w2):
        assert force(w) == pytest.approx((w * math.tan(math.radians(phi)) + c * area) * g,
                                         rel=1e-9, abs=1e-12)
    assert force(w1) + force(w2) == pytest.approx(2 * force(0.5 * (w1 + w2)), rel=1e-9,
                                                  abs=1e-9)


@pytest.mark.slow
@settings(max_examples=40, deadline=None)
@given(name=st.sampled_from(TERRAIN_NAMES), d1=st.floats(-0.2, 1.2), d2=st.floats(-0.2, 1.2))
def test_steady_slip_balances_the_demand_and_grows_with_it(name, d1, d2):
    terrain = get_terrain(name)
    lo, hi = sorted((d1, d2))
    s_lo, s_hi = steady_slip(terrain, lo), steady_slip(terrain, hi)
    assert 0.0 <= s_lo <= s_hi <= 1.0
    if 0.0 < s_lo < 1.0:
        net = (float(traction_coefficient(terrain.curve, s_lo))
               - float(soil_resistance_coefficient(terrain, s_lo)))
        assert net == pytest.approx(lo, abs=1e-8)


@pytest.mark.slow
@settings(max_examples=30, deadline=None)
@given(f=st.floats(0.02, 0.2), s_ss=st.floats(0.02, 0.3), ratio=st.floats(1.05, 3.0))
def test_calibrate_janosi_round_trips_its_two_slips(f, s_ss, ratio):
    s_acc = min(1.0, s_ss * ratio * (f + 1.0 / G_M_S2) / f)
    assume(s_acc < 0.99)
    curve = calibrate_janosi(f, s_ss, s_acc)
    terrain = TerrainParams("X", curve, f, 0.0, 0.5, 0.0, 0.0, 1.0, "test")
    assert steady_slip(terrain) == pytest.approx(s_ss, abs=1e-7)
    assert steady_slip(terrain, 1.0 / G_M_S2) == pytest.approx(s_acc, abs=1e-7)


@pytest.mark.parametrize("kr", [0.0, 1.0, -0.1, float("nan")])
def test_janosi_curve_refuses_a_residual_ratio_outside_zero_one_when_built(kr):
    # K_r = 0 passed the dataclass (mutant '0.0 <= residual_ratio') and failed only at the
    # first traction, in patch_mobilisation
    with pytest.raises(ConfigError, match="residual_ratio"):
        JanosiCurve(0.5, 0.3, residual_ratio=kr)


@pytest.mark.parametrize("load", [-100.0, -1e-9])
def test_coulomb_lateral_friction_of_a_negatively_loaded_contact_is_none(load):
    # a negative load flipped the friction into a force along the slide (mu 0.5, load
    # -100 N, sliding at +0.1 m/s: +50 N, pushing); the soil law
    # (soil_lateral_force_and_slope) clips the load at 0, as this one now does
    force, slope = lateral_force_and_slope(0.5, np.array([load, 100.0]), np.array([0.1, 0.1]))
    assert force[0] == 0.0 and slope[0] == 0.0
    assert force[1] == pytest.approx(-50.0, rel=1e-3) and slope[1] < 0.0


@pytest.mark.parametrize("mass", [-50.0, 0.0, float("nan"), float("inf"), True, "50"])
def test_grade_resistance_refuses_a_mass_that_is_no_mass(mass):
    # -50 kg climbing 0.1 rad gave -48.95 N (a grade that pushes uphill), NaN a NaN force
    with pytest.raises(ConfigError, match="mass_kg"):
        grade_resistance_n(mass, 0.1)


def test_husky_hysteresis_warns_between_the_no_load_and_the_traction_current():
    # SNOW at 0.5 m/s: no-load 1 A, with the traction 2.461 A; 2.4 A buys torque, but less
    # than the traction needs (mutant 'torque < 0' returned a negative hysteresis)
    with pytest.warns(DataWarning, match="current_a 2.4 A"):
        assert husky_hysteresis_for_current(get_terrain("SNOW"), 2.4, 0.5) == 0.0


def test_a_tie_between_drive_and_lateral_moments_does_not_spin():
    # 'spinning needs the moment of the longitudinal forces to exceed the lateral one'
    from terrain.terramechanics import can_turn_in_place, traction_peak
    from terrain.vehicles import ContactGeometry
    geometry = ContactGeometry(np.array([[1.0, 1.0], [1.0, -1.0], [-1.0, 1.0], [-1.0, -1.0]]),
                               np.array([0, 1, 0, 1]), np.full(4, 0.25), False, 0.165,
                               ("left", "right"))
    curve = JanosiCurve(0.5, 0.01)
    mu = traction_peak(curve).mu_max
    for lateral, spins in ((mu, False), (0.99 * mu, True)):
        terrain = TerrainParams("X", curve, 0.0, 0.0, lateral, 0.0, 0.0, 1.0, "test")
        assert can_turn_in_place(geometry, terrain) is spins


@pytest.mark.parametrize("slip", [True, np.array([True, False]), "0.1", "abc", None,
                                  [0.1, None]])
def test_traction_refuses_a_slip_that_is_no_number(slip):
    # True was full slip (asphalt mu(1) = 0.76), '0.1' was parsed, 'abc' a bare ValueError
    # and None a silent NaN
    with pytest.raises(DataFormatError, match="slip"):
        traction_curve_and_slope(get_terrain("ASPHALT").curve, slip)


def test_traction_takes_integer_and_float_slips():
    curve = get_terrain("ASPHALT").curve
    assert traction_coefficient(curve, np.array([0, 1])) == pytest.approx(
        traction_coefficient(curve, np.array([0.0, 1.0])))
