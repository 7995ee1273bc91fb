"""Alignment of a run's streams onto one clock: an explicit, documented step.

Method (recorded in the returned frame's ``attrs``):

1. The common clock is a uniform grid at ``rate_hz`` over the time span covered by *every*
   requested stream (latest start to earliest end), so no value is extrapolated.
2. A stream sampled more than 1.5 times faster than the grid (the 100 Hz BorealTC IMU on a
   50 Hz grid; by more than its timestamps' rounding, :data:`STEP_SLACK`) is first low-pass
   filtered (4th-order Butterworth, zero phase, cut-off 0.4 x ``rate_hz``), each gap-free
   segment on its own, so that resampling does not alias vibration into the band of
   interest. A segment of 15 samples or fewer is padded by
   fewer samples than the filter's default (all but one), so it is filtered too. The odd
   extension (point reflection about each end sample) keeps a long segment's end values
   close for a stream at twice the grid rate (the 100 Hz IMU on the 50 Hz grid: a linear
   ramp's to 1e-5 of its span), less so for a faster one, whose filter settles over more
   samples than the padding's 15 (a 3 s ramp at 200 Hz on a 10 Hz grid misses its ends by
   0.2 % of its span, at 1000 Hz on a 6.5 Hz grid by 2.4 %), and not a short one's: filtered
   with one sample of padding, two samples of a 30 Hz tone at 100 Hz, 0.296 and 0.817,
   become 0.196 and 0.283. A one-sample segment is kept as it is. A NaN or inf sample is
   kept, and each run of finite samples around it is filtered on its own (the filter
   spread it over its whole segment), so it spoils only the grid points next to it (step
   3). A stream between 1 and 1.5 times the grid rate is NOT filtered (the margin keeps a clock's
   jitter about the grid rate from filtering a stream sampled at it); no shipped or
   simulated stream falls there, but content of such a stream between 0.5 x ``rate_hz``
   and its own Nyquist frequency aliases (a 30 Hz tone of a 70 Hz stream reads as 20 Hz on
   a 50 Hz grid): resample it at its own rate or at under 2/3 of it.
3. Every stream is then linearly interpolated onto the grid. The ~6.5 Hz (BorealTC) or
   ~15 Hz (Vulpi) wheel stream is thus interpolated between its samples.
4. Grid points that fall inside a timestamp gap of any stream (a step longer than
   ``gap_factor`` x its median step, by more than the timestamps' rounding:
   :func:`gap_steps`, see :mod:`terrain.io.measured`) are set to NaN, never
   interpolated across; the windowing step drops windows that contain them and counts them.

The maths is NumPy-only (:func:`overlap_grid`, :func:`align_arrays`): the batch readers'
path (:func:`align_streams`, a run's stream frames in, a frame out) and the streaming
service (ring-buffer arrays in, one window out) call the same functions.

Both files of a measured run start at ``time = 0`` (``shared/data/README.md``); no clock
offset is applied here. An estimated lag between streams is the business of the audit.
"""

from __future__ import annotations

import functools
from typing import Sequence

import numba
import numpy as np
import pandas as pd
from scipy import signal

from terrain.errors import (ConfigError, DataFormatError, TimestampError, config_integer,
                            config_numbers, config_positive, duplicated,
                            first_non_number_cell)
from terrain.run import TIME, Run, clock_slack, times_out_of_order

#: Default clock rate, Hz: the slowest IMU rate of the shipped datasets (Vulpi, 50 Hz), so
#: every dataset gets identical features and the combined model sees one definition.
DEFAULT_RATE_HZ = 50.0

#: Most points of one batch grid (:func:`align_streams`): 50 million, 11.6 days at 50 Hz and
#: 3.6 GB for 8 channels, far beyond a logged run. A longer span is a clock that jumps (a
#: last timestamp of 1.7e9 s, the Unix epoch, after 30 s of data asked for 8.5e10 points,
#: 633 GiB, a bare MemoryError) or a clock in other units, not a run to align.
MAX_GRID_POINTS = 50_000_000

#: Samples of odd extension at each end of a gap-free segment for the zero-phase anti-alias
#: filter: ``scipy.signal.sosfiltfilt``'s default for the filter's two second-order sections
#: (3 x (2 x 2 + 1)); a shorter segment is padded by all its samples but one.
FILTER_PAD_SAMPLES = 15


def overlap_grid(times_s: Sequence[np.ndarray], rate_hz: float) -> np.ndarray:
    """Uniform clock at ``rate_hz`` over the span every stream covers (step 1 of the method).

    Parameters
    ----------
    times_s : sequence of numpy.ndarray
        One ``(m_i,)`` increasing timestamp array per stream, s (each non-empty).
    rate_hz : float
        Rate of the clock, Hz (> 0).

    Returns
    -------
    numpy.ndarray
        ``(n,)`` grid ``t0 + k / rate_hz`` from the latest first sample ``t0`` to the
        earliest last sample, s; empty when the spans do not overlap.

    Raises
    ------
    ConfigError
        If ``rate_hz`` is not a finite number > 0, or no stream or an empty one is given
        (Python's bare ``max() arg is an empty sequence`` or an IndexError before).
    """
    t0, n = _grid_span(times_s, rate_hz, "overlap_grid")
    return t0 + np.arange(n) / rate_hz


def _grid_span(times_s: Sequence[np.ndarray], rate_hz: float,
               owner: str) -> tuple[float, int]:
    """First point ``t0`` (s) and number of points of :func:`overlap_grid` (0: no overlap);
    ``owner`` names the caller in the error of a ``rate_hz`` that is not finite and > 0
    (inf raised a bare OverflowError)."""
    config_positive(owner, rate_hz=rate_hz)
    try:
        t0 = max(float(t[0]) for t in times_s)
        t1 = min(float(t[-1]) for t in times_s)
    except (ValueError, IndexError):   # (no cost on the usual call)
        raise ConfigError(f"{owner} needs at least one stream and a sample in each, got "
                          f"{[len(t) for t in times_s]} sample(s)") from None
    if t1 <= t0:
        return t0, 0
    n = int(np.floor((t1 - t0) * rate_hz + 1e-9)) + 1
    # a point the grid's own arithmetic puts at or before t1 is in: on an epoch clock
    # (1.7e9 s) (t1 - t0) * rate_hz fell just short of k for a stream ending on t0 + k / rate
    while n <= MAX_GRID_POINTS and t0 + n / rate_hz <= t1:
        n += 1
    return t0, n


def _check_tail(owner: str, n_last, name: str, time_s, finite: bool) -> None:
    """ConfigError unless ``n_last`` is an integer >= 0 and ``time_s`` a number, not NaN
    (and finite where ``finite``); the arguments of the grid-tail functions."""
    config_integer(f"{owner}.n_last", n_last, 0)
    config_numbers(owner, **{name: time_s})
    if np.isnan(time_s) or (finite and not np.isfinite(time_s)):
        raise ConfigError(f"{owner}.{name} must be a {'finite ' if finite else ''}time, got "
                          f"{time_s!r}")


def overlap_grid_tail(times_s: Sequence[np.ndarray], rate_hz: float, before_s: float,
                      n_last: int) -> tuple[np.ndarray, int]:
    """The last points of :func:`overlap_grid` earlier than a time, without building it.

    A stream service aligns one window at a time; building the whole grid over a long
    timestamp gap costs its length times the rate, for every window inside the gap.

    Parameters
    ----------
    times_s : sequence of numpy.ndarray
        As for :func:`overlap_grid`.
    rate_hz : float
        Rate of the clock, Hz (> 0).
    before_s : float
        Only grid points ``< before_s`` count, s.
    n_last : int
        How many of them, at most, to return (the latest).

    Returns
    -------
    tail : numpy.ndarray
        ``(min(n_last, end),)`` the points ``grid[end - n_last:end]``, equal to the values
        of ``overlap_grid(times_s, rate_hz)``, s.
    end : int
        Number of grid points ``< before_s`` (0 when the spans do not overlap).

    Raises
    ------
    ConfigError
        If ``rate_hz`` is not a finite number > 0, ``before_s`` not a number (NaN
        included; -inf and inf give none and all points), or ``n_last`` not an integer
        >= 0 (2.5 gave points between the grid's).
    """
    t0, n = _grid_span(times_s, rate_hz, "overlap_grid_tail")
    # (int(ceil(nan)) was a bare ValueError, of inf OverflowError)
    _check_tail("overlap_grid_tail", n_last, "before_s", before_s, finite=False)
    # first k with t0 + k / rate >= before_s, on the grid's own float arithmetic
    end = int(np.ceil(np.clip((before_s - t0) * rate_hz, 0, n)))
    while end > 0 and t0 + (end - 1) / rate_hz >= before_s:
        end -= 1
    while end < n and t0 + end / rate_hz < before_s:
        end += 1
    return t0 + np.arange(max(end - n_last, 0), end) / rate_hz, end


def anchored_grid_tail(times_s: Sequence[np.ndarray], rate_hz: float, anchor_s: float,
                       n_last: int) -> tuple[np.ndarray, int]:
    """The last points of a clock at ``rate_hz`` through ``anchor_s``, inside the overlap.

    The grid of :func:`overlap_grid` starts at the streams' latest first sample, so its
    phase follows whichever sample a caller read first. A stream service that cuts one
    window at a time reads a different first sample for each window (a float tie of its
    look-back bound with a sample stamp decided which), so its grid should be anchored at a
    time of its choosing instead: a sample of the stream the grid stays on, or the
    decision clock.

    Parameters
    ----------
    times_s : sequence of numpy.ndarray
        As for :func:`overlap_grid`.
    rate_hz : float
        Rate of the clock, Hz (> 0).
    anchor_s : float
        A point of the clock, its latest candidate, s: the grid is ``anchor_s - k /
        rate_hz`` for whole ``k >= 0``.
    n_last : int
        How many points, at most, to return (the latest).

    Returns
    -------
    tail : numpy.ndarray
        ``(min(n_last, count),)`` the latest points of the grid inside the span every
        stream covers (latest first sample to earliest last sample, each end moved out by
        :func:`terrain.run.clock_slack`), increasing, s.
    count : int
        Number of grid points inside that span (0 when the spans do not overlap or the
        anchor is before it).

    Raises
    ------
    ConfigError
        If ``rate_hz`` is not a finite number > 0, ``anchor_s`` not a finite number, or
        ``n_last`` not an integer >= 0.
    """
    t0, n = _grid_span(times_s, rate_hz, "anchored_grid_tail")
    _check_tail("anchored_grid_tail", n_last, "anchor_s", anchor_s, finite=True)
    t1 = min(float(t[-1]) for t in times_s)
    # a point within the clock's rounding of the span's ends is inside it (the window that
    # starts at a stream's first sample starts there whichever way anchor - k / rate rounds;
    # interpolation there reads the end sample's value)
    t0, t1 = t0 - float(clock_slack(t0)), t1 + float(clock_slack(t1))
    if n == 0 or anchor_s < t0:
        return np.empty(0), 0
    # the first k with anchor - k / rate <= t1, and the last with anchor - k / rate >= t0,
    # on the grid's own float arithmetic
    k_first = max(0, int(np.ceil((anchor_s - t1) * rate_hz)))
    while k_first > 0 and anchor_s - (k_first - 1) / rate_hz <= t1:
        k_first -= 1
    while anchor_s - k_first / rate_hz > t1:
        k_first += 1
    k_last = int(np.floor((anchor_s - t0) * rate_hz))
    while anchor_s - (k_last + 1) / rate_hz >= t0:
        k_last += 1
    while k_last >= 0 and anchor_s - k_last / rate_hz < t0:
        k_last -= 1
    count = max(0, k_last - k_first + 1)
    k = np.arange(k_first + min(n_last, count) - 1, k_first - 1, -1)
    return anchor_s - k / rate_hz, count


#: Slack of the bounds on a stream's time step, a fraction of the bound: a step within it
#: of ``gap_factor`` x the median step is not longer than that (no gap), and a stream whose
#: rate is within it of 1.5 x the grid's is not faster than that (not filtered).
#: Timestamps carry float rounding (1e-16 of a clock from 0, 2.4e-7 s at an epoch clock's
#: 1.7e9 s: up to 3e-5 of a 10 ms step's bound), which made two lost samples of a 10 Hz
#: clock, a step of exactly three, a gap one time in five, and a 150 Hz stream on a 100 Hz
#: grid filtered for nearly half of its clock starts.
STEP_SLACK = 1e-4


def gap_steps(steps_s: np.ndarray, step_s: float, gap_factor: float) -> np.ndarray:
    """Which time steps are gaps: longer than ``gap_factor`` x the usual step (the rule of
    the readers and of the alignment), a step within :data:`STEP_SLACK` of that bound not.

    Parameters
    ----------
    steps_s : numpy.ndarray
        ``(m,)`` time steps, s (``numpy.diff`` of the timestamps).
    step_s : float
        The stream's usual (median) step, s.
    gap_factor : float
        A step longer than ``gap_factor`` x ``step_s`` is a gap (> 1).

    Returns
    -------
    numpy.ndarray
        ``(m,)`` bool: ``steps_s > gap_factor * step_s * (1 + STEP_SLACK)``.
    """
    return np.asarray(steps_s) > gap_factor * step_s * (1.0 + STEP_SLACK)


def median_step(t_s: np.ndarray) -> float:
    """Median time step of increasing timestamps (the reference of the gap rule), s.

    Parameters
    ----------
    t_s : numpy.ndarray
        ``(m,)`` increasing timestamps, s (``m >= 2``).

    Returns
    -------
    float
        Median of ``diff(t_s)``, s (a partial sort: cheaper than ``numpy.median`` on the
        short arrays of a streaming window).
    """
    d = np.diff(t_s)
    k = d.size // 2
    if d.size % 2:
        return float(np.partition(d, k)[k])
    p = np.partition(d, (k - 1, k))
    return float(0.5 * (p[k - 1] + p[k]))


def align_arrays(times_s: Sequence[np.ndarray], values: Sequence[np.ndarray],
                 grid_s: np.ndarray, rate_hz: float, gap_factor: float = 3.0,
                 steps_s: Sequence[float] | None = None) -> np.ndarray:
    """Resample streams onto grid points (steps 2-4 of the method); NumPy only.

    ``grid_s`` may be any part of the stream's :func:`overlap_grid` (the streaming service
    passes only the points of its window): each grid point's value depends only on the
    stream samples, so a part of the grid gets exactly the values of the whole.

    Parameters
    ----------
    times_s : sequence of numpy.ndarray
        One ``(m_i,)`` strictly increasing timestamp array per stream, s (``m_i >= 2``).
    values : sequence of numpy.ndarray
        One ``(m_i, c_i)`` value array per stream, SI units.
    grid_s : numpy.ndarray
        ``(n,)`` grid points inside every stream's span, s.
    rate_hz : float
        Rate of the clock the grid belongs to, Hz; a stream faster than 1.5 x this is
        anti-alias filtered first.
    gap_factor : float
        A step longer than ``gap_factor`` x the stream's median step is a gap.
    steps_s : sequence of float or None
        Each stream's usual (median) step, s, when the caller knows it better than the
        samples given (the streaming service passes its ring buffers' recent median);
        ``None``: the median step of each stream's samples (:func:`median_step`).

    Returns
    -------
    numpy.ndarray
        ``(n, sum(c_i))``: the streams' channels side by side, in the order given; NaN at
        grid points inside a gap of that stream.

    Raises
    ------
    ConfigError
        ``values`` not one ``(m_i, c_i)`` array per timestamp array (20 rows for 40
        timestamps were read as a stream of 20 samples), or ``steps_s`` not one finite
        time > 0 per stream (a step of 0 was a bare
        ZeroDivisionError; NaN made no step a gap and left a fast stream unfiltered).
    """
    if len(values) != len(times_s):
        raise ConfigError(f"align_arrays: {len(times_s)} timestamp array(s) and "
                          f"{len(values)} value array(s): one of each per stream")
    for k, (t, v) in enumerate(zip(times_s, values)):
        if np.ndim(v) != 2 or len(v) != len(t):
            raise ConfigError(f"align_arrays: stream {k}: " + (
                f"values of shape {np.shape(v)}, expected (samples, channels)"
                if np.ndim(v) != 2 else
                f"{len(v)} row(s) of values for {len(t)} timestamp(s)"))
    if steps_s is not None:
        if len(steps_s) != len(times_s):
            raise ConfigError(f"align_arrays.steps_s holds one step per stream: "
                              f"{len(times_s)} stream(s), {len(steps_s)} step(s)")
        config_positive("align_arrays", **{f"steps_s[{k}]": s for k, s in enumerate(steps_s)})
    out = np.empty((len(grid_s), sum(v.shape[1] for v in values)))
    col = 0
    for k, (t, v) in enumerate(zip(times_s, values)):
        dt = np.diff(t)
        step = median_step(t) if steps_s is None else float(steps_s[k])
        is_gap = gap_steps(dt, step, gap_factor)
        native = 1.0 / step
        if native > 1.5 * rate_hz * (1.0 + STEP_SLACK):   # (exactly 1.5 x: not filtered)
            sos = signal.butter(4, 0.4 * rate_hz, fs=native, output="sos")
            v = v.copy()
            gaps = np.flatnonzero(is_gap)
            # filter each gap-free segment on its own: never smear across a gap
            for a, b in zip(np.r_[0, gaps + 1], np.r_[gaps + 1, len(t)]):
                v[a:b] = _filter_segment(sos, v[a:b])
        _interp_into(np.asarray(grid_s, dtype=float), np.asarray(t, dtype=float),
                     np.asarray(v, dtype=float), is_gap, out, col)
        col += v.shape[1]
    return out


def _filter_segment(sos: np.ndarray, seg: np.ndarray) -> np.ndarray:
    """Zero-phase low-pass of one gap-free segment ``(m, c)``, every column on its own.

    A finite segment is filtered whole (odd extension of ``min(FILTER_PAD_SAMPLES, m - 1)``
    samples, one sample kept as it is). In a column holding NaN or inf each run of finite
    samples is filtered on its own and the non-finite samples are kept: the filter spread
    one NaN over the whole segment (every window of the run dropped), and interpolation
    then spoils only the grid points next to it, as in a stream that is not filtered.
    """
    finite = np.isfinite(seg)
    if finite.all():
        if len(seg) < 2:
            return seg
        return signal.sosfiltfilt(sos, seg, axis=0,
                                  padlen=min(FILTER_PAD_SAMPLES, len(seg) - 1))
    out = seg.copy()
    for k in range(seg.shape[1]):
        edges = np.flatnonzero(np.diff(np.r_[0, finite[:, k].astype(np.int8), 0]))
        for a, b in zip(edges[::2], edges[1::2]):
            if b - a > 1:
                out[a:b, k] = signal.sosfiltfilt(sos, seg[a:b, k],
                                                 padlen=min(FILTER_PAD_SAMPLES, b - a - 1))
    return out


@numba.njit(cache=True, nogil=True)
def _interp_into(grid, t, v, is_gap, out, col):   # pragma: no cover - compiled
    """Linear interpolation of every column of ``v`` (``(m, c)``, at increasing ``t``) onto
    ``grid`` into ``out[:, col:col + c]``, NaN at a grid point strictly inside a gap step
    ``(t[j], t[j + 1])`` (``is_gap[j]``); outside ``[t[0], t[-1]]`` the end values.

    The arithmetic is :func:`numpy.interp`'s, operation for operation (``slope * (x -
    t[j]) + v[j]``, the sample value on a sample time, the right end's value at ``t[-1]``,
    and its retries when the result is NaN), so the values are bit-identical to it (tested,
    ``tests/io/test_align.py``)."""
    m, c = v.shape
    j = 0
    for i in range(grid.shape[0]):
        x = grid[i]
        if not x >= t[0]:       # left of the samples (or NaN): numpy's left value
            for k in range(c):
                out[i, col + k] = v[0, k] if x < t[0] else np.nan
            continue
        if x >= t[m - 1]:
            for k in range(c):
                out[i, col + k] = v[m - 1, k]
            continue
        if t[j] > x:            # a grid out of order: search from the start again
            j = 0
        while t[j + 1] <= x:    # t[j] <= x < t[j + 1]
            j += 1
        if is_gap[j] and x > t[j]:
            for k in range(c):
                out[i, col + k] = np.nan
            continue
        for k in range(c):
            if t[j] == x:
                out[i, col + k] = v[j, k]
                continue
            slope = (v[j + 1, k] - v[j, k]) / (t[j + 1] - t[j])
            r = slope * (x - t[j]) + v[j, k]
            if np.isnan(r):
                r = slope * (x - t[j + 1]) + v[j + 1, k]
                if np.isnan(r) and v[j, k] == v[j + 1, k]:
                    r = v[j, k]
            out[i, col + k] = r


def interpolated_mean_count(n_samples: int, rate_hz: float, native_rate_hz: float,
                            n_phases: int = 64) -> float:
    """Effective number of independent stream samples in the mean of one aligned window.

    A stream slower than the clock is linearly interpolated onto it (step 3 of the method),
    so the ``n_samples`` window values are hat-weighted sums of the stream's own samples
    ``e_j``: the window mean is ``sum_j w_j e_j`` and its noise variance is
    ``sigma^2 sum_j w_j^2`` for white sample noise of variance ``sigma^2``. This returns
    ``1 / E[sum_j w_j^2]``, the expectation taken over the offset of the stream's samples
    against the window (uniform), so ``sigma / sqrt(count)`` is the noise std of the window
    mean. It is slightly more than ``window length x native rate`` (13 for BorealTC's 6.5 Hz
    wheel stream in 2 s): the samples just outside the window share its edge values. For a
    stream at least as fast as the clock (anti-alias filtered, then interpolated) the count
    is taken as ``n_samples`` (one independent value per clock sample, an approximation).
    Memoised (it depends on its scalar arguments only): the single-window slip features call
    it for every window. The arguments are checked on every call, before the memo is looked
    up (its key read ``True`` as 1 and ``20.0`` as 20, so an argument refused on a first
    call was accepted once an equal one had been memoised).

    Parameters
    ----------
    n_samples : int
        Window length in clock samples (>= 1).
    rate_hz : float
        Clock rate, Hz (> 0).
    native_rate_hz : float
        The stream's own sample rate, Hz (> 0).
    n_phases : int
        Offsets averaged over (evenly spaced over one stream step).

    Returns
    -------
    float
        Effective sample count (>= 1).

    Raises
    ------
    ConfigError
        A count that is not an integer >= 1 (a boolean or 2.5 gave a count without a word),
        or a rate that is not a finite number > 0, named.
    """
    config_integer("interpolated_mean_count.n_samples", n_samples, 1)
    config_integer("interpolated_mean_count.n_phases", n_phases, 1)
    config_positive("interpolated_mean_count", rate_hz=rate_hz, native_rate_hz=native_rate_hz)
    return _interpolated_mean_count(int(n_samples), float(rate_hz), float(native_rate_hz),
                                    int(n_phases))


@functools.lru_cache(maxsize=64)
def _interpolated_mean_count(n_samples: int, rate_hz: float, native_rate_hz: float,
                             n_phases: int) -> float:
    # the memoised computation of interpolated_mean_count, of checked arguments only
    if native_rate_hz >= rate_hz:
        return float(n_samples)
    t = np.arange(n_samples) / rate_hz
    sum_sq = 0.0
    for phase in (np.arange(n_phases) + 0.5) / n_phases:
        # stream samples bracketing the window, offset by `phase` of a step
        tau = (np.arange(np.floor(-phase) - 1, np.ceil(t[-1] * native_rate_hz) + 2)
               + phase) / native_rate_hz
        hat = np.maximum(0.0, 1.0 - np.abs(t[:, None] - tau[None, :]) * native_rate_hz)
        sum_sq += float(np.sum(hat.mean(axis=0) ** 2))
    return max(1.0, n_phases / sum_sq)


def check_gap_factor(owner: str, gap_factor: float) -> None:
    """Refuse a gap factor that is not a finite number > 1 (the gap rule of this module).

    A step longer than ``gap_factor`` x the stream's median step is a gap: NaN or inf makes
    no step a gap, 1 or less nearly every one (every window dropped).

    Parameters
    ----------
    owner : str
        Name of the caller, for the message (``"<owner>.gap_factor ..."``).
    gap_factor : float
        The factor, dimensionless.

    Raises
    ------
    ConfigError
        ``gap_factor`` not a number, or not finite and > 1.
    """
    config_numbers(owner, gap_factor=gap_factor)
    if not 1.0 < gap_factor < np.inf:
        raise ConfigError(f"{owner}.gap_factor must be a finite number > 1 (a step longer "
                          f"than gap_factor x the median step is a gap), got {gap_factor!r}")


def first_non_number(cells: pd.Series) -> int | None:
    """Row of the first cell of a column that is neither a real number nor missing (text,
    even text that spells a number such as ``"1e3"`` or ``"nan"``, bytes, a date, a
    duration, a boolean, a complex number, a ``decimal.Decimal``), or None: the rule of a
    data column's cells, for the alignment's clock (booleans were the times 0 and 1 s, text
    the numbers it spells), the writer's (a date was written as its text) and the slip
    features' probabilities.

    The cells are judged by :func:`terrain.errors.first_non_number_cell`, the rule the
    kinematics' arguments share (:func:`terrain.vehicles.common.float_arrays`), with
    ``allow_missing=True``: a missing cell (``None``, pandas' ``NA``, ``NaT``) is a missing
    sample here, left to the caller's missing-value rule (the writer refuses it naming the
    row; the readers interpolate an isolated one and count it), where an argument refuses
    it.

    Parameters
    ----------
    cells : pandas.Series
        The column.

    Returns
    -------
    int or None
        0 for a column whose dtype holds no real number (boolean, text, dates, durations,
        complex), the first such cell's row in an object column, None otherwise.
    """
    if cells.dtype.kind in "iuf":
        return None
    if cells.dtype.kind != "O" or isinstance(cells.dtype, pd.StringDtype):
        return 0
    return first_non_number_cell(cells, allow_missing=True)


def align_streams(run: Run, streams: tuple[str, ...] = ("imu", "wheels"),
                  rate_hz: float = DEFAULT_RATE_HZ, gap_factor: float = 3.0) -> pd.DataFrame:
    """Put the named streams of ``run`` on one uniform clock.

    The batch readers' wrapper of :func:`overlap_grid` and :func:`align_arrays`.

    Parameters
    ----------
    run : Run
        The run; streams missing from it are skipped (a wheel-only run gives a frame with
        only wheel channels).
    streams : tuple of str
        Stream names to align (their channel names must not collide).
    rate_hz : float
        Rate of the common clock, Hz (finite, > 0).
    gap_factor : float
        A step longer than ``gap_factor`` x the stream's median step is a gap (finite,
        > 1).

    Returns
    -------
    pandas.DataFrame
        Shape ``(n_samples, 1 + n_channels)``: ``t_s`` then every numeric channel
        (float64, integer columns included; text columns left out), SI units;
        ``attrs`` holds ``rate_hz``, ``method``, ``streams``, and the columns left out
        (text, boolean: not resampled) as ``dropped_columns`` (``"<stream>.<column>"``,
        in stream and column order) and their count ``n_dropped_columns``.

    Raises
    ------
    ConfigError
        If ``rate_hz`` is not a finite number > 0, ``gap_factor`` not a finite number > 1
        (NaN or inf made no step a gap, 1 or less nearly every one), ``streams`` one text
        instead of a tuple of names, or two streams share a channel name.
    DataFormatError
        If none of ``streams`` is in the run, one of them lacks ``t_s``
        (:class:`~terrain.errors.MissingColumnError`) or holds a column twice, one of
        them has fewer than 2 samples, their
        time spans do not overlap, or their overlap would make more than
        :data:`MAX_GRID_POINTS` grid points (naming the stream's longest step and its row).
    TimestampError
        A stream's ``t_s`` not numbers (booleans, text, dates), or not finite and strictly
        increasing (the :class:`Run` contract), naming the stream and the first offending
        row.
    """
    config_positive("align_streams", rate_hz=rate_hz)
    check_gap_factor("align_streams", gap_factor)
    if isinstance(streams, str):    # ("imu" was read as the streams 'i', 'm', 'u')
        raise ConfigError(f"align_streams.streams is a tuple of stream names, got the text "
                          f"{streams!r}: write ({streams!r},)")
    present = [s for s in streams if s in run.streams]
    if not present:
        raise DataFormatError(f"run has none of the streams {list(streams)} "
                              f"(has {list(run.streams)})", run.source)
    for name in present:
        # (a bare KeyError 't_s'; a column twice a bare AttributeError or broadcast error)
        frame = run.require_columns(name, ())
        twice = duplicated(list(frame.columns))
        if twice:
            raise DataFormatError(f"stream {name!r} has column(s) {twice} twice: which one "
                                  "to align is unknown; rename or drop one", run.source,
                                  str(twice[0]))
        clock = frame[TIME]
        row = first_non_number(clock)
        if row is not None:
            # (booleans were the times 0 and 1 s, text the numbers it spells)
            raise TimestampError(f"stream {name!r}: timestamps must be numbers (s), got "
                                 f"{clock.iloc[row]!r} ({clock.dtype}) at row {row}",
                                 run.source, TIME, row)
    frames = [run.streams[s] for s in present]
    # numeric channels, integer ones included (a shipped Parquet column may hold int64:
    # leaving it out made every feature of it a KeyError); text channels (a simulated run's
    # per-sample ``terrain`` label) are not resampled
    channels = [[c for c in f.columns if c != TIME and f[c].dtype.kind in "iuf"]
                for f in frames]
    dropped = tuple(f"{s}.{c}" for s, f, ch in zip(present, frames, channels)
                    for c in f.columns if c != TIME and c not in ch)
    flat = [c for ch in channels for c in ch]
    clash = duplicated(flat)
    if clash:
        raise ConfigError(f"streams {present} share channel name(s) {clash}; align them "
                          "separately")
    times = [f[TIME].to_numpy(dtype=float) for f in frames]
    for name, t in zip(present, times):
        if t.size < 2:    # the overlap's ends read each stream's first and last sample
            # (one sample made an empty grid: "do not overlap in time", which was untrue)
            count = "no samples" if t.size == 0 else "1 sample"
            raise DataFormatError(f"stream {name!r} has {count}: nothing to align (a stream "
                                  f"needs 2 to be interpolated)", run.source, TIME)
        # the interpolation takes the order for granted: two swapped samples were read
        # without a word, a NaN time made the grid's length a bare ValueError
        out_of_order = times_out_of_order(t)
        if out_of_order.size:
            row = int(out_of_order[0])
            raise TimestampError(f"stream {name!r}: timestamps must increase strictly, got "
                                 f"{float(t[row])!r} at row {row}", run.source, TIME, row)
    t0, n_points = _grid_span(times, rate_hz, "align_streams")
    if n_points > MAX_GRID_POINTS:
        # name the longest step inside the overlap: where the clock most likely jumps
        steps = [np.diff(t) for t in times]
        k = int(np.argmax([d.max() for d in steps]))
        row = int(np.argmax(steps[k])) + 1
        raise DataFormatError(
            f"streams {present} overlap for {n_points / rate_hz:.4g} s: {n_points:.3g} points "
            f"at {rate_hz:g} Hz, more than the {MAX_GRID_POINTS:.3g} of a run's clock; stream "
            f"{present[k]!r} steps from {float(times[k][row - 1])!r} to "
            f"{float(times[k][row])!r} s at row {row} (a clock that jumps, or in other units "
            "than seconds?)", run.source, TIME, row)
    grid = t0 + np.arange(n_points) / rate_hz   # overlap_grid's points
    if grid.size == 0:
        raise DataFormatError(f"streams {present} do not overlap in time", run.source)
    aligned = align_arrays(times, [f[ch].to_numpy(dtype=float) for f, ch in
                                   zip(frames, channels)], grid, rate_hz, gap_factor)
    frame = pd.DataFrame(np.column_stack([grid, aligned]), columns=[TIME] + flat)
    frame.attrs.update(rate_hz=float(rate_hz), streams=tuple(present),
                       dropped_columns=dropped, n_dropped_columns=len(dropped),
                       method="anti-alias low-pass (Butterworth 4, 0.4 fs, zero phase) for "
                              "faster streams, then linear interpolation; NaN inside gaps")
    return frame
