"""Plausibility rules applied to every incoming sample (pluggable).

The rules are those of the readers (:mod:`terrain.io.measured` and :mod:`terrain.io.plausibility`),
applied sample by sample instead of file by file:

* ``time_not_increasing``: a timestamp not strictly after the stream's previous one (the
  reader's :class:`~terrain.errors.TimestampError`); the sample is rejected;
* ``non_finite``: a NaN or inf channel value; the sample is rejected, so the alignment
  interpolates linearly across it, which is the reader's repair of isolated non-finite
  samples; a longer burst leaves a timestamp gap that the alignment never bridges;
* ``implausible_rate``: a gyro rate above
  :data:`terrain.io.measured.MAX_PLAUSIBLE_RATE_RAD_S` (deg/s sent as rad/s); rejected.

A rule is any callable ``rule(channels, t_s, values, last_t_s) -> (keep, reason)``; the
service takes a tuple of them, so a robot can add its own.
"""

from __future__ import annotations

from typing import Callable, Sequence

import numpy as np

from terrain.io.measured import MAX_PLAUSIBLE_RATE_RAD_S
from terrain.run import IMU_CHANNELS

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
    running = np.maximum.accumulate(np.r_[last_t_s, t_s])
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
    cols = [i for i, c in enumerate(channels) if c in IMU_CHANNELS[:3]]
    if not cols:
        return np.ones(len(t_s), dtype=bool), "implausible_rate"
    with np.errstate(invalid="ignore"):
        ok = ~(np.abs(values[:, cols]) > MAX_PLAUSIBLE_RATE_RAD_S).any(axis=1)
    return ok, "implausible_rate"


#: The readers' rules, in the order they are applied.
DEFAULT_RULES: tuple[SampleRule, ...] = (finite_values, time_increasing, plausible_gyro)
