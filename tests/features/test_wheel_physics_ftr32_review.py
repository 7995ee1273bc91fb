"""Wheel-physics motion fractions at their thresholds (review ftr32, mutant survivor).

``moving__fraction`` counts ``|v| > v0`` and ``turning__fraction`` ``|omega| > w0``: a robot
driven exactly at a scale counts as standing (going straight), as the docstring of
:func:`features.wheel_physics.physics_features` says; a ``>=`` passed every test.
"""

import numpy as np
import pytest

from features.wheel_physics import PHYSICS_FEATURES, physics_features

N = 10
V0, W0, TRACK_M = 0.25, 0.5, 1.0     # powers of two: v and omega below are exact


def _fractions(vel_l, vel_r):
    out = physics_features(np.full((1, N), vel_l), np.full((1, N), vel_r), np.ones((1, N)),
                           np.ones((1, N)), 50.0, track_m=TRACK_M, speed_scale_m_s=V0,
                           yaw_scale_rad_s=W0)[0]
    return (out[PHYSICS_FEATURES.index("moving__fraction")],
            out[PHYSICS_FEATURES.index("turning__fraction")])


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_driving_exactly_at_the_speed_scale_is_standing_just_above_is_moving(sign):
    assert _fractions(sign * V0, sign * V0) == (0.0, 0.0)       # v = +-v0 exactly
    above = np.nextafter(V0, 1.0)
    assert _fractions(sign * above, sign * above) == (1.0, 0.0)


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_turning_exactly_at_the_yaw_scale_is_straight_just_above_is_turning(sign):
    half = 0.5 * W0 * TRACK_M         # omega = (v_R - v_L) / B = +-w0 exactly, v = 0
    assert _fractions(-sign * half, sign * half) == (0.0, 0.0)
    above = np.nextafter(half, 1.0)
    assert _fractions(-sign * above, sign * above) == (0.0, 1.0)


def test_current_quantiles_of_a_known_ramp():
    # I_R - I_L and I_L + I_R both 0, 1, ..., 10 A (shuffled): numpy's linear quantiles are
    # the values at 10 %, 50 % and 90 % of the ramp; a q90 read at 0.95 passed every test
    order = np.random.default_rng(3).permutation(11)
    ramp = np.arange(11.0)[order]
    out = physics_features(np.full((1, 11), 0.5), np.full((1, 11), 0.5),
                           np.zeros((1, 11)), ramp[None], 50.0)[0]
    got = {k: out[PHYSICS_FEATURES.index(k)] for k in PHYSICS_FEATURES if "__q" in k}
    assert got == {"cur_sum__q10": 1.0, "cur_sum__q50": 5.0, "cur_sum__q90": 9.0,
                   "cur_diff_abs__q50": 5.0, "cur_diff_abs__q90": 9.0}
    # |I_R - I_L|: the same ramp from the left side's current
    out = physics_features(np.full((1, 11), 0.5), np.full((1, 11), 0.5),
                           ramp[None], np.zeros((1, 11)), 50.0)[0]
    assert out[PHYSICS_FEATURES.index("cur_diff_abs__q90")] == 9.0
