"""Review io4 of terrain.io.align: non-finite values of a filtered stream, a stream of one
sample."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from terrain.errors import DataFormatError
from terrain.io.align import align_arrays, align_streams
from terrain.run import IMU_CHANNELS, TIME, WHEEL_CHANNELS


def _imu(t, **cols):
    frame = pd.DataFrame({TIME: t, **{c: np.zeros(len(t)) for c in IMU_CHANNELS}})
    for c, v in cols.items():
        frame[c] = v
    return frame


def _wheels(t):
    return pd.DataFrame({TIME: t, **{c: np.full(len(t), 0.5) for c in WHEEL_CHANNELS}})


def test_one_nan_sample_of_a_filtered_stream_stays_local(make_run):
    # the 100 Hz IMU is low-passed before resampling: one NaN sample went through the
    # zero-phase filter and made the whole gap-free segment NaN (all 247 grid rows of wx
    # here, every window of the run dropped); it must spoil only the grid points next to it,
    # as it does in a stream that is not filtered
    t = np.arange(0, 500) / 100.0
    wx = np.sin(2 * np.pi * 1.0 * t)
    clean = align_streams(make_run({"imu": _imu(t, wx=wx), "wheels": _wheels(t[::7])}))
    wx_nan = wx.copy()
    wx_nan[200] = np.nan                                    # t = 2.00 s
    frame = align_streams(make_run({"imu": _imu(t, wx=wx_nan), "wheels": _wheels(t[::7])}))
    tt = frame[TIME].to_numpy()
    bad = np.isnan(frame["wx"].to_numpy())
    assert bad.any() and (np.abs(tt[bad] - 2.0) < 0.011).all()
    assert np.isfinite(frame.drop(columns=["wx"]).to_numpy()).all()   # other channels intact
    # far from the NaN the values are the clean run's (the segments' ends settle)
    far = np.abs(tt - 2.0) > 0.5
    np.testing.assert_allclose(frame["wx"].to_numpy()[far], clean["wx"].to_numpy()[far],
                               atol=1e-3)


def test_a_finite_filtered_stream_is_unchanged_by_the_non_finite_split():
    # a finite segment is filtered whole, as before (the documented figures)
    from scipy import signal

    t = np.arange(0, 300) / 100.0
    v = np.random.default_rng(0).standard_normal((300, 2))
    grid = np.arange(0, 100) / 50.0 + 0.5
    got = align_arrays([t], [v], grid, 50.0)
    sos = signal.butter(4, 20.0, fs=100.0, output="sos")
    filt = signal.sosfiltfilt(sos, v, axis=0, padlen=15)
    expected = np.column_stack([np.interp(grid, t, filt[:, k]) for k in range(2)])
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12)


def test_a_stream_of_one_sample_is_named_not_called_disjoint(make_run):
    # one IMU sample inside the wheels' span: "do not overlap in time" was the message
    t_wh = np.arange(0, 20) / 10.0
    run = make_run({"imu": _imu(np.array([1.0])), "wheels": _wheels(t_wh)})
    with pytest.raises(DataFormatError, match="'imu' has 1 sample"):
        align_streams(run)


def test_grid_tail_before_an_infinite_time_is_the_whole_grid_and_nan_is_refused():
    # int(ceil(inf)) raised a bare OverflowError, int(ceil(nan)) a bare ValueError
    from terrain.errors import ConfigError
    from terrain.io.align import overlap_grid, overlap_grid_tail

    times = [np.arange(0, 101) / 100.0, np.arange(0, 11) / 10.0]
    grid = overlap_grid(times, 50.0)
    tail, end = overlap_grid_tail(times, 50.0, np.inf, 3)
    assert end == grid.size
    np.testing.assert_array_equal(tail, grid[-3:])
    tail, end = overlap_grid_tail(times, 50.0, -np.inf, 3)
    assert end == 0 and tail.size == 0
    with pytest.raises(ConfigError, match="overlap_grid_tail.before_s"):
        overlap_grid_tail(times, 50.0, float("nan"), 3)


def test_streams_given_as_one_name_is_refused_not_spelt_out(make_run):
    # streams="imu" was iterated letter by letter: "run has none of the streams
    # ['i', 'm', 'u']", and "wheels" the same, although the run has both
    from terrain.errors import ConfigError

    t = np.arange(0, 100) / 100.0
    run = make_run({"imu": _imu(t), "wheels": _wheels(t[::7])})
    with pytest.raises(ConfigError, match=r"align_streams.streams .*\('imu',\)"):
        align_streams(run, streams="imu")
