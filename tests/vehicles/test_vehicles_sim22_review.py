"""Boundary review of the vehicle kinematics (sim22): thresholds met exactly."""

import numpy as np

from terrain.vehicles.icr import chi_from_truth, icr_expansion_factor, inverse_icr_factor


def test_a_yaw_rate_exactly_at_the_threshold_is_left_out_of_chi():
    """chi_from_truth uses the samples turning *faster* than min_yaw_rate_rad_s: exactly at
    it a sample is left out (a recording that turns at it only gives NaN), one ulp above it
    is used."""
    track, thr = 0.5, 0.1
    at = np.full(5, thr)
    assert np.isnan(chi_from_truth(-0.2 * at, 0.2 * at, at, track, thr))
    above = np.full(5, np.nextafter(thr, 1.0))
    chi = chi_from_truth(-0.25 * above, 0.25 * above, above, track, thr)
    assert np.isclose(chi, 1.0)


def test_icr_factor_at_straight_driving_and_no_net_turn():
    """Straight driving (the ICR at infinity, no commanded turn): chi unknown (NaN), the
    ridge fit's a = 0; a commanded turn answered by exactly no net turn (sum x y = 0): inf
    (sum(x y) <= 0 is 'does not turn')."""
    x = np.zeros(10)
    assert np.isnan(icr_expansion_factor(np.full(10, 0.3), x))
    assert inverse_icr_factor(np.full(10, 0.3), x, floor_rad_s=0.1) == 0.0
    assert np.isnan(inverse_icr_factor(np.full(10, 0.3), x))
    x = np.array([0.5, 0.5])
    assert icr_expansion_factor(np.array([0.2, -0.2]), x) == np.inf
