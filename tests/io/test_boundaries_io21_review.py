"""Boundaries of the readers, the alignment and the plausibility rules (review io21): a value
exactly at a limit, the grid's last point, counts at their bounds."""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from terrain.io.align import overlap_grid, overlap_grid_tail


@settings(max_examples=200, deadline=None)
@given(t0=st.sampled_from([0.0, 0.1, 12345.678, 1.0e6, 1.7e9, 1.7e9 + 0.37]),
       rate_hz=st.sampled_from([6.5, 10.0, 15.0, 33.3, 50.0, 100.0]),
       k=st.integers(1, 100_000))
def test_a_stream_ending_on_a_grid_point_keeps_that_point_on_an_epoch_clock(t0, rate_hz, k):
    """The grid runs from the latest first sample to the earliest last one: a stream that
    ends exactly on the grid's point ``t0 + k / rate_hz`` (the grid's own arithmetic) has
    it as the grid's last point. On an epoch clock (1.7e9 s) the point was dropped for
    about half of all ``k``: ``(t1 - t0) * rate_hz`` rounded just below ``k``."""
    t1 = t0 + k / rate_hz
    times = [np.array([t0, t1]), np.array([t0 - 1.0, t0 + 0.5 / rate_hz, t1 + 3.0])]
    grid = overlap_grid(times, rate_hz)
    assert grid.size == k + 1
    assert grid[-1] == t1
    # the streaming service's tail of the grid agrees: every point, the last included
    tail, end = overlap_grid_tail(times, rate_hz, np.inf, 3)
    assert end == k + 1 and np.array_equal(tail, grid[-3:])


@pytest.mark.parametrize("dataset, imu_hz, warned", [
    ("borealtc", 110.0, False), ("borealtc", 90.0, False),     # exactly 10 % off: passes
    ("borealtc", 110.5, True), ("borealtc", 89.5, True),
    ("vulpi", 55.0, False), ("vulpi", 45.0, False)])
def test_an_imu_rate_exactly_a_tenth_off_the_datasets_passes_both_ways(
        tmp_path, synth_imu, synth_pro, write_run, dataset, imu_hz, warned):
    """``terrain convert`` warns of an IMU rate *more than* 10 % off the dataset's: one
    exactly 10 % above it (110 Hz for BorealTC's 100 Hz) was warned of, one exactly 10 %
    below it (90 Hz) not (110 / 100 - 1 is 0.10000000000000009 in floating point)."""
    from terrain.io.shipped import convert_dataset

    write_run(tmp_path / "csv", "ASPHALT", "00", synth_imu(duration_s=4.0, rate_hz=imu_hz),
              synth_pro(duration_s=4.0, rate_hz=10.0))
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        entry = convert_dataset(tmp_path / "csv", dataset, tmp_path / "data")
    assert entry["sampling_rates_hz"]["imu"] == imu_hz
    said = [str(w.message) for w in seen if "IMU runs at" in str(w.message)]
    assert bool(said) == warned


@settings(max_examples=60, deadline=None)
@given(rate_hz=st.sampled_from([10.0, 15.0, 50.0, 100.0]),
       t0=st.sampled_from([0.0, 0.37, 1.7e9]), start=st.integers(0, 150))
def test_a_stretch_lasting_exactly_the_stuck_limit_is_stuck_wherever_it_starts(
        rate_hz, t0, start):
    """Rule ``stuck_sensor`` counts a stretch of one exact value lasting at least
    :data:`STUCK_IMU_S` (1 s, inclusive): 51 samples of a 50 Hz IMU span exactly 1 s. The
    timestamps' float rounding decided it: stuck for 166 of 200 starting rows, not for
    the other 34 (``t[b] - t[a]`` 0.9999999999999998 s); one sample fewer is never stuck."""
    from terrain.io.plausibility import STUCK_IMU_S, stuck_stretches

    n_steps = int(round(STUCK_IMU_S * rate_hz))
    t = t0 + np.arange(400) / rate_hz
    for samples, stuck in ((n_steps + 1, True), (n_steps, False)):
        wz = 2.0 + np.sin(0.37 * np.arange(400))
        wz[start:start + samples] = 0.5
        found = stuck_stretches({"imu": pd.DataFrame({"t_s": t, "wz": wz})})
        assert ("imu.wz" in found) == stuck


def _lost_two(rate_hz: float, t0: float, k: int, n: int = 80) -> np.ndarray:
    """Timestamps of an ``n``-sample clock at ``rate_hz`` from ``t0`` without samples
    ``k + 1`` and ``k + 2``: one step of exactly three usual steps."""
    return np.delete(t0 + np.arange(n) / rate_hz, [k + 1, k + 2])


@settings(max_examples=80, deadline=None)
@given(rate_hz=st.sampled_from([6.5, 10.0, 15.0, 50.0, 100.0]),
       t0=st.sampled_from([0.0, 0.37, 1.7e9]), k=st.integers(3, 60))
def test_a_step_of_exactly_gap_factor_usual_steps_is_no_gap(rate_hz, t0, k):
    """A gap is a step *longer than* ``gap_factor`` x the median step: two lost samples make
    a step of exactly 3 steps, no gap. The timestamps' float rounding decided it: at 10 Hz
    from 0 one such step in five was a gap, its grid points NaN. A step a hundredth of a
    step longer is one, in the alignment and in the readers' gap list alike."""
    from terrain.io.align import align_arrays

    for extra, gap in ((0.0, False), (0.01, True)):
        t = _lost_two(rate_hz, t0, k)
        t[k + 1:] += extra / rate_hz
        v = np.sin(np.arange(t.size, dtype=float))[:, None]
        grid = np.linspace(t[k], t[k + 1], 7)[1:-1]      # inside the long step
        out = align_arrays([t], [v], grid, rate_hz, gap_factor=3.0)
        assert np.isnan(out).all() == gap and np.isfinite(out).all() != gap


@pytest.mark.parametrize("k", range(5, 20))
def test_the_readers_list_no_gap_for_a_step_of_exactly_three_usual_steps(tmp_path, k):
    """The readers' gap list follows the same rule: a 10 Hz wheel file that lost two
    samples has no gap (it had one for k = 8, 9, 17, 18 ...), and no window is dropped."""
    from terrain.io.measured import read_stream_csv

    t = _lost_two(10.0, 0.0, k)
    n = t.size
    frame = pd.DataFrame({"time": t, "curL": 5.0 + np.sin(t), "curR": 5.0 + np.cos(t),
                          "velL": 0.5 + 0.01 * np.sin(3 * t), "velR": 0.5 + 0.0 * t})
    path = tmp_path / "pro_00.csv"
    frame.to_csv(path, index=False, float_format="%.9g")
    _, report = read_stream_csv(path, "pro")
    assert report.gaps == [] and n == 78


@settings(max_examples=60, deadline=None)
@given(grid_hz=st.sampled_from([10.0, 50.0, 100.0]), t0=st.floats(0.0, 100.0),
       n=st.integers(40, 120))
def test_a_stream_exactly_one_and_a_half_times_the_grid_rate_is_not_filtered(grid_hz, t0, n):
    """Only a stream *more than* 1.5 x the grid rate is anti-alias filtered; one at exactly
    1.5 x (a 150 Hz IMU on the 100 Hz grid, 15 Hz wheels on a 10 Hz one) is interpolated
    as it is. Its median step's rounding decided it: 150 Hz on 100 Hz filtered for 409 of
    903 clock starts and lengths. A stream 1 % faster still is filtered."""
    from terrain.io.align import align_arrays

    for native_hz, filtered in ((1.5 * grid_hz, False), (1.515 * grid_hz, True)):
        t = t0 + np.arange(n) / native_hz
        v = np.cos(2.9 * np.arange(n))[:, None]     # content near the stream's Nyquist
        grid = t[0] + np.arange(int((t[-1] - t[0]) * grid_hz)) / grid_hz
        out = align_arrays([t], [v], grid, grid_hz)
        plain = np.interp(grid, t, v[:, 0])[:, None]
        assert np.array_equal(out, plain) != filtered


@settings(max_examples=60, deadline=None)
@given(t0=st.sampled_from([0.0, 0.37, 12.34, 1.7e9]), wheel_s=st.integers(30, 199),
       imu_first=st.booleans())
def test_a_stream_running_on_exactly_two_seconds_is_not_warned_of(t0, wheel_s, imu_first):
    """Rule ``clock_overlap``'s likely case is strict: a stream running on for exactly
    :data:`MAX_UNUSED_SPAN_S` (2 s) beyond the other (an overlap of under 20 s, so the
    tenth of it is no longer bound) is not warned of, wherever the clocks start; their
    float rounding made 10.3 - 8.3 s 2.0000000000000018 s, warned. 2.1 s is warned of."""
    from terrain.io.plausibility import _check_clocks

    for extra_s, warned in ((2.0, False), (2.1, True)):
        wheels = t0 + np.arange(wheel_s + 1) / 10.0            # wheel_s tenths of a second
        imu = t0 + np.arange(round((wheel_s / 10.0 + extra_s) * 50) + 1) / 50.0
        if imu_first:       # the IMU starts early instead of running on
            imu = imu - extra_s
        found: list[str] = []
        _check_clocks(pd.DataFrame({"t_s": imu}), pd.DataFrame({"t_s": wheels}),
                      lambda s: s, found)
        assert bool(found) == warned


@pytest.mark.parametrize("t0", [0.0, 0.37, 0.1, 12.34, 1.7e9])
def test_clocks_overlapping_for_exactly_half_the_shorter_stream_pass_wherever_they_start(t0):
    """An IMU over 4 s and wheels starting 2 s into it, over 4 s: they overlap for exactly
    half of the shorter, which passes (strict bound), wherever the clocks start."""
    from terrain.io.plausibility import _check_clocks

    imu = t0 + np.arange(201) / 50.0
    wheels = t0 + 2.0 + np.arange(41) / 10.0
    found: list[str] = []
    unused = _check_clocks(pd.DataFrame({"t_s": imu}), pd.DataFrame({"t_s": wheels}),
                           lambda s: s, found)
    assert found == [] and unused == pytest.approx({"imu": 2.0, "wheels": 2.0})
