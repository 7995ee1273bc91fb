"""Boundary review (est22): values exactly at the thresholds, limits and edges of the
estimation package."""

import numpy as np
from hypothesis import given, settings, strategies as st

from terrain.estimation.observer import eta_from_truth


@settings(max_examples=60, deadline=None)
@given(v=st.floats(-2.0, 2.0), w=st.floats(-1.0, 1.0), other=st.floats(0.05, 2.0))
def test_eta_from_truth_is_undefined_at_a_zero_rim_speed_even_with_no_speed_floor(v, w, other):
    # min_speed_m_s = 0 is allowed (>= 0): a rim speed of 0 is not below it, but eta = g / 0
    # is no efficiency (it was inf, or NaN for 0 / 0)
    eta = eta_from_truth(np.array([v, v]), np.array([w, w]), np.array([0.0, other]),
                         np.array([other, -0.0]), 0.25, min_speed_m_s=0.0)
    assert np.isnan(eta[0, 0]) and np.isnan(eta[1, 1])
    assert np.isfinite(eta[0, 1]) and np.isfinite(eta[1, 0])


def test_eta_from_truth_speed_floor_is_inclusive_one_ulp_either_side():
    floor = 0.1
    rims = np.array([np.nextafter(floor, 0.0), floor, np.nextafter(floor, 1.0)])
    eta = eta_from_truth(np.full(3, 0.1), np.zeros(3), rims, -rims, 0.25,
                         min_speed_m_s=floor)
    assert np.isnan(eta[0]).all()                # below the floor: undefined
    assert np.isfinite(eta[1:]).all()            # at it and above: defined
    np.testing.assert_allclose(eta[1], [1.0, -1.0])
