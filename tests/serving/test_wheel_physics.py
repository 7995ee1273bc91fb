"""Wheel-physics features recover planted current balances; run-grouped evaluation helpers."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from features.wheel_physics import PHYSICS_FEATURES, WheelPhysicsFeatures, physics_features
from terrain.errors import ConfigError
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
    assert len({s.run_id for s in seg_a}) == len(seg_a)  # each run used once
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
    for (fold, train, _s, segs), (fold_p, train_p, _sp, segs_p) in zip(quiet, shown):
        assert fold == fold_p and segs == segs_p
        assert [r.run_id for r in train] == [r.run_id for r in train_p]
        test_ids = every - {r.run_id for r in train}
        assert {s.run_id for s in segs} <= test_ids and segs  # the stream: held-out runs only
        held += list(test_ids)
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
