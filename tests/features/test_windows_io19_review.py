"""Review io19: the windows of a run with timestamp holes, against a brute-force oracle.

The oracle rebuilds the common clock from the stream clocks (latest start to earliest end,
``rate_hz`` apart), marks a clock point bad when it falls strictly inside a step of any
stream longer than 3 median steps (a gap), and cuts the window positions ``0, hop, 2 hop``
whose ``n`` points all lie on the clock. ``make_windows`` must keep exactly the positions
without a bad point, count the others as ``dropped_gap`` (or ``empty_gap`` when every
point is bad for every stream), and every sample of a kept window must equal a linear
interpolation of the stream samples (no value across a gap, none beyond the streams' ends).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from hypothesis import given, settings
from hypothesis import strategies as st
import pytest

from features.windows import WindowConfig, make_windows
from terrain.run import IMU_CHANNELS, TIME, WHEEL_CHANNELS, Run


def _clock(rate_hz: float, duration_s: float, start_s: float, holes: list) -> np.ndarray:
    """Timestamps at ``rate_hz`` from ``start_s``, the samples inside each hole removed."""
    t = start_s + np.arange(int(duration_s * rate_hz)) / rate_hz
    for a, length in holes:
        t = t[(t <= start_s + a) | (t >= start_s + a + length)]
    return t


def _oracle(times: list[np.ndarray], rate_hz: float, n: int, hop: int):
    t0 = max(t[0] for t in times)
    t1 = min(t[-1] for t in times)
    grid = t0 + np.arange(int(np.floor((t1 - t0) * rate_hz + 1e-9)) + 1) / rate_hz
    bad = np.zeros((len(times), grid.size), dtype=bool)    # per stream
    for k, t in enumerate(times):
        dt = np.diff(t)
        for j in np.flatnonzero(dt > 3.0 * np.median(dt)):
            bad[k] |= (grid > t[j]) & (grid < t[j + 1])
    starts = np.arange(0, grid.size - n + 1, hop)
    hit = np.array([bad[:, s:s + n].any() for s in starts], dtype=bool)
    # wholly inside a gap of every stream: no finite value at all
    empty = np.array([bad[:, s:s + n].all(axis=1).all() for s in starts], dtype=bool)
    return grid, starts[~hit], int((hit & ~empty).sum()), int(empty.sum())


@pytest.mark.slow
@settings(max_examples=40, deadline=None, derandomize=True)
@given(imu_holes=st.lists(st.tuples(st.floats(0.5, 9.0), st.floats(0.04, 1.5)), max_size=2),
       wheel_holes=st.lists(st.tuples(st.floats(0.5, 9.0), st.floats(0.5, 2.0)), max_size=2),
       wheel_start=st.floats(0.0, 0.3), wheel_hz=st.sampled_from([6.5, 15.0]),
       window_s=st.sampled_from([0.5, 1.0, 1.7]), hop_s=st.sampled_from([None, 0.1, 0.3, 2.0]),
       rate_hz=st.sampled_from([20.0, 50.0]))
def test_kept_windows_are_the_gap_free_positions_of_the_clock(
        imu_holes, wheel_holes, wheel_start, wheel_hz, window_s, hop_s, rate_hz):
    rng = np.random.default_rng(5)
    t_i = _clock(100.0, 10.0, 0.0, imu_holes)
    t_w = _clock(wheel_hz, 10.0, wheel_start, wheel_holes)
    # linear channels: their interpolation is exact, so every kept sample is known
    imu = pd.DataFrame({TIME: t_i, **{c: 0.3 * k * t_i + k for k, c in enumerate(IMU_CHANNELS)}})
    wheels = pd.DataFrame({TIME: t_w, **{c: -0.2 * k * t_w + rng.normal()
                                         for k, c in enumerate(WHEEL_CHANNELS)}})
    run = Run("mem/00", "mem", "ICE", {"imu": imu, "wheels": wheels})
    config = WindowConfig(window_s=window_s, hop_s=hop_s, rate_hz=rate_hz)
    ws = make_windows([run], IMU_CHANNELS + WHEEL_CHANNELS, config)
    grid, kept, dropped, empty = _oracle([t_i, t_w], rate_hz, config.n_samples,
                                         config.hop_samples)
    np.testing.assert_allclose(ws.t_start_s, grid[kept], rtol=0, atol=1e-9)
    assert (ws.counts["dropped_gap"], ws.counts["empty_gap"]) == (dropped, empty)
    for w, start in enumerate(kept):
        t = grid[start:start + config.n_samples]
        assert t[0] >= max(t_i[0], t_w[0]) and t[-1] <= min(t_i[-1], t_w[-1])
        for j, c in enumerate(IMU_CHANNELS):
            # the 100 Hz IMU is low-passed for a 20 Hz clock: a line is kept up to the
            # filter's end effects (terrain.io.align, step 2)
            np.testing.assert_allclose(ws.X[w, j], np.interp(t, t_i, imu[c]),
                                       rtol=0, atol=1e-3 * (1 + abs(0.3 * j) * 10))
        for j, c in enumerate(WHEEL_CHANNELS):
            np.testing.assert_allclose(ws.X[w, len(IMU_CHANNELS) + j],
                                       np.interp(t, t_w, wheels[c]), rtol=0, atol=1e-9)
