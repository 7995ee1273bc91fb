"""Per-window reference implementation of :class:`features.transformers.WindowFeatures`.

Built from ``scipy.stats`` and ``scipy.signal.periodogram`` one window and one channel at a
time: slow, but independent of the vectorised calculators. The benchmark times both in the
same process (speed ratio) and the tests check they agree.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
from scipy import signal, stats

from features.transformers import WindowFeatures
from terrain.run import IMU_CHANNELS


def reference_features(X: np.ndarray, channels: Sequence[str], rate_hz: float) -> np.ndarray:
    """Same columns as ``WindowFeatures(channels, rate_hz)`` with default settings.

    Parameters
    ----------
    X : numpy.ndarray
        ``(n_windows, n_channels, n_samples)`` windows, each channel in its SI unit (read
        as float64, as ``WindowFeatures`` reads them: float32 windows are not computed in
        float32).
    channels : sequence of str
        Names of the channels, in the order of axis 1 of ``X``.
    rate_hz : float
        Sampling rate of the windows, Hz (sets the periodogram frequencies and the default
        bands up to ``rate_hz/2``).

    Returns
    -------
    numpy.ndarray
        ``(n_windows, n_features)``, columns in the order of
        ``WindowFeatures(channels, rate_hz).get_feature_names_out()``.
    """
    X = np.asarray(X, dtype=float)     # (float32 moments were 1e-2 off WindowFeatures')
    fx = WindowFeatures(tuple(channels), rate_hz).fit(X)
    idx = {c: i for i, c in enumerate(channels)}
    rows = []
    for w in X:
        row = []
        for x in w:
            row += [x.mean(), x.std(), stats.skew(x) if x.std() > 1e-6 else 0.0,
                    stats.kurtosis(x) if x.std() > 1e-6 else 0.0, np.sqrt(np.mean(x ** 2)),
                    x.min(), x.max(), np.mean(np.abs(np.diff(x)))]
        for c in channels:
            if c not in IMU_CHANNELS:
                continue
            f, p = signal.periodogram(w[idx[c]], fs=rate_hz, window="hann", detrend="constant",
                                      scaling="density")
            # WindowFeatures' rule: [lo, hi) with a bin within 1e-9 of the bin spacing of
            # an edge on it (rfftfreq gives 5 Hz as 4.999999999999999), and the nearest
            # bin(s) for a band holding none (a short window's bins are wider than a band)
            tol = 1e-9 * (f[1] - f[0]) if len(f) > 1 else 0.0
            for lo, hi in fx.bands_:
                sel = (f >= lo - tol) & (f < hi - tol)
                if not sel.any():
                    gap = np.abs(f - 0.5 * (lo + hi))
                    sel = gap == gap.min()
                row.append(np.log10(p[sel].mean() + 1e-12))
        for name in fx.get_feature_names_out()[len(row):]:
            sig = name.split("__")[0]
            if name.endswith("per_speed"):
                vel = w[idx["vel_" + sig[-1]]]
                row.append(w[idx[sig]].mean() / max(np.abs(vel).mean(), fx.min_speed_m_s))
            else:
                x, y = w[idx["yaw_rate_wheels"]], w[idx["wz"]]
                row.append(np.dot(x, y) / (np.dot(x, x) + len(x) * fx.turn_floor_rad_s ** 2))
        rows.append(row)
    return np.asarray(rows)
