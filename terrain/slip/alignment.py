"""Time alignment of the encoder and velocity sources (seed 001 ch. 7.2.2).

The wheel encoders of AgriMaRo report a low-pass filtered speed (ODrive Hall-sensor filter),
so the rim speed lags the velocity estimated from camera and IMU, which produces false
negative slip in acceleration transients. Two remedies:

* the thesis's: slow the camera down with its EMA (``alpha = 0.2``, eq. 7.8) and leave the
  encoders unfiltered (``AgriMaRoEKFSettings.ema_alpha``);
* :func:`estimate_lag`: measure the lag from the data by cross-correlating the time
  derivatives of the two speeds (transients dominate the derivative, constant slip offsets
  drop out) and subtract it from the encoder timestamps before filtering and before the slip
  is computed. The slip at time ``t`` then uses the encoder sample taken at ``t + lag``
  (post-processing; online, delay the velocity by ``lag`` instead).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from terrain.errors import EstimationError


@dataclass(frozen=True)
class LagEstimate:
    """Result of :func:`estimate_lag`.

    Attributes
    ----------
    lag_s : float
        Delay of the signal behind the reference, s (positive: the signal lags).
    correlation : float
        Normalised cross-correlation of the derivatives at the peak (-1..1).
    n_samples : int
        Samples of the common grid used.
    """

    lag_s: float
    correlation: float
    n_samples: int


def estimate_lag(t_ref_s: np.ndarray, ref: np.ndarray, t_sig_s: np.ndarray, sig: np.ndarray,
                 *, max_lag_s: float = 1.0, rate_hz: float = 100.0) -> LagEstimate:
    """Delay of ``sig`` behind ``ref`` from the cross-correlation of their derivatives.

    Both series are linearly interpolated on a common uniform grid at ``rate_hz`` over their
    overlap (NaN samples dropped), differentiated, and cross-correlated over lags in
    ``[-max_lag_s, max_lag_s]``; the peak is refined by a parabola through its neighbours.

    Parameters
    ----------
    t_ref_s, ref : ndarray, shape (k1,)
        Reference signal (e.g. the camera forward speed), s and its unit.
    t_sig_s, sig : ndarray, shape (k2,)
        Delayed signal (e.g. the encoder rim speed), same unit.
    max_lag_s : float
        Largest lag searched, s (> 0).
    rate_hz : float
        Grid rate, Hz.

    Returns
    -------
    LagEstimate

    Raises
    ------
    EstimationError
        Too little overlap or a flat signal (no transient to align on).
    """
    if not (max_lag_s > 0 and rate_hz > 0):
        raise EstimationError("max_lag_s and rate_hz must be > 0")
    tr, r = _finite(t_ref_s, ref)
    ts, s = _finite(t_sig_s, sig)
    t0, t1 = max(tr[0], ts[0]), min(tr[-1], ts[-1])
    max_k = int(round(max_lag_s * rate_hz))
    n = int(np.floor((t1 - t0) * rate_hz)) + 1 if t1 > t0 else 0
    if n < 4 * max_k or n < 20:
        raise EstimationError(f"signals overlap {max(t1 - t0, 0):.2f} s, too short to estimate "
                              f"a lag of up to {max_lag_s} s")
    grid = t0 + np.arange(n) / rate_hz
    a = np.gradient(np.interp(grid, tr, r))
    b = np.gradient(np.interp(grid, ts, s))
    a -= a.mean()
    b -= b.mean()
    na, nb = np.linalg.norm(a), np.linalg.norm(b)
    if na == 0 or nb == 0:
        raise EstimationError("a signal is constant: no transient to estimate the lag from")
    nfft = 1 << int(np.ceil(np.log2(2 * n)))
    xc = np.fft.irfft(np.fft.rfft(b, nfft) * np.conj(np.fft.rfft(a, nfft)), nfft)
    lags = np.arange(-max_k, max_k + 1)
    vals = xc[lags % nfft] / (na * nb)
    i = int(np.argmax(vals))
    frac = 0.0
    if 0 < i < vals.size - 1:
        y0, y1, y2 = vals[i - 1], vals[i], vals[i + 1]
        den = y0 - 2 * y1 + y2
        frac = 0.5 * (y0 - y2) / den if den != 0 else 0.0
    return LagEstimate(lag_s=float((lags[i] + frac) / rate_hz), correlation=float(vals[i]),
                       n_samples=int(n))


def _finite(t: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    t = np.asarray(t, dtype=float)
    v = np.asarray(v, dtype=float)
    if t.shape != v.shape or t.ndim != 1:
        raise EstimationError(f"time and values must be 1-D of one shape, got {t.shape}, "
                              f"{v.shape}")
    ok = np.isfinite(t) & np.isfinite(v)
    if ok.sum() < 20:
        raise EstimationError("fewer than 20 finite samples")
    return t[ok], v[ok]
