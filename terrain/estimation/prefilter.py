"""Signal pre-filters applied to sensor samples before the EKF.

* :func:`ema_filter`: the exponential moving average of seed ``001_59da564c4b2d6a48.txt``
  eq. 6.12 / 7.8, ``z_new = alpha z_prev + (1 - alpha) z_raw``.
* :func:`robust_noise_std`: a data-driven noise level for a measurement row (the thesis
  measured R in static tests, ch. 4.4.3; while driving, the residual about a short moving
  average gives the same quantity).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.ndimage import uniform_filter1d
from scipy.signal import lfilter

from terrain.errors import EstimationError, is_integer, refuse_booleans


def ema_filter(values: np.ndarray, alpha: float,
               angle_columns: Sequence[int] = ()) -> np.ndarray:
    """Exponential moving average along axis 0 (seed 001 eq. 6.12).

    ``y_0 = z_0``, ``y_k = alpha y_{k-1} + (1 - alpha) z_k``. ``alpha = 0`` returns the input
    unchanged. A non-finite sample is replaced, inside the recursion, by the previous finite
    *input* sample (held over; leading ones by the first finite sample), so the average keeps
    moving towards it, and stays non-finite in the output, so the EKF still skips and counts
    it: ``[0, 10, nan, 10]`` with ``alpha = 0.5`` gives ``[0, 5, nan, 8.75]`` (repeating the
    previous output instead would give 7.5 at the end).

    Angles (``angle_columns``) are averaged along their unwrapped sequence (``numpy.unwrap``
    over the held-over samples): a heading reported in [-pi, pi) jumps by 2 pi where it
    crosses pi, and averaging across the jump would invent headings in between. Their
    output is left unwrapped (within 2 pi k of the input; the EKF wraps the innovation,
    :func:`terrain.estimation.model.wrap_angle`); a sequence with no step over pi comes out
    as if it were not an angle.

    Parameters
    ----------
    values : ndarray, shape (k,) or (k, d)
        Samples of one sensor, in time order.
    alpha : float
        Smoothing coefficient in [0, 1) (0.1 in eq. 6.12; 0.2 for the camera, ch. 7.2.2).
    angle_columns : sequence of int
        Columns of ``values`` (``(k, d)`` input) that are angles in rad.

    Returns
    -------
    ndarray, same shape as ``values``

    Raises
    ------
    EstimationError
        ``alpha`` not a number in [0, 1) (a boolean or text included), ``values`` not of
        shape ``(k,)`` or ``(k, d)`` or holding booleans (a mask was averaged as 0 and 1),
        or an angle column that is not an integer or lies outside the values' columns.

    Examples
    --------
    >>> ema_filter(np.array([0.0, 10.0, np.nan, 10.0]), 0.5).tolist()
    [0.0, 5.0, nan, 8.75]
    """
    try:      # (float() took the text "0.5", and False as "no filtering")
        if isinstance(alpha, (bool, np.bool_, str, bytes)):
            raise TypeError
        ok = 0.0 <= float(alpha) < 1.0
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise EstimationError(f"EMA alpha must be a number in [0, 1), got {alpha!r}")
    refuse_booleans(EstimationError, "ema_filter", values=values)
    v = np.asarray(values, dtype=float)
    if v.ndim not in (1, 2):        # (a scalar was a bare IndexError, (k, d, e) taken as 1 column)
        raise EstimationError(f"EMA values must have shape (k,) or (k, d), got {v.shape}")
    n_columns = v.shape[1] if v.ndim == 2 else 1
    # (0.5 passed as column 0, then a bare IndexError)
    if not all(is_integer(c) for c in angle_columns):
        raise EstimationError(f"EMA angle columns must be integer column indices, got "
                              f"{list(angle_columns)}")
    if any(not 0 <= int(c) < n_columns for c in angle_columns):
        raise EstimationError(f"EMA angle columns {list(angle_columns)} outside the "
                              f"{n_columns} column(s) of the values")
    if alpha == 0.0 or v.shape[0] == 0:
        return v.copy()
    flat = v.reshape(v.shape[0], -1)
    bad = ~np.isfinite(flat)
    filled = flat.copy()
    if bad.any():
        for j in range(flat.shape[1]):
            col = filled[:, j]
            idx = np.where(~bad[:, j], np.arange(col.size), 0)
            np.maximum.accumulate(idx, out=idx)
            first = np.flatnonzero(~bad[:, j])
            col[:] = col[idx] if first.size else 0.0
            if first.size:
                col[: first[0]] = col[first[0]]
    angles = list(angle_columns)
    if angles:
        filled[:, angles] = np.unwrap(filled[:, angles], axis=0)
    a = float(alpha)
    out, _ = lfilter([1.0 - a], [1.0, -a], filled, axis=0, zi=a * filled[:1])
    out[bad] = np.nan
    return out.reshape(v.shape)


def robust_noise_std(values: np.ndarray, rate_hz: float, window_s: float = 0.5) -> np.ndarray:
    """Noise standard deviation of each column: 1.4826 x MAD of the signal minus its
    ``window_s`` moving average (non-finite samples ignored).

    Parameters
    ----------
    values : ndarray, shape (k,) or (k, d)
        Samples (any unit), one column per channel.
    rate_hz : float
        Sampling rate, Hz.
    window_s : float
        Moving-average window, s: ``round(window_s rate_hz)`` samples, made odd (the next
        odd number, so that it is centred) and at least 3 (0.5 s at 100 Hz: 51 samples).

    Returns
    -------
    ndarray, shape (d,) (or a 0-d array for 1-D input), units of ``values``.
        NaN for a column with fewer finite samples than the window (none at all included);
        a column of exactly as many has its value.

    Raises
    ------
    EstimationError
        ``rate_hz`` or ``window_s`` not a finite number > 0 (a boolean or text included), or
        ``values`` not of shape ``(k,)`` or ``(k, d)`` or holding booleans (a mask's 0/1
        steps were measured as noise).
    """
    for name, value in (("rate_hz", rate_hz), ("window_s", window_s)):
        try:     # (float() takes True as 1 and the text "100" as 100: neither is a rate)
            ok = (not isinstance(value, (bool, np.bool_, str, bytes))
                  and bool(np.isfinite(float(value)) and float(value) > 0.0))
        except (TypeError, ValueError):
            ok = False
        if not ok:
            raise EstimationError(f"robust_noise_std: {name} must be a finite number > 0, "
                                  f"got {value!r}")
    refuse_booleans(EstimationError, "robust_noise_std", values=values)
    v = np.asarray(values, dtype=float)
    if v.ndim not in (1, 2):
        raise EstimationError(f"robust_noise_std: values must have shape (k,) or (k, d), got "
                              f"{v.shape}")
    flat = v[:, None] if v.ndim == 1 else v
    w = max(3, int(round(window_s * rate_hz)) | 1)
    out = np.empty(flat.shape[1])
    for j in range(flat.shape[1]):
        col = flat[:, j]
        col = col[np.isfinite(col)]
        if col.size < w:
            out[j] = np.nan
            continue
        res = col - uniform_filter1d(col, w, mode="nearest")
        out[j] = 1.4826 * np.median(np.abs(res - np.median(res)))
    return out if v.ndim > 1 else out[0]
