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

A cross-correlation always has a maximum, clear or not. :func:`gated_lag` accepts it only as a
clear peak (:class:`LagGate`): a correlation of at least ``min_correlation``, not at the end
of the searched range, and, where both halves of the overlap give a clear peak of their own,
halves that agree. On the shipped BorealTC runs (gyro against the wheel yaw rate, whose
quantised wheel speeds take a handful of values) the whole-run peaks are 0.02-0.26 and the
lags span -1.000 s (the search bound) to +0.909 s, with halves of one run disagreeing
(SNOW/11: -0.665 and +0.553 s); on simulated runs with a planted lag the peaks are 0.45-0.48
(AgriMaRo, camera speed against rim speed), 0.54-0.55 (Husky on ICE) and 0.78-0.83 (Husky
on ASPHALT), and the halves agree within 0.09 s.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from terrain.errors import (ConfigError, EstimationError, ShapeError, TimeStepError,
                            config_numbers, config_positive, refuse_booleans)


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
    applied : bool
        Whether the lag is to be applied (:func:`gated_lag`; True from :func:`estimate_lag`,
        which does not judge the peak).
    reason : str
        Why it is not applied, in words (empty when applied).
    at_range_end : bool
        Whether the maximum lies on the first or last lag searched (the maximum of a
        correlation still rising there, not a peak).
    """

    lag_s: float
    correlation: float
    n_samples: int
    applied: bool = True
    reason: str = ""
    at_range_end: bool = False

    @property
    def estimated(self) -> bool:
        """Whether a lag was estimated at all (False for :func:`lag_not_estimated`)."""
        return bool(np.isfinite(self.lag_s))


def lag_not_estimated(reason: str) -> LagEstimate:
    """The :class:`LagEstimate` of a lag that could not be estimated: ``lag_s`` and
    ``correlation`` NaN, no samples, not applied, ``reason`` saying why.

    Parameters
    ----------
    reason : str
        Why, in words (a missing reference stream, the :class:`EstimationError` of
        :func:`estimate_lag`).

    Returns
    -------
    LagEstimate
        ``estimated`` False.
    """
    return LagEstimate(float("nan"), float("nan"), 0, applied=False, reason=reason)


@dataclass(frozen=True)
class LagGate:
    """When :func:`gated_lag` applies a cross-correlation lag.

    Parameters
    ----------
    min_correlation : float
        Least normalised cross-correlation of the derivatives at the peak (default 0.3:
        between the shipped BorealTC runs, 0.02-0.26, whose lags are not reproducible, and
        the simulated runs with a planted lag, 0.45-0.83; module docstring). Simulated SNOW
        runs (terrain vibration on the gyro) reach only 0.07-0.09 and lose their lag.
    halves_tolerance_s : float or None
        Largest difference, s, between the lags of the two halves of the overlap when both
        halves give a peak of at least ``min_correlation`` (a half too short or flat for a
        lag of its own, or with a weaker peak, is not compared); None: no halves check.

    Raises
    ------
    ConfigError
        A value that is not a real number, ``min_correlation`` outside [0, 1] (or NaN), or a
        negative (or NaN) tolerance; a :class:`ValueError`, as before.
    """

    min_correlation: float = 0.3
    halves_tolerance_s: float | None = 0.1

    def __post_init__(self) -> None:
        config_numbers("LagGate", optional=("halves_tolerance_s",),
                       min_correlation=self.min_correlation,
                       halves_tolerance_s=self.halves_tolerance_s)
        if not 0.0 <= self.min_correlation <= 1.0:
            raise ConfigError(f"LagGate.min_correlation must be in [0, 1], got "
                              f"{self.min_correlation}")
        if self.halves_tolerance_s is not None and not self.halves_tolerance_s >= 0:
            raise ConfigError(f"LagGate.halves_tolerance_s must be >= 0, got "
                              f"{self.halves_tolerance_s}")


def estimate_lag(t_ref_s: np.ndarray, ref: np.ndarray, t_sig_s: np.ndarray, sig: np.ndarray,
                 *, max_lag_s: float = 1.0, rate_hz: float = 100.0) -> LagEstimate:
    """Delay of ``sig`` behind ``ref`` from the cross-correlation of their derivatives.

    Both series are linearly interpolated on a common uniform grid at ``rate_hz`` over their
    overlap (NaN samples dropped), differentiated, and cross-correlated over lags in
    ``[-max_lag_s, max_lag_s]``; the peak is refined by a parabola through its neighbours.

    Parameters
    ----------
    t_ref_s, ref : ndarray, shape (k1,)
        Reference signal (e.g. the camera forward speed): strictly increasing times, s, and
        its unit.
    t_sig_s, sig : ndarray, shape (k2,)
        Delayed signal (e.g. the encoder rim speed): strictly increasing times, s, same
        unit.
    max_lag_s : float
        Largest lag searched, s (finite, at least half a grid step ``0.5 / rate_hz``).
    rate_hz : float
        Grid rate, Hz (finite, > 0).

    Returns
    -------
    LagEstimate

    Raises
    ------
    ConfigError
        ``max_lag_s`` or ``rate_hz`` not a finite positive number (the argument is named),
        or ``max_lag_s`` under half a grid step (no lag but 0 would be searched).
    TimeStepError
        ``t_ref_s`` or ``t_sig_s`` (their finite samples) not strictly increasing: the
        argument, the first offending sample and the count are named.
    ShapeError
        A time and its values not 1-D of one shape (the arguments are named).
    EstimationError
        Fewer than 20 finite samples in a signal, too little overlap, a flat signal (no
        transient to align on: constant, or a steady ramp whose derivative is constant to
        within the rounding of its values), or a time or signal of booleans; the signal,
        ``ref`` or ``sig`` (or its time), is named.
    """
    # (inf overflowed int() below, NaN compared False)
    config_positive("estimate_lag", max_lag_s=max_lag_s, rate_hz=rate_hz)
    # the nearest grid lag, halves up (Python's round() takes 0.5 to 0 and 2.5 to 2)
    max_k = int(np.floor(max_lag_s * rate_hz + 0.5 + 1e-9))
    if max_k < 1:
        raise ConfigError(f"max_lag_s {max_lag_s:g} s is under half a grid step of "
                          f"{1 / rate_hz:g} s (rate_hz {rate_hz:g}): only the lag 0 would be "
                          "searched")
    tr, r = _finite(t_ref_s, ref, "t_ref_s", "ref")
    ts, s = _finite(t_sig_s, sig, "t_sig_s", "sig")
    t0, t1 = max(tr[0], ts[0]), min(tr[-1], ts[-1])
    n = int(np.floor((t1 - t0) * rate_hz)) + 1 if t1 > t0 else 0
    if n < 4 * max_k or n < 20:
        raise EstimationError(f"signals overlap {max(t1 - t0, 0):.2f} s, too short to estimate "
                              f"a lag of up to {max_lag_s} s")
    grid = t0 + np.arange(n) / rate_hz
    ra, sb = np.interp(grid, tr, r), np.interp(grid, ts, s)
    a, b = np.gradient(ra), np.gradient(sb)
    a -= a.mean()
    b -= b.mean()
    # flat: a derivative varying by no more than the rounding of the values, not only by 0
    # (a steady ramp's constant derivative left its 1e-16 noise, correlated to a lag)
    flat = [name for name, d, v in (("ref", a, ra), ("sig", b, sb))
            if not np.abs(d).max() > 1e-9 * np.abs(v).max()]
    if flat:
        raise EstimationError(f"{' and '.join(flat)} is constant over the {t1 - t0:.2f} s "
                              "overlap (or a steady ramp, of constant derivative): no "
                              "transient to estimate the lag from")
    na, nb = np.linalg.norm(a), np.linalg.norm(b)
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
                       n_samples=int(n), at_range_end=i in (0, vals.size - 1))


def gated_lag(t_ref_s: np.ndarray, ref: np.ndarray, t_sig_s: np.ndarray, sig: np.ndarray,
              *, max_lag_s: float = 1.0, rate_hz: float = 100.0,
              gate: LagGate = LagGate()) -> LagEstimate:
    """:func:`estimate_lag`, with its peak judged: ``applied`` only for a clear peak.

    The peak is not applied when its correlation is below ``gate.min_correlation``, when it
    lies on the first or last lag searched (``LagEstimate.at_range_end``: the maximum of a
    correlation that is still rising there), or when the two halves of the
    overlap each give a peak of at least ``gate.min_correlation`` and their lags differ by
    more than ``gate.halves_tolerance_s``. ``reason`` lists every failed check.

    Parameters
    ----------
    t_ref_s, ref, t_sig_s, sig : ndarray
        As in :func:`estimate_lag`.
    max_lag_s, rate_hz : float
        As in :func:`estimate_lag`.
    gate : LagGate
        The checks.

    Returns
    -------
    LagEstimate
        The whole overlap's estimate, with ``applied`` and ``reason``.

    Raises
    ------
    TimeStepError, EstimationError, ConfigError
        As :func:`estimate_lag` on the whole overlap.
    """
    est = estimate_lag(t_ref_s, ref, t_sig_s, sig, max_lag_s=max_lag_s, rate_hz=rate_hz)
    reasons = []
    if est.correlation < gate.min_correlation:
        reasons.append(f"peak correlation {est.correlation:.3f} below "
                       f"{gate.min_correlation:g}")
    # on the lag searched last, not within half a step of max_lag_s: max_lag_s off the grid
    # rounds to the nearest grid lag, and a refined peak one step inside was flagged
    if est.at_range_end:
        reasons.append(f"peak at the end of the searched range +-{max_lag_s:g} s")
    if gate.halves_tolerance_s is not None:
        tr, r = _finite(t_ref_s, ref, "t_ref_s", "ref")
        ts, s = _finite(t_sig_s, sig, "t_sig_s", "sig")
        mid = 0.5 * (max(tr[0], ts[0]) + min(tr[-1], ts[-1]))
        halves = []
        for first in (True, False):
            a, b = (tr < mid, ts < mid) if first else (tr >= mid, ts >= mid)
            try:
                h = estimate_lag(tr[a], r[a], ts[b], s[b], max_lag_s=max_lag_s,
                                 rate_hz=rate_hz)
            except EstimationError:
                continue
            if h.correlation >= gate.min_correlation:
                halves.append(h.lag_s)
        if len(halves) == 2 and abs(halves[0] - halves[1]) > gate.halves_tolerance_s:
            reasons.append(f"halves of the run disagree ({halves[0]:+.3f} and "
                           f"{halves[1]:+.3f} s)")
    return replace(est, applied=not reasons, reason="; ".join(reasons))


def _finite(t: np.ndarray, v: np.ndarray, name: str, v_name: str
            ) -> tuple[np.ndarray, np.ndarray]:
    """The samples of ``t`` and ``v`` (named ``name`` and ``v_name`` in errors) where both
    are finite; their times must increase strictly (``np.interp`` reads unsorted or
    duplicated times silently wrong: a planted 0.37 s lag came out -0.75 s at correlation
    0.96)."""
    # (a thresholded speed was correlated as 0/1 steps)
    refuse_booleans(EstimationError, **{name: t, v_name: v})
    t = np.asarray(t, dtype=float)
    v = np.asarray(v, dtype=float)
    if t.shape != v.shape or t.ndim != 1:
        raise ShapeError(f"{name}, {v_name} must be 1-D of one shape, got {t.shape}, "
                         f"{v.shape}")
    ok = np.isfinite(t) & np.isfinite(v)
    if ok.sum() < 20:
        raise EstimationError(f"fewer than 20 finite samples in {v_name} ({int(ok.sum())} of "
                              f"{ok.size} with a finite {name})")
    idx = np.flatnonzero(ok)
    bad = np.flatnonzero(np.diff(t[idx]) <= 0)
    if bad.size:
        i, j = idx[bad[0]], idx[bad[0] + 1]
        what = "a duplicate of" if t[j] == t[i] else "before"
        raise TimeStepError(f"{name} must increase strictly: sample {j} ({t[j]:.6g} s) is "
                            f"{what} sample {i} ({t[i]:.6g} s), {bad.size} such step(s) in "
                            f"all")
    return t[ok], v[ok]
