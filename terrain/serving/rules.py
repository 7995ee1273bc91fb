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
"""

from __future__ import annotations

import functools
from typing import Callable, Sequence

import numpy as np

from terrain.io.plausibility import CHANNEL_LIMITS
from terrain.run import IMU_CHANNELS

#: Largest plausible ``|timestamp|``, s: 1e11 s is 3,170 years, 55 times a Unix time of
#: today (1.8e9 s), while a Unix time in ms is already 1.8e12; at 1e11 s a float64 still
#: resolves 1.5e-5 s, far below the 2.5 ms period of a 400 Hz IMU.
MAX_PLAUSIBLE_TIME_S = 1e11

#: rule(channels, t_s (n,), values (n, n_channels), last_t_s) -> (keep (n,) bool, reason)
SampleRule = Callable[[Sequence[str], np.ndarray, np.ndarray, float], tuple[np.ndarray, str]]


def time_increasing(channels: Sequence[str], t_s: np.ndarray, values: np.ndarray,
                    last_t_s: float) -> tuple[np.ndarray, str]:
    """Keep samples whose time is strictly after every earlier kept sample of the stream.

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
    running = np.maximum.accumulate(np.concatenate(((last_t_s,), t_s)))
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
