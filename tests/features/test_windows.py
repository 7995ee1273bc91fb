"""Windowing: counts, partitions, steady-motion filter, signal selection, skipped runs."""

from __future__ import annotations

import re
import warnings

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from features.ekf_signals import EKF_CHANNELS
from features.transformers import WindowFeatures
from features.windows import (ALL_CHANNELS, DERIVED_WHEEL_CHANNELS, HUSKY_TRACK_M,
                              MAX_WINDOW_SAMPLES, SIGNAL_SETS, SPEED_CHANNELS, WindowConfig,
                              add_derived_channels, make_windows, required_streams,
                              resolve_signals, window_frame)
from terrain.errors import ConfigError
from terrain.io.align import median_step, overlap_grid
from terrain.io.report import input_report
from terrain.run import IMU_CHANNELS, TIME, WHEEL_CHANNELS, Run


def _streams(duration_s=20.0, vel=None, seed=0):
    """IMU at 100 Hz and wheels at 10 Hz over [0, duration_s]; ``vel(t)`` the wheel speed."""
    rng = np.random.default_rng(seed)
    ti = np.arange(int(duration_s * 100) + 1) / 100.0
    imu = pd.DataFrame({TIME: ti, **{c: 0.05 * rng.standard_normal(len(ti))
                                     for c in IMU_CHANNELS}})
    imu["az"] += 9.81
    tw = np.arange(int(duration_s * 10) + 1) / 10.0
    v = np.full(len(tw), 0.5) if vel is None else vel(tw)
    wheels = pd.DataFrame({TIME: tw, "vel_l": v, "vel_r": v + 0.1,
                           "cur_l": 5.0 + rng.standard_normal(len(tw)),
                           "cur_r": 6.0 + rng.standard_normal(len(tw))})
    return {"imu": imu, "wheels": wheels}


@pytest.mark.parametrize("window_s, hop_s, rate_hz, n_windows, n_samples", [
    (2.0, None, 50.0, 10, 100),   # 1001 grid points: starts 0, 100, ..., 900
    (2.0, 1.0, 50.0, 19, 100),
    (1.7, 0.1, 50.0, 184, 85),    # starts 0, 5, ..., 915
    (2.0, 0.5, 100.0, 37, 200),   # 2001 grid points: starts 0, 50, ..., 1800
    (5.0, None, 20.0, 4, 100),    # 401 grid points: starts 0, 100, 200, 300
])
def test_window_counts_and_sample_counts(make_run, window_s, hop_s, rate_hz, n_windows,
                                         n_samples):
    config = WindowConfig(window_s=window_s, hop_s=hop_s, rate_hz=rate_hz)
    assert config.n_samples == n_samples
    ws = make_windows([make_run(_streams())], "all", config)
    assert ws.X.shape == (n_windows, len(ALL_CHANNELS), n_samples)
    assert len(ws) == ws.counts["windows"] == n_windows
    hop = hop_s or window_s
    np.testing.assert_allclose(ws.t_start_s, np.arange(n_windows) * hop, atol=1e-9)
    np.testing.assert_allclose(ws.t_end_s - ws.t_start_s, window_s, atol=1e-9)
    assert ws.t_end_s.max() <= 20.0 + 1 / rate_hz + 1e-9
    assert ws.rate_hz == rate_hz and ws.channels == ALL_CHANNELS


def test_windows_carry_run_id_label_and_values(make_run):
    runs = [make_run(_streams(seed=1), "t/ASPHALT/00", "ASPHALT"),
            make_run(_streams(duration_s=10.0, seed=2), "t/SNOW/01", "SNOW")]
    ws = make_windows(runs, ["wz", "vel_r"], WindowConfig(window_s=2.0, rate_hz=100.0))
    assert list(ws.run_ids) == ["t/ASPHALT/00"] * 10 + ["t/SNOW/01"] * 5
    assert list(ws.labels) == ["ASPHALT"] * 10 + ["SNOW"] * 5
    assert list(ws.groups) == list(ws.run_ids)
    # at 100 Hz the IMU is not filtered: window 3 of run 0 is samples 600..799 of wz
    np.testing.assert_allclose(ws.X[3, 0], runs[0].streams["imu"]["wz"].to_numpy()[600:800])
    np.testing.assert_allclose(ws.X[:, 1], 0.6)


def test_partitions_are_never_crossed(make_run):
    config = WindowConfig(window_s=1.7, hop_s=0.1, rate_hz=50.0, partition_s=5.0)
    ws = make_windows([make_run(_streams(duration_s=21.0), "t/ICE/00", "ICE")], "all", config)
    # 1051 grid points -> 4 full partitions of 250 samples, 34 windows each
    assert len(ws) == 4 * 34
    first = np.floor(ws.t_start_s / 5.0 + 1e-9)
    last = np.floor((ws.t_end_s - 1 / 50.0) / 5.0 + 1e-9)
    np.testing.assert_array_equal(first, last)
    assert list(ws.groups) == [f"t/ICE/00#{int(k)}" for k in first]
    assert sorted(set(ws.groups)) == [f"t/ICE/00#{k}" for k in range(4)]
    assert ws.t_end_s.max() <= 20.0 + 1e-9  # trailing partial partition dropped


def test_partition_tail_and_runs_without_a_full_partition_are_counted(make_run):
    config = WindowConfig(window_s=1.7, hop_s=0.1, rate_hz=50.0, partition_s=5.0)
    runs = [make_run(_streams(duration_s=21.0), "t/ICE/00", "ICE"),
            make_run(_streams(duration_s=4.0), "t/ICE/01", "ICE"),    # > 1 window, < 1 part.
            make_run(_streams(duration_s=1.0), "t/ICE/02", "ICE")]    # < 1 window
    ws = make_windows(runs, "all", config)
    per_run = ws.counts["per_run"]
    # 1051 grid points: 4 partitions of 250 and a 51-sample tail; 201 and 51 points: all tail
    assert per_run["t/ICE/00"]["partition_tail_s"] == pytest.approx(1.02)
    assert per_run["t/ICE/01"]["partition_tail_s"] == pytest.approx(4.02)
    assert per_run["t/ICE/01"]["windows"] == 0
    assert ws.counts["partition_tail_s"] == pytest.approx(1.02 + 4.02 + 1.02)
    assert ws.counts["too_short_runs"] == ["t/ICE/01", "t/ICE/02"]
    assert ws.counts["reasons"] == {"t/ICE/01": "shorter than one 5 s partition",
                                    "t/ICE/02": "shorter than one 1.7 s window"}
    plain = make_windows(runs[:1], "all", WindowConfig(window_s=2.0, rate_hz=50.0))
    assert plain.counts["partition_tail_s"] == 0.0 and plain.counts["too_short_runs"] == []


def test_the_run_tail_after_the_last_window_is_counted_with_and_without_partitions(make_run):
    # a 21 s run cut into 2 s windows left 1.02 s after its last window uncounted (no
    # partition, so partition_tail_s 0): only the partition protocol counted its tail
    runs = [make_run(_streams(duration_s=21.0), "t/ICE/00", "ICE"),
            make_run(_streams(duration_s=1.0), "t/ICE/01", "ICE")]    # < 1 window
    plain = make_windows(runs, "all", WindowConfig(window_s=2.0, rate_hz=50.0))
    per_run = plain.counts["per_run"]
    # 1051 grid points: windows 0..999, 51 samples after; 51 points: no window, all tail
    assert per_run["t/ICE/00"]["window_tail_s"] == pytest.approx(1.02)
    assert per_run["t/ICE/01"]["window_tail_s"] == pytest.approx(1.02)
    assert plain.counts["window_tail_s"] == pytest.approx(2.04)
    assert plain.counts["partition_tail_s"] == 0.0
    # with partitions: 4 partitions of 250 samples, 85-sample windows every 10 samples end
    # at 245 (5 samples, 0.1 s, after each), and the 51-sample partition tail
    config = WindowConfig(window_s=1.7, hop_s=0.2, rate_hz=50.0, partition_s=5.0)
    parts = make_windows(runs[:1], "all", config)
    assert parts.counts["window_tail_s"] == pytest.approx(4 * 0.1)
    assert parts.counts["partition_tail_s"] == pytest.approx(1.02)
    report = input_report(runs, plain.counts, 2.0).text()
    assert ("not windowed: 2.0 s of run tails after the last full window in t/ICE/00, "
            "t/ICE/01") in report


def test_the_time_between_windows_of_a_hop_longer_than_the_window_is_counted(make_run):
    # `terrain cv --window-s 2 --hop-s 5` cut a window every 5 s and left the 3 s between
    # two windows out of every count: only the tail after the last window was reported
    runs = [make_run(_streams(duration_s=21.0), "t/ICE/00", "ICE")]
    sparse = make_windows(runs, "all", WindowConfig(window_s=2.0, hop_s=5.0, rate_hz=50.0))
    c = sparse.counts["per_run"]["t/ICE/00"]
    # 1051 grid points: windows at 0, 250, 500, 750, 1000 (100 samples each, the last ends at
    # 1100 > 1051: so four), 150 samples between each pair, 1051 - 850 = 201 after the last
    assert len(sparse) == 4
    assert c["between_windows_s"] == pytest.approx(3 * 3.0)
    assert c["window_tail_s"] == pytest.approx(4.02)
    # every sample is in a window, between two, or after the last
    assert (len(sparse) * 2.0 + c["between_windows_s"] + c["window_tail_s"]
            == pytest.approx(c["aligned_s"]))
    assert sparse.counts["between_windows_s"] == pytest.approx(9.0)
    report = input_report(runs, sparse.counts, 2.0)
    assert ("not windowed: 9.0 s between windows (a hop longer than the window) in t/ICE/00"
            in report.text())
    assert report.metrics()["input_between_windows_s"] == pytest.approx(9.0)
    # overlapping or touching windows leave nothing between them
    for hop_s in (None, 1.0, 2.0):
        dense = make_windows(runs, "all", WindowConfig(window_s=2.0, hop_s=hop_s,
                                                       rate_hz=50.0))
        assert dense.counts["between_windows_s"] == 0.0
        assert "between windows" not in input_report(runs, dense.counts, 2.0).text()


def test_steady_only_drops_windows_with_speed_changes(make_run):
    # steady 0.5 m/s until 10 s, then a 1 Hz +-0.4 m/s oscillation
    vel = (lambda t: np.where(t < 10.0, 0.5, 0.5 + 0.4 * np.sin(2 * np.pi * (t - 10.0))))
    run = make_run(_streams(vel=vel))
    base = dict(window_s=2.0, hop_s=1.0, rate_hz=50.0)
    every = make_windows([run], "all", WindowConfig(**base))
    steady = make_windows([run], "all", WindowConfig(**base, steady_only=True))
    np.testing.assert_allclose(steady.t_start_s, np.arange(9.0))  # windows ending by 10 s
    assert steady.counts["dropped_unsteady"] == len(every) - len(steady) == 10
    assert every.counts["dropped_unsteady"] == 0
    v = steady.X[:, [steady.channels.index("vel_l"), steady.channels.index("vel_r")]].mean(1)
    assert (v.std(axis=-1) <= 0.1).all()


@pytest.mark.parametrize("field, value", [("min_speed_m_s", np.nan),
                                          ("max_speed_std_m_s", np.nan),
                                          ("max_speed_std_m_s", -0.1),
                                          ("min_speed_m_s", np.inf),
                                          ("min_speed_m_s", "0.1")])
def test_steady_thresholds_that_are_not_finite_non_negative_numbers_are_refused(
        make_run, field, value):
    """A NaN or negative steady-motion threshold was taken: NaN (or a negative spread) made
    every window of the run of ``test_steady_only_drops_windows_with_speed_changes``
    "unsteady" (19 of 19 dropped, against 9 kept and 10 dropped)."""
    with pytest.raises(ConfigError, match=f"WindowConfig.{field}"):
        WindowConfig(steady_only=True, **{field: value})


def test_steady_only_drops_standstill(make_run):
    run = make_run(_streams(vel=lambda t: np.zeros_like(t)))
    ws = make_windows([run], "wheels", WindowConfig(window_s=2.0, steady_only=True))
    assert len(ws) == 0 and ws.counts["dropped_unsteady"] == 10
    assert ws.X.shape == (0, len(SIGNAL_SETS["wheels"]), 100)


def test_steady_only_keeps_steady_reversing(make_run):
    """Driving backwards at a steady speed is steady motion: the speed test is on
    |mean(vel_mean)|, not on its signed value."""
    run = make_run(_streams(vel=lambda t: np.full_like(t, -0.5)))
    ws = make_windows([run], "wheels", WindowConfig(window_s=2.0, steady_only=True))
    assert len(ws) == 10 and ws.counts["dropped_unsteady"] == 0


@pytest.mark.parametrize("field, over", [("min_speed_m_s", 0.25 + 1e-9),
                                         ("max_speed_std_m_s", 0.25 - 1e-9)])
def test_steady_thresholds_are_inclusive(field, over):
    """|mean| >= min_speed and std <= max_speed_std: a window exactly on a threshold is
    steady, one a hair beyond it is not. The speed alternates 0.25 / 0.75 m/s (mean 0.5,
    std 0.25, exact in binary) or is 0.25 m/s throughout (mean 0.25, std 0)."""
    n = 300
    if field == "min_speed_m_s":
        v = np.full(n, 0.25)
    else:
        v = np.where(np.arange(n) % 2 == 0, 0.25, 0.75)
    frame = pd.DataFrame({TIME: np.arange(n) / 50.0, "vel_l": v, "vel_r": v})
    base = dict(window_s=2.0, rate_hz=50.0, steady_only=True, min_speed_m_s=0.1,
                max_speed_std_m_s=0.1)
    on = WindowConfig(**{**base, "min_speed_m_s": 0.25, "max_speed_std_m_s": 0.25})
    X, *_, counts = window_frame(frame, ["vel_l"], on)
    assert len(X) == 3 and counts["dropped_unsteady"] == 0
    X, *_, counts = window_frame(frame, ["vel_l"], WindowConfig(**{**on.__dict__, field: over}))
    assert len(X) == 0 and counts["dropped_unsteady"] == 3


def test_steady_only_applies_to_imu_only_selection(make_run):
    run = make_run(_streams(vel=lambda t: np.zeros_like(t)))
    ws = make_windows([run], "imu", WindowConfig(window_s=2.0, steady_only=True))
    assert len(ws) == 0 and ws.counts["dropped_unsteady"] == 10
    moving = make_run(_streams(vel=lambda t: np.full_like(t, 0.5)))
    ws = make_windows([moving], "imu", WindowConfig(window_s=2.0, steady_only=True))
    assert len(ws) == 10 and ws.channels == IMU_CHANNELS


def test_steady_only_skips_a_run_without_wheels_even_for_imu_signals(make_run):
    imu_only = make_run({"imu": _streams()["imu"]}, "t/ICE/00", "ICE")
    ws = make_windows([imu_only], "imu", WindowConfig(window_s=2.0, steady_only=True))
    assert len(ws) == 0 and ws.counts["skipped_runs"] == ["t/ICE/00"]
    assert ws.counts["reasons"] == {"t/ICE/00": "no wheels stream, which steady_only needs"}
    assert ("1 run(s) skipped (no wheels stream, which steady_only needs): t/ICE/00"
            in input_report([imu_only], ws.counts, 2.0).text())
    assert len(make_windows([imu_only], "imu", WindowConfig(window_s=2.0))) == 10
    with pytest.raises(ConfigError, match="vel_l"):
        window_frame(pd.DataFrame({TIME: np.arange(300) / 50.0, "wz": 0.0}), ["wz"],
                     WindowConfig(window_s=2.0, rate_hz=50.0, steady_only=True))


def test_steady_only_counts_a_wheel_gap_as_a_gap_for_imu_signals(make_run):
    # standing still before 10 s, 0.5 m/s after; the wheel stream has a hole over (4, 8) s
    streams = _streams(vel=lambda t: np.where(t < 10.0, 0.0, 0.5))
    wheels = streams["wheels"]
    streams["wheels"] = wheels[(wheels[TIME] < 4.0) | (wheels[TIME] > 8.0)]
    run = make_run(streams, "t/ICE/00", "ICE")
    config = WindowConfig(window_s=2.0, steady_only=True)
    with warnings.catch_warnings():
        warnings.simplefilter("error")          # no "Mean of empty slice" from the hole
        imu = make_windows([run], "imu", config)
    every = make_windows([run], "all", config)
    # the 4 windows holding the hole are gaps, as with the wheel channels selected; the
    # other standing-still window is unsteady
    for ws in (imu, every):
        assert ws.counts["dropped_gap"] == 4 and ws.counts["dropped_unsteady"] == 1
        np.testing.assert_allclose(ws.t_start_s, [10.0, 12.0, 14.0, 16.0, 18.0])


@pytest.mark.parametrize("signals, expected", [
    ("imu", IMU_CHANNELS),
    ("wheels", WHEEL_CHANNELS + DERIVED_WHEEL_CHANNELS),
    ("all", IMU_CHANNELS + WHEEL_CHANNELS + DERIVED_WHEEL_CHANNELS),
    (["imu", "cur_diff"], IMU_CHANNELS + ("cur_diff",)),
    (("wz", "imu"), ("wz", "wx", "wy", "ax", "ay", "az")),
    (["vel_l", "vel_l", "wheels"], WHEEL_CHANNELS + DERIVED_WHEEL_CHANNELS),
])
def test_resolve_signals(signals, expected):
    assert resolve_signals(signals) == expected


def test_all_no_speed_drops_the_forward_speeds_only(make_run):
    """``all-no-speed`` is ``all`` without the forward wheel speeds (and so without the
    per-speed current features); the windows still need the wheel stream, whose speeds make
    the turning channels, and those equal the ``all`` windows' channels."""
    channels = resolve_signals("all-no-speed")
    assert channels == tuple(c for c in ALL_CHANNELS if c not in SPEED_CHANNELS)
    assert not set(channels) & {"vel_l", "vel_r", "vel_mean"}
    assert {"cur_l", "cur_r", "vel_diff", "yaw_rate_wheels"} <= set(channels)
    assert required_streams(channels) == ("imu", "wheels")
    run = make_run(_streams())
    full = make_windows([run], "all", WindowConfig(window_s=2.0))
    no_speed = make_windows([run], "all-no-speed", WindowConfig(window_s=2.0))
    keep = [full.channels.index(c) for c in channels]
    np.testing.assert_array_equal(no_speed.X, full.X[:, keep])
    names = WindowFeatures(channels).fit(no_speed.X).feature_names_out_
    assert not any("per_speed" in n or n.startswith("vel_l") for n in names)


@pytest.mark.parametrize("signals", [None, 5, ["imu", None], [["imu"]]])
def test_resolve_signals_refuses_what_is_not_names(signals):
    # None and 5 were Python's bare TypeError (list(None)), a nested list was unhashable
    with pytest.raises(ConfigError, match="signal"):
        resolve_signals(signals)


@pytest.mark.parametrize("signals", ["imus", ["imu", "speed"], ["WZ"], []])
def test_resolve_signals_rejects_unknown_names(signals):
    with pytest.raises(ConfigError) as info:
        resolve_signals(signals)
    if signals:
        assert "imu" in str(info.value) and "wheels" in str(info.value)


def test_required_streams():
    assert required_streams(IMU_CHANNELS) == ("imu",)
    assert required_streams(["cur_sum"]) == ("wheels",)
    assert required_streams(["wz", "yaw_rate_wheels"]) == ("imu", "wheels")
    # the EKF channels come from the IMU and the wheel encoders together
    assert required_streams(EKF_CHANNELS) == ("imu", "wheels")
    assert required_streams(["ekf_nis"]) == ("imu", "wheels")


def test_derived_channels():
    frame = pd.DataFrame({TIME: [0.0, 0.1], "vel_l": [0.4, 1.0], "vel_r": [0.6, 1.0],
                          "cur_l": [3.0, 2.0], "cur_r": [5.0, 2.0]})
    out = add_derived_channels(frame)
    np.testing.assert_allclose(out["vel_mean"], [0.5, 1.0])
    np.testing.assert_allclose(out["vel_diff"], [0.2, 0.0])
    np.testing.assert_allclose(out["cur_sum"], [8.0, 4.0])
    np.testing.assert_allclose(out["cur_diff"], [2.0, 0.0])
    np.testing.assert_allclose(out["yaw_rate_wheels"], [0.2 / HUSKY_TRACK_M, 0.0])
    imu_only = frame[[TIME]].assign(wz=[0.0, 0.1])
    assert add_derived_channels(imu_only) is imu_only


def test_run_without_imu_skipped_for_all_kept_for_wheels(make_run):
    full = make_run(_streams(), "t/FLOORING/00", "FLOORING")
    wheel_only = make_run({"wheels": _streams()["wheels"]}, "t/FLOORING/04", "FLOORING")
    ws_all = make_windows([full, wheel_only], "all", WindowConfig(window_s=2.0))
    assert ws_all.counts["skipped_runs"] == ["t/FLOORING/04"]
    assert set(ws_all.run_ids) == {"t/FLOORING/00"}
    ws_imu = make_windows([full, wheel_only], ["wz"], WindowConfig(window_s=2.0))
    assert ws_imu.counts["skipped_runs"] == ["t/FLOORING/04"]
    ws_wheels = make_windows([full, wheel_only], "wheels", WindowConfig(window_s=2.0))
    assert ws_wheels.counts["skipped_runs"] == []
    assert list(ws_wheels.run_ids) == ["t/FLOORING/00"] * 10 + ["t/FLOORING/04"] * 10


def test_shipped_runs_without_imu_are_listed(borealtc_runs):
    ws = make_windows(borealtc_runs, "all", WindowConfig(window_s=2.0))
    assert sorted(ws.counts["skipped_runs"]) == ["borealtc/FLOORING/04",
                                                 "borealtc/FLOORING/06", "borealtc/ICE/01"]
    assert len(set(ws.run_ids)) == len(borealtc_runs) - 3
    assert np.isfinite(ws.X).all()


def test_subset_keeps_provenance(make_run):
    ws = make_windows([make_run(_streams())], "imu", WindowConfig(window_s=2.0))
    sub = ws.subset(np.arange(len(ws)) % 2 == 0)
    assert len(sub) == 5 and sub.channels == ws.channels
    np.testing.assert_array_equal(sub.t_start_s, ws.t_start_s[::2])
    np.testing.assert_array_equal(sub.X, ws.X[::2])


def test_subset_counts_state_the_subset_not_the_parent(make_run):
    # a subset kept the parent's counts: 10 windows of one run reported as the parent's 20
    # (10 per run), and its per_run dict was the parent's own object
    runs = [make_run(_streams(seed=i), f"t/ASPHALT/0{i}") for i in range(2)]
    ws = make_windows(runs, "all", WindowConfig(window_s=2.0, rate_hz=50.0))
    sub = ws.subset(ws.run_ids == "t/ASPHALT/00")
    assert len(sub) == sub.counts["windows"] == 10 and ws.counts["windows"] == 20
    assert sub.counts["not_selected"] == 10
    assert {r: e["windows"] for r, e in sub.counts["per_run"].items()} == {
        "t/ASPHALT/00": 10, "t/ASPHALT/01": 0}
    assert sub.counts["per_run"]["t/ASPHALT/01"]["not_selected"] == 10
    assert {r: e["windows"] for r, e in ws.counts["per_run"].items()} == {
        "t/ASPHALT/00": 10, "t/ASPHALT/01": 10}          # the parent's are unchanged
    table = input_report(runs, sub.counts).table
    assert table["windows"].tolist() == [10, 0]
    # a resample repeating windows leaves out only the windows it never picks
    boot = ws.subset(np.array([0, 0, 0, 12]))
    assert boot.counts["windows"] == 4 and boot.counts["not_selected"] == 18
    assert {r: (e["windows"], e["not_selected"]) for r, e in boot.counts["per_run"].items()} \
        == {"t/ASPHALT/00": (3, 9), "t/ASPHALT/01": (1, 9)}
    odd = sub.subset(np.array([1, 3, 5]))                 # index arrays too, chained
    assert odd.counts["windows"] == 3 and odd.counts["not_selected"] == 17
    assert odd.counts["per_run"]["t/ASPHALT/00"] == {
        **ws.counts["per_run"]["t/ASPHALT/00"], "windows": 3, "not_selected": 7}


@pytest.mark.parametrize("kwargs, words", [
    (dict(window_s=0.0), "window_s and rate_hz must be finite numbers > 0"),
    # a negative hop was also refused as "under one sample": each setting by its own rule
    (dict(hop_s=-1.0), "hop_s must be a finite number > 0 s, got -1.0"),
    (dict(window_s=2.0, partition_s=1.0), "partition_s must be finite and >= window_s"),
    (dict(window_s=0.05, rate_hz=50.0), "a window must hold at least 4 samples"),
    (dict(rate_hz=0.0), "window_s and rate_hz must be finite numbers > 0"),
    # under one sample: it was cut at 0.02 s without a word
    (dict(hop_s=0.001, rate_hz=50.0), "hop_s 0.001 s is under one sample at 50 Hz")])
def test_window_config_rejects_bad_settings(kwargs, words):
    with pytest.raises(ConfigError, match=re.escape(words)):
        WindowConfig(**kwargs)


def test_window_config_sample_limit_is_inclusive():
    """:data:`MAX_WINDOW_SAMPLES` is the most samples a window may hold: exactly that many
    is allowed (10 000 s at 100 Hz), one more is refused."""
    assert WindowConfig(window_s=10_000.0, rate_hz=100.0).n_samples == MAX_WINDOW_SAMPLES
    with pytest.raises(ConfigError, match="at most"):
        WindowConfig(window_s=10_000.01, rate_hz=100.0)


def test_runs_sharing_an_id_are_refused(make_run):
    # two runs under one id were windowed as one: 15 windows of 'sim/ASPHALT/5' with start
    # times 0..8 then 0..18 s, per_run counting the second run's 10 only
    runs = [make_run(_streams(duration_s=10.0, seed=0), "sim/ASPHALT/5"),
            make_run(_streams(duration_s=20.0, seed=1), "sim/ASPHALT/5"),
            make_run(_streams(duration_s=10.0, seed=2), "sim/ASPHALT/6")]
    with pytest.raises(ConfigError, match=r"\['sim/ASPHALT/5'\]"):
        make_windows(runs, "all", WindowConfig(window_s=2.0))


@settings(max_examples=80, deadline=None)
@given(start_s=st.floats(0.0, 5.0), wheel_hz=st.sampled_from([6.5, 10.0, 15.0, 20.0]),
       n_wheel=st.integers(2, 200), rate_hz=st.sampled_from([10.0, 15.0, 20.0, 50.0]),
       window_s=st.floats(0.4, 4.0), hop_frac=st.one_of(st.none(), st.floats(0.05, 1.5)),
       partition_frac=st.one_of(st.none(), st.floats(1.0, 4.0)),
       gap=st.one_of(st.none(), st.tuples(st.floats(0.0, 1.0), st.floats(0.0, 0.5))))
def test_window_count_formula_and_spans_on_random_runs(start_s, wheel_hz, n_wheel, rate_hz,
                                                       window_s, hop_frac, partition_frac,
                                                       gap):
    """For any gap-free or gapped wheel run: the windows cut, dropped for the gap and wholly
    inside it add up to floor((N - n) / hop) + 1 per partition (N clock samples, n per
    window), every window lies inside its run and outside its gap, and its ids and times
    are its run's, in order."""
    if round(window_s * rate_hz) < 4:
        return
    hop_s = None if hop_frac is None else max(hop_frac * window_s, 1.0 / rate_hz)
    partition_s = None if partition_frac is None else partition_frac * window_s
    config = WindowConfig(window_s=window_s, hop_s=hop_s, rate_hz=rate_hz,
                          partition_s=partition_s)
    t = start_s + np.arange(n_wheel) / wheel_hz
    keep = np.ones(n_wheel, dtype=bool)
    hole = None
    if gap is not None:            # a hole of wheel samples: a step > 3 median steps
        a = int(gap[0] * (n_wheel - 1))
        b = a + 4 + int(gap[1] * n_wheel)
        if 1 <= a and b < n_wheel - 1:
            keep[a:b] = False
            # a gap by align's own rule only: where the hole holds most of a short run's
            # steps the median step is the hole's and it is interpolated over (7 samples at
            # 6.5 Hz less 4: steps 0.77 s and 0.15 s, median 0.46 s)
            if t[b] - t[a - 1] > 3.0 * median_step(t[keep]):
                hole = (t[a - 1], t[b])
    wheels = pd.DataFrame({TIME: t[keep], "vel_l": 0.5, "vel_r": 0.6,
                           "cur_l": 5.0 + np.arange(n_wheel)[keep] % 3, "cur_r": 6.0})
    run = Run("t/ICE/07", "t", "ICE", {"wheels": wheels}, source="hypothesis run")
    ws = make_windows([run], "wheels", config)
    total = len(overlap_grid([t[keep]], rate_hz))     # clock samples of the run
    assert total - 1 <= (t[-1] - t[0]) * rate_hz + 1e-6 < total
    n, hop = config.n_samples, config.hop_samples
    length = config.partition_samples or total
    per_part = (length - n) // hop + 1 if length >= n else 0
    expected = per_part * (total // length)
    c = ws.counts
    assert len(ws) == c["windows"] == c["per_run"]["t/ICE/07"]["windows"]
    assert len(ws) + c["dropped_gap"] + c["empty_gap"] == expected
    if hole is None:
        assert len(ws) == expected
    shortest = max(n, length) if partition_s else n
    assert (c["too_short_runs"] == ["t/ICE/07"]) == (total < shortest)
    period = 1.0 / rate_hz
    last = ws.t_end_s - period                          # time of a window's last sample
    assert (ws.t_start_s >= t[0] - 1e-9).all() and (last <= t[-1] + 1e-9).all()
    np.testing.assert_allclose(ws.t_end_s - ws.t_start_s, n * period, rtol=0, atol=1e-9)
    assert (np.diff(ws.t_start_s) > 0).all()
    if hole is not None:                              # no window holds a sample of the hole
        assert ((last < hole[0] + 1e-9) | (ws.t_start_s > hole[0])).all()
        assert ((ws.t_start_s >= hole[1] - 1e-9) | (last <= hole[0] + 1e-9)).all()
    assert np.isfinite(ws.X).all() and ws.X.shape[1:] == (len(ws.channels), n)
    assert set(ws.run_ids) <= {"t/ICE/07"} and set(ws.labels) <= {"ICE"}
    if partition_s is not None:
        k = np.array([int(g.split("#")[1]) for g in ws.groups], dtype=int)
        first = np.round((ws.t_start_s - t[0]) * rate_hz).astype(int)
        np.testing.assert_array_equal(first // length, k)
        np.testing.assert_array_equal((first + n - 1) // length, k)
    else:
        assert list(ws.groups) == list(ws.run_ids)


def test_window_hop_and_partition_lengths_round_to_the_nearest_sample():
    """Lengths in seconds become the nearest whole number of samples, not the number below:
    0.29 s at 100 Hz is 28.999999999999996 samples in floating point, i.e. 29 samples
    (truncated it was 28: 0.28 s windows started every 0.28 s, a partition of 0.56 s)."""
    config = WindowConfig(window_s=0.29, hop_s=0.29, rate_hz=100.0, partition_s=0.57)
    assert (config.n_samples, config.hop_samples, config.partition_samples) == (29, 29, 57)
    n = 200
    frame = pd.DataFrame({TIME: np.arange(n) / 100.0, "wz": np.arange(n, dtype=float)})
    X, t0, t1, _, _ = window_frame(frame, ["wz"],
                                   WindowConfig(window_s=0.29, hop_s=0.29, rate_hz=100.0))
    assert X.shape == (6, 1, 29)
    np.testing.assert_allclose(t0, 0.29 * np.arange(6), atol=1e-12)
    np.testing.assert_allclose(t1 - t0, 0.29, atol=1e-12)
    np.testing.assert_array_equal(X[:, 0, 0], 29 * np.arange(6))


@pytest.mark.parametrize("partition_s", [None, 2.0])
def test_a_run_of_exactly_one_window_or_partition_is_not_too_short(partition_s):
    """A run whose aligned clock holds exactly one window (and one partition) of samples
    gives that window and is not listed as too short; one sample less gives none and is."""
    def run(n_wheel):
        t = np.arange(n_wheel) / 50.0
        wheels = pd.DataFrame({TIME: t, "vel_l": 0.5, "vel_r": 0.6, "cur_l": 5.0,
                               "cur_r": 6.0})
        return Run("t/ICE/07", "t", "ICE", {"wheels": wheels}, source="test run")

    config = WindowConfig(window_s=2.0, rate_hz=50.0, partition_s=partition_s)
    exact = make_windows([run(100)], "wheels", config)
    assert len(exact) == 1 and exact.counts["too_short_runs"] == []
    assert exact.counts["window_tail_s"] == 0.0 and exact.counts["partition_tail_s"] == 0.0
    short = make_windows([run(99)], "wheels", config)
    assert len(short) == 0 and short.counts["too_short_runs"] == ["t/ICE/07"]


def test_a_window_of_4_samples_is_the_shortest_accepted():
    """At least 4 samples per window: 0.08 s at 50 Hz (4) is accepted, 0.06 s (3) refused."""
    assert WindowConfig(window_s=0.08, rate_hz=50.0).n_samples == 4
    with pytest.raises(ConfigError, match="at least 4 samples"):
        WindowConfig(window_s=0.06, rate_hz=50.0)


def test_a_run_without_wheels_the_signals_need_is_not_blamed_on_steady_only(make_run):
    """Only a run skipped because ``steady_only`` asks for wheels (IMU signals) gets the
    steady-only reason; a run lacking the wheel stream that its signals themselves need is
    reported as such."""
    imu_only = make_run({"imu": _streams()["imu"]}, "t/ICE/00", "ICE")
    for config in (WindowConfig(window_s=2.0), WindowConfig(window_s=2.0, steady_only=True)):
        ws = make_windows([imu_only], "all", config)
        assert ws.counts["skipped_runs"] == ["t/ICE/00"] and ws.counts["reasons"] == {}
        text = input_report([imu_only], ws.counts, 2.0).text()
        assert "skipped (no wheels stream): t/ICE/00" in text
        assert "steady_only" not in text


@pytest.mark.parametrize("vel_l, vel_r", [(0.0, 0.4), (0.4, 0.0)])
def test_steady_motion_is_judged_on_the_mean_of_both_wheel_speeds(vel_l, vel_r):
    """One side standing while the other drives at 0.4 m/s is steady motion at 0.2 m/s
    (``vel_mean``), whichever side stands."""
    n = 300
    frame = pd.DataFrame({TIME: np.arange(n) / 50.0, "vel_l": np.full(n, vel_l),
                          "vel_r": np.full(n, vel_r)})
    config = WindowConfig(window_s=2.0, rate_hz=50.0, steady_only=True, min_speed_m_s=0.15)
    X, *_, counts = window_frame(frame, ["vel_l"], config)
    assert len(X) == 3 and counts["dropped_unsteady"] == 0
    X, *_, counts = window_frame(frame, ["vel_l"],
                                 WindowConfig(**{**config.__dict__, "min_speed_m_s": 0.25}))
    assert len(X) == 0 and counts["dropped_unsteady"] == 3


@pytest.mark.parametrize("field", ["window_s", "hop_s", "rate_hz", "partition_s"])
@pytest.mark.parametrize("value", [True, "2", [2.0]])
def test_window_lengths_and_rate_that_are_not_numbers_are_refused(field, value):
    """A window length, hop, partition or rate must be a real number: ``True`` was taken as
    1 (``window_s=True`` cut 1 s windows of 50 samples without a word) and text or a list
    raised Python's bare TypeError ("'<' not supported between instances of 'int' and
    'str'"), naming no field."""
    with pytest.raises(ConfigError, match=f"WindowConfig.{field} must be a real number"):
        WindowConfig(**{field: value})
