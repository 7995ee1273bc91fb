"""Feature calculators: small pure functions over a batch of windows.

Each calculator takes ``x`` of shape ``(n_windows, n_channels, n_samples)`` (SI units of each
channel) and returns ``(n_windows, n_channels)``. Names follow tsfresh's reversible
convention ``<signal>__<feature>[__<param>]``; the registry :data:`STATISTICS` is explicit (no
discovery by introspection).
"""

from __future__ import annotations

from types import MappingProxyType
from typing import Callable, Mapping

import numpy as np
from scipy import signal

from terrain.vehicles.icr import inverse_icr_factor

_EPS = 1e-12


def mean(x: np.ndarray) -> np.ndarray:
    """Mean over samples.

    Parameters
    ----------
    x : numpy.ndarray
        ``(n_windows, n_channels, n_samples)``, each channel in its SI unit.

    Returns
    -------
    numpy.ndarray
        ``(n_windows, n_channels)``, unit of the channel.
    """
    return x.mean(axis=-1)


def std(x: np.ndarray) -> np.ndarray:
    """Population standard deviation over samples.

    Parameters
    ----------
    x : numpy.ndarray
        ``(n_windows, n_channels, n_samples)``, each channel in its SI unit.

    Returns
    -------
    numpy.ndarray
        ``(n_windows, n_channels)``, unit of the channel.
    """
    return x.std(axis=-1)


def _standardised_moment(x: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Standardised central moment ``m_k / m_2^(k/2)`` over samples.

    Parameters
    ----------
    x : numpy.ndarray
        ``(n_windows, n_channels, n_samples)``, each channel in its SI unit.
    k : int
        Order of the moment (3: skewness, 4: kurtosis).

    Returns
    -------
    varies : numpy.ndarray of bool
        ``(n_windows, n_channels)``, ``m_2 > 1e-12`` (the window is not constant).
    moment : numpy.ndarray
        ``(n_windows, n_channels)``, dimensionless (``m_2`` floored at 1e-12).
    """
    d = x - x.mean(axis=-1, keepdims=True)
    d2 = d * d
    m2 = d2.mean(axis=-1)
    # integer powers as products: ``d ** 3`` goes through the general ``pow`` (about 30x
    # slower per element); the results agree to a few ulp
    mk = (d2 * d if k == 3 else d2 * d2 if k == 4 else d ** k).mean(axis=-1)
    return m2 > _EPS, mk / np.maximum(m2, _EPS) ** (k / 2)


def skewness(x: np.ndarray) -> np.ndarray:
    """Fisher skewness m3 / m2^1.5 (0 for a constant window).

    Parameters
    ----------
    x : numpy.ndarray
        ``(n_windows, n_channels, n_samples)``, each channel in its SI unit.

    Returns
    -------
    numpy.ndarray
        ``(n_windows, n_channels)``, dimensionless.
    """
    varies, moment = _standardised_moment(x, 3)
    return np.where(varies, moment, 0.0)


def kurtosis(x: np.ndarray) -> np.ndarray:
    """Excess kurtosis m4 / m2^2 - 3 (0 for a constant window).

    Parameters
    ----------
    x : numpy.ndarray
        ``(n_windows, n_channels, n_samples)``, each channel in its SI unit.

    Returns
    -------
    numpy.ndarray
        ``(n_windows, n_channels)``, dimensionless.
    """
    varies, moment = _standardised_moment(x, 4)
    return np.where(varies, moment - 3.0, 0.0)


def rms(x: np.ndarray) -> np.ndarray:
    """Root mean square over samples.

    Parameters
    ----------
    x : numpy.ndarray
        ``(n_windows, n_channels, n_samples)``, each channel in its SI unit.

    Returns
    -------
    numpy.ndarray
        ``(n_windows, n_channels)``, unit of the channel.
    """
    return np.sqrt((x ** 2).mean(axis=-1))


def minimum(x: np.ndarray) -> np.ndarray:
    """Minimum over samples.

    Parameters
    ----------
    x : numpy.ndarray
        ``(n_windows, n_channels, n_samples)``, each channel in its SI unit.

    Returns
    -------
    numpy.ndarray
        ``(n_windows, n_channels)``, unit of the channel.
    """
    return x.min(axis=-1)


def maximum(x: np.ndarray) -> np.ndarray:
    """Maximum over samples.

    Parameters
    ----------
    x : numpy.ndarray
        ``(n_windows, n_channels, n_samples)``, each channel in its SI unit.

    Returns
    -------
    numpy.ndarray
        ``(n_windows, n_channels)``, unit of the channel.
    """
    return x.max(axis=-1)


def mean_abs_diff(x: np.ndarray) -> np.ndarray:
    """Mean absolute first difference over samples.

    Parameters
    ----------
    x : numpy.ndarray
        ``(n_windows, n_channels, n_samples)``, each channel in its SI unit.

    Returns
    -------
    numpy.ndarray
        ``(n_windows, n_channels)``, unit of the channel per sample.
    """
    return np.abs(np.diff(x, axis=-1)).mean(axis=-1)


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
        Window length, samples.
    rate_hz : float
        Sampling rate, Hz.
    bands_hz : tuple of (low, high)
        Bands ``[low, high)`` in Hz; a band holding no FFT bin gets the nearest bin(s).

    Returns
    -------
    numpy.ndarray
        ``(n_samples // 2 + 1, n_bands)``; column ``k`` is ``1 / m`` on the ``m`` bins of
        band ``k`` and 0 elsewhere, so ``psd @ W`` is the mean density of each band.
    """
    freqs = np.fft.rfftfreq(n_samples, d=1.0 / rate_hz)
    weights = np.zeros((len(freqs), len(bands_hz)))
    for k, (lo, hi) in enumerate(bands_hz):
        sel = (freqs >= lo) & (freqs < hi)
        if not sel.any():
            sel = np.abs(freqs - 0.5 * (lo + hi)) == np.abs(freqs - 0.5 * (lo + hi)).min()
        weights[sel, k] = 1.0 / sel.sum()
    return weights


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
    """
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
        ``(n_windows, n_channels, n_samples)``.
    rate_hz : float
        Sampling rate, Hz.
    bands_hz : tuple of (low, high)
        Bands ``[low, high)`` in Hz; a band holding no FFT bin gets the nearest bin.
    weights : numpy.ndarray or None
        ``band_weights(n_samples, rate_hz, bands_hz)``, precomputed by a caller that
        transforms many batches (computed here when ``None``).
    taper : numpy.ndarray or None
        ``hann_taper(n_samples)``, precomputed likewise.

    Returns
    -------
    numpy.ndarray
        ``(n_windows, n_channels, n_bands)``, log10(unit^2/Hz).
    """
    n = x.shape[-1]
    taper = hann_taper(n) if taper is None else taper
    weights = band_weights(n, rate_hz, bands_hz) if weights is None else weights
    spec = np.fft.rfft((x - x.mean(axis=-1, keepdims=True)) * taper, axis=-1)
    psd = (np.abs(spec) ** 2) / (rate_hz * (taper ** 2).sum())
    psd[..., 1:] *= 2.0
    return np.log10(psd @ weights + _EPS)


def per_speed(current: np.ndarray, speed: np.ndarray, min_speed_m_s: float) -> np.ndarray:
    """Mean current per unit mean wheel speed, A/(m/s).

    ``mean(current) / max(mean(|speed|), min_speed_m_s)``: the floor keeps near-standstill
    windows finite.

    Parameters
    ----------
    current, speed : numpy.ndarray
        ``(n_windows, n_samples)`` in A and m/s.
    min_speed_m_s : float
        Floor of the mean absolute speed, m/s.

    Returns
    -------
    numpy.ndarray
        ``(n_windows,)``, A/(m/s).
    """
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
