"""Physical invariants of the terramechanics laws, as Hypothesis properties.

* traction curves: ``mu(0) = 0``, odd in the slip, non-decreasing up to the traction peak,
  the slope they return is the derivative of ``mu`` and of the motion resistance;
* Bekker sinkage of a wheel: grows with the load, falls as the soil stiffens (``k_c`` and
  ``k_phi`` scaled up), never deeper than the wheel radius or the layer;
* lateral soil force: opposes the lateral sliding (dissipative), odd in ``v_lat``, bounded by
  the tabulated strength, and grows with the load on a soil whose shear does not soften;
* bulldozing grows with the wall's depth and width, linearly in the width;
* the friction ellipse: longitudinal force along the longitudinal slip, side force against
  the side slip, resultant never above the curve's maximum friction, isotropic (``k_S`` = 1)
  contacts rotate the force with the slip.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from terrain.terramechanics.catalogue import TERRAIN_NAMES, get_terrain
from terrain.terramechanics.combined_slip import combined_slip_coefficients
from terrain.terramechanics.lateral import (SOILS, bulldozing_force_n, soil_contact,
                                            soil_lateral_force_and_slope, wheel_sinkage_m)
from terrain.terramechanics.traction import (traction_curve_and_slope, traction_peak)

#: Husky tyre: width, firm footprint, radius (m); static wheel load (N).
B, L0, R = 0.11, 0.08, 0.1651
W = 50.0 * 9.80665 / 4.0
_CONTACTS = {name: soil_contact(soil, B, L0, R, 4.0 * W) for name, soil in SOILS.items()}
_PEAKS = {name: traction_peak(get_terrain(name).curve) for name in TERRAIN_NAMES}


@settings(max_examples=200, deadline=None)
@given(name=st.sampled_from(TERRAIN_NAMES), s1=st.floats(0.0, 1.0), s2=st.floats(0.0, 1.0))
def test_traction_is_odd_and_rises_up_to_its_peak(name, s1, s2):
    terrain = get_terrain(name)
    lo, hi = sorted((s1, s2))
    mu, _ = traction_curve_and_slope(terrain.curve, np.array([0.0, lo, hi, -lo, -hi]))
    assert mu[0] == 0.0
    np.testing.assert_allclose(mu[3:], -mu[1:3], rtol=0, atol=1e-15)
    assert np.all(mu[1:3] >= 0.0)
    peak = _PEAKS[name]
    if hi <= peak.slip:
        assert mu[2] >= mu[1] - 1e-12
    assert mu[2] <= peak.mu_max * (1 + 1e-9)


@settings(max_examples=200, deadline=None)
@given(name=st.sampled_from(TERRAIN_NAMES), s=st.floats(1e-3, 1.0 - 1e-3))
def test_curve_slopes_are_the_derivatives_of_traction_and_resistance(name, s):
    terrain = get_terrain(name)
    h = 1e-6
    c = terrain.curve.coefficients(np.array([s - h, s, s + h]), terrain.soil_resistance)
    assert c.dmu_ds[1] == pytest.approx((c.mu[2] - c.mu[0]) / (2 * h), rel=1e-4, abs=1e-6)
    assert c.dresistance_ds[1] == pytest.approx((c.resistance[2] - c.resistance[0]) / (2 * h),
                                                rel=1e-4, abs=1e-6)
    assert np.all(c.resistance >= 0.0)


@settings(max_examples=60, deadline=None)
@given(soil=st.sampled_from(sorted(SOILS)), w1=st.floats(1.0, 600.0), w2=st.floats(1.0, 600.0),
       stiffer=st.floats(1.1, 5.0))
def test_sinkage_grows_with_the_load_and_falls_with_the_soil_stiffness(soil, w1, w2, stiffer):
    params = SOILS[soil]
    assume(abs(w1 - w2) > 1e-3 * max(w1, w2))
    lo, hi = sorted((w1, w2))
    z_lo, l_lo = wheel_sinkage_m(lo, B, L0, R, params)
    z_hi, l_hi = wheel_sinkage_m(hi, B, L0, R, params)
    assert 0.0 < z_lo <= z_hi <= R                 # capped at the radius (SNOW, 550 N)
    assert z_lo < z_hi or z_lo == R
    assert L0 <= l_lo <= l_hi <= 2 * R
    stiff = replace(params, k_c=stiffer * params.k_c, k_phi=stiffer * params.k_phi)
    z_stiff = wheel_sinkage_m(hi, B, L0, R, stiff)[0]
    assert z_stiff < z_hi or z_stiff == R
    layer = replace(params, layer_depth_m=0.5 * z_hi)
    assert wheel_sinkage_m(hi, B, L0, R, layer)[0] == pytest.approx(0.5 * z_hi, rel=1e-12)


@settings(max_examples=200, deadline=None)
@given(soil=st.sampled_from(sorted(SOILS)), load=st.floats(0.0, 4.0 * W),
       v_lat=st.floats(-1.0, 1.0), rim=st.floats(-2.0, 2.0))
def test_lateral_soil_force_opposes_the_slide_and_is_bounded_by_the_strength(
        soil, load, v_lat, rim):
    contact = _CONTACTS[soil]
    args = (np.array([load]), np.array([v_lat]), np.array([rim]))
    force, slope, _ = soil_lateral_force_and_slope(contact, *args)
    mirrored, _, _ = soil_lateral_force_and_slope(contact, args[0], -args[1], -args[2])
    strength = np.interp(load, contact.load_grid_n, contact.strength_grid_n)
    assert force[0] * v_lat <= 0.0                          # dissipative
    assert mirrored[0] == pytest.approx(-force[0], abs=1e-12)
    assert abs(force[0]) <= strength * (1 + 1e-12)
    assert slope[0] <= 0.0
    if v_lat != 0.0:
        assert slope[0] == pytest.approx(force[0] / v_lat, rel=1e-9, abs=1e-12)


@settings(max_examples=100, deadline=None)
@given(w1=st.floats(1.0, 4.0 * W), w2=st.floats(1.0, 4.0 * W), v_lat=st.floats(0.001, 1.0),
       rim=st.floats(0.0, 2.0))
def test_lateral_soil_force_grows_with_the_load_where_the_shear_does_not_soften(
        w1, w2, v_lat, rim):
    # PLOUGHED: exponential shear curve, so a longer (more loaded) patch mobilises more
    contact = _CONTACTS["PLOUGHED"]
    assert SOILS["PLOUGHED"].residual_ratio is None
    lo, hi = sorted((w1, w2))
    force, _, _ = soil_lateral_force_and_slope(contact, np.array([lo, hi]),
                                               np.full(2, v_lat), np.full(2, rim))
    assert -force[1] >= -force[0] - 1e-12


@settings(max_examples=100, deadline=None)
@given(soil=st.sampled_from(sorted(SOILS)), z1=st.floats(0.0, 0.15), z2=st.floats(0.0, 0.15),
       width=st.floats(0.01, 0.5), k=st.floats(0.1, 10.0))
def test_bulldozing_grows_with_the_wall_and_is_linear_in_its_width(soil, z1, z2, width, k):
    params = SOILS[soil]
    lo, hi = sorted((z1, z2))
    r_lo, r_hi = bulldozing_force_n(np.array([lo, hi]), width, params)
    assert 0.0 <= r_lo <= r_hi
    assert bulldozing_force_n(hi, k * width, params) == pytest.approx(k * r_hi, rel=1e-12)
    # Wong eq. 2.61: cohesion term linear in z, weight term quadratic (the 0.5 z^2 gamma_s)
    no_c = replace(params, cohesion_pa=0.0)
    assert bulldozing_force_n(2 * hi, width, no_c) == pytest.approx(
        4 * bulldozing_force_n(hi, width, no_c), rel=1e-12)
    no_g = replace(params, unit_weight_n_m3=0.0)
    assert bulldozing_force_n(2 * hi, width, no_g) == pytest.approx(
        2 * bulldozing_force_n(hi, width, no_g), rel=1e-12)


RIGID = tuple(n for n in TERRAIN_NAMES if get_terrain(n).soil_resistance == 0.0
              and type(get_terrain(n).curve).__name__ == "BurckhardtCurve")


@settings(max_examples=200, deadline=None)
@given(name=st.sampled_from(RIGID), s_l=st.floats(-1.0, 1.0), s_s=st.floats(-3.0, 3.0),
       k_s=st.floats(0.05, 1.0), hold=st.sampled_from((None, 1.0)),
       turn=st.floats(-np.pi, np.pi))
def test_friction_ellipse_directions_and_bound(name, s_l, s_s, k_s, hold, turn):
    curve = get_terrain(name).curve
    peak = _PEAKS[name]
    hold_slip = peak.slip if hold is None else hold
    c = combined_slip_coefficients(curve, s_l, s_s, k_s, float(hold_slip))
    assert c.mu_long * s_l >= 0.0 and c.mu_side * s_s <= 0.0
    assert np.hypot(c.mu_long, c.mu_side / k_s) <= peak.mu_max * (1 + 1e-9)
    if s_s == 0.0:   # pure longitudinal slip: the curve itself (up to the hold)
        mu = traction_curve_and_slope(curve, np.clip(s_l, -hold_slip, hold_slip))[0]
        assert c.mu_long == pytest.approx(float(mu), rel=1e-12, abs=1e-15)
    # isotropic contact: rotating the slip vector rotates the force vector
    rot = np.array([[np.cos(turn), -np.sin(turn)], [np.sin(turn), np.cos(turn)]])
    iso = combined_slip_coefficients(curve, s_l, s_s, 1.0, float(hold_slip))
    r_l, r_s = rot @ [s_l, s_s]
    assume(abs(r_l) <= 1.0)
    iso_r = combined_slip_coefficients(curve, r_l, r_s, 1.0, float(hold_slip))
    # the side force opposes the side slip: the force is (mu_long, -mu_side) along the slip
    np.testing.assert_allclose([iso_r.mu_long, -iso_r.mu_side],
                               rot @ [float(iso.mu_long), -float(iso.mu_side)],
                               rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("name", RIGID)
@pytest.mark.parametrize("s", [1e-20, 1e-17, 1e-12, 1e-9])
def test_burckhardt_traction_keeps_its_digits_at_tiny_slip(name, s):
    # mu = c1 (1 - e^-c2 s) - c3 s = (c1 c2 - c3) s + O(s^2): with 1 - exp(-c2 s) written out,
    # exp rounded to 1 below c2 s ~ 1e-16 and the traction was -c3 s, against the slip (dry
    # asphalt at s = 1e-20: -5.2e-21); at s = 1e-12 it had 5 digits left
    curve = get_terrain(name).curve
    mu = float(curve.coefficients(np.array([s]), 0.0).mu[0])
    x = curve.c2 * s                                 # <= 3e-7: the series to x^3 is exact
    expected = curve.c1 * (x - x * x / 2 + x ** 3 / 6) - curve.c3 * s
    assert mu == pytest.approx(expected, rel=1e-9, abs=0.0)


@settings(max_examples=100, deadline=None)
@given(c1=st.floats(0.05, 1.5), c2=st.floats(5.0, 300.0), log_c3=st.floats(-6.0, 0.0))
def test_burckhardt_peak_is_its_closed_form_however_little_it_falls(c1, c2, log_c3):
    # d mu / ds = c1 c2 e^(-c2 s) - c3 = 0 at s* = ln(c1 c2 / c3) / c2: a curve that falls
    # past s* by a fraction as small as 1e-6 of its peak still has that interior peak
    from terrain.terramechanics.traction import BurckhardtCurve
    c3 = 10.0 ** log_c3
    s_star = np.log(c1 * c2 / c3) / c2
    assume(0.01 < s_star < 0.99)
    mu_star = c1 * -np.expm1(-c2 * s_star) - c3 * s_star
    mu_one = c1 * -np.expm1(-c2) - c3
    assume(mu_one >= 0.0)                    # a curve that turns negative is refused
    assume(mu_star - mu_one > 1e-6 * mu_star)
    curve = BurckhardtCurve(c1, c2, c3)
    peak = traction_peak(curve)
    assert not peak.monotonic
    assert peak.slip == pytest.approx(s_star, abs=1e-4)
    assert peak.mu == pytest.approx(mu_star, rel=1e-9)


@pytest.mark.parametrize("soil", ["SANDY_LOAM", "SNOW"])
def test_a_load_above_the_table_gets_its_largest_row_with_slip_sinkage_and_shared_shear(soil):
    # soil_lateral_force_and_slope: "a load above the table gets the strength and contact
    # length of its largest row", also on a soil whose strength is recomputed at the slipping
    # wheel's deeper wall (slip sinkage) and shared with the traction (combined shear)
    params = replace(SOILS[soil], slip_sinkage_ratio=2.0, combined_shear=True)
    contact = soil_contact(params, B, L0, R, 2.0 * W)
    top = contact.load_grid_n[-1]
    kw = dict(slip_ratio=np.full(2, 0.3), shear_long=np.full(2, 0.5))
    force, slope, share = soil_lateral_force_and_slope(
        contact, np.array([top, 3.0 * top]), np.full(2, 0.05), np.full(2, 0.5), **kw)
    assert force[1] == pytest.approx(force[0], rel=1e-12)
    assert slope[1] == pytest.approx(slope[0], rel=1e-12)
    np.testing.assert_allclose(share[1], share[0], rtol=1e-12)
    low, _, _ = soil_lateral_force_and_slope(contact, np.array([-50.0, 0.0]), np.full(2, 0.05),
                                             np.full(2, 0.5), **kw)
    assert np.all(low == 0.0)                      # a negative load is an unloaded wheel


@settings(max_examples=150, deadline=None)
@given(a_long=st.floats(-50.0, 50.0), a_lat=st.floats(-50.0, 50.0),
       kr=st.sampled_from((None, 0.4, 0.9)))
def test_combined_shear_shares_ignore_signs_and_stay_in_zero_one(a_long, a_lat, kr):
    # combined_shear_shares: "sign ignored", shares in (0, 1], 1 where the other direction
    # does not slip, and the resultant of the two shared forces never exceeds the strength
    from terrain.terramechanics.lateral import combined_shear_shares, shear_mobilisation
    ref = combined_shear_shares(np.array([abs(a_long)]), np.array([abs(a_lat)]), kr)
    got = combined_shear_shares(np.array([a_long]), np.array([a_lat]), kr)
    np.testing.assert_allclose(got, ref, rtol=1e-12, atol=0.0)
    share_x, share_y = float(got[0][0]), float(got[1][0])
    assert 0.0 < share_x <= 1.0 + 1e-12 and 0.0 < share_y <= 1.0 + 1e-12
    if a_lat == 0.0:
        assert share_x == pytest.approx(1.0, rel=1e-12)
    g_x, g_y = shear_mobilisation(np.array([abs(a_long), abs(a_lat)]), kr)
    assert np.hypot(share_x * g_x, share_y * g_y) <= 1.0


@settings(max_examples=100, deadline=None)
@given(soil=st.sampled_from(sorted(SOILS)), load=st.floats(1.0, 1000.0), k=st.floats(0.1, 10.0),
       area=st.floats(1.1, 4.0))
def test_bekker_plate_sinkage_scales_as_the_load_to_the_power_one_over_n(soil, load, k, area):
    # p = W / (b l) = (k_c / b + k_phi) z^n: z(k W) = k^(1/n) z(W); a longer plate sinks less
    from terrain.terramechanics.resistance import bekker_sinkage_m
    s = SOILS[soil]
    z = bekker_sinkage_m(load, B, L0, s.k_c, s.k_phi, s.n)
    assert bekker_sinkage_m(k * load, B, L0, s.k_c, s.k_phi, s.n) == pytest.approx(
        k ** (1.0 / s.n) * z, rel=1e-12)
    assert bekker_sinkage_m(load, B, area * L0, s.k_c, s.k_phi, s.n) == pytest.approx(
        area ** (-1.0 / s.n) * z, rel=1e-12)


@pytest.mark.parametrize("c1, c2, c3", [(0.1, 5.0, 0.2), (0.5, 2.0, 0.6)])
def test_burckhardt_curve_refuses_a_traction_that_turns_against_the_slip(c1, c2, c3):
    # c1 c2 > c3 (the curve rises from 0) but c1 (1 - e^-c2) < c3: mu(1) < 0, so a wheel
    # spinning forward at full slip pushed the body backward (0.1, 5, 0.2: mu(1) = -0.10,
    # negative from s = 0.445 on) and the contact gave the body more power than its motors put
    # in; the curve is concave, so mu(1) >= 0 is mu >= 0 on all of [0, 1]
    from terrain.errors import ConfigError
    from terrain.terramechanics.traction import BurckhardtCurve
    with pytest.raises(ConfigError, match=r"BurckhardtCurve.*mu\(1\)"):
        BurckhardtCurve(c1, c2, c3)
    # the published sets keep mu >= 0 up to full slip (Kiencke & Nielsen's table)
    for name in RIGID:
        curve = get_terrain(name).curve
        assert curve.c1 * -np.expm1(-curve.c2) >= curve.c3
