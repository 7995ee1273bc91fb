"""EKF-derived channels as a selectable signal set (``ekf``, ``all+ekf``)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import pandas as pd

from features.ekf_signals import (EKF_CHANNELS, add_ekf_channels, ekf_channel_frame,
                                  window_ekf_channels)
from features.transformers import WindowFeatures
from features.windows import (ALL_CHANNELS, SIGNAL_SETS, WindowConfig, make_windows,
                              required_streams, resolve_signals)
from terrain.estimation.skid_steer import SkidSteerSettings
from terrain.errors import ConfigError, DataFormatError, NonFiniteInputError, ShapeError
from pipelines.validation.harness import simulate_husky
from terrain.io.align import align_streams
from terrain.run import Run


@pytest.fixture(scope="module")
def husky_run():
    return replace(simulate_husky("ASPHALT", seed=4, duration_s=40.0, icr_expansion=1.5).run,
                   run_id="sim/ASPHALT/00")


def test_signal_sets_keep_the_raw_default_and_add_ekf():
    assert SIGNAL_SETS["all"] == ALL_CHANNELS and not set(EKF_CHANNELS) & set(ALL_CHANNELS)
    assert resolve_signals("all+ekf") == ALL_CHANNELS + EKF_CHANNELS
    assert resolve_signals(["all", "ekf"]) == ALL_CHANNELS + EKF_CHANNELS
    assert resolve_signals(["wz", "ekf_icr_chi"]) == ("wz", "ekf_icr_chi")
    assert required_streams(["ekf_icr_chi"]) == ("imu", "wheels")
    with pytest.raises(ConfigError, match="ekf_icr_chi"):
        resolve_signals(["ekf_nonsense"])


@pytest.mark.slow
def test_windows_with_ekf_channels(husky_run):
    config = WindowConfig(window_s=2.0, rate_hz=50.0)
    ws = make_windows([husky_run], "all+ekf", config)
    raw = make_windows([husky_run], "all", config)
    assert ws.channels == ALL_CHANNELS + EKF_CHANNELS
    assert len(ws) == len(raw) and np.isfinite(ws.X).all()
    np.testing.assert_array_equal(ws.X[:, :len(ALL_CHANNELS)], raw.X)   # raw part unchanged
    chi = ws.X[:, ws.channels.index("ekf_icr_chi")].mean(axis=1)
    assert 1.4 < np.median(chi[len(chi) // 2:]) < 2.0          # planted 1.5 x scrub ~1.1
    bias = ws.X[:, ws.channels.index("ekf_gyro_bias")]
    assert np.abs(bias[-1]).max() < 0.01                        # no gyro bias planted
    fx = WindowFeatures(channels=ws.channels, rate_hz=ws.rate_hz).fit(ws.X)
    names = list(fx.get_feature_names_out())
    assert "ekf_icr_chi__mean" in names and "ekf_nis__std" in names
    assert not any(n.startswith("ekf_") and "band" in n for n in names)
    assert np.isfinite(fx.transform(ws.X)).all()


@pytest.mark.slow
def test_runs_without_imu_are_skipped_and_gaps_stay_nan(husky_run):
    no_imu = Run("sim/ASPHALT/01", "sim", "ASPHALT", {"wheels": husky_run.streams["wheels"]})
    ws = make_windows([husky_run, no_imu], "ekf", WindowConfig(window_s=2.0, rate_hz=50.0))
    assert ws.counts["skipped_runs"] == ["sim/ASPHALT/01"]
    frame = align_streams(husky_run, ("imu", "wheels"), 50.0)
    frame.loc[500:520, ["vel_l", "vel_r", "wz"]] = np.nan           # a gap
    ekf = ekf_channel_frame(frame, wheel_rate_hz=husky_run.rate_hz("wheels"))
    assert ekf.loc[500:520].isna().all().all()
    assert np.isfinite(ekf.loc[530:].to_numpy()).all()                # the filter recovers
    assert add_ekf_channels(frame.drop(columns=["wz"])).shape[1] == frame.shape[1] - 1


def test_window_channels_equal_the_frame_path_on_each_window(husky_run):
    # the lean batch path is the frame path on a frame holding only that window
    ws = make_windows([husky_run], "all", WindowConfig(window_s=2.0, hop_s=1.5, rate_hz=50.0))
    X = ws.X[::4]
    wheel_hz = husky_run.rate_hz("wheels")
    out = window_ekf_channels(X, ws.channels, ws.rate_hz, wheel_rate_hz=wheel_hz)
    assert out.shape == (len(X), len(EKF_CHANNELS), X.shape[2])
    t = np.arange(X.shape[2]) / ws.rate_hz
    idx = {c: ws.channels.index(c) for c in ("vel_l", "vel_r", "wz")}
    for i, x in enumerate(X):
        frame = pd.DataFrame({"t_s": t, **{c: x[j] for c, j in idx.items()}})
        ref = ekf_channel_frame(frame, wheel_rate_hz=wheel_hz).to_numpy().T
        np.testing.assert_allclose(out[i], ref, rtol=1e-9, atol=1e-12)
    # each window from the prior: a window's channels do not depend on the others
    np.testing.assert_array_equal(
        window_ekf_channels(X[3:4], ws.channels, ws.rate_hz, wheel_rate_hz=wheel_hz), out[3:4])
    assert np.isfinite(out).all()


@pytest.mark.slow
def test_window_channels_find_a_planted_icr_expansion_within_a_turning_window():
    run = replace(simulate_husky("ASPHALT", seed=4, duration_s=40.0, icr_expansion=3.0).run,
                  run_id="sim/ASPHALT/03")
    ws = make_windows([run], "all", WindowConfig(window_s=2.0, rate_hz=50.0))
    out = window_ekf_channels(ws.X, ws.channels, ws.rate_hz, wheel_rate_hz=run.rate_hz("wheels"))
    chi_end = out[:, EKF_CHANNELS.index("ekf_icr_chi"), -1]
    mean_yaw_rate = np.abs(ws.X[:, ws.channels.index("wz")]).mean(axis=1)
    turning, straight = mean_yaw_rate > 0.1, mean_yaw_rate < 0.03
    assert turning.sum() >= 4 and straight.sum() >= 4
    # 2 s of turning suffice: chi ends within 5 % of the planted 3 (from the prior 1.5) ...
    np.testing.assert_allclose(chi_end[turning], 3.0, rtol=0.05)
    # ... while straight windows carry no information on it and keep the prior
    np.testing.assert_allclose(chi_end[straight], SkidSteerSettings().chi0, rtol=0.01)


def test_window_channels_reject_missing_channels_and_gaps(husky_run):
    ws = make_windows([husky_run], "all", WindowConfig(window_s=2.0, rate_hz=50.0))
    keep = [i for i, c in enumerate(ws.channels) if c != "wz"]
    with pytest.raises(DataFormatError, match="wz"):
        window_ekf_channels(ws.X[:, keep], [ws.channels[i] for i in keep], ws.rate_hz)
    X = ws.X[:3].copy()
    X[1, ws.channels.index("vel_l"), 7] = np.nan
    with pytest.raises(NonFiniteInputError, match="window 1"):
        window_ekf_channels(X, ws.channels, ws.rate_hz)
    with pytest.raises(ShapeError, match="n_windows"):
        window_ekf_channels(ws.X[0], ws.channels, ws.rate_hz)
    with pytest.raises(ConfigError, match="rate_hz"):
        window_ekf_channels(ws.X[:2], ws.channels, 0.0)
    # channels are read by position: a second wz was ignored without a word
    i = ws.channels.index("wz")
    X2 = np.concatenate([ws.X[:2], ws.X[:2, i:i + 1]], axis=1)
    with pytest.raises(DataFormatError, match=r"\['wz'\] named twice"):
        window_ekf_channels(X2, list(ws.channels) + ["wz"], ws.rate_hz)


def test_a_run_of_one_aligned_sample_is_too_short_not_a_key_error():
    # IMU and wheel streams that overlap by 0.01 s align to one 50 Hz row: the run is shorter
    # than a window, as it is for the raw signal sets, not a KeyError on the EKF columns
    imu = pd.DataFrame({"t_s": [0.0, 0.01], "wx": 0.0, "wy": 0.0, "wz": 0.0, "ax": 0.0,
                        "ay": 0.0, "az": 9.81})
    wheels = pd.DataFrame({"t_s": [0.0, 0.1], "vel_l": 0.5, "vel_r": 0.6, "cur_l": 5.0,
                           "cur_r": 6.0})
    run = Run("t/ICE/00", "t", "ICE", {"imu": imu, "wheels": wheels})
    ws = make_windows([run], "all+ekf", WindowConfig(window_s=2.0, rate_hz=50.0))
    assert len(ws) == 0 and ws.channels == ALL_CHANNELS + EKF_CHANNELS
    assert ws.counts["too_short_runs"] == ["t/ICE/00"]
    assert ws.counts["per_run"]["t/ICE/00"]["aligned_s"] == pytest.approx(0.02)


def test_a_left_wheel_spinning_faster_on_a_straight_run_shows_on_the_left_side():
    # the gyro says straight (wz = 0) while the left wheel reads 0.2 m/s above the right:
    # the left side slips forward (rim faster than its ground), the right backward, and the
    # wheel innovations of the first steps (before the filter's bias absorbs the mismatch)
    # take the same signs (measured minus predicted)
    n = 200
    t = np.arange(n) / 50.0
    frame = pd.DataFrame({"t_s": t, "vel_l": np.full(n, 0.6), "vel_r": np.full(n, 0.4),
                          "wz": np.zeros(n)})
    settings = SkidSteerSettings(track_m=0.9)
    ch = ekf_channel_frame(frame, settings=settings)
    late, early = ch.iloc[n // 2:], ch.iloc[1:6]
    assert (late["ekf_slip_l"] > 0.05).all() and (late["ekf_slip_r"] < -0.05).all()
    assert (early["ekf_innov_vel_l"] > 0.05).all() and (early["ekf_innov_vel_r"] < -0.05).all()
    # the frame path and the window path use the settings' track width alike
    X = frame[["vel_l", "vel_r", "wz"]].to_numpy().T[None]
    out = window_ekf_channels(X, ("vel_l", "vel_r", "wz"), 50.0, settings=settings)
    np.testing.assert_allclose(out[0], ekf_channel_frame(frame, settings=settings).to_numpy().T,
                               rtol=1e-9, atol=1e-12)


def test_run_windows_take_the_ekf_channels_of_the_whole_run_at_its_wheel_rate(husky_run):
    """The EKF channels of ``make_windows`` are those of the filter run over the whole aligned
    run with the run's native wheel rate (the wheel variance inflated by grid rate / native
    rate); without that rate the filter trusts the interpolated wheel samples as independent
    50 Hz readings and its channels differ."""
    config = WindowConfig(window_s=2.0, rate_hz=50.0)
    ws = make_windows([husky_run], "ekf", config)
    frame = align_streams(husky_run, ("imu", "wheels"), 50.0)
    want = ekf_channel_frame(frame, wheel_rate_hz=husky_run.rate_hz("wheels")).to_numpy()
    n = config.n_samples
    first = np.round(ws.t_start_s * 50.0).astype(int) - int(round(frame["t_s"].iloc[0] * 50.0))
    assert len(ws) > 10
    for k in range(0, len(ws), 5):
        np.testing.assert_allclose(ws.X[k], want[first[k]:first[k] + n].T, rtol=1e-12)
    plain = ekf_channel_frame(frame).to_numpy()
    assert not np.allclose(plain[first[5]:first[5] + n].T, ws.X[5], rtol=1e-3)


def test_an_imu_gap_alone_makes_every_ekf_channel_nan(husky_run):
    """A grid row without the gyro (IMU gap, wheel speeds present) is a gap of the EKF
    channels too, as a row without the wheels is: the channels there would come from a
    filter that saw only half its measurements."""
    frame = align_streams(husky_run, ("imu", "wheels"), 50.0)
    frame.loc[500:520, "wz"] = np.nan                               # the IMU alone
    frame.loc[700:720, ["vel_l", "vel_r"]] = np.nan                 # the wheels alone
    ekf = ekf_channel_frame(frame, wheel_rate_hz=husky_run.rate_hz("wheels"))
    assert ekf.loc[500:520].isna().all().all() and ekf.loc[700:720].isna().all().all()
    assert np.isfinite(ekf.loc[530:690].to_numpy()).all()


def test_each_innovation_channel_is_the_filters_innovation_of_that_name(husky_run):
    # the ekf_innov_* channels are named by the filter's own measurement names, not by
    # position: each equals the innovation column the filter labels with that name
    from terrain.estimation.skid_steer import skid_steer_on_frame

    frame = align_streams(husky_run, ("imu", "wheels"), 50.0)
    wheel_hz = husky_run.rate_hz("wheels")
    res = skid_steer_on_frame(frame, SkidSteerSettings(), wheel_rate_hz=wheel_hz)
    out = ekf_channel_frame(frame, wheel_rate_hz=wheel_hz)
    assert {f"ekf_innov_{name}" for name in res.measurement_names} <= set(EKF_CHANNELS)
    for i, name in enumerate(res.measurement_names):
        expected = np.where(res.accepted[:, i], res.y[:, i], np.nan)
        np.testing.assert_array_equal(out[f"ekf_innov_{name}"].to_numpy(), expected)
