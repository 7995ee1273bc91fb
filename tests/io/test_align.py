"""Alignment onto one clock: grid, overlap, anti-alias filtering, provenance in attrs."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from terrain.errors import ConfigError, DataFormatError
from terrain.io.align import (align_arrays, align_streams, interpolated_mean_count, median_step,
                              overlap_grid, overlap_grid_tail)
from terrain.run import IMU_CHANNELS, TIME, WHEEL_CHANNELS


def _imu(t, wz=None):
    n = len(t)
    wz = np.zeros(n) if wz is None else wz
    return pd.DataFrame({TIME: t, "wx": np.zeros(n), "wy": np.zeros(n), "wz": wz,
                         "ax": np.zeros(n), "ay": np.zeros(n), "az": np.full(n, 9.81)})


def _wheels(t, vel_l=None):
    n = len(t)
    vel_l = np.full(n, 0.5) if vel_l is None else vel_l
    return pd.DataFrame({TIME: t, "vel_l": vel_l, "vel_r": np.full(n, 0.6),
                         "cur_l": np.full(n, 5.0), "cur_r": np.full(n, 6.0)})


def _rms(x):
    return float(np.sqrt(np.mean(np.square(x))))


def test_uniform_grid_over_the_overlap_only(make_run):
    t_imu = np.arange(0, 1001) / 100.0            # 0 .. 10 s at 100 Hz
    t_wh = 0.3 + np.arange(0, 60) / 6.5           # 0.3 .. ~9.38 s at 6.5 Hz
    run = make_run({"imu": _imu(t_imu), "wheels": _wheels(t_wh)})
    frame = align_streams(run, rate_hz=50.0)
    t = frame[TIME].to_numpy()
    np.testing.assert_allclose(np.diff(t), 1 / 50.0, rtol=0, atol=1e-12)
    assert t[0] == pytest.approx(0.3)                       # latest start
    assert t_wh[-1] - 1 / 50.0 < t[-1] <= t_wh[-1] + 1e-9  # earliest end, no extrapolation
    assert list(frame.columns) == [TIME, *IMU_CHANNELS, *WHEEL_CHANNELS]
    assert np.isfinite(frame.to_numpy()).all()


@pytest.mark.parametrize("rate_hz", [20.0, 50.0, 100.0])
def test_grid_rate_is_the_requested_rate(make_run, rate_hz):
    run = make_run({"imu": _imu(np.arange(0, 501) / 100.0),
                    "wheels": _wheels(np.arange(0, 51) / 10.0)})
    frame = align_streams(run, rate_hz=rate_hz)
    assert len(frame) == int(5.0 * rate_hz) + 1
    assert 1.0 / np.median(np.diff(frame[TIME])) == pytest.approx(rate_hz)


def test_slow_stream_is_linearly_interpolated(make_run):
    t_wh = np.arange(0, 66) / 6.5
    run = make_run({"imu": _imu(np.arange(0, 1001) / 100.0),
                    "wheels": _wheels(t_wh, vel_l=0.1 + 0.05 * t_wh)})
    frame = align_streams(run, rate_hz=50.0)
    np.testing.assert_allclose(frame["vel_l"], 0.1 + 0.05 * frame[TIME], atol=1e-12)


def test_sine_below_cutoff_survives_100_to_50_hz(make_run):
    t = np.arange(0, 2001) / 100.0
    run = make_run({"imu": _imu(t, wz=np.sin(2 * np.pi * 3.0 * t))})
    frame = align_streams(run, ("imu",), rate_hz=50.0)
    tg = frame[TIME].to_numpy()
    np.testing.assert_allclose(np.diff(tg), 0.02, atol=1e-12)
    err = frame["wz"].to_numpy() - np.sin(2 * np.pi * 3.0 * tg)
    assert np.max(np.abs(err)) < 1e-3  # gain of the 20 Hz Butterworth at 3 Hz is ~1


def test_tone_above_new_nyquist_is_attenuated_not_aliased(make_run):
    t = np.arange(0, 2001) / 100.0
    tone = np.sin(2 * np.pi * 40.0 * t)
    run = make_run({"imu": _imu(t, wz=tone)})
    frame = align_streams(run, ("imu",), rate_hz=50.0)
    wz = frame["wz"].to_numpy()
    # plain decimation would fold the 40 Hz tone onto 10 Hz at full amplitude
    assert _rms(tone[::2]) > 0.6
    assert _rms(wz) < 0.01 * _rms(tone)


def test_attrs_record_method_rate_and_streams(make_run):
    run = make_run({"imu": _imu(np.arange(0, 501) / 100.0),
                    "wheels": _wheels(np.arange(0, 51) / 10.0)})
    frame = align_streams(run, rate_hz=25.0)
    assert frame.attrs["rate_hz"] == 25.0
    assert frame.attrs["streams"] == ("imu", "wheels")
    method = frame.attrs["method"]
    assert "Butterworth" in method and "linear interpolation" in method and "gap" in method


def test_missing_stream_is_skipped_and_recorded(make_run):
    run = make_run({"wheels": _wheels(np.arange(0, 51) / 10.0)})
    frame = align_streams(run, ("imu", "wheels"), rate_hz=50.0)
    assert frame.attrs["streams"] == ("wheels",)
    assert list(frame.columns) == [TIME, *WHEEL_CHANNELS]


def test_bad_requests_raise_typed_errors(make_run):
    run = make_run({"imu": _imu(np.arange(0, 101) / 100.0),
                    "wheels": _wheels(2.0 + np.arange(0, 11) / 10.0)})
    with pytest.raises(ConfigError):
        align_streams(run, rate_hz=0.0)
    with pytest.raises(DataFormatError, match="overlap"):
        align_streams(run)                        # imu 0-1 s, wheels 2-3 s
    with pytest.raises(DataFormatError, match="none of the streams"):
        align_streams(run, ("truth",))


def test_gap_in_slow_stream_gives_nan(make_run):
    t_wh = np.r_[np.arange(0, 31) / 10.0, 5.0 + np.arange(0, 51) / 10.0]  # no sample in (3, 5)
    run = make_run({"imu": _imu(np.arange(0, 1001) / 100.0), "wheels": _wheels(t_wh)})
    frame = align_streams(run, rate_hz=50.0)
    t = frame[TIME].to_numpy()
    inside = (t > 3.0) & (t < 5.0)
    assert np.isnan(frame.loc[inside, list(WHEEL_CHANNELS)].to_numpy()).all()
    assert np.isfinite(frame.loc[~inside].to_numpy()).all()
    assert np.isfinite(frame.loc[inside, list(IMU_CHANNELS)].to_numpy()).all()


def test_streams_sharing_a_channel_name_are_rejected(make_run):
    t = np.arange(0, 501) / 100.0
    run = make_run({"imu": _imu(t), "other": _imu(t)})
    with pytest.raises(ConfigError, match="share channel"):
        align_streams(run, ("imu", "other"), rate_hz=50.0)


def test_anti_alias_filter_does_not_smear_across_a_gap(make_run):
    # IMU at 100 Hz: wz = 0 before a 2 s gap and 1 rad/s after it
    t = np.r_[np.arange(0, 501) / 100.0, 7.0 + np.arange(0, 501) / 100.0]
    run = make_run({"imu": _imu(t, wz=(t > 6).astype(float)),
                    "wheels": _wheels(np.arange(0, 121) / 10.0)})
    frame = align_streams(run, rate_hz=50.0)
    tt, wz = frame[TIME].to_numpy(), frame["wz"].to_numpy()
    assert np.isnan(wz[(tt > 5.0) & (tt < 7.0)]).all()
    # right up to the gap edges the step has not leaked through the zero-phase filter
    np.testing.assert_allclose(wz[tt <= 5.0], 0.0, atol=1e-9)
    np.testing.assert_allclose(wz[tt >= 7.0], 1.0, atol=1e-9)


@pytest.mark.parametrize("n_segment", [5, 8, 16, 22])
@pytest.mark.parametrize("phase", [0.0, 0.3, 1.2])
def test_short_segment_between_gaps_is_anti_alias_filtered_too(n_segment, phase):
    # a 30 Hz tone of a 100 Hz stream folds onto 20 Hz of a 50 Hz grid at full amplitude
    # unless filtered; a segment between two gaps shorter than the filter's padding is
    # filtered with a shorter one (it was left unfiltered below 28 samples). The zero-phase
    # filter's odd extension keeps a segment's end samples, short or long; inside, the tone
    # is cut
    t = np.r_[np.arange(0, 300), 400 + np.arange(n_segment), 522 + np.arange(300)] / 100.0
    v = np.sin(2 * np.pi * 30.0 * t + phase)[:, None]
    grid = np.arange(0, 8.2, 0.02)
    out = align_arrays([t], [v], grid, 50.0)[:, 0]
    inside = (grid > 4.0) & (grid < 4.0 + (n_segment - 1) / 100.0 - 1e-9)
    long = (grid >= 1.0) & (grid <= 2.0)
    assert np.abs(out[long]).max() < 0.01
    raw = np.sin(2 * np.pi * 30.0 * grid[inside] + phase)
    assert _rms(out[inside]) < 0.5 * _rms(raw)


@pytest.mark.parametrize("n_segment", [2, 5])
def test_short_segment_is_filtered_with_all_its_samples_but_one_as_padding(n_segment):
    """A gap-free segment of fewer than 16 samples is filtered by ``sosfiltfilt`` with a
    padding of all its samples but one (a two-sample segment included); on its own sample
    times the aligned values are that filter's output."""
    from scipy import signal

    t = np.r_[np.arange(0, 300), 400 + np.arange(n_segment), 522 + np.arange(300)] / 100.0
    v = np.sin(2 * np.pi * 30.0 * t + 0.3)[:, None]
    seg = slice(300, 300 + n_segment)
    out = align_arrays([t], [v], t[seg], 50.0)[:, 0]
    sos = signal.butter(4, 20.0, fs=100.0, output="sos")
    want = signal.sosfiltfilt(sos, v[seg, 0], padlen=n_segment - 1)
    np.testing.assert_allclose(out, want, rtol=0, atol=1e-12)
    assert np.abs(out - v[seg, 0]).max() > 0.05      # filtered, not passed through


@pytest.mark.parametrize("native_hz, filtered", [(60.0, False), (74.0, False), (76.0, True),
                                                 (100.0, True)])
def test_only_a_stream_over_1_5_times_the_grid_rate_is_anti_alias_filtered(native_hz,
                                                                           filtered):
    """Between 1 and 1.5 times the grid rate a stream is interpolated as it is (a clock's
    jitter about the grid rate must not switch the filter on); above, it is filtered."""
    t = np.arange(0, 400) / native_hz
    v = np.sin(2 * np.pi * 7.0 * t)[:, None] + 0.3 * np.sin(2 * np.pi * 29.0 * t)[:, None]
    grid = overlap_grid([t], 50.0)
    out = align_arrays([t], [v], grid, 50.0)[:, 0]
    plain = np.interp(grid, t, v[:, 0])
    if filtered:
        assert np.abs(out - plain).max() > 0.1
    else:
        np.testing.assert_array_equal(out, plain)


def test_a_step_of_exactly_gap_factor_median_steps_is_no_gap():
    """The gap rule is strict, as the reader's (:mod:`terrain.io.measured`): at 0.125 s
    steps (exact in binary) a 0.375 s step is interpolated across, a 0.5 s step is a gap."""
    for big, is_gap in ((0.375, False), (0.5, True)):
        t = np.r_[np.arange(8) * 0.125, 0.875 + big + np.arange(8) * 0.125]
        v = np.arange(t.size, dtype=float)[:, None]
        grid = np.array([0.875 + big / 2])
        out = align_arrays([t], [v], grid, 8.0)[0, 0]
        assert np.isnan(out) == is_gap
        if not is_gap:
            assert out == 7.5


def test_one_sample_segment_keeps_its_value():
    t = np.r_[np.arange(0, 300), 400, 500 + np.arange(300)] / 100.0
    v = np.sin(2 * np.pi * 1.0 * t)[:, None]
    out = align_arrays([t], [v], np.array([4.0]), 50.0)
    np.testing.assert_allclose(out[0, 0], v[300, 0])


def test_numpy_core_on_part_of_the_grid_gives_the_values_of_the_whole(make_run):
    # the streaming service aligns only its window's grid points: with a filtered 100 Hz
    # IMU, a gap in the wheels and a sine, each grid point must equal the batch frame's
    rng = np.random.default_rng(3)
    t_imu = np.arange(0, 1001) / 100.0
    t_wh = np.r_[np.arange(0, 31) / 6.5, 6.0 + np.arange(0, 26) / 6.5]
    run = make_run({"imu": _imu(t_imu, wz=np.sin(2 * np.pi * 3 * t_imu)
                                + 0.1 * rng.standard_normal(t_imu.size)),
                    "wheels": _wheels(t_wh, vel_l=np.cos(t_wh))})
    whole = align_streams(run, rate_hz=50.0)
    times = [run.streams[s][TIME].to_numpy() for s in ("imu", "wheels")]
    values = [run.streams[s].drop(columns=TIME).to_numpy() for s in ("imu", "wheels")]
    grid = overlap_grid(times, 50.0)
    np.testing.assert_array_equal(grid, whole[TIME].to_numpy())
    part = slice(120, 260)  # crosses the wheel gap (4.6-6 s)
    got = align_arrays(times, values, grid[part], 50.0)
    expected = whole.drop(columns=TIME).to_numpy()[part]
    np.testing.assert_array_equal(np.isnan(got), np.isnan(expected))
    assert np.isnan(got).any() and np.isfinite(got[:, :6]).all()
    np.testing.assert_array_equal(got[np.isfinite(got)], expected[np.isfinite(expected)])


def test_overlap_grid_is_empty_without_overlap_and_median_step_is_the_median():
    assert overlap_grid([np.arange(5.0), 10 + np.arange(5.0)], 10.0).size == 0
    # a span of 1.1 s at 50 Hz is 54.99999999999999 steps in floats: the grid still reaches
    # the last common sample (56 points), not one step short of it
    grid = overlap_grid([np.arange(1, 13) / 10.0, np.arange(0, 25) / 10.0], 50.0)
    assert grid.size == 56 and grid[-1] == pytest.approx(1.2, abs=1e-12)
    with pytest.raises(ConfigError):
        overlap_grid([np.arange(5.0)], 0.0)
    for n in (2, 3, 10, 11):
        t = np.cumsum(np.random.default_rng(n).uniform(0.01, 0.2, n))
        assert median_step(t) == pytest.approx(float(np.median(np.diff(t))), abs=0, rel=1e-15)


@pytest.mark.parametrize("native_hz,n_samples,rate_hz", [(1.0 / 0.1538, 100, 50.0),
                                                         (15.0, 100, 50.0), (6.5, 200, 100.0)])
def test_interpolated_mean_count_matches_monte_carlo(native_hz, n_samples, rate_hz):
    """The noise of the mean of a linearly interpolated window (align_arrays) of white
    samples has the variance sigma^2 / count."""
    rng = np.random.default_rng(3)
    grid = np.arange(n_samples) / rate_hz
    means = []
    for _ in range(4000):
        t = (np.arange(-3, int(n_samples / rate_hz * native_hz) + 4) + rng.uniform()) / native_hz
        e = rng.standard_normal((t.size, 1))
        means.append(align_arrays([t], [e], grid, rate_hz)[:, 0].mean())
    count = interpolated_mean_count(n_samples, rate_hz, native_hz)
    assert np.var(means) * count == pytest.approx(1.0, abs=0.06)
    # the interpolated window mean averages a little more than `duration x native rate`
    assert n_samples / rate_hz * native_hz < count < n_samples / rate_hz * native_hz + 1.0


def test_interpolated_mean_count_limits():
    # a stream at least as fast as the clock: one independent value per clock sample
    assert interpolated_mean_count(100, 50.0, 100.0) == 100.0
    assert interpolated_mean_count(100, 50.0, 50.0) == 100.0       # as fast: the same
    assert interpolated_mean_count(1, 50.0, 6.5) >= 1.0
    with pytest.raises(ConfigError):
        interpolated_mean_count(0, 50.0, 6.5)


@given(st.floats(0.0, 5.0), st.floats(0.5, 60.0), st.sampled_from([6.5, 10.0, 50.0, 100.0]),
       st.floats(-2.0, 70.0), st.integers(1, 300))
@settings(max_examples=200, deadline=None)
def test_overlap_grid_tail_is_the_whole_grids_tail(t0, span, rate_hz, before_s, n_last):
    times = [t0 + np.linspace(0.0, span, 7), np.array([t0 - 1.0, t0 + span / 2, t0 + span])]
    grid = overlap_grid(times, rate_hz)
    tail, end = overlap_grid_tail(times, rate_hz, before_s, n_last)
    want_end = int(np.searchsorted(grid, before_s, side="left"))
    assert end == want_end
    np.testing.assert_array_equal(tail, grid[max(want_end - n_last, 0):want_end])
    assert overlap_grid_tail([np.arange(5.0), 10 + np.arange(5.0)], 10.0, 20.0, 3)[1] == 0


@pytest.mark.parametrize("t0, rate_hz", [(0.0, 50.0), (0.1, 50.0), (0.37, 6.5), (1.3, 100.0)])
def test_overlap_grid_tail_before_a_grid_point_excludes_it(t0, rate_hz):
    """``before_s`` equal to grid point ``k`` (as the grid's own float arithmetic gives it)
    counts the ``k`` points before it, never the point itself."""
    times = [t0 + np.linspace(0.0, 3.0, 7)]
    grid = overlap_grid(times, rate_hz)
    for k in range(grid.size):
        tail, end = overlap_grid_tail(times, rate_hz, float(grid[k]), 2)
        assert end == k
        np.testing.assert_array_equal(tail, grid[max(k - 2, 0):k])


def _numpy_align_oracle(t, v, grid, gap_s):
    """The NumPy resampling ``align_arrays`` had before its compiled loop: ``numpy.interp``
    per column, NaN at grid points strictly inside a gap step."""
    out = np.column_stack([np.interp(grid, t, v[:, j]) for j in range(v.shape[1])])
    i = np.searchsorted(t, grid, side="right") - 1
    inside = (i >= 0) & (i < len(t) - 1)
    inside[inside] &= (np.diff(t) > gap_s)[i[inside]] & (grid[inside] > t[i[inside]])
    out[inside] = np.nan
    return out


@given(st.integers(2, 40), st.integers(1, 120), st.integers(0, 2**32 - 1),
       st.sampled_from(["inside", "around", "on_samples", "shuffled"]))
@settings(max_examples=300, deadline=None)
def test_compiled_resampling_is_bit_identical_to_numpy_interp(m, n, seed, where):
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.choice([0.01, 0.15, 0.1538, 0.6], m)) + rng.uniform(-1, 1)
    v = rng.standard_normal((m, 3)) * rng.choice([1e-3, 1.0, 1e6], 3)
    v[rng.uniform(size=v.shape) < 0.05] = np.nan             # a NaN sample stays NaN-local
    v[:, 2] = np.where(rng.uniform(size=m) < 0.5, 7.0, v[:, 2])   # flat runs
    if where == "on_samples":
        grid = np.sort(rng.choice(t, n))
    else:
        span = (t[0], t[-1]) if where == "inside" else (t[0] - 1.0, t[-1] + 1.0)
        grid = np.sort(rng.uniform(*span, n))
        if where == "shuffled":
            rng.shuffle(grid)
    grid = np.r_[grid, t[-1]] if n % 2 else grid              # the last sample's own time
    step = float(np.median(np.diff(t)))
    got = align_arrays([t], [v], grid, rate_hz=1000.0, gap_factor=3.0, steps_s=[step])
    expected = _numpy_align_oracle(t, v, grid, 3.0 * step)
    np.testing.assert_array_equal(np.isnan(got), np.isnan(expected))
    assert np.array_equal(got, expected, equal_nan=True)


def test_an_integer_channel_is_aligned_not_left_out(make_run):
    # align_streams took only float64 columns: an int64 column (a shipped Parquet file may
    # hold one, _check_table accepts it) vanished from the aligned frame, and windowing any
    # signal set that needs it failed with a bare KeyError
    t = np.arange(0, 101) / 10.0
    wheels = _wheels(t)
    wheels["cur_l"] = wheels["cur_l"].astype(np.int64)
    frame = align_streams(make_run({"wheels": wheels}), ("wheels",), rate_hz=50.0)
    assert list(frame.columns) == [TIME, *WHEEL_CHANNELS]
    assert frame["cur_l"].dtype == np.float64
    np.testing.assert_array_equal(frame["cur_l"].to_numpy(), 5.0)


@pytest.mark.parametrize("gap_factor", [float("nan"), 1.0, 0.5, -3.0, float("inf"), "3", True])
def test_a_gap_factor_that_is_no_gap_rule_is_refused(make_run, gap_factor):
    # NaN (or inf) made no step a gap: a 2 s hole of the wheel stream was interpolated
    # across; 1.0 made every step a little over the median one a gap (277 of 470 grid
    # points NaN on a jittery stream instead of the 99 of the hole)
    run = make_run({"imu": _imu(np.arange(0, 1001) / 100.0),
                    "wheels": _wheels(np.r_[np.arange(0, 31) / 10.0,
                                            5.0 + np.arange(0, 51) / 10.0])})
    with pytest.raises(ConfigError, match=r"align_streams\.gap_factor .*"
                                          + repr(gap_factor).replace("'", ".")):
        align_streams(run, rate_hz=50.0, gap_factor=gap_factor)


@pytest.mark.parametrize("rate_hz", [float("inf"), float("nan"), -50.0, "50"])
def test_a_rate_that_is_not_a_finite_positive_number_is_a_config_error(make_run, rate_hz):
    # rate_hz=inf raised a bare OverflowError (cannot convert float infinity to integer)
    run = make_run({"wheels": _wheels(np.arange(0, 51) / 10.0)})
    with pytest.raises(ConfigError, match=r"align_streams\.rate_hz .*"
                                          + repr(rate_hz).replace("'", ".")):
        align_streams(run, ("wheels",), rate_hz=rate_hz)
    with pytest.raises(ConfigError, match="rate_hz"):
        overlap_grid([np.arange(0, 51) / 10.0], rate_hz)


def test_text_columns_left_out_are_recorded_in_attrs(make_run):
    # a simulated run's per-sample 'terrain' label (text) was left out of the aligned frame
    # without a trace: attrs held only rate_hz, streams and method
    t = np.arange(0, 101) / 10.0
    truth = pd.DataFrame({TIME: t, "x_m": t, "terrain": np.where(t < 5, "GRASS", "SNOW"),
                          "note": "ok"})
    run = make_run({"wheels": _wheels(t), "truth": truth})
    frame = align_streams(run, ("wheels", "truth"), rate_hz=50.0)
    assert list(frame.columns) == [TIME, *WHEEL_CHANNELS, "x_m"]
    assert frame.attrs["dropped_columns"] == ("truth.terrain", "truth.note")
    assert frame.attrs["n_dropped_columns"] == 2
    plain = align_streams(run, ("wheels",), rate_hz=50.0)
    assert plain.attrs["dropped_columns"] == () and plain.attrs["n_dropped_columns"] == 0


@pytest.mark.slow
def test_a_clock_that_jumps_is_named_not_a_memory_error(make_run):
    """A last wheel timestamp of 1.7e9 s (the Unix epoch) after 10 s of data: the overlap
    asked for an 8.5e10-point grid (633 GiB, a bare MemoryError through every wheel-only
    command). It is refused before any grid is built, naming the step and its row; a span
    just under the bound still aligns."""
    from terrain.io.align import MAX_GRID_POINTS

    t = np.arange(66) / 6.5
    jumped = np.append(t, 1.7e9)
    run = make_run({"wheels": _wheels(jumped)})
    with pytest.raises(DataFormatError, match=r"stream 'wheels' steps from 10\.0 to "
                                              r"1700000000\.0 s at row 66") as info:
        align_streams(run, ("wheels",), rate_hz=50.0)
    assert info.value.column == TIME and info.value.row == 66
    # the bound is on the grid's points: at 1 Hz the same 1.7e9 s span is still refused,
    # a span of MAX_GRID_POINTS - 1 steps at 1e-3 Hz is not (7 points aligned)
    slow = np.array([0.0, (MAX_GRID_POINTS - 1) * 1e3 / 2, (MAX_GRID_POINTS - 1) * 1e3])
    with pytest.raises(DataFormatError, match="more than the"):
        align_streams(make_run({"wheels": _wheels(jumped)}), ("wheels",), rate_hz=1.0)
    assert len(align_streams(make_run({"wheels": _wheels(slow)}), ("wheels",),
                             rate_hz=1e-3)) == MAX_GRID_POINTS
