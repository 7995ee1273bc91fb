"""SAE longitudinal slip of a wheel or track: the one place the formula lives.

``s = (omega r - v_long) / max(|omega r|, |v_long|)`` (seed ``001_59da564c4b2d6a48.txt``
eqs. 7.1-7.2, denominator of eq. 7.7), in [-1, 1], signed by the direction of travel:
driving forward, positive in traction (the rim is faster) and negative in braking; in
reverse the signs flip (rim -1.0 m/s, ground -0.8 m/s: -0.2), so a caller that wants the
traction sign multiplies by the sign of the rim speed (as :mod:`terrain.slip.odometry`
does). Every caller (the simulator's contact model, the post-hoc slip estimate
of :mod:`terrain.slip`, the terramechanics calibration) calls :func:`sae_slip`; they differ
only in its conditioning options:

* ``saturation``: the slip is clipped to ``[-saturation, saturation]`` (1 in ch. 7.2.1);
* ``dead_band_m_s``: slip forced to 0 when both speeds are below it (0.05 m/s in ch. 7.2.1,
  :data:`THESIS_DEAD_BAND_M_S`; where: :func:`in_dead_band`);
* ``speed_floor_m_s``: the denominator is floored at this speed, so near standstill the slip
  is linear in the speed difference instead of jumping between -1 and 1 (the simulator's
  low-speed regularisation, 0.02 m/s, :data:`terrain.sim.dynamics.SLIP_SPEED_FLOOR_M_S`).

:func:`sae_slip_and_velocity_slope` also returns ``d s / d v_long``, which the simulator's
linearly implicit integrator needs.

Its inverse, for the estimators that carry the slip as a state: :func:`rim_speed_from_slip`
(compiled, with its derivatives: the EKF's wheel row) and :func:`ground_speed_from_slip`.
With ``q = sign(speed) s`` (``q >= 0``: the rim is the faster, traction forward or reverse;
``q < 0``: braking), eq. 7.1 solved for the rim speed gives ``omega r = v / (1 - q)`` and
eq. 7.2 gives ``omega r = v (1 + q)``.
"""

from __future__ import annotations

import numba
import numpy as np

from terrain.errors import DataFormatError, EstimationError, ShapeError, refuse_booleans
from terrain.terramechanics.traction import check_numeric_pair

#: Dead band of seed 001 ch. 7.2.1, m/s: slip is 0 when both speeds are below it.
THESIS_DEAD_BAND_M_S = 0.05


def _check(speed_floor_m_s: float, dead_band_m_s: float, saturation: float) -> None:
    try:
        # an infinite floor or dead band gave slip 0 everywhere; an infinite saturation
        # clips nothing and is kept
        valid = bool(0 <= speed_floor_m_s < np.inf and 0 <= dead_band_m_s < np.inf
                     and saturation > 0)
    except (TypeError, ValueError):  # text, None or an array given for a scalar option
        valid = False
    if not valid:
        raise EstimationError(
            f"sae_slip: speed floor and dead band must be finite and >= 0 and saturation > 0, "
            f"got speed_floor_m_s={speed_floor_m_s}, dead band {dead_band_m_s}, saturation "
            f"{saturation}")


def sae_slip_denominator(rim_speed_m_s: np.ndarray | float, v_long_m_s: np.ndarray | float,
                         speed_floor_m_s: float) -> np.ndarray:
    """Denominator of the SAE slip, ``max(|omega r|, |v_long|, speed_floor_m_s)``, m/s.

    Seed ``001_59da564c4b2d6a48.txt`` eqs. 7.1-7.2 (the larger of the two speeds) with the
    simulator's low-speed floor. The simulator's side slip of the tyre's combined-slip law
    and the slope of a rate-weakening soil divide by the same speed
    (:func:`terrain.sim.forces.contact_forces`).

    Parameters
    ----------
    rim_speed_m_s : float or ndarray, shape (...)
        Rim speed ``omega r``, m/s.
    v_long_m_s : float or ndarray, shape (...)
        Longitudinal contact velocity, m/s; broadcast with ``rim_speed_m_s``.
    speed_floor_m_s : float
        Floor of the denominator, m/s (> 0 keeps it away from 0).

    Returns
    -------
    ndarray, shape (...)
        The denominator, m/s.
    """
    return np.maximum(np.maximum(np.abs(rim_speed_m_s), np.abs(v_long_m_s)), speed_floor_m_s)


def _ratio(rim: np.ndarray, v: np.ndarray, speed_floor_m_s: float
           ) -> tuple[np.ndarray, np.ndarray]:
    """Unsaturated slip and its denominator (eqs. 7.1-7.2); needs ``speed_floor_m_s > 0``."""
    den = sae_slip_denominator(rim, v, speed_floor_m_s)
    return (rim - v) / den, den


def in_dead_band(rim_speed_m_s: np.ndarray, v_long_m_s: np.ndarray,
                 dead_band_m_s: float = THESIS_DEAD_BAND_M_S) -> np.ndarray:
    """Where both speeds are below the dead band, so :func:`sae_slip` sets the slip to 0
    (seed 001 ch. 7.2.1).

    Parameters
    ----------
    rim_speed_m_s, v_long_m_s : ndarray, broadcastable shapes
        Rim speed ``omega r`` and longitudinal wheel velocity, m/s.
    dead_band_m_s : float, optional
        Dead band, m/s, >= 0 (0: no sample is in it).

    Returns
    -------
    ndarray of bool, broadcast shape of the inputs
    """
    return (np.abs(rim_speed_m_s) < dead_band_m_s) & (np.abs(v_long_m_s) < dead_band_m_s)


def _floats(value) -> bool:
    """Whether ``value`` is a float or an array of floats (no boolean to refuse in it)."""
    return isinstance(value, float) or (isinstance(value, np.ndarray)
                                        and value.dtype.kind == "f")


def sae_slip(rim_speed_m_s: np.ndarray | float, v_long_m_s: np.ndarray | float, *,
             speed_floor_m_s: float = 0.0, dead_band_m_s: float = THESIS_DEAD_BAND_M_S,
             saturation: float = 1.0) -> np.ndarray:
    """SAE longitudinal slip (seed 001 eqs. 7.1, 7.2 and the denominator of eq. 7.7).

    ``s = (omega r - v_long) / max(|omega r|, |v_long|, speed_floor_m_s)``, clipped to
    ``[-saturation, saturation]``, 0 where both ``|omega r|`` and ``|v_long|`` are below
    ``dead_band_m_s`` and where both are exactly 0 (0/0); NaN or infinite inputs give NaN.

    Parameters
    ----------
    rim_speed_m_s : float or ndarray, shape (...)
        Rim (peripheral) speed ``omega r`` of the wheel, m/s (eq. 7.6); for the thesis's
        estimate the *raw* encoder speed (ch. 7.2).
    v_long_m_s : float or ndarray, shape (...)
        Longitudinal velocity of the wheel centre (or contact point) along its rolling
        direction, m/s (eq. 7.5); broadcast with ``rim_speed_m_s``.
    speed_floor_m_s : float, optional
        Floor of the denominator, m/s, finite and >= 0 (0: none, the thesis's formula; the
        simulator uses 0.02 m/s).
    dead_band_m_s : float, optional
        Speed below which (both speeds) the slip is 0, m/s, finite and >= 0 (default 0.05,
        ch. 7.2.1; the simulator passes 0).
    saturation : float, optional
        Clip bound, > 0 (1 in ch. 7.2.1; infinite: no clipping).

    Returns
    -------
    ndarray, broadcast shape of the inputs
        Slip, dimensionless.

    Raises
    ------
    EstimationError
        Negative, infinite, NaN or non-numeric speed floor or dead band, or non-positive
        saturation.
    DataFormatError
        A speed that is not a number (text, None, a boolean: ``True`` was 1 m/s).
    ShapeError
        Speeds whose shapes do not broadcast.
    """
    _check(speed_floor_m_s, dead_band_m_s, saturation)
    # a mask passed for a speed was a speed of 1 m/s (floats, the simulator's every step,
    # pass on two type tests: the full check cost 6 us a call, 2 % of a simulated minute)
    if not (_floats(rim_speed_m_s) and _floats(v_long_m_s)):
        refuse_booleans(DataFormatError, "sae_slip", rim_speed_m_s=rim_speed_m_s,
                        v_long_m_s=v_long_m_s)
    try:
        if rim_speed_m_s is None or v_long_m_s is None:  # asarray would make it NaN
            raise TypeError("got None")
        rim = np.asarray(rim_speed_m_s, dtype=float)
        v = np.asarray(v_long_m_s, dtype=float)
    except (TypeError, ValueError) as exc:
        raise DataFormatError(f"sae_slip: rim_speed_m_s and v_long_m_s must be numbers or "
                              f"numeric arrays ({exc})") from None
    if rim.shape != v.shape and rim.ndim and v.ndim:
        try:
            np.broadcast_shapes(rim.shape, v.shape)
        except ValueError:
            raise ShapeError(f"sae_slip: rim_speed_m_s of shape {rim.shape} and v_long_m_s "
                             f"of shape {v.shape} do not broadcast") from None
    if speed_floor_m_s > 0:
        # minimum/maximum: same values as np.clip, less call overhead (simulator inner loop)
        s = np.minimum(np.maximum(_ratio(rim, v, speed_floor_m_s)[0], -saturation), saturation)
    else:
        den = np.maximum(np.abs(rim), np.abs(v))
        with np.errstate(divide="ignore", invalid="ignore"):
            s = np.where(den > 0, (rim - v) / np.where(den > 0, den, 1.0), 0.0)
        s = np.clip(s, -saturation, saturation)
        s = np.where(np.isnan(rim) | np.isnan(v), np.nan, s)
    if dead_band_m_s > 0:
        s = np.where(in_dead_band(rim, v, dead_band_m_s), 0.0, s)
    return s


def sae_slip_and_velocity_slope(rim_speed_m_s: np.ndarray, v_long_m_s: np.ndarray,
                                speed_floor_m_s: float) -> tuple[np.ndarray, np.ndarray]:
    """SAE slip saturated to [-1, 1] and its derivative with respect to ``v_long``.

    The slip is :func:`sae_slip` with ``speed_floor_m_s`` (no dead band, saturation 1). Its
    derivative at fixed rim speed ``w`` is ``-w sign(v) / v^2`` where the body speed sets the
    denominator (``|v| >= max(|w|, floor)``), ``-1 / den`` otherwise, and 0 beyond saturation
    (``|w - v| / den > 1``). At exactly ``|slip| = 1`` it is the slope of the unsaturated
    side: a wheel turning on a body at rest gets ``-1 / den``, so the simulator's linearly
    implicit step from rest holds the body behind its rims instead of stepping it
    explicitly. It is the contact-force Jacobian factor of the simulator
    (:func:`terrain.sim.forces.contact_forces`).

    Parameters
    ----------
    rim_speed_m_s : ndarray, shape (c,)
        Rim speeds ``omega r`` of the contacts, m/s.
    v_long_m_s : ndarray, shape (c,)
        Longitudinal contact velocities, m/s.
    speed_floor_m_s : float
        Floor of the denominator, m/s, finite and > 0.

    Returns
    -------
    slip : ndarray, shape (c,)
        Dimensionless, in [-1, 1].
    dslip_dv : ndarray, shape (c,)
        ``d slip / d v_long``, s/m.

    Raises
    ------
    EstimationError
        Non-positive or infinite speed floor.
    """
    if not 0 < speed_floor_m_s < np.inf:   # inf gave slip 0 and slope 0 everywhere
        raise EstimationError(f"speed_floor_m_s must be finite and > 0, got {speed_floor_m_s}")
    ratio, den = _ratio(rim_speed_m_s, v_long_m_s, speed_floor_m_s)
    v = v_long_m_s
    # |v| >= max(|w|, floor) is den == |v| (den = max(|w|, |v|, floor); False with a NaN,
    # as the comparison): one comparison instead of recomputing the maximum
    body_dominant = den == np.abs(v)
    # where the body dominates, |v| >= floor > 0: v^2 needs no clamp (one at 1e-6 m^2/s^2
    # bent the slope below 1 mm/s)
    ds_dv = np.where(body_dominant,
                     -rim_speed_m_s * np.sign(v) / np.where(body_dominant, v * v, 1.0),
                     -1.0 / den)
    ds_dv = np.where(np.abs(ratio) > 1.0, 0.0, ds_dv)
    return np.minimum(np.maximum(ratio, -1.0), 1.0), ds_dv


@numba.njit(cache=True)
def rim_speed_from_slip(ground_speed_m_s: float, slip: float) -> tuple[float, float, float]:
    """Rim speed of a wheel at a given ground speed and SAE slip, and its derivatives.

    The inverse of :func:`sae_slip` (no floor, no dead band) on ``|slip| < 1``, with
    ``q = sign(v) slip`` (``sign(0) = +1``): ``omega r = v / (1 - q)`` where ``q >= 0`` (the
    rim is the faster: eq. 7.1, ``s = (omega r - v) / (omega r)``, solved for ``omega r``)
    and ``omega r = v (1 + q)`` where ``q < 0`` (the ground is the faster: eq. 7.2,
    ``s = (omega r - v) / v``), seed ``001_59da564c4b2d6a48.txt``. Both branches meet at
    ``q = 0`` with the same slope, ``d(omega r)/ds = |v|``.

    Parameters
    ----------
    ground_speed_m_s : float
        Longitudinal ground speed ``v`` of the wheel's contact, m/s.
    slip : float
        SAE slip ``s``, dimensionless, ``-1 <= q < 1``.

    Returns
    -------
    rim_speed_m_s : float
        ``omega r``, m/s; NaN (as both derivatives) where ``q >= 1`` or ``q < -1`` or the
        slip is NaN (no rim speed gives that slip: ``q = 1`` divided by zero, ``q > 1`` ran
        the rim against the ground); ``q = -1`` is the locked wheel, rim speed 0.
    d_rim_d_ground : float
        ``d(omega r) / dv`` at fixed slip, dimensionless.
    d_rim_d_slip : float
        ``d(omega r) / ds`` at fixed ground speed, m/s.
    """
    sign = 1.0 if ground_speed_m_s >= 0.0 else -1.0
    q = sign * slip
    if not -1.0 <= q < 1.0:   # q >= 1 divided by zero or ran the rim against the ground
        return np.nan, np.nan, np.nan
    if q >= 0.0:
        k = 1.0 / (1.0 - q)
        return ground_speed_m_s * k, k, abs(ground_speed_m_s) * k * k
    k = 1.0 + q
    return ground_speed_m_s * k, k, abs(ground_speed_m_s)


def ground_speed_from_slip(rim_speed_m_s: np.ndarray | float, slip: np.ndarray | float
                           ) -> np.ndarray:
    """Ground speed of a wheel's contact that a rim speed and an SAE slip imply.

    The other inverse of :func:`sae_slip` (no floor, no dead band) on ``|slip| < 1``, with
    ``q = sign(omega r) slip`` (``sign(0) = +1``): ``v = omega r (1 - q)`` where ``q >= 0``
    (eq. 7.1) and ``v = omega r / (1 + q)`` where ``q < 0`` (eq. 7.2), seed
    ``001_59da564c4b2d6a48.txt``; :func:`rim_speed_from_slip` undone.

    Parameters
    ----------
    rim_speed_m_s : float or ndarray, shape (...)
        Rim speed ``omega r``, m/s.
    slip : float or ndarray, shape (...)
        SAE slip, dimensionless, ``|slip| < 1`` (``q = 1``: a wheel spinning on a body at
        rest, ground speed 0); broadcast with ``rim_speed_m_s``.

    Returns
    -------
    ndarray, broadcast shape of the inputs
        Ground speed, m/s; NaN where ``q > 1`` or ``q <= -1`` (no ground speed gives that
        slip: ``q > 1`` made it run against the rim, ``q = -1`` gave 1e12 m/s).

    Raises
    ------
    DataFormatError
        ``rim_speed_m_s`` or ``slip`` not a number or a numeric array (None was a NaN speed,
        ``True`` a slip of 1, text a bare ValueError;
        :func:`~terrain.terramechanics.traction.numeric_array`).
    ShapeError
        ``rim_speed_m_s`` and ``slip`` of shapes that do not broadcast.
    """
    rim, slip_in = np.asarray(rim_speed_m_s), np.asarray(slip)
    # (float or integer arrays of one shape pass on three tests)
    if (rim.dtype.kind not in "iuf" or slip_in.dtype.kind not in "iuf"
            or rim.shape != slip_in.shape):
        check_numeric_pair("ground_speed_from_slip", rim_speed_m_s=rim_speed_m_s, slip=slip)
    rim = rim.astype(float, copy=False)
    q = np.where(rim >= 0.0, 1.0, -1.0) * slip_in.astype(float, copy=False)
    # 1 + q as it is inside the domain (a floor at 1e-12 returned omega r 1e12 for every
    # q within 1e-12 of -1); NaN where q <= -1 (no division by 0 or a negative 1 + q)
    v = np.where(q >= 0.0, rim * (1.0 - q), rim / np.where(q <= -1.0, np.nan, 1.0 + q))
    return np.where((q > 1.0) | (q <= -1.0), np.nan, v)
