"""Boundary review of the terramechanics relations (sim22): values at and next to a limit."""

import numpy as np
import pytest

from terrain.terramechanics.slip import (ground_speed_from_slip, rim_speed_from_slip,
                                         sae_slip)


@pytest.mark.parametrize("q", [np.nextafter(-1.0, 0.0), -1.0 + 1e-15, -1.0 + 1e-13])
@pytest.mark.parametrize("rim", [1.0, -2.0])
def test_ground_speed_next_to_a_locked_wheel_is_the_inverse_not_a_floor(q, rim):
    """Just inside the domain, q = sign(omega r) s one ulp (or 1e-13) above -1, eq. 7.2 gives
    v = omega r / (1 + q). A 1e-12 floor on 1 + q (kept from before q = -1 was made NaN)
    returned omega r 1e12 there: at q = -1 + 1e-13 a tenth of the ground speed, at one ulp
    above -1 a ten-thousandth, and sae_slip of that speed was not the slip given."""
    slip = np.sign(rim) * q
    v = float(ground_speed_from_slip(rim, slip))
    assert v == pytest.approx(rim / (1.0 + q), rel=1e-12)
    assert float(sae_slip(rim, v, dead_band_m_s=0.0)) == pytest.approx(slip, abs=1e-15)
    # and it undoes rim_speed_from_slip there
    assert float(ground_speed_from_slip(rim_speed_from_slip(v, slip)[0], slip)) == \
        pytest.approx(v, rel=1e-9)
    assert np.isnan(ground_speed_from_slip(rim, np.sign(rim) * -1.0))


def test_ground_speed_of_a_nan_slip_stays_nan():
    got = ground_speed_from_slip(np.array([1.0, -1.0, 0.0]), np.array([np.nan] * 3))
    assert np.isnan(got).all()


def test_a_speed_exactly_at_the_dead_band_is_outside_it():
    """``in_dead_band``: both speeds *below* the band (strict). At exactly 0.05 m/s the slip
    is the ratio; one ulp below, 0."""
    from terrain.terramechanics.slip import THESIS_DEAD_BAND_M_S, in_dead_band
    band = THESIS_DEAD_BAND_M_S
    below = np.nextafter(band, 0.0)
    assert not in_dead_band(band, 0.0) and not in_dead_band(0.0, -band)
    assert in_dead_band(below, -below)
    assert float(sae_slip(band, 0.0)) == 1.0
    assert float(sae_slip(0.0, -band)) == 1.0         # reverse: sign of the travel
    assert float(sae_slip(below, 0.0)) == 0.0


def test_the_slip_is_plus_minus_one_on_zero_speeds_and_zero_at_zero_over_zero():
    assert float(sae_slip(0.3, 0.0, dead_band_m_s=0.0)) == 1.0      # spinning at rest
    assert float(sae_slip(0.0, 0.3, dead_band_m_s=0.0)) == -1.0     # locked, moving
    assert float(sae_slip(0.0, 0.0, dead_band_m_s=0.0)) == 0.0      # 0 / 0
    assert float(sae_slip(0.0, -0.0, dead_band_m_s=0.0)) == 0.0


def test_the_velocity_slope_at_exactly_full_slip_is_the_unsaturated_sides():
    """``sae_slip_and_velocity_slope``: a wheel spinning on a body at rest (slip exactly 1)
    gets ``-1 / den``, the slope of the side where the body moves forward (not 0, the
    saturated side's); just past full slip the slope is 0."""
    from terrain.terramechanics.slip import sae_slip_and_velocity_slope
    rim = np.array([0.5, -0.5, 0.5])
    v = np.array([0.0, 0.0, -1e-6])          # last: the body backwards, slip past 1
    s, d = sae_slip_and_velocity_slope(rim, v, 0.02)
    np.testing.assert_array_equal(s, [1.0, -1.0, 1.0])
    np.testing.assert_allclose(d[:2], [-2.0, -2.0])
    assert d[2] == 0.0


@pytest.mark.parametrize("v", [1.3, -0.7, 0.0])
def test_rim_speed_branches_meet_at_zero_slip(v):
    """Eq. 7.1 (q >= 0) and eq. 7.2 (q < 0) meet at q = 0: same rim speed and slopes one ulp
    either side (the switch between the drive and brake definitions at equal speeds)."""
    at = np.array(rim_speed_from_slip(v, 0.0))
    up = np.array(rim_speed_from_slip(v, np.nextafter(0.0, 1.0)))
    down = np.array(rim_speed_from_slip(v, np.nextafter(0.0, -1.0)))
    np.testing.assert_allclose(up, at, rtol=1e-12, atol=1e-300)
    np.testing.assert_allclose(down, at, rtol=1e-12, atol=1e-300)
    assert at[0] == v and at[2] == abs(v)
    # and the inverse at q = 1 - ulp is finite, at q = 1 NaN, at q = -1 the locked wheel
    assert np.isfinite(rim_speed_from_slip(1.0, np.nextafter(1.0, 0.0))[0])
    assert np.isnan(rim_speed_from_slip(1.0, 1.0)[0])
    assert rim_speed_from_slip(1.0, -1.0)[0] == 0.0


@pytest.mark.parametrize("c1, c2, peak", [
    (1.0, 2e6, 1e-5),        # between the first two points of traction_peak's grid
    (1.0, 3e5, 5e-5),        # on its second point
    (0.8, 1.0, 0.9),
    (0.8, 1.0, 0.99),        # next to full slip, still an interior maximum
    (1.2, 5.0, 0.4)])
def test_burckhardt_peak_is_found_where_the_curve_peaks(c1, c2, peak):
    """Burckhardt peaks at ``ln(c1 c2 / c3) / c2``; traction_peak finds it (and its mu) on
    a 20001-point grid refined between the grid neighbours, however close to 0 or 1 (a
    valid curve, mu(1) >= 0, peaks at ``ln(c2) / c2`` or later: large c2 near 0)."""
    from terrain.terramechanics.traction import BurckhardtCurve, traction_peak
    c3 = c1 * c2 * np.exp(-c2 * peak)
    got = traction_peak(BurckhardtCurve(c1, c2, c3))
    assert not got.monotonic
    assert got.slip == pytest.approx(peak, abs=1e-7)
    mu = c1 * -np.expm1(-c2 * peak) - c3 * peak
    assert got.mu == pytest.approx(mu, rel=1e-12) and got.mu_max == got.mu
