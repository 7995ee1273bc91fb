"""Plausibility rules applied to every incoming sample (pluggable).

The rules are those of the readers (:mod:`terrain.io.measured` and :mod:`terrain.io.plausibility`),
applied sample by sample instead of file by file:

* ``time_not_increasing``: a timestamp not strictly after the stream's previous one (the
  reader's :class:`~terrain.errors.TimestampError`); the sample is rejected;
* ``non_finite``: a NaN or inf channel value; the sample is rejected, so the alignment
  interpolates linearly across it, which is the reader's repair of isolated non-finite
  samples; a longer burst leaves a timestamp gap that the alignment never bridges;
* ``implausible_rate``: a gyro rate above
  :data:`terrain.io.measured.MAX_PLAUSIBLE_RATE_RAD_S` (deg/s sent as rad/s); rejected;
* ``implausible_value``: an accelerometer, wheel-speed or motor-current value beyond the
  readers' range (:data:`terrain.io.plausibility.CHANNEL_LIMITS`, the bound
  :func:`terrain.io.plausibility.check_ranges` refuses a file beyond); rejected;
* ``implausible_time``: a timestamp beyond :data:`MAX_PLAUSIBLE_TIME_S` (a clock in ms or
  ns since an epoch, or a corrupted stamp); rejected. Beyond about ``1e16`` s adding one
  hop to a float64 time no longer changes it, so such a stamp accepted would make the
  service's decision clock stand still.

A rule is any callable ``rule(channels, t_s, values, last_t_s) -> (keep, reason)``; the
service takes a tuple of them, so a robot can add its own.

One rule judges a stretch of samples rather than each one: ``stuck_sensor``
(:class:`StuckWatch`), a channel repeating one exact value for long (the readers'
:func:`terrain.io.plausibility.stuck_stretches`); it flags the windows holding the stretch
(``stuck:<stream>.<channel>[,...]``, the readers' flag) and drops nothing, as the readers
and the served model do.
"""

from __future__ import annotations

import functools
from collections import deque
from typing import Callable, Sequence

import numpy as np

from terrain.io.plausibility import CHANNEL_LIMITS, is_stuck, stuck_limit_s
from terrain.run import IMU_CHANNELS

#: Largest plausible ``|timestamp|``, s: 1e11 s is 3,170 years, 55 times a Unix time of
#: today (1.8e9 s), while a Unix time in ms is already 1.8e12; at 1e11 s a float64 still
#: resolves 1.5e-5 s, far below the 2.5 ms period of a 400 Hz IMU.
MAX_PLAUSIBLE_TIME_S = 1e11

#: rule(channels, t_s (n,), values (n, n_channels), last_t_s) -> (keep (n,) bool, reason)
SampleRule = Callable[[Sequence[str], np.ndarray, np.ndarray, float], tuple[np.ndarray, str]]


def time_increasing(channels: Sequence[str], t_s: np.ndarray, values: np.ndarray,
                    last_t_s: float) -> tuple[np.ndarray, str]:
    """Keep samples whose time is strictly after every earlier kept sample of the stream
    (a NaN stamp is refused and judges no later sample).

    Parameters
    ----------
    channels : sequence of str
        Channel names of the stream (unused).
    t_s : numpy.ndarray
        ``(n,)`` timestamps of the chunk, s.
    values : numpy.ndarray
        ``(n, n_channels)`` values (unused).
    last_t_s : float
        Time of the stream's newest accepted sample, s (``-inf`` if none).

    Returns
    -------
    keep : numpy.ndarray
        ``(n,)`` bool.
    reason : str
        ``"time_not_increasing"``.
    """
    # fmax: a NaN stamp (refused, by finite_values too) leaves the running maximum as it
    # was; with maximum it became NaN and every later sample of the chunk was refused
    running = np.fmax.accumulate(np.concatenate(((last_t_s,), t_s)))
    return t_s > running[:-1], "time_not_increasing"


def finite_values(channels: Sequence[str], t_s: np.ndarray, values: np.ndarray,
                  last_t_s: float) -> tuple[np.ndarray, str]:
    """Keep samples whose time and every value are finite.

    Parameters
    ----------
    channels : sequence of str
        Channel names (unused).
    t_s : numpy.ndarray
        ``(n,)`` timestamps, s.
    values : numpy.ndarray
        ``(n, n_channels)`` values.
    last_t_s : float
        Unused.

    Returns
    -------
    keep : numpy.ndarray
        ``(n,)`` bool.
    reason : str
        ``"non_finite"``.
    """
    return np.isfinite(values).all(axis=1) & np.isfinite(t_s), "non_finite"


def plausible_gyro(channels: Sequence[str], t_s: np.ndarray, values: np.ndarray,
                   last_t_s: float) -> tuple[np.ndarray, str]:
    """Keep samples whose gyro rates are below the reader's plausibility limit.

    Parameters
    ----------
    channels : sequence of str
        Channel names; ``wx, wy, wz`` are checked when present.
    t_s : numpy.ndarray
        ``(n,)`` timestamps, s (unused).
    values : numpy.ndarray
        ``(n, n_channels)``, rad/s for the gyro channels.
    last_t_s : float
        Unused.

    Returns
    -------
    keep : numpy.ndarray
        ``(n,)`` bool.
    reason : str
        ``"implausible_rate"``.
    """
    return _within_ranges(channels, values, gyro=True), "implausible_rate"


def plausible_values(channels: Sequence[str], t_s: np.ndarray, values: np.ndarray,
                     last_t_s: float) -> tuple[np.ndarray, str]:
    """Keep samples whose accelerometer, wheel-speed and motor-current values lie within
    the readers' ranges (the gyro has :func:`plausible_gyro`).

    Parameters
    ----------
    channels : sequence of str
        Channel names; those of :data:`terrain.io.plausibility.CHANNEL_LIMITS` other than
        ``wx, wy, wz`` are checked.
    t_s : numpy.ndarray
        ``(n,)`` timestamps, s (unused).
    values : numpy.ndarray
        ``(n, n_channels)`` values in the units of ``CHANNEL_LIMITS`` (m/s^2, m/s, A).
    last_t_s : float
        Unused.

    Returns
    -------
    keep : numpy.ndarray
        ``(n,)`` bool.
    reason : str
        ``"implausible_value"``.
    """
    return _within_ranges(channels, values, gyro=False), "implausible_value"


def _within_ranges(channels: Sequence[str], values: np.ndarray, gyro: bool) -> np.ndarray:
    """``(n,)`` bool: rows whose gyro channels (``gyro``) or other channels of
    :data:`terrain.io.plausibility.CHANNEL_LIMITS` (not ``gyro``) lie within their range; a
    NaN is left to :func:`finite_values`."""
    limits = _range_limits(tuple(channels), gyro)
    if limits is None:
        return np.ones(len(values), dtype=bool)
    return ~(np.abs(values) > limits).any(axis=1)   # NaN > limit is False: kept here


@functools.lru_cache(maxsize=256)
def _range_limits(channels: tuple[str, ...], gyro: bool) -> np.ndarray | None:
    """``(n_channels,)`` bound of each channel checked by :func:`_within_ranges` (inf for
    the others), or None when none is checked; computed once per channel tuple (one
    comparison per sample instead of one per channel: the rules run on every push)."""
    limits = np.array([CHANNEL_LIMITS[c].limit
                       if c in CHANNEL_LIMITS and (c in IMU_CHANNELS[:3]) == gyro else np.inf
                       for c in channels], dtype=float)
    limits.flags.writeable = False
    return limits if np.isfinite(limits).any() else None


def plausible_time(channels: Sequence[str], t_s: np.ndarray, values: np.ndarray,
                   last_t_s: float) -> tuple[np.ndarray, str]:
    """Keep samples whose timestamp is within :data:`MAX_PLAUSIBLE_TIME_S` of 0.

    Parameters
    ----------
    channels : sequence of str
        Channel names (unused).
    t_s : numpy.ndarray
        ``(n,)`` timestamps on the service clock, s.
    values : numpy.ndarray
        ``(n, n_channels)`` values (unused).
    last_t_s : float
        Unused.

    Returns
    -------
    keep : numpy.ndarray
        ``(n,)`` bool.
    reason : str
        ``"implausible_time"``.
    """
    with np.errstate(invalid="ignore"):
        return ~(np.abs(t_s) > MAX_PLAUSIBLE_TIME_S), "implausible_time"


#: The readers' rules, in the order they are applied.
DEFAULT_RULES: tuple[SampleRule, ...] = (finite_values, plausible_time, time_increasing,
                                         plausible_gyro, plausible_values)


class StuckWatch:
    """Rule ``stuck_sensor`` on a live stream: stretches of one exact repeated value.

    The readers' rule (:func:`terrain.io.plausibility.stuck_stretches`, criterion
    :func:`terrain.io.plausibility.is_stuck`, judged channels
    :func:`terrain.io.plausibility.stuck_limit_s`) followed sample by sample with constant
    memory: per judged channel, the value and start of its current stretch, plus the last
    ``max_stretches`` ended stuck stretches.

    Parameters
    ----------
    stream : str
        Stream name (for the flags).
    channels : sequence of str
        The stream's channels, in its value order.
    max_stretches : int
        Ended stuck stretches remembered per channel (older ones no longer flag anything).
    """

    def __init__(self, stream: str, channels: Sequence[str], max_stretches: int = 16) -> None:
        limits = [(j, c, stuck_limit_s(stream, c)) for j, c in enumerate(channels)]
        judged = [(j, c, lim) for j, c, lim in limits if lim is not None]
        self.columns = np.array([j for j, _, _ in judged], dtype=int)
        self.keys = [f"{stream}.{c}" for _, c, _ in judged]
        self.limits_s = np.array([lim for _, _, lim in judged], dtype=float)
        self.value = np.full(len(judged), np.nan)   # value of the current stretch
        self.start_t = np.full(len(judged), np.nan)  # time of its first sample, s
        self.count = np.zeros(len(judged), dtype=int)
        self.last_t = -np.inf
        self.ended: list[deque] = [deque(maxlen=max_stretches) for _ in judged]
        self._repeats = False   # whether a channel's current stretch holds > 1 sample

    def update(self, t_s: np.ndarray, values: np.ndarray) -> None:
        """Follow accepted samples (in increasing time).

        Parameters
        ----------
        t_s : numpy.ndarray
            ``(n,)`` timestamps, s.
        values : numpy.ndarray
            ``(n, n_channels)`` values in the stream's channel order.
        """
        if not len(t_s) or not self.columns.size:
            return
        if len(t_s) == 1:  # the usual push: all channels at once, no loop over samples
            x = values[0, self.columns]
            changed = x != self.value                     # NaN (the start): changed
            if not self._repeats and changed.all():       # a live sensor: ~4 us
                self.start_t[:] = t_s[0]
                self.count[:] = 1
                self.value = x
                self.last_t = float(t_s[0])
                return
            ended = changed & is_stuck(self.last_t - self.start_t, self.count, self.limits_s)
            for k in np.flatnonzero(ended):
                self.ended[k].append((float(self.start_t[k]), self.last_t))
            self.start_t[changed] = t_s[0]
            self.count = np.where(changed, 1, self.count + 1)
            self.value = x.astype(float)
            self.last_t = float(t_s[0])
            self._repeats = bool(self.count.max() > 1)
            return
        x = values[:, self.columns]
        for k in range(self.columns.size):
            col = x[:, k]
            change = np.flatnonzero(np.diff(np.r_[self.value[k], col]) != 0)  # NaN: change
            if change.size:
                end_t = float(t_s[change[0] - 1]) if change[0] > 0 else self.last_t
                n = self.count[k] + change[0]
                if is_stuck(end_t - self.start_t[k], n, self.limits_s[k]):
                    self.ended[k].append((float(self.start_t[k]), end_t))
                # stretches that start and end inside the chunk
                starts, ends = change[:-1], change[1:] - 1
                long = is_stuck(t_s[ends] - t_s[starts], ends - starts + 1, self.limits_s[k])
                self.ended[k].extend((float(t_s[a]), float(t_s[b]))
                                     for a, b in zip(starts[long], ends[long]))
                self.start_t[k], self.count[k] = t_s[change[-1]], len(col) - change[-1]
            else:
                self.count[k] += len(col)
            self.value[k] = col[-1]
        self.last_t = float(t_s[-1])
        self._repeats = bool(self.count.max() > 1)

    def stuck_between(self, t_lo_s: float, t_hi_s: float) -> list[str]:
        """The judged channels stuck somewhere in ``[t_lo_s, t_hi_s)``.

        Parameters
        ----------
        t_lo_s, t_hi_s : float
            A decision's window, s.

        Returns
        -------
        list of str
            ``<stream>.<channel>`` of each such channel, in the stream's channel order (the
            keys of :func:`terrain.io.plausibility.stuck_stretches`).
        """
        now = (is_stuck(self.last_t - self.start_t, self.count, self.limits_s)
               & (self.start_t < t_hi_s)) if self._repeats and self.last_t >= t_lo_s else ()
        return [key for k, key in enumerate(self.keys)
                if (len(now) and now[k]) or any(a < t_hi_s and b >= t_lo_s
                                                for a, b in self.ended[k])]
