"""Features review (ftr12): mutants that survived the feature tests. The short time scale of
the wheel-physics features is the window's last ``short_s`` seconds; the straight-driving
mean current leaves out the samples turning on an arc; the slip targets average the truth
over the half-open window ``[t_start, t_end)`` and give chi at the turn-rate threshold
itself; a window leaving a gap is a dropped window of data, not an empty position."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

import features.slip_features as slip_features
from features.slip_features import SLIP_CHANNELS, slip_feature_matrix, slip_targets
from features.wheel_physics import PHYSICS_FEATURES, WheelPhysicsFeatures, physics_features
from features.windows import WindowConfig, WindowSet, as_windows, window_frame
from terrain.run import TIME, WHEEL_CHANNELS, Run
from terrain.vehicles import HUSKY

RATE = 10.0


def test_the_short_scale_is_the_last_short_s_seconds_of_the_window():
    # 6 s at 10 Hz: standing at 3 A for 4 s, then driving a ramp at rising current for the
    # last 2 s; the ``__last2s`` columns are the features of those last 20 samples alone
    n, m = 60, 20
    rng = np.random.default_rng(12)
    v = np.r_[np.zeros(n - m), np.linspace(0.2, 1.0, m)]
    cur_l = np.r_[np.full(n - m, 1.5), np.linspace(3.0, 5.0, m)] + 0.05 * rng.random(n)
    cur_r = cur_l + 0.3 * rng.random(n)
    X = np.stack([v, v + 0.01 * rng.random(n), cur_l, cur_r])[None]   # WHEEL_CHANNELS
    fx = WheelPhysicsFeatures(WHEEL_CHANNELS, RATE, short_s=2.0).fit(X)
    F = fx.transform(X)
    names = list(fx.get_feature_names_out())
    last = [names.index(f"{f}__last2s") for f in PHYSICS_FEATURES]
    want = physics_features(*(X[:, i, -m:] for i in range(4)), RATE)
    np.testing.assert_allclose(F[:, last], want, rtol=1e-12, atol=1e-12)
    first = physics_features(*(X[:, i, :m] for i in range(4)), RATE)
    assert F[0, names.index("cur_sum__q50__last2s")] > 5.0 > first[0, 13]


def test_the_straight_mean_leaves_out_the_samples_turning_on_an_arc():
    # first half straight at 1 m/s drawing 10 A (both sides), second half on an arc at the
    # same mean speed (v_R - v_L = 1 m/s, omega = 1.75 rad/s >> w0) drawing 30 A: the
    # straight weight m_v (1 - m_w) keeps only the straight half, the turning weight m_w
    # only the arc, each shrunk to the window mean (20 A) by one sample's weight
    n = 40
    vel_l = np.r_[np.ones(n // 2), np.full(n // 2, 0.5)]
    vel_r = np.r_[np.ones(n // 2), np.full(n // 2, 1.5)]
    cur = np.r_[np.full(n // 2, 5.0), np.full(n // 2, 15.0)]
    out = physics_features(vel_l[None], vel_r[None], cur[None], cur[None], RATE)[0]
    f = dict(zip(PHYSICS_FEATURES, out))
    v, om, i_sum = 0.5 * (vel_l + vel_r), (vel_r - vel_l) / HUSKY.track_m, 2 * cur
    m_v, m_w = np.tanh(np.abs(v) / 0.05), np.tanh(np.abs(om) / 0.1)
    w_s = m_v * (1.0 - m_w)
    np.testing.assert_allclose(f["cur_sum__straight_mean_a"],
                               (w_s @ i_sum + i_sum.mean()) / (w_s.sum() + 1.0), rtol=1e-12)
    np.testing.assert_allclose(f["cur_sum__turning_mean_a"],
                               (m_w @ i_sum + i_sum.mean()) / (m_w.sum() + 1.0), rtol=1e-12)
    assert abs(f["cur_sum__straight_mean_a"] - 10.0) < 0.5     # (21 - 1) / 21 of the way
    assert abs(f["cur_sum__turning_mean_a"] - 30.0) < 0.5


def _truth_run(yaw_rate):
    tt = np.arange(1000) / 100.0                      # 0, 0.01, ..., 9.99 s; 2.0 exactly
    truth = pd.DataFrame({TIME: tt, "slip_1": tt, "slip_2": 0.2, "yaw_rate": yaw_rate,
                          "v_by": 0.01, "terrain": "SNOW"})
    return Run("sim1", "sim", "SNOW", {"truth": truth})


def _window_set(t0):
    n = 100
    values = {c: np.zeros((len(t0), n)) for c in SLIP_CHANNELS}
    values.update(vel_l=np.full((len(t0), n), 0.5), vel_r=np.full((len(t0), n), 0.8))
    X = np.stack([values[c] for c in SLIP_CHANNELS], axis=1)
    t0 = np.asarray(t0, dtype=float)
    ids = np.array(["sim1"] * len(t0), dtype=object)
    return WindowSet(X, SLIP_CHANNELS, ids, ids, np.array(["SNOW"] * len(t0), dtype=object),
                     t0, t0 + 2.0, 50.0)


def test_slip_targets_average_the_truth_over_the_half_open_window():
    # a window [0, 2) s holds the truth samples 0 .. 1.99 s, not the one at 2.00 s, which
    # starts the next window: the mean of slip_1 = t is 0.995, not 1.0
    Y = slip_targets([_truth_run(0.35)], _window_set([0.0, 2.0]), HUSKY.track_m)
    np.testing.assert_allclose(Y["slip_1"], [0.995, 2.995], rtol=1e-12)


def test_the_chi_target_is_given_at_the_turn_rate_threshold_itself(monkeypatch):
    # "NaN when the robot turns slower than MIN_TURN_RATE_RAD_S": a window turning at the
    # threshold has its chi (a threshold of 0.125 rad/s, whose window mean is exact)
    monkeypatch.setattr(slip_features, "MIN_TURN_RATE_RAD_S", 0.125)
    ws = _window_set([0.0])
    Y = slip_targets([_truth_run(0.125)], ws, HUSKY.track_m)
    np.testing.assert_allclose(Y["chi"], 0.3 / (HUSKY.track_m * 0.125), rtol=1e-12)
    below = slip_targets([_truth_run(0.124)], ws, HUSKY.track_m)
    assert np.isnan(below["chi"]).all()


def test_a_window_that_starts_inside_a_gap_and_leaves_it_is_dropped_not_empty():
    # 10 Hz, a gap over samples 5..14, 1 s windows every 0.5 s: the window over 5..14 lies
    # wholly in the gap (a position, not a window of data: empty_gap); those over 0..9 and
    # 10..19 hold data on one side of the gap (dropped_gap), whichever side it is on
    t = np.arange(40) / RATE
    x = np.where((np.arange(40) >= 5) & (np.arange(40) < 15), np.nan, 1.0 + t)
    frame = pd.DataFrame({TIME: t, "ax": x, "wz": 2.0 * x})
    X, t0, t1, _, counts = window_frame(frame, ("ax", "wz"),
                                        WindowConfig(window_s=1.0, hop_s=0.5, rate_hz=RATE))
    assert (counts["dropped_gap"], counts["empty_gap"]) == (2, 1)
    np.testing.assert_allclose(t0, [1.5, 2.0, 2.5, 3.0])
    assert np.isfinite(X).all()


@pytest.mark.parametrize("value", [True, "1.5", 1.5 + 2.0j, np.bool_(False)])
def test_object_windows_of_booleans_text_or_complex_are_refused_as_the_plain_ones(value):
    # as_windows refused bool, text and complex dtypes, but an object array (a pandas
    # frame's to_numpy() over mixed columns) holding them was converted: True as 1.0 and
    # the text "1.5" parsed to 1.5, the very conversions the dtype check is there to stop
    X = np.full((2, 4, 40), 0.5, dtype=object)
    X[1, 2, 7] = value
    with pytest.raises(ValueError, match="X must hold real numbers"):
        as_windows(X, ("wz", "ax", "cur_l", "vel_l"))
    fine = np.full((2, 4, 40), 0.5, dtype=object)
    fine[1, 2, 7] = np.float32(2.0)                  # real numbers of any type stay accepted
    assert as_windows(fine, ("wz", "ax", "cur_l", "vel_l"))[1, 2, 7] == 2.0


def test_the_pitch_feature_removes_the_window_acceleration_from_the_accelerometer():
    # level ground, speeding up at 0.5 m/s^2: the accelerometer reads a_x = 0.5 m/s^2 of
    # specific force that is no tilt; with the slope of the rim speed removed the pitch is
    # 0 (arctan(0.5 / 9.81) = 0.051 rad of climbing otherwise)
    n = 100
    ramp = 0.5 + 0.5 * np.arange(n) / 50.0
    values = {c: np.zeros((1, n)) for c in SLIP_CHANNELS}
    values.update(vel_l=ramp[None], vel_r=ramp[None], ax=np.full((1, n), 0.5),
                  az=np.full((1, n), 9.81))
    X = np.stack([values[c] for c in SLIP_CHANNELS], axis=1)
    names, f = slip_feature_matrix(X, SLIP_CHANNELS, 50.0, HUSKY)
    np.testing.assert_allclose(f[0, names.index("vel_mean__slope")], 0.5, rtol=1e-12)
    assert abs(f[0, names.index("pitch")]) < 1e-12


def test_the_terrain_target_of_a_window_is_the_terrain_at_its_centre():
    # the truth switches from ICE to SNOW at 0.5 s: the window [0, 2) s, centred on 1 s,
    # is SNOW's (its first samples are ICE's)
    run = _truth_run(0.35)
    truth = run.streams["truth"].copy()
    truth["terrain"] = np.where(truth[TIME] < 0.5, "ICE", "SNOW")
    run = Run("sim1", "sim", "SNOW", {"truth": truth})
    Y = slip_targets([run], _window_set([0.0]), HUSKY.track_m)
    assert list(Y["terrain"]) == ["SNOW"]
