"""Wheel-physics features recover planted current balances; run-grouped evaluation helpers."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from features.wheel_physics import PHYSICS_FEATURES, WheelPhysicsFeatures, physics_features
from terrain.errors import ConfigError, NonFiniteInputError, ShapeError
from terrain.serving.evaluation import (concatenated_streams, held_out_folds, pool_scores,
                                        score_stream, switching_delays, truth_at)

RATE = 10.0


def _planted(n_windows=40, n=80, seed=0, c0=1.0, c_drive=3.0, c_turn=6.0, d_arc=2.5):
    """Windows whose currents obey the documented balances exactly (plus small noise)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / RATE
    v = 0.3 + 0.2 * np.sin(2 * np.pi * rng.uniform(0.05, 0.3, (n_windows, 1)) * t)
    omega = 0.4 * np.sin(2 * np.pi * rng.uniform(0.05, 0.2, (n_windows, 1)) * t
                         + rng.uniform(0, 6, (n_windows, 1)))
    vel_l, vel_r = v - 0.5708 * omega / 2, v + 0.5708 * omega / 2
    m_v, m_w = np.tanh(np.abs(v) / 0.05), np.tanh(np.abs(omega) / 0.1)
    i_sum = c0 + c_drive * m_v + c_turn * m_w + 0.01 * rng.standard_normal(v.shape)
    i_diff = d_arc * np.sign(omega) * m_v
    return vel_l, vel_r, 0.5 * (i_sum - i_diff), 0.5 * (i_sum + i_diff)


def test_current_balance_coefficients_recover_the_planted_terrain_currents():
    vel_l, vel_r, cur_l, cur_r = _planted()
    F = physics_features(vel_l, vel_r, cur_l, cur_r, RATE, ridge=1e-6)
    col = {name: F[:, i] for i, name in enumerate(PHYSICS_FEATURES)}
    np.testing.assert_allclose(np.median(col["cur_sum__turn_a"]), 6.0, atol=0.3)
    np.testing.assert_allclose(np.median(col["cur_diff__arc_turn_a"]), 2.5, atol=0.1)
    assert np.median(col["cur_sum__resid_std_a"]) < 0.05
    # a terrain with twice the turning resistance doubles the turning current feature
    F2 = physics_features(*_planted(c_turn=12.0), RATE, ridge=1e-6)
    turn2 = F2[:, PHYSICS_FEATURES.index("cur_sum__turn_a")]
    np.testing.assert_allclose(np.median(turn2), 12.0, atol=0.5)


def _numpy_physics_features(vel_l, vel_r, cur_l, cur_r, rate_hz, track_m=0.5708,
                            v0=0.05, w0=0.1, ridge=1e-3):
    """The features written with NumPy's own functions (the formulation the compiled kernel
    of ``physics_features`` must reproduce)."""
    def ridge_fit(y, A, intercept=False):
        # with an intercept (column 0 of ones) it is unpenalised: centre, solve, recover
        n = A.shape[1]
        X, yc = A, y
        if intercept:
            X = A[..., 1:] - A[..., 1:].mean(axis=1, keepdims=True)
            yc = y - y.mean(axis=1, keepdims=True)
        G = np.einsum("wsi,wsj->wij", X, X) + ridge * n * np.eye(X.shape[2])[None]
        coef = np.linalg.solve(G, np.einsum("wsi,ws->wi", X, yc)[..., None])[..., 0]
        if intercept:
            c0 = y.mean(axis=1) - np.einsum("wi,wi->w", A[..., 1:].mean(axis=1), coef)
            coef = np.concatenate([c0[:, None], coef], axis=1)
        return coef, (y - np.einsum("wsi,wi->ws", A, coef)).std(axis=1)

    v, omega = 0.5 * (vel_l + vel_r), (vel_r - vel_l) / track_m
    i_sum, i_diff = cur_l + cur_r, cur_r - cur_l
    acc = np.gradient(v, 1.0 / rate_hz, axis=1) if v.shape[1] > 1 else np.zeros_like(v)
    abs_v, abs_o = np.abs(v), np.abs(omega)
    m_v, m_w = np.tanh(abs_v / v0), np.tanh(abs_o / w0)
    c, e_sum = ridge_fit(i_sum, np.stack([np.ones_like(v), m_v, np.abs(acc), m_w], axis=-1),
                         intercept=True)
    d, e_diff = ridge_fit(i_diff, np.stack([np.sign(omega) * m_v, omega], axis=-1))
    w_turn, w_straight = m_w, m_v * (1.0 - m_w)
    mean_all = i_sum.mean(1)
    q_sum = np.quantile(i_sum, [0.1, 0.5, 0.9], axis=1)
    q_diff = np.quantile(np.abs(i_diff), [0.5, 0.9], axis=1)
    ripple = np.diff(i_sum, axis=1).std(axis=1) if i_sum.shape[1] > 2 else np.zeros(len(v))
    cols = [c[:, 0], c[:, 1], c[:, 2], c[:, 3], e_sum, d[:, 0], d[:, 1], e_diff,
            ((w_turn * i_sum).sum(1) + mean_all) / (w_turn.sum(1) + 1.0),
            ((w_straight * i_sum).sum(1) + mean_all) / (w_straight.sum(1) + 1.0),
            mean_all / np.maximum(abs_v.mean(1), v0), mean_all / np.maximum(abs_o.mean(1), w0),
            q_sum[0], q_sum[1], q_sum[2], q_diff[0], q_diff[1], ripple, abs_v.mean(1),
            v.std(1), abs_o.mean(1), omega.std(1), np.abs(acc).mean(1),
            (abs_v > v0).mean(1), (abs_o > w0).mean(1)]
    return np.stack(cols, axis=1)


@pytest.mark.parametrize("n", [1, 2, 3, 20, 40])
def test_compiled_features_equal_the_numpy_formulation(n):
    vel_l, vel_r, cur_l, cur_r = _planted(n_windows=30, n=max(n, 3), seed=n)
    parts = [a[:, :n].copy() for a in (vel_l, vel_r, cur_l, cur_r)]
    parts[0][:3] = 0.0                                   # standing windows: m_v = 0, acc = 0
    parts[1][:3] = 0.0
    parts[1][3:6] = parts[0][3:6]                        # straight: omega = 0, sign 0
    parts[2][6] = 4.0                                    # constant current, tied quantiles
    got = physics_features(*parts, RATE)
    want = _numpy_physics_features(*parts, RATE)
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-9)


def test_compiled_features_equal_the_numpy_formulation_on_real_windows(borealtc_runs):
    from features.windows import WindowConfig, make_windows
    ws = make_windows(borealtc_runs[:6], "wheels", WindowConfig(window_s=4.0, rate_hz=10.0,
                                                                hop_s=2.0))
    idx = [list(ws.channels).index(c) for c in ("vel_l", "vel_r", "cur_l", "cur_r")]
    parts = [ws.X[:, i, :] for i in idx]
    assert len(parts[0]) > 100
    np.testing.assert_allclose(physics_features(*parts, 10.0),
                               _numpy_physics_features(*parts, 10.0), rtol=1e-9, atol=1e-9)


def test_physics_features_refuse_bad_settings_and_shapes():
    parts = _planted(n_windows=2, n=10)
    for bad in ({"ridge": 0.0}, {"rate_hz": np.nan}, {"track_m": -1.0},
                {"speed_scale_m_s": np.inf}):
        kw = {"rate_hz": RATE, **bad}
        rate = kw.pop("rate_hz")
        with pytest.raises(ConfigError, match=next(iter(bad))):
            physics_features(*parts, rate, **kw)
    with pytest.raises(ShapeError):
        physics_features(parts[0], parts[1], parts[2], parts[3][:, :5], RATE)
    with pytest.raises(ShapeError):
        physics_features(*(p[0] for p in parts), RATE)


def test_transformer_names_and_two_time_scales():
    vel_l, vel_r, cur_l, cur_r = _planted(n_windows=5)
    X = np.stack([vel_l, vel_r, cur_l, cur_r], axis=1)
    fx = WheelPhysicsFeatures(channels=("vel_l", "vel_r", "cur_l", "cur_r"), rate_hz=RATE,
                              short_s=2.0).fit(X)
    out = fx.transform(X)
    names = fx.get_feature_names_out()
    assert out.shape == (5, 2 * len(PHYSICS_FEATURES)) == (5, len(names))
    assert names[len(PHYSICS_FEATURES)] == f"{PHYSICS_FEATURES[0]}__last2s"
    short = physics_features(*(X[:, i, -20:] for i in range(4)), RATE)
    np.testing.assert_allclose(out[:, len(PHYSICS_FEATURES):], short)
    with pytest.raises(ConfigError):
        WheelPhysicsFeatures(channels=("vel_l", "vel_r")).fit(X[:, :2])
    with pytest.raises(ValueError):
        fx.transform(X[:, :, :40])


def test_concatenated_streams_switch_terrain_and_are_reproducible(borealtc_runs):
    runs = [r for r in borealtc_runs if r.has_imu][:20]
    a, seg_a = concatenated_streams(runs, ("imu", "wheels"), seed=3)
    b, seg_b = concatenated_streams(runs, ("imu", "wheels"), seed=3)
    assert seg_a == seg_b and len(seg_a) >= 5
    assert len({s.run_id for s in seg_a}) == len(seg_a)  # each run used once...
    # ... and every run used: in a piece or named too short for one
    assert ({s.run_id for s in seg_a} | set(a.meta["skipped_runs"])
            == {r.run_id for r in runs})
    assert all(s.duration_s <= 120.0 for s in seg_a)
    switches = sum(p.terrain != s.terrain for p, s in zip(seg_a[:-1], seg_a[1:]))
    assert switches >= len(seg_a) // 2
    t = a.streams["wheels"]["t_s"].to_numpy()
    assert (np.diff(t) > 0).all()
    # every sample carries the label of its source piece
    truth = truth_at(seg_a, t)
    assert (truth != None).all()  # noqa: E711


def test_held_out_folds_hold_every_run_out_once_and_show_progress(borealtc_runs, capsys):
    runs = [r for r in borealtc_runs if r.has_imu][:20]
    quiet = list(held_out_folds(runs, ("imu", "wheels"), seed=1, n_splits=4))
    assert "held-out streams" not in capsys.readouterr().err
    shown = list(held_out_folds(runs, ("imu", "wheels"), seed=1, n_splits=4, progress=True))
    assert "held-out streams, seed 1" in capsys.readouterr().err
    every = {r.run_id for r in runs}
    held = []
    for (fold, train, stream, segs), (fold_p, train_p, _sp, segs_p) in zip(quiet, shown):
        assert fold == fold_p and segs == segs_p
        assert [r.run_id for r in train] == [r.run_id for r in train_p]
        test_ids = every - {r.run_id for r in train}
        # the stream: the held-out runs, every one of them but those named too short for a
        # piece (a subset passed a stream that left test runs out unnamed: they were then
        # neither trained on nor scored)
        in_stream = [s.run_id for s in segs]
        skipped = list(stream.meta["skipped_runs"])
        assert len(set(in_stream)) == len(in_stream) and not set(in_stream) & set(skipped)
        assert set(in_stream) | set(skipped) == test_ids
        held += in_stream + skipped
    assert sorted(held) == sorted(every)  # each run held out exactly once


def _join_steps(stream: pd.DataFrame, segments) -> tuple[np.ndarray, float]:
    """Steps across the switches of one stream, s, and its median step, s."""
    t = stream["t_s"].to_numpy()
    starts = [s.t_from_s + s.t_offset_s for s in segments[1:]]
    first = np.searchsorted(t, starts)
    return t[first] - t[first - 1], float(np.median(np.diff(t)))


def test_concatenated_stream_clock_runs_on_across_a_switch(borealtc_runs):
    # a robot driving onto the next terrain keeps logging: by default the step across a
    # switch stays below two usual steps of every stream, so the service's gap rule (three
    # usual steps) does not fire; an explicit dropout is a gap on the 100 Hz IMU
    runs = [r for r in borealtc_runs if r.has_imu][:10]
    cont, segs = concatenated_streams(runs, ("imu", "wheels"), seed=2)
    gappy, segs_g = concatenated_streams(runs, ("imu", "wheels"), seed=2, gap_s=0.1)
    assert [s.run_id for s in segs] == [s.run_id for s in segs_g] and len(segs) >= 4
    for name in ("imu", "wheels"):
        joins, step = _join_steps(cont.streams[name], segs)
        assert (joins > 0).all() and (joins < 2.0 * step).all(), name
    joins, step = _join_steps(gappy.streams["imu"], segs_g)
    assert (joins > 3.0 * step).all()


def test_switching_delay_and_accuracy_of_known_decisions(borealtc_runs):
    runs = [r for r in borealtc_runs if r.has_imu][:12]
    _, segs = concatenated_streams(runs, ("wheels",), seed=1)
    t = np.arange(0.0, segs[-1].t_from_s + segs[-1].t_offset_s + segs[-1].duration_s, 0.5)
    truth = truth_at(segs, t)
    # decisions that follow the truth 3 s late
    lagged = truth_at(segs, t - 3.0)
    decided = np.where(lagged == None, truth, lagged)  # noqa: E711
    delays = switching_delays(segs, t, decided)
    changes = [s for p, s in zip(segs[:-1], segs[1:]) if s.terrain != p.terrain]
    assert len(delays) == len(changes)
    np.testing.assert_allclose(delays, 3.0, atol=0.5 + 1e-9)
    score = score_stream(segs, t, decided, window_s=3.0)
    assert 0.9 < score.accuracy < 1.0 and score.median_delay_s == pytest.approx(
        np.median(delays))
    # every wrong decision is within 3 s of a switch: the settled ones are all right
    assert score.accuracy_settled == 1.0 and 0 < score.n_settled < score.n_decisions
    assert sum(sum(r.values()) for r in score.confusion.values()) == score.n_decisions
    pooled = pool_scores(pd.DataFrame([score.__dict__ | {"delays_s": list(score.delays_s)}
                                       for _ in range(2)]))
    assert pooled["accuracy"] == pytest.approx(score.accuracy)
    assert pooled["n_switches"] == 2 * len(delays)
    assert all(0.8 < r <= 1.0 for r in pooled["recall"].values())


@pytest.mark.parametrize("which, value", [(0, np.nan), (2, np.nan), (3, np.inf)])
def test_physics_features_name_a_non_finite_input(which, value):
    """A NaN or inf sample raised numpy's bare LinAlgError 'Array must not contain infs or
    NaNs' from inside the compiled ridge fit, naming no input."""
    parts = [p.copy() for p in _planted(n_windows=3, n=10)]
    parts[which][1, 4] = value
    name = ("vel_l", "vel_r", "cur_l", "cur_r")[which]
    with pytest.raises(NonFiniteInputError,
                       match=rf"physics_features: {name} holds 1 non-finite sample \(window 1"):
        physics_features(*parts, RATE)


def test_a_wheel_channel_named_twice_is_refused():
    """Channels are read by position: the first of two ``cur_l`` was read and the other
    ignored without a word."""
    X = np.stack([*_planted(n_windows=3, n=40), np.zeros((3, 40))], axis=1)
    with pytest.raises(ConfigError, match=r"channels \['cur_l'\] given twice"):
        WheelPhysicsFeatures(channels=("vel_l", "vel_r", "cur_l", "cur_r", "cur_l"),
                             rate_hz=RATE).fit(X)


def test_transformer_names_the_channel_and_window_of_a_non_finite_sample():
    """It said only "X contains NaN or inf"."""
    X = np.stack(_planted(n_windows=3, n=40), axis=1)
    fitted = WheelPhysicsFeatures(rate_hz=RATE).fit(X)
    X[1, 2, 5] = np.nan
    with pytest.raises(ValueError, match=r"NaN or inf \(1 value\): 'cur_l' in window 1$"):
        fitted.transform(X)


def test_transformer_reads_the_wheel_channels_by_name_and_passes_its_settings():
    vel_l, vel_r, cur_l, cur_r = _planted(n_windows=4, n=40)
    # channels in another order, with an unused one between
    X = np.stack([cur_r, vel_l, np.zeros_like(vel_l), cur_l, vel_r], axis=1)
    chans = ("cur_r", "vel_l", "wz", "cur_l", "vel_r")
    out = WheelPhysicsFeatures(channels=chans, rate_hz=RATE, short_s=None).fit(X).transform(X)
    np.testing.assert_allclose(out, physics_features(vel_l, vel_r, cur_l, cur_r, RATE))
    # the track width and ridge set on the transformer reach the features
    fx = WheelPhysicsFeatures(channels=chans, rate_hz=RATE, short_s=None, track_m=1.1,
                              ridge=0.5).fit(X)
    want = physics_features(vel_l, vel_r, cur_l, cur_r, RATE, track_m=1.1, ridge=0.5)
    np.testing.assert_allclose(fx.transform(X), want)
    assert not np.allclose(want, out)


@pytest.mark.parametrize("short_s, names", [
    (4.0, 1),      # 40 samples: the whole window again, not a second scale
    (0.25, 1),     # rounds to 2 samples: too few for the fits
    (0.29, 2),     # rounds (not truncates) to 3 samples: a second scale
])
def test_transformer_keeps_a_short_scale_only_of_3_samples_to_less_than_the_window(short_s,
                                                                                   names):
    X = np.stack(_planted(n_windows=3, n=40), axis=1)
    fx = WheelPhysicsFeatures(rate_hz=RATE, short_s=short_s).fit(X)
    assert len(fx.get_feature_names_out()) == names * len(PHYSICS_FEATURES)
    assert fx.transform(X).shape == (3, names * len(PHYSICS_FEATURES))
    if names == 2:
        assert fx.get_feature_names_out()[-1] == f"{PHYSICS_FEATURES[-1]}__last0.29s"
        np.testing.assert_allclose(fx.transform(X)[:, len(PHYSICS_FEATURES):],
                                   physics_features(*(X[:, i, -3:] for i in range(4)), RATE))


def test_physics_features_refuse_windows_of_no_sample():
    parts = _planted(n_windows=2, n=10)
    with pytest.raises(ShapeError, match="n_samples >= 1"):
        physics_features(*(p[:, :0] for p in parts), RATE)


@pytest.mark.parametrize("value", [True, "10", [10.0]])
def test_settings_that_are_not_numbers_are_refused_naming_them(value):
    """``rate_hz=True`` was taken as 1 Hz (the features of 10 Hz windows computed at 1 Hz
    without a word) and text gave NumPy's "ufunc 'isfinite' not supported"; the
    transformer's ``short_s`` / ``rate_hz`` as text failed on "can't multiply sequence"."""
    parts = _planted(n_windows=2, n=20)
    with pytest.raises(ConfigError, match="physics_features.rate_hz must be a real number"):
        physics_features(*parts, value)
    with pytest.raises(ConfigError, match="physics_features.ridge must be a real number"):
        physics_features(*parts, RATE, ridge=value)
    X = np.stack(parts, axis=1)
    for field in ("rate_hz", "short_s"):
        with pytest.raises(ConfigError, match=f"WheelPhysicsFeatures.{field} must be a real"):
            WheelPhysicsFeatures(**{field: value}).fit(X)


@pytest.mark.parametrize("n_channels", [3, 5])
def test_windows_of_another_channel_count_than_named_are_refused(n_channels):
    """The channels are read by position from ``channels``: windows holding one channel
    more than named were read without a word (the features of the first four channels,
    whatever they were), one fewer failed on NumPy's "index 3 is out of bounds"."""
    X = np.zeros((3, n_channels, 40))
    good = np.stack(_planted(n_windows=3, n=40), axis=1)
    fitted = WheelPhysicsFeatures(rate_hz=RATE).fit(good)
    for call in (lambda: WheelPhysicsFeatures(rate_hz=RATE).fit(X),
                 lambda: fitted.transform(X)):
        with pytest.raises(ValueError, match=rf"expected X of shape \(n_windows, 4, "
                                             rf"n_samples\), got \(3, {n_channels}, 40\)"):
            call()


def _piece(run_id, terrain, a_s, duration_s):
    """A piece of a stream starting at ``a_s`` on the stream clock (its run's own clock
    starting at 5 s)."""
    from terrain.serving.evaluation import Segment

    return Segment(run_id, terrain, 5.0, a_s - 5.0, duration_s)


def test_a_switch_is_counted_once_its_delay_from_the_new_pieces_start():
    """Known decisions on hand-made pieces with a 0.5 s dropout at every switch: the delay
    runs from the new piece's first instant (not the previous piece's end), a flicker back
    to the old terrain does not count the switch again, two pieces of one terrain side by
    side are no switch, a terrain first named only in the next piece is never followed
    (inf), and the decisions between pieces are scored nowhere."""
    segs = [_piece("r0", "ICE", 0.0, 30.0), _piece("r1", "SNOW", 30.5, 30.0),
            _piece("r2", "SNOW", 61.0, 20.0), _piece("r3", "ASPHALT", 81.5, 20.0),
            _piece("r4", "ICE", 102.0, 20.0)]
    t = np.arange(0.0, 122.0, 0.5)
    decided = np.full(len(t), "ICE", dtype=object)
    decided[t >= 33.0] = "SNOW"                          # 2.5 s after SNOW's start
    decided[(t >= 40.0) & (t < 42.0)] = "ICE"            # a flicker back
    decided[t >= 102.0] = "ASPHALT"                      # ASPHALT only after its piece
    decided[t >= 105.0] = "ICE"                          # 3 s after ICE's start
    np.testing.assert_array_equal(switching_delays(segs, t, decided), [2.5, np.inf, 3.0])
    np.testing.assert_array_equal(truth_at(segs, np.array([29.5, 30.0, 30.5, 60.5, 61.0])),
                                  np.array(["ICE", None, "SNOW", None, "SNOW"], dtype=object))
    score = score_stream(segs, t, decided, window_s=2.0)
    inside = [(s.t_from_s + s.t_offset_s, s.duration_s, s.terrain) for s in segs]
    truth = [next((k for a, d, k in inside if a <= ti < a + d), None) for ti in t]
    scored = [(d == k) for d, k in zip(decided, truth) if k is not None]
    assert score.n_decisions == len(scored) == len(t) - 4   # 30.0, 60.5, 81.0, 101.5
    assert score.accuracy == pytest.approx(np.mean(scored))
    assert score.delays_s == (2.5, np.inf, 3.0) and score.median_delay_s == 3.0
    # settled: the window's start (2 s back) inside a piece of the same terrain
    assert score.n_settled == sum(k is not None and k == next(
        (j for a, d, j in inside if a <= ti - 2.0 < a + d), None) for ti, k in zip(t, truth))
