"""Review revtm: physical invariants of the slip, traction, resistance and combined-slip
relations not pinned elsewhere: reversal and exchange symmetry and scale invariance of the SAE
slip, self-similarity of the Janosi-Hanamoto curve in ``s / k``, mirror symmetry of the friction
ellipse, homogeneity of the Coulomb lateral friction and of Wong's turning moment, the
``W^(1/n)`` law of Bekker's compaction coefficient and the grade force's bounds."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from terrain.terramechanics import (TERRAIN_NAMES, JanosiCurve, bekker_compaction_coefficient,
                                    get_terrain, grade_resistance_n, sae_slip,
                                    soil_resistance_coefficient, steady_slip,
                                    traction_coefficient, turning_resistance_moment_nm)
from terrain.terramechanics.combined_slip import combined_slip_coefficients
from terrain.terramechanics.efficiency import tractive_efficiency
from terrain.terramechanics.resistance import G_M_S2, lateral_force_and_slope

SPEEDS = st.floats(-5.0, 5.0, allow_subnormal=False)
SLIPS = st.floats(-1.0, 1.0, allow_subnormal=False)
FAST = settings(max_examples=60, deadline=None)


@FAST
@given(w=st.lists(SPEEDS, min_size=1, max_size=6), v=st.lists(SPEEDS, min_size=1, max_size=6),
       floor=st.sampled_from([0.0, 0.02]), band=st.sampled_from([0.0, 0.05]))
def test_sae_slip_flips_sign_when_both_speeds_reverse_or_are_exchanged(w, v, floor, band):
    # driving backward mirrors driving forward (module docstring: "in reverse the signs
    # flip"), and exchanging rim and ground speed turns traction into the same braking
    n = min(len(w), len(v))
    w, v = np.array(w[:n]), np.array(v[:n])
    opts = dict(speed_floor_m_s=floor, dead_band_m_s=band)
    s = sae_slip(w, v, **opts)
    np.testing.assert_array_equal(sae_slip(-w, -v, **opts), -s)
    np.testing.assert_array_equal(sae_slip(v, w, **opts), -s)


@FAST
@given(w=SPEEDS, v=SPEEDS, k=st.floats(1e-3, 1e3))
def test_sae_slip_is_dimensionless_without_floor_or_dead_band(w, v, k):
    # the thesis's formula (no floor, no dead band) is a ratio of speeds: any unit gives it
    s = float(sae_slip(w, v, dead_band_m_s=0.0))
    assert abs(float(sae_slip(k * w, k * v, dead_band_m_s=0.0)) - s) <= 1e-12
    assert -1.0 <= s <= 1.0


@FAST
@given(mu_max=st.floats(0.05, 1.5), k=st.floats(0.01, 2.0), a=st.floats(0.1, 10.0),
       s=st.floats(0.0, 1.0))
def test_janosi_curve_depends_on_the_slip_over_its_shear_slip_only(mu_max, k, a, s):
    # mu = mu_max g(s / k) (Wong ch. 2.4-2.5): stretching K / L and the slip alike keeps mu
    # (a soil of doubled K under a contact of doubled length is the same curve)
    s_scaled = min(s * a, 1.0)
    s = s_scaled / a
    one = float(traction_coefficient(JanosiCurve(mu_max, k), s))
    other = float(traction_coefficient(JanosiCurve(mu_max, k * a), s_scaled))
    assert abs(one - other) <= 1e-12 * max(1.0, mu_max)
    assert 0.0 <= one <= mu_max


@FAST
@given(name=st.sampled_from(TERRAIN_NAMES), s_l=SLIPS, s_s=st.floats(-2.0, 2.0),
       k_s=st.floats(0.1, 1.0))
def test_friction_ellipse_is_mirror_symmetric_in_both_slips(name, s_l, s_s, k_s):
    # a mirrored manoeuvre (side slip to the other side, braking for traction) mirrors the
    # forces: mu_long odd in s_L and even in s_S, mu_side the reverse
    curve = get_terrain(name).curve
    base = combined_slip_coefficients(curve, s_l, s_s, k_s)
    side = combined_slip_coefficients(curve, s_l, -s_s, k_s)
    brake = combined_slip_coefficients(curve, -s_l, s_s, k_s)
    assert float(side.mu_long) == float(base.mu_long)
    assert float(side.mu_side) == -float(base.mu_side)
    assert float(brake.mu_long) == -float(base.mu_long)
    assert float(brake.mu_side) == float(base.mu_side)
    # the side force opposes the side slip, the drive force follows the longitudinal one
    assert float(base.mu_side) * s_s <= 0.0 and float(base.mu_long) * s_l >= 0.0


@FAST
@given(mu=st.floats(0.0, 1.5), n=st.floats(0.0, 5e3), v=st.floats(-2.0, 2.0),
       slide=st.floats(1e-3, 0.5), k=st.floats(0.1, 10.0))
def test_coulomb_lateral_friction_is_odd_in_speed_and_homogeneous(mu, n, v, slide, k):
    # F = -mu N tanh(v / v_slide): odd in v, linear in N, a function of v / v_slide only
    force, slope = (float(x) for x in lateral_force_and_slope(mu, n, v, slide))
    assert float(lateral_force_and_slope(mu, n, -v, slide)[0]) == -force
    assert abs(float(lateral_force_and_slope(mu, k * n, v, slide)[0]) - k * force) \
        <= 1e-9 * (1.0 + abs(k * force))
    assert abs(float(lateral_force_and_slope(mu, n, k * v, k * slide)[0]) - force) \
        <= 1e-9 * (1.0 + abs(force))
    assert abs(force) <= mu * n * (1.0 + 1e-12) and slope <= 0.0


@FAST
@given(load=st.floats(1.0, 5e3), k=st.floats(1.1, 10.0), n=st.floats(0.3, 1.5),
       width=st.floats(0.05, 0.5), length=st.floats(0.05, 2.0))
def test_bekker_compaction_coefficient_grows_as_the_load_to_the_power_one_over_n(
        load, k, n, width, length):
    # R_c / W = b (k_c/b + k_phi) z^(n+1) / ((n+1) W) with z ~ W^(1/n): R_c / W ~ W^(1/n)
    # (Wong eqs. 2.33 and 2.54): a heavier wheel loses a larger share of its load to the rut
    k_c, k_phi = 2.0e4, 1.5e6
    one = bekker_compaction_coefficient(load, width, length, k_c, k_phi, n)
    heavier = bekker_compaction_coefficient(k * load, width, length, k_c, k_phi, n)
    assert heavier > one > 0.0
    np.testing.assert_allclose(heavier / one, k ** (1.0 / n), rtol=1e-9)


@FAST
@given(mu=st.floats(0.0, 2.0), w=st.floats(0.0, 1e4), l_m=st.floats(0.0, 3.0),
       k=st.floats(0.1, 10.0))
def test_turning_resistance_moment_is_linear_in_each_input(mu, w, l_m, k):
    # M_r = mu_t W l / 4 (Wong ch. 7.2): doubling the vehicle's weight doubles the moment
    m = turning_resistance_moment_nm(mu, w, l_m)
    assert m >= 0.0
    for args in ((k * mu, w, l_m), (mu, k * w, l_m), (mu, w, k * l_m)):
        np.testing.assert_allclose(turning_resistance_moment_nm(*args), k * m, rtol=1e-12,
                                   atol=1e-300)


@FAST
@given(mass=st.floats(1.0, 5e3), pitch=st.floats(-1.5, 1.5))
def test_grade_force_is_odd_in_the_pitch_and_never_exceeds_the_weight(mass, pitch):
    # m g sin(pitch) (seed 003 eq. 10): downhill pushes as much as uphill holds back
    f = float(grade_resistance_n(mass, pitch))
    assert float(grade_resistance_n(mass, -pitch)) == -f
    assert abs(f) <= mass * G_M_S2
    assert f * pitch >= 0.0


@FAST
@given(name=st.sampled_from(TERRAIN_NAMES))
def test_tractive_efficiency_is_zero_at_zero_and_full_slip(name):
    # at s = 0 the wheel pulls nothing (mu = 0); at s = 1 the body stands still: neither
    # delivers drawbar power (Wong ch. 4.2, eta = (F_net / F)(1 - s))
    terrain = get_terrain(name)
    assert float(tractive_efficiency(terrain, 0.0)) == 0.0
    assert float(tractive_efficiency(terrain, 1.0)) == 0.0
    assert float(tractive_efficiency(terrain, -1.0)) == 0.0


@FAST
@given(x=st.floats(1e-6, 0.05), sign=st.sampled_from([-1.0, 1.0]),
       slide=st.sampled_from([0.005, 0.02, 0.2]))
def test_coulomb_lateral_slope_is_the_secant_at_small_slide_speeds_too(x, sign, slide):
    # mutant check: the secant switched to its limit 1 / v_slide only below |v| / v_slide =
    # 1e-6; switching at 1e-2 steepened the slope by up to 3e-5 (tanh(x) / x = 1 - x^2 / 3)
    # where the implicit integrator of a slowly sliding wheel reads it
    v = sign * x * slide
    force, slope = (float(f) for f in lateral_force_and_slope(0.6, 300.0, v, slide))
    np.testing.assert_allclose(slope * v, force, rtol=1e-12)


@FAST
@given(name=st.sampled_from(TERRAIN_NAMES))
def test_steady_slip_at_a_net_demand_of_exactly_zero_is_zero(name):
    # boundary of "a demand below -soil_resistance(0) needs no traction": at exactly
    # -soil_resistance(0) the wheel needs no slip either
    terrain = get_terrain(name)
    demand = -float(soil_resistance_coefficient(terrain, 0.0))
    assert steady_slip(terrain, demand) == 0.0
