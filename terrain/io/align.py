"""Alignment of a run's streams onto one clock: an explicit, documented step.

Method (recorded in the returned frame's ``attrs``):

1. The common clock is a uniform grid at ``rate_hz`` over the time span covered by *every*
   requested stream (latest start to earliest end), so no value is extrapolated.
2. A stream sampled faster than the grid (the 100 Hz BorealTC IMU on a 50 Hz grid) is first
   low-pass filtered (4th-order Butterworth, zero phase, cut-off 0.4 x ``rate_hz``), each
   gap-free segment on its own, so that resampling does not alias vibration into the band of
   interest. Segments too short to filter (<= 27 samples) are interpolated unfiltered.
3. Every stream is then linearly interpolated onto the grid. The ~6.5 Hz (BorealTC) or
   ~15 Hz (Vulpi) wheel stream is thus interpolated between its samples.
4. Grid points that fall inside a timestamp gap of any stream (a step longer than
   ``gap_factor`` x its median step, see :mod:`terrain.io.measured`) are set to NaN, never
   interpolated across; the windowing step drops windows that contain them and counts them.

Both files of a measured run start at ``time = 0`` (``shared/data/README.md``); no clock
offset is applied here. An estimated lag between streams is the business of the audit.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy import signal

from terrain.errors import ConfigError, DataFormatError
from terrain.run import TIME, Run

#: Default clock rate, Hz: the slowest IMU rate of the shipped datasets (Vulpi, 50 Hz), so
#: every dataset gets identical features and the combined model sees one definition.
DEFAULT_RATE_HZ = 50.0


def align_streams(run: Run, streams: tuple[str, ...] = ("imu", "wheels"),
                  rate_hz: float = DEFAULT_RATE_HZ, gap_factor: float = 3.0) -> pd.DataFrame:
    """Put the named streams of ``run`` on one uniform clock.

    Parameters
    ----------
    run : Run
        The run; streams missing from it are skipped (a wheel-only run gives a frame with
        only wheel channels).
    streams : tuple of str
        Stream names to align (their channel names must not collide).
    rate_hz : float
        Rate of the common clock, Hz (> 0).
    gap_factor : float
        A step longer than ``gap_factor`` x the stream's median step is a gap.

    Returns
    -------
    pandas.DataFrame
        Shape ``(n_samples, 1 + n_channels)``: ``t_s`` then every channel, SI units;
        ``attrs`` holds ``rate_hz``, ``method`` and ``streams``.

    Raises
    ------
    ConfigError
        If ``rate_hz`` is not positive, or two streams share a channel name.
    DataFormatError
        If none of ``streams`` is in the run, or their time spans do not overlap.
    """
    if not rate_hz > 0:
        raise ConfigError(f"rate_hz must be > 0, got {rate_hz}")
    present = [s for s in streams if s in run.streams]
    if not present:
        raise DataFormatError(f"run has none of the streams {list(streams)} "
                              f"(has {list(run.streams)})", run.source)
    t0 = max(run.streams[s][TIME].iloc[0] for s in present)
    t1 = min(run.streams[s][TIME].iloc[-1] for s in present)
    if t1 <= t0:
        raise DataFormatError(f"streams {present} do not overlap in time", run.source)
    n = int(np.floor((t1 - t0) * rate_hz + 1e-9)) + 1
    grid = t0 + np.arange(n) / rate_hz
    columns: dict[str, np.ndarray] = {TIME: grid}
    for name in present:
        frame = run.streams[name]
        t = frame[TIME].to_numpy()
        dt = np.diff(t)
        step = float(np.median(dt))
        channels = [c for c in frame.columns if c != TIME and frame[c].dtype.kind == "f"]
        values = frame[channels].to_numpy(dtype=float)
        clash = sorted(set(channels) & set(columns))
        if clash:
            raise ConfigError(f"streams {present} share channel name(s) {clash}; align them "
                              "separately")
        gaps = np.flatnonzero(dt > gap_factor * step)
        native = 1.0 / step
        if native > 1.5 * rate_hz:
            sos = signal.butter(4, 0.4 * rate_hz, fs=native, output="sos")
            values = values.copy()
            # filter each gap-free segment on its own: never smear across a gap
            for a, b in zip(np.r_[0, gaps + 1], np.r_[gaps + 1, len(t)]):
                if b - a > 27:  # sosfiltfilt's default padding needs > 3 (2 x 4 + 1) samples
                    values[a:b] = signal.sosfiltfilt(sos, values[a:b], axis=0)
        in_gap = np.zeros(n, dtype=bool)
        for i in gaps:
            in_gap |= (grid > t[i]) & (grid < t[i + 1])
        for j, c in enumerate(channels):
            col = np.interp(grid, t, values[:, j])
            col[in_gap] = np.nan
            columns[c] = col
    frame = pd.DataFrame(columns)
    frame.attrs.update(rate_hz=float(rate_hz), streams=tuple(present),
                       method="anti-alias low-pass (Butterworth 4, 0.4 fs, zero phase) for "
                              "faster streams, then linear interpolation; NaN inside gaps")
    return frame
