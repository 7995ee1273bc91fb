"""Wheel-physics features review (feat3): hand values of single features on windows whose
physics is known, and the short time scale dropped where it would repeat the window."""

from __future__ import annotations

import numpy as np

from features.wheel_physics import PHYSICS_FEATURES, WheelPhysicsFeatures, physics_features
from terrain.vehicles import HUSKY

RATE = 10.0


def _features(vel_l, vel_r, cur_l, cur_r):
    arrays = [np.atleast_2d(np.asarray(a, dtype=float)) for a in (vel_l, vel_r, cur_l, cur_r)]
    out = physics_features(*arrays, RATE)
    return {name: out[0, i] for i, name in enumerate(PHYSICS_FEATURES)}


def test_yaw_rate_command_is_the_speed_difference_over_the_track():
    # omega = (v_R - v_L) / B (seed 000 eq. 2 with 2d = B): 0.2 m/s over 0.5708 m
    n = 30
    f = _features(np.full(n, 0.3), np.full(n, 0.5), np.full(n, 4.0), np.full(n, 5.0))
    np.testing.assert_allclose(f["yaw_rate_cmd__abs_mean"], 0.2 / HUSKY.track_m, rtol=1e-12)
    np.testing.assert_allclose(f["vel_mean__abs_mean"], 0.4, rtol=1e-12)
    np.testing.assert_allclose(f["cur_sum__per_yaw_rate"], 9.0 / (0.2 / HUSKY.track_m),
                               rtol=1e-12)
    assert f["turning__fraction"] == 1.0 and f["moving__fraction"] == 1.0


def test_straight_and_turning_means_weigh_the_samples_of_that_motion():
    # first half standing at 2 A, second half driving straight at 1 m/s with 10 A: the
    # straight mean is the driving current shrunk by one sample's weight to the window
    # mean; no sample turns, so the turning mean is the window mean
    n = 40
    v = np.r_[np.zeros(n // 2), np.ones(n // 2)]
    cur = np.r_[np.full(n // 2, 1.0), np.full(n // 2, 5.0)]       # per side: sum 2 A, 10 A
    f = _features(v, v, cur, cur)
    w = np.tanh(1.0 / 0.05) * (n // 2)
    np.testing.assert_allclose(f["cur_sum__straight_mean_a"], (w * 10.0 + 6.0) / (w + 1.0),
                               rtol=1e-12)
    np.testing.assert_allclose(f["cur_sum__turning_mean_a"], 6.0, rtol=1e-12)
    np.testing.assert_allclose(f["moving__fraction"], 0.5)


def test_ripple_and_acceleration_of_known_sequences():
    # ripple: population std of the first differences of I_L + I_R; acceleration:
    # numpy.gradient of the mean speed (one-sided at the ends), s^-1 scaled by the rate
    n = 25
    s = np.arange(n, dtype=float)
    cur = 0.5 * (1.0 + 0.01 * s ** 2)                 # I_L + I_R = 1 + 0.01 s^2
    v = 0.1 + 0.002 * s ** 2                           # a = 0.004 s * RATE inside
    f = _features(v, v, cur, cur)
    np.testing.assert_allclose(f["cur_sum__ripple_a"], np.diff(2 * cur).std(), rtol=1e-12)
    acc = np.gradient(v, 1.0 / RATE)
    assert acc[0] == (v[1] - v[0]) * RATE
    np.testing.assert_allclose(f["accel__abs_mean"], np.abs(acc).mean(), rtol=1e-12)


def test_a_short_scale_of_the_whole_window_is_not_repeated():
    # documented: the short scale is dropped where it rounds to the whole window (the same
    # features twice); 2 s at 10 Hz is the whole of a 20-sample window
    X = np.ones((2, 4, 20))
    names = WheelPhysicsFeatures(short_s=2.0, rate_hz=RATE).fit(X).get_feature_names_out()
    assert list(names) == list(PHYSICS_FEATURES)
    names = WheelPhysicsFeatures(short_s=1.9, rate_hz=RATE).fit(X).get_feature_names_out()
    assert len(names) == 2 * len(PHYSICS_FEATURES) and names[-1].endswith("__last1.9s")
