"""The one angle wrap of the project (terrain.vehicles.common.wrap_angle)."""

import math

import numba
import numpy as np
from hypothesis import given, settings, strategies as st

from terrain.estimation import wrap_angle as estimation_wrap_angle
from terrain.vehicles.common import wrap_angle

finite_angles = st.floats(min_value=-1e4, max_value=1e4, allow_nan=False)


@numba.njit(cache=False)
def _compiled(angle_rad):
    return wrap_angle(angle_rad)


@settings(deadline=None)        # the first call compiles the numba twin
@given(finite_angles)
def test_wrap_lands_in_half_open_interval_and_keeps_the_direction(angle_rad):
    wrapped = wrap_angle(angle_rad)
    assert -math.pi <= wrapped < math.pi
    turns = (angle_rad - wrapped) / (2.0 * math.pi)
    assert abs(turns - round(turns)) < 1e-9
    assert _compiled(angle_rad) == wrapped          # the numba loops wrap the same way


def test_sum_rounding_just_below_minus_pi_gives_minus_pi_not_plus_pi():
    # (a + pi) is -4.4e-16: its remainder modulo 2 pi rounds to 2 pi, and the bare
    # formula returned +pi, outside [-pi, pi)
    just_below = np.nextafter(-np.pi, -np.inf)
    assert wrap_angle(just_below) == -np.pi
    assert _compiled(just_below) == -np.pi
    assert wrap_angle(np.array([just_below, np.pi, -np.pi]))[0] == -np.pi
    np.testing.assert_array_equal(wrap_angle(np.array([np.pi, -np.pi, 3 * np.pi])), -np.pi)


def test_nan_stays_nan_and_arrays_keep_their_shape():
    angles = np.array([[0.5, np.nan], [7.0, -7.0]])
    wrapped = wrap_angle(angles)
    assert wrapped.shape == (2, 2)
    assert np.isnan(wrapped[0, 1]) and math.isnan(_compiled(math.nan))
    np.testing.assert_allclose(wrapped[1], [7.0 - 2 * np.pi, -7.0 + 2 * np.pi])


def test_estimation_exports_the_same_function():
    assert estimation_wrap_angle is wrap_angle
