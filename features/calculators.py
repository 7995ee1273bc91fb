"""Feature calculators: small pure functions over a batch of windows.

Each calculator takes ``x`` of shape ``(n_windows, n_channels, n_samples)`` (SI units of each
channel) and returns ``(n_windows, n_channels)``. Names follow tsfresh's reversible
convention ``<signal>__<feature>[__<param>]``; the registry :data:`STATISTICS` is explicit (no
discovery by introspection).
"""

from __future__ import annotations

from types import MappingProxyType
from typing import Callable, Mapping, Sequence

import numba
import numpy as np
from scipy import signal

from terrain.errors import (ConfigError, ShapeError, config_integer, config_numbers,
                            config_positive, real_arrays)
from terrain.vehicles.icr import inverse_icr_factor

_EPS = 1e-12
_INF = float("inf")


#: Statistic names in the order of their codes in :func:`_statistics_kernel`.
_STATISTIC_NAMES = ("mean", "std", "skewness", "kurtosis", "rms", "min", "max",
                    "mean_abs_diff")


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _statistics_kernel(x, codes, out):   # pragma: no cover - compiled
    """The statistics of every row of ``x`` (``(m, n)``), one pass for the sums, extremes
    and first differences and one for the central moments; ``out[r, k]`` is the statistic
    of code ``codes[k]`` (the order of :data:`_STATISTIC_NAMES`) of row ``r``.

    Definitions (population moments, ``d = x - mean``): ``std = sqrt(mean(d^2))``;
    skewness ``mean(d^3) / m2^1.5`` and excess kurtosis ``mean(d^4) / m2^2 - 3`` with
    ``m2 = mean(d^2)``, both 0 when ``m2 <= 1e-12`` (a constant window); ``rms =
    sqrt(mean(x^2))``; ``mean_abs_diff = mean(|x[i+1] - x[i]|)`` (NaN for one sample). A
    NaN sample makes every statistic of its row NaN."""
    m, n = x.shape
    for r in range(m):
        total = total_sq = total_abs_diff = 0.0
        x0 = lo = hi = x[r, 0]
        has_nan = False
        for i in range(n):
            v = x[r, i]
            total += v - x0   # offsets from the first sample: the level is not rounded
            total_sq += v * v
            if v < lo:
                lo = v
            if v > hi:
                hi = v
            if v != v:
                has_nan = True
            if i > 0:
                total_abs_diff += abs(v - x[r, i - 1])
        mu = x0 + total / n
        dm = s2 = s3 = s4 = 0.0
        for i in range(n):
            d = x[r, i] - mu
            d2 = d * d
            dm += d
            s2 += d2
            s3 += d2 * d
            s4 += d2 * d2
        # moments about the exact mean mu + dm from those about the rounded mu (the
        # corrected two-pass algorithm, Chan, Golub & LeVeque 1983, Am. Stat. 37(3))
        dm, s2, s3, s4 = dm / n, s2 / n, s3 / n, s4 / n
        mean = mu + dm
        m2 = max(s2 - dm * dm, 0.0)
        m3 = s3 - 3.0 * dm * s2 + 2.0 * dm * dm * dm
        m4 = s4 - 4.0 * dm * s3 + 6.0 * dm * dm * s2 - 3.0 * dm * dm * dm * dm
        varies = m2 > _EPS
        for k in range(codes.shape[0]):
            c = codes[k]
            if c == 0:
                val = mean
            elif c == 1:
                val = np.sqrt(m2)
            elif c == 2:
                val = m3 / max(m2, _EPS) ** 1.5 if varies or m2 != m2 else 0.0
            elif c == 3:
                val = m4 / max(m2, _EPS) ** 2 - 3.0 if varies or m2 != m2 else 0.0
            elif c == 4:
                val = np.sqrt(total_sq / n)
            elif c == 5:
                val = np.nan if has_nan else lo
            elif c == 6:
                val = np.nan if has_nan else hi
            else:
                val = total_abs_diff / (n - 1)
            out[r, k] = val


def statistics(x: np.ndarray, names: Sequence[str]) -> np.ndarray:
    """Several statistics of every window and channel at once (one compiled pass).

    The one implementation of the statistics of :data:`STATISTICS` (each of those functions
    is this with one name): population moments over the last axis, ``d = x - mean``:

    * ``mean``; ``std`` ``sqrt(mean(d^2))``; ``rms`` ``sqrt(mean(x^2))``; ``min``; ``max``;
    * ``skewness`` (Fisher, biased) ``m3 / m2^1.5`` and ``kurtosis`` (excess, biased)
      ``m4 / m2^2 - 3``, ``m_k = mean(d^k)``, both 0 for a constant window
      (``m2 <= 1e-12``), as ``scipy.stats.skew`` / ``kurtosis`` with ``bias=True`` give them
      otherwise (tested against scipy, ``features/reference.py``);
    * ``mean_abs_diff``: ``mean(|x[i+1] - x[i]|)``, NaN for a one-sample window.

    A NaN sample makes every statistic of its window and channel NaN.

    Parameters
    ----------
    x : numpy.ndarray
        ``(..., n_samples)``, e.g. ``(n_windows, n_channels, n_samples)``, each channel in
        its SI unit; ``n_samples >= 1``.
    names : sequence of str
        Statistic names (keys of :data:`STATISTICS`), in output order.

    Returns
    -------
    numpy.ndarray
        ``(..., len(names))`` float64: the statistics of each row of ``x`` in the order of
        ``names``; unit of the channel (``mean``, ``std``, ``rms``, ``min``, ``max``), per
        sample (``mean_abs_diff``) or dimensionless (``skewness``, ``kurtosis``).

    Raises
    ------
    ConfigError
        An unknown statistic name, or ``names`` given as one text or not a sequence (None).
    DataFormatError
        ``x`` holds booleans (a mask) or does not convert to real numbers (text).
    ShapeError
        ``x`` is a scalar or holds no sample per row.
    """
    if isinstance(names, str):    # ("mean" was read as the unknown names 'm', 'e', 'a', 'n')
        raise ConfigError(f"statistics: names must be a sequence of names, got the text "
                          f"{names!r}; one name is written ({names!r},)")
    if not hasattr(names, "__iter__"):      # (None was a bare TypeError)
        raise ConfigError(f"statistics: names must be a sequence of names, got {names!r}")
    unknown = [s for s in names if s not in _STATISTIC_NAMES]
    if unknown:
        raise ConfigError(f"unknown statistics {unknown}; valid: {list(_STATISTIC_NAMES)}")
    x, = real_arrays("statistics", x=x)
    if x.ndim < 1 or x.shape[-1] < 1:
        raise ShapeError(f"statistics need at least one sample per row, got shape {x.shape}")
    rows = np.ascontiguousarray(x.reshape(-1, x.shape[-1]))
    out = np.empty((len(rows), len(names)))
    _statistics_kernel(rows, np.array([_STATISTIC_NAMES.index(s) for s in names],
                                      dtype=np.int64), out)
    return out.reshape(x.shape[:-1] + (len(names),))


def mean(x: np.ndarray) -> np.ndarray:
    """Mean over samples.

    :func:`statistics` with ``names=("mean",)``, where the definition lives.

    Parameters
    ----------
    x : numpy.ndarray
        ``(n_windows, n_channels, n_samples)`` (or any ``(..., n_samples)``), each channel
        in its SI unit.

    Returns
    -------
    numpy.ndarray
        ``(n_windows, n_channels)`` (``x.shape[:-1]``), unit of the channel.
    """
    return statistics(x, ("mean",))[..., 0]


def std(x: np.ndarray) -> np.ndarray:
    """Population standard deviation over samples.

    :func:`statistics` with ``names=("std",)``, where the definition lives.

    Parameters
    ----------
    x : numpy.ndarray
        ``(n_windows, n_channels, n_samples)`` (or any ``(..., n_samples)``), each channel
        in its SI unit.

    Returns
    -------
    numpy.ndarray
        ``(n_windows, n_channels)`` (``x.shape[:-1]``), unit of the channel.
    """
    return statistics(x, ("std",))[..., 0]


def skewness(x: np.ndarray) -> np.ndarray:
    """Fisher skewness m3 / m2^1.5 (0 for a constant window).

    :func:`statistics` with ``names=("skewness",)``, where the definition lives.

    Parameters
    ----------
    x : numpy.ndarray
        ``(n_windows, n_channels, n_samples)`` (or any ``(..., n_samples)``), each channel
        in its SI unit.

    Returns
    -------
    numpy.ndarray
        ``(n_windows, n_channels)`` (``x.shape[:-1]``), dimensionless.
    """
    return statistics(x, ("skewness",))[..., 0]


def kurtosis(x: np.ndarray) -> np.ndarray:
    """Excess kurtosis m4 / m2^2 - 3 (0 for a constant window).

    :func:`statistics` with ``names=("kurtosis",)``, where the definition lives.

    Parameters
    ----------
    x : numpy.ndarray
        ``(n_windows, n_channels, n_samples)`` (or any ``(..., n_samples)``), each channel
        in its SI unit.

    Returns
    -------
    numpy.ndarray
        ``(n_windows, n_channels)`` (``x.shape[:-1]``), dimensionless.
    """
    return statistics(x, ("kurtosis",))[..., 0]


def rms(x: np.ndarray) -> np.ndarray:
    """Root mean square over samples.

    :func:`statistics` with ``names=("rms",)``, where the definition lives.

    Parameters
    ----------
    x : numpy.ndarray
        ``(n_windows, n_channels, n_samples)`` (or any ``(..., n_samples)``), each channel
        in its SI unit.

    Returns
    -------
    numpy.ndarray
        ``(n_windows, n_channels)`` (``x.shape[:-1]``), unit of the channel.
    """
    return statistics(x, ("rms",))[..., 0]


def minimum(x: np.ndarray) -> np.ndarray:
    """Minimum over samples.

    :func:`statistics` with ``names=("min",)``, where the definition lives.

    Parameters
    ----------
    x : numpy.ndarray
        ``(n_windows, n_channels, n_samples)`` (or any ``(..., n_samples)``), each channel
        in its SI unit.

    Returns
    -------
    numpy.ndarray
        ``(n_windows, n_channels)`` (``x.shape[:-1]``), unit of the channel.
    """
    return statistics(x, ("min",))[..., 0]


def maximum(x: np.ndarray) -> np.ndarray:
    """Maximum over samples.

    :func:`statistics` with ``names=("max",)``, where the definition lives.

    Parameters
    ----------
    x : numpy.ndarray
        ``(n_windows, n_channels, n_samples)`` (or any ``(..., n_samples)``), each channel
        in its SI unit.

    Returns
    -------
    numpy.ndarray
        ``(n_windows, n_channels)`` (``x.shape[:-1]``), unit of the channel.
    """
    return statistics(x, ("max",))[..., 0]


def mean_abs_diff(x: np.ndarray) -> np.ndarray:
    """Mean absolute first difference over samples (NaN for one sample).

    :func:`statistics` with ``names=("mean_abs_diff",)``, where the definition lives.

    Parameters
    ----------
    x : numpy.ndarray
        ``(n_windows, n_channels, n_samples)`` (or any ``(..., n_samples)``), each channel
        in its SI unit.

    Returns
    -------
    numpy.ndarray
        ``(n_windows, n_channels)`` (``x.shape[:-1]``), unit of the channel per sample.
    """
    return statistics(x, ("mean_abs_diff",))[..., 0]


STATISTICS: Mapping[str, Callable[[np.ndarray], np.ndarray]] = MappingProxyType({
    "mean": mean, "std": std, "skewness": skewness, "kurtosis": kurtosis, "rms": rms,
    "min": minimum, "max": maximum, "mean_abs_diff": mean_abs_diff,
})


def band_weights(n_samples: int, rate_hz: float,
                 bands_hz: tuple[tuple[float, float], ...]) -> np.ndarray:
    """Averaging matrix from one-sided FFT bins to frequency bands.

    Parameters
    ----------
    n_samples : int
        Window length, samples (an integer >= 1).
    rate_hz : float
        Sampling rate, Hz.
    bands_hz : tuple of (low, high)
        Bands ``[low, high)`` in Hz, finite, ``low < high``, overlapping ``[0, rate_hz / 2]``
        (``high > 0``, ``low`` at most the Nyquist frequency); a band holding no FFT bin
        gets the nearest bin(s). A bin within ``1e-9`` of the bin spacing of an edge counts
        as on it (the float rounding of the bin frequencies and of the edges, e.g. 5 Hz as
        4.999999999999999 Hz, would put it in the band below).

    Returns
    -------
    numpy.ndarray
        ``(n_samples // 2 + 1, n_bands)``; column ``k`` is ``1 / m`` on the ``m`` bins of
        band ``k`` and 0 elsewhere, so ``psd @ W`` is the mean density of each band.

    Raises
    ------
    ConfigError
        ``n_samples`` not an integer >= 1, ``rate_hz`` not a finite number > 0, a band that
        is not a ``(low, high)`` pair of real numbers (booleans and text refused), or a band
        that is not finite, has ``low >= high``, ends at or below 0 Hz or starts above the
        Nyquist frequency (it would hold no content, only a borrowed nearest bin), or
        ``bands_hz`` not a sequence of bands (None, a number).
    """
    # (0 was a bare ZeroDivisionError, 2.5 or -4 an error inside NumPy, True one sample)
    config_integer("band_weights.n_samples", n_samples, 1)
    config_numbers("band_weights", rate_hz=rate_hz)
    if not (np.isfinite(rate_hz) and rate_hz > 0):
        raise ConfigError(f"band_weights: rate_hz must be a finite number > 0 Hz, "
                          f"got {rate_hz!r}")
    nyquist = 0.5 * rate_hz
    if not hasattr(bands_hz, "__iter__"):      # (None was a bare TypeError)
        raise ConfigError(f"band_weights.bands_hz must be a sequence of (low, high) pairs in "
                          f"Hz, got {bands_hz!r:.60}")
    bands_hz = tuple(_band_edges(k, band) for k, band in enumerate(bands_hz))
    for lo, hi in bands_hz:
        if not (np.isfinite(lo) and np.isfinite(hi)):
            raise ConfigError(f"band ({lo:g}, {hi:g}) Hz: the edges must be finite")
        if not lo < hi:
            raise ConfigError(f"band ({lo:g}, {hi:g}) Hz must have its lower edge below its "
                              f"upper")
        if hi <= 0.0:
            raise ConfigError(f"band ({lo:g}, {hi:g}) Hz must end above 0 Hz")
        if lo > nyquist:
            raise ConfigError(f"band ({lo:g}, {hi:g}) Hz starts above the Nyquist frequency "
                              f"{nyquist:g} Hz of a {rate_hz:g} Hz signal: it holds no "
                              f"content")
    freqs = np.fft.rfftfreq(n_samples, d=1.0 / rate_hz)
    # a bin on an edge (to rounding: 1e-9 of the bin spacing) is the band's it starts
    tol = 1e-9 * rate_hz / n_samples
    weights = np.zeros((len(freqs), len(bands_hz)))
    for k, (lo, hi) in enumerate(bands_hz):
        sel = (freqs >= lo - tol) & (freqs < hi - tol)
        if not sel.any():
            sel = np.abs(freqs - 0.5 * (lo + hi)) == np.abs(freqs - 0.5 * (lo + hi)).min()
        weights[sel, k] = 1.0 / sel.sum()
    return weights


def _band_edges(k: int, band) -> tuple[float, float]:
    """Band ``k`` of ``bands_hz`` as its two edges, refused unless a (low, high) pair of real
    numbers (three edges or one number was NumPy's unpacking error, text its ``isfinite``
    error, and ``True`` passed as 1 Hz)."""
    try:
        if isinstance(band, (str, bytes)):
            raise TypeError
        lo, hi = band
    except (TypeError, ValueError):
        raise ConfigError(f"band_weights.bands_hz[{k}] must be a (low, high) pair of edges "
                          f"in Hz, got {band!r:.60}") from None
    config_numbers("band_weights", **{f"bands_hz[{k}][0]": lo, f"bands_hz[{k}][1]": hi})
    return float(lo), float(hi)


def hann_taper(n_samples: int) -> np.ndarray:
    """Periodic Hann taper, as ``scipy.signal.periodogram(window="hann")`` uses.

    Parameters
    ----------
    n_samples : int
        Window length, samples.

    Returns
    -------
    numpy.ndarray
        ``(n_samples,)`` dimensionless taper.

    Raises
    ------
    ConfigError
        ``n_samples`` not an integer >= 1 (0, 2.5 and None were SciPy's bare ValueError or
        TypeError, ``True`` too).
    """
    config_integer("hann_taper.n_samples", n_samples, 1)
    return signal.get_window("hann", n_samples)


def band_log_power(x: np.ndarray, rate_hz: float,
                   bands_hz: tuple[tuple[float, float], ...],
                   weights: np.ndarray | None = None,
                   taper: np.ndarray | None = None) -> np.ndarray:
    """Log10 of the mean power spectral density in frequency bands.

    The window mean is removed and a periodic Hann taper applied before the FFT (one periodogram per
    window; the density is one-sided, unit^2/Hz).

    Parameters
    ----------
    x : numpy.ndarray
        ``(n_windows, n_channels, n_samples)``, computed in float64 whatever its dtype (as
        :func:`statistics` reads it: NumPy transforms float32 in single precision, which
        put the band powers of a 1e4 +- 1e-2 signal 0.03 decades off those of its values).
    rate_hz : float
        Sampling rate, Hz.
    bands_hz : tuple of (low, high)
        Bands ``[low, high)`` in Hz (as :func:`band_weights` accepts them); a band holding
        no FFT bin gets the nearest bin.
    weights : numpy.ndarray or None
        ``band_weights(n_samples, rate_hz, bands_hz)``, precomputed by a caller that
        transforms many batches (computed here when ``None``).
    taper : numpy.ndarray or None
        ``hann_taper(n_samples)``, precomputed likewise.

    Returns
    -------
    numpy.ndarray
        ``(n_windows, n_channels, n_bands)``, log10(unit^2/Hz) of the band's density plus
        ``1e-12`` unit^2/Hz (the floor that keeps a band without power, a constant window's,
        finite at -12: a density near 1e-12 reads above its own log and does not scale with
        the signal).

        A NaN or inf sample makes every band of its window and channel NaN.

    Raises
    ------
    ConfigError
        A band :func:`band_weights` refuses (when ``weights`` is not given), or ``rate_hz``
        not a finite number > 0 (with ``weights`` given, 0 Hz was a NaN density).
    DataFormatError
        ``x`` holds booleans (a mask) or does not convert to real numbers (text).
    ShapeError
        ``x`` a scalar (or None) or of fewer than 2 samples per row (one sample, the mean
        removed, read as a band power of exactly 0: ``-12``), or ``weights`` / ``taper``
        not of this window length (``(n_samples // 2 + 1, n_bands)`` / ``(n_samples,)``;
        NumPy's bare matmul or broadcasting error).
    """
    x, = real_arrays("band_log_power", x=x)
    if x.ndim < 1 or x.shape[-1] < 2:
        raise ShapeError(f"band_log_power: x needs at least 2 samples per row (a spectrum), "
                         f"got shape {x.shape}")
    n = x.shape[-1]
    if weights is None:
        weights = band_weights(n, rate_hz, bands_hz)
    else:
        # (band_weights checks it otherwise; fast path for the transformers' float rate)
        if not (isinstance(rate_hz, float) and 0.0 < rate_hz < _INF):
            config_positive("band_log_power", rate_hz=rate_hz)
        shape = getattr(weights, "shape", ())
        if len(shape) != 2 or shape[0] != n // 2 + 1:
            raise ShapeError(f"band_log_power: weights of shape {np.shape(weights)} for "
                             f"windows of {n} samples; band_weights gives "
                             f"({n // 2 + 1}, n_bands)")
    taper = hann_taper(n) if taper is None else taper
    if getattr(taper, "shape", None) != (n,):
        raise ShapeError(f"band_log_power: taper of shape {np.shape(taper)} for windows of "
                         f"{n} samples")
    spec = np.fft.rfft((x - x.mean(axis=-1, keepdims=True)) * taper, axis=-1)
    psd = (np.abs(spec) ** 2) / (rate_hz * (taper ** 2).sum())
    # one-sided: every bin but DC and, for an even length, Nyquist holds its mirror's power
    psd[..., 1:(n - 1) // 2 + 1] *= 2.0
    return np.log10(psd @ weights + _EPS)


@numba.njit(cache=True, nogil=True)
def quantile_sorted(sorted_x, q):   # pragma: no cover - compiled
    """``numpy.quantile(x, q)`` of an already sorted 1-D array, numba-compiled.

    NumPy's default method (``linear``: position ``q (n - 1)``) with its two-sided
    interpolation (from the lower neighbour when the fraction is below 0.5, from the upper
    one otherwise), so the result equals :func:`numpy.quantile`'s to the last bit (tested).
    Used inside compiled kernels (:mod:`features.wheel_physics`) and by the streaming
    service's per-window rules, where :func:`numpy.percentile` costs ~15 times more.

    Parameters
    ----------
    sorted_x : numpy.ndarray
        ``(n,)`` values sorted ascending, ``n >= 1`` (any unit; NaN-free).
    q : float
        Quantile in [0, 1].

    Returns
    -------
    float
        The ``q`` quantile, in the unit of ``sorted_x``.

    Raises
    ------
    ValueError
        ``q`` outside [0, 1] (or NaN), or ``sorted_x`` empty (compiled code has no bounds
        check: they read memory beyond the array's ends).
    """
    if not 0.0 <= q <= 1.0:
        raise ValueError("quantile_sorted: q must be a number in [0, 1]")
    if sorted_x.shape[0] < 1:
        raise ValueError("quantile_sorted: sorted_x must hold at least one value")
    pos = q * (sorted_x.shape[0] - 1)
    lo = int(np.floor(pos))
    hi = min(lo + 1, sorted_x.shape[0] - 1)
    t = pos - lo
    a, b = sorted_x[lo], sorted_x[hi]
    return b - (b - a) * (1.0 - t) if t >= 0.5 else a + (b - a) * t


def per_speed(current: np.ndarray, speed: np.ndarray, min_speed_m_s: float) -> np.ndarray:
    """Mean current per unit mean wheel speed, A/(m/s).

    ``mean(current) / max(mean(|speed|), min_speed_m_s)``: the floor keeps near-standstill
    windows finite.

    Parameters
    ----------
    current, speed : numpy.ndarray
        ``(n_windows, n_samples)`` in A and m/s.
    min_speed_m_s : float
        Floor of the mean absolute speed, m/s (finite, > 0).

    Returns
    -------
    numpy.ndarray
        ``(n_windows,)``, A/(m/s).

    Raises
    ------
    ConfigError
        ``min_speed_m_s`` not a finite number > 0 (0 or a negative floor gave an infinite
        feature for a standing window, ``True`` was a floor of 1 m/s, NaN a NaN feature).
    DataFormatError
        ``current`` or ``speed`` holds booleans (a mask was read as 1 A or 1 m/s) or does
        not convert to real numbers (text, None: NumPy's bare TypeError or AttributeError).
    ShapeError
        ``current`` and ``speed`` not of one shape (NumPy broadcast one window's speed to
        every window's current, or failed naming neither), or of no sample per window (a
        NaN feature with a RuntimeWarning).
    """
    if not (isinstance(min_speed_m_s, float) and 0.0 < min_speed_m_s < _INF):
        config_positive("per_speed", min_speed_m_s=min_speed_m_s)
    if not (isinstance(current, np.ndarray) and isinstance(speed, np.ndarray)
            and current.dtype.kind == "f" == speed.dtype.kind and current.shape == speed.shape
            and current.ndim and current.shape[-1]):
        # (the transformers' float windows skip the checks: this runs per decision)
        current, speed = real_arrays("per_speed", current=current, speed=speed)
        if current.shape != speed.shape or not current.ndim or not current.shape[-1]:
            raise ShapeError(f"per_speed: current and speed must be (n_windows, n_samples >= "
                             f"1) arrays of one shape, got {current.shape} and {speed.shape}")
    return current.mean(axis=-1) / np.maximum(np.abs(speed).mean(axis=-1), min_speed_m_s)


def regression_gain(y: np.ndarray, x: np.ndarray, floor: float) -> np.ndarray:
    """Least-squares gain of ``y`` on ``x`` through the origin, ridge-floored, per window.

    With ``y`` the gyro yaw rate and ``x`` the ideal differential-drive yaw rate
    ``(v_R - v_L) / B`` this is ``1 / chi``, the inverse ICR expansion factor of the
    skid-steer; the fit is :func:`terrain.vehicles.icr.inverse_icr_factor` (model and
    sources there).

    Parameters
    ----------
    y : numpy.ndarray
        ``(n_windows, n_samples)``, gyro yaw rate, rad/s.
    x : numpy.ndarray
        ``(n_windows, n_samples)``, commanded yaw rate ``(v_R - v_L) / B``, rad/s.
    floor : float
        Ridge floor, rad/s (same unit as ``x``): the denominator is
        ``sum(x^2) + n_samples floor^2``, which pulls the gain to 0 when the robot barely
        turns.

    Returns
    -------
    numpy.ndarray
        ``(n_windows,)``, ``sum(x y) / (sum(x^2) + n floor^2)`` (dimensionless).
    """
    return inverse_icr_factor(y, x, floor)
