"""ICR expansion factor ``chi`` of a skid-steer vehicle: the one least-squares fit.

Model
-----
Ideal differential drive commands the yaw rate ``x = (v_R - v_L) / B`` (seed
``000_f24201ff985633bf.txt`` eq. 2 with ``B = 2 d``; seed ``003_557e4138a8e06c5e.txt`` eq. 7
without slip). A skid-steer vehicle scrubs its tyres sideways in a turn, which moves the
instantaneous centres of rotation (ICR) of the two sides outward: it turns as if its track
were ``chi B`` wide (Mandow et al., "Experimental kinematics for wheeled skid-steer mobile
robots", IROS 2007; seed ``000`` eq. 3 with the slip of both sides folded into ``chi``)::

    yaw_rate = x / chi = a x,        a = 1 / chi

Fit
---
Least squares of the measured (or simulated) yaw rate ``y`` on ``x`` through the origin::

    a = sum(x y) / (sum(x^2) + n floor^2),        chi = 1 / a

The optional ridge ``floor`` (same unit as ``x``) pulls ``a`` to 0 when the vehicle barely
turns (the window features of :mod:`features.calculators`); the audit fits without floor and
reports ``chi = sum(x^2) / sum(x y)`` (infinite when the vehicle does not turn the commanded
way, e.g. a robot that digs in).

Every caller that needs ``chi`` (the audit's yaw-rate effects, its model-free facts and its
lateral-friction what-if, the window feature ``yaw_rate_gain``, the true ``chi`` of a
simulated skid-steer run that the EKF estimate is checked against) calls these functions.
"""

from __future__ import annotations

import numpy as np

from terrain.errors import ShapeError, config_positive
from terrain.vehicles.common import float_arrays


def _origin_slope(y: np.ndarray, x: np.ndarray, floor: float = 0.0) -> np.ndarray:
    """Least-squares slope of ``y = a x`` through the origin along the last axis, ridge
    ``floor``: ``sum(x y) / (sum(x^2) + n floor^2)`` (NaN where the denominator is 0, or
    where a sample of ``x`` or ``y`` is NaN or infinite: an infinite yaw rate gave 0 or
    +-inf).

    Parameters
    ----------
    y, x : ndarray, shape (..., n)
        Response and regressor (any unit; ``a`` in unit of y per unit of x).
    floor : float
        Ridge floor, unit of ``x``.

    Returns
    -------
    ndarray, shape (...)
    """
    n = x.shape[-1]
    den = (x ** 2).sum(axis=-1) + n * float(floor) ** 2
    num = (x * y).sum(axis=-1)
    broken = ~(np.isfinite(x) & np.isfinite(y)).all(axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(broken, np.nan, num / den)


def _same_shape(**arrays: np.ndarray) -> None:
    """Raise :class:`~terrain.errors.ShapeError` naming the shapes unless all are equal."""
    shapes = {name: np.shape(a) for name, a in arrays.items()}
    if len(set(shapes.values())) > 1:
        raise ShapeError("arrays of different shapes: " + ", ".join(
            f"{name} {shape}" for name, shape in shapes.items()))


def inverse_icr_factor(yaw_rate_rad_s: np.ndarray, commanded_yaw_rate_rad_s: np.ndarray,
                       floor_rad_s: float = 0.0) -> np.ndarray | float:
    """Least-squares ``a = 1 / chi`` of ``yaw_rate = a x`` along the last axis.

    Parameters
    ----------
    yaw_rate_rad_s : ndarray, shape (..., n)
        Yaw rate the vehicle shows (gyro, or a simulated one), rad/s.
    commanded_yaw_rate_rad_s : ndarray, shape (..., n)
        Ideal differential-drive yaw rate ``x = (v_R - v_L) / B`` at the same samples, rad/s.
    floor_rad_s : float, optional
        Ridge floor, rad/s (finite, >= 0; default 0: plain least squares): the denominator
        is ``sum(x^2) + n floor^2``.

    Returns
    -------
    ndarray, shape (...), or float
        ``a = sum(x y) / (sum(x^2) + n floor^2)`` (dimensionless); NaN where the denominator
        is 0 (no sample, or no commanded turn and no floor) or a sample is NaN or infinite.

    Raises
    ------
    ShapeError
        The two arrays differ in shape, or are single numbers (no sample axis).
    EstimationError
        An array of booleans, or one that is not numbers (text), named.
    ConfigError
        ``floor_rad_s`` not a finite number >= 0 (text, None or a boolean included).

    References
    ----------
    Seed ``000_f24201ff985633bf.txt`` eqs. 2-3; Mandow et al., IROS 2007 (ICR expansion).
    """
    # NaN gave NaN for every fit, a negative floor acted as its absolute value (squared)
    config_positive("inverse_icr_factor", allow_zero=True, floor_rad_s=floor_rad_s)
    y, x = float_arrays("inverse_icr_factor", yaw_rate_rad_s=yaw_rate_rad_s,
                        commanded_yaw_rate_rad_s=commanded_yaw_rate_rad_s)
    _same_shape(yaw_rate_rad_s=y, commanded_yaw_rate_rad_s=x)
    if x.ndim == 0:     # x.shape[-1] of _origin_slope raised a bare IndexError
        raise ShapeError("inverse_icr_factor: the yaw rates need a sample axis, shape (..., n), "
                         "got single numbers of shape ()")
    out = _origin_slope(y, x, floor_rad_s)
    return float(out) if np.ndim(out) == 0 else out


def icr_expansion_factor(yaw_rate_rad_s: np.ndarray,
                         commanded_yaw_rate_rad_s: np.ndarray) -> float:
    """Least-squares ICR expansion factor ``chi = sum(x^2) / sum(x y)`` of one sample set.

    The reciprocal of :func:`inverse_icr_factor` without floor, written as a ratio so that a
    vehicle that does not turn the commanded way gives ``inf`` instead of a negative or
    infinite ``a``.

    Parameters
    ----------
    yaw_rate_rad_s : ndarray, shape (n,)
        Yaw rate the vehicle shows (gyro, or a simulated one), rad/s.
    commanded_yaw_rate_rad_s : ndarray, shape (n,)
        Ideal differential-drive yaw rate ``x = (v_R - v_L) / B``, rad/s.

    Returns
    -------
    float
        ``chi`` (dimensionless, 1 = ideal differential drive); ``inf`` when
        ``sum(x y) <= 0`` (the vehicle does not turn, or turns against the command); NaN
        when a sample is NaN or infinite (an infinite yaw rate gave chi = 0, or inf) or no
        turn was commanded (``sum(x^2) = 0``: no sample, or a straight run with the ICR at
        infinity): an unknown chi, not a dug-in vehicle.

    Raises
    ------
    ShapeError
        The two arrays differ in shape.
    EstimationError
        An array of booleans, or one that is not numbers (text), named.

    References
    ----------
    Mandow et al., "Experimental kinematics for wheeled skid-steer mobile robots", IROS 2007;
    seed ``000_f24201ff985633bf.txt`` eqs. 2-3.
    """
    y, x = float_arrays("icr_expansion_factor", yaw_rate_rad_s=yaw_rate_rad_s,
                        commanded_yaw_rate_rad_s=commanded_yaw_rate_rad_s)
    _same_shape(yaw_rate_rad_s=y, commanded_yaw_rate_rad_s=x)
    sxy, sxx = float(np.sum(x * y)), float(np.sum(x * x))
    # a straight run or no sample gave inf ("dug in"), an infinite sample 0 or inf
    if not (np.isfinite(x).all() and np.isfinite(y).all()) or sxx == 0.0:
        return float("nan")
    return sxx / sxy if sxy > 0 else float("inf")


def chi_from_truth(v_left_m_s: np.ndarray, v_right_m_s: np.ndarray, yaw_rate_rad_s: np.ndarray,
                   track_m: float, min_yaw_rate_rad_s: float = 0.1) -> float:
    """Effective ICR factor of a recording from its true motion: least squares of
    ``v_R - v_L = chi B yaw_rate`` over the samples turning faster than
    ``min_yaw_rate_rad_s`` (the side-speed difference regressed on the true yaw rate, the
    error-free variable of a simulation's truth).

    Parameters
    ----------
    v_left_m_s, v_right_m_s : ndarray, shape (N,)
        True rim speeds, m/s.
    yaw_rate_rad_s : ndarray, shape (N,)
        True yaw rate, rad/s.
    track_m : float
        Track width B, m (finite, > 0).
    min_yaw_rate_rad_s : float
        Samples turning slower than this are left out, rad/s (finite, >= 0).

    Returns
    -------
    float
        ``chi`` (dimensionless); NaN when the recording never turns, or a yaw rate (or a
        side speed of a turning sample) is NaN or infinite: an unknown chi.

    Raises
    ------
    ShapeError
        The three arrays differ in shape.
    EstimationError
        An array of booleans, or one that is not numbers (text), named.
    ConfigError
        ``track_m`` is not a finite length > 0 (a negative one flipped chi's sign, 0 gave
        NaN), or ``min_yaw_rate_rad_s`` not a finite number >= 0 (text, None or a boolean
        included).

    References
    ----------
    Mandow et al., IROS 2007 (ICR expansion); seed ``000_f24201ff985633bf.txt`` eqs. 2-3.
    """
    config_positive("chi_from_truth", track_m=track_m)
    # NaN left every sample out (NaN: "never turns"), True was a 1 rad/s threshold
    config_positive("chi_from_truth", allow_zero=True, min_yaw_rate_rad_s=min_yaw_rate_rad_s)
    left, right, w = float_arrays("chi_from_truth", v_left_m_s=v_left_m_s,
                                  v_right_m_s=v_right_m_s, yaw_rate_rad_s=yaw_rate_rad_s)
    _same_shape(v_left_m_s=left, v_right_m_s=right, yaw_rate_rad_s=w)
    d = right - left
    # |NaN| > threshold is False: the sample was dropped unseen (an infinite one is broken)
    if not np.isfinite(w).all():
        return float("nan")
    turning = np.abs(w) > min_yaw_rate_rad_s
    if not turning.any():
        return float("nan")
    return float(_origin_slope(d[turning], track_m * w[turning]))


__all__ = ["inverse_icr_factor", "icr_expansion_factor", "chi_from_truth"]
