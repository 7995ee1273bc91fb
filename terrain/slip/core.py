"""Per-wheel SAE longitudinal slip (seed ``001_59da564c4b2d6a48.txt`` ch. 7.1-7.2).

* :func:`wheel_longitudinal_velocity`: the EKF body velocity moved to each wheel and projected
  on its rolling direction (eqs. 7.3-7.5);
* :func:`sae_slip` (defined once, in :mod:`terrain.terramechanics.slip`, re-exported here):
  ``s = (omega r - v_long) / max(|omega r|, |v_long|)`` (eqs. 7.1, 7.2 and
  the denominator of eq. 7.7), saturated to [-1, 1], forced to 0 when both speeds are below
  the 0.05 m/s dead band (ch. 7.2.1). ``omega`` must be the *raw* encoder speed (ch. 7.2: the
  EKF-filtered speed is coupled to the estimated velocity and would bias the slip to zero).

Everything is vectorised over a whole run (arrays ``(N, n_wheels)``).
"""

from __future__ import annotations

import numpy as np

from terrain.errors import EstimationError, ShapeError, config_positive, refuse_booleans
from terrain.terramechanics.slip import THESIS_DEAD_BAND_M_S, sae_slip
from terrain.vehicles.swerve import wheel_rim_speed

#: Dead band of ch. 7.2.1, m/s: slip is 0 when both speeds are below it.
DEAD_BAND_M_S = THESIS_DEAD_BAND_M_S


def wheel_longitudinal_velocity(v_bx_m_s: np.ndarray, v_by_m_s: np.ndarray,
                                yaw_rate_rad_s: np.ndarray, positions_m: np.ndarray,
                                delta_rad: np.ndarray | None = None) -> np.ndarray:
    """Longitudinal velocity of each wheel centre (seed 001 eqs. 7.3-7.5).

    ``v_x,i = v_bx - yaw_rate d_y,i`` (7.3), ``v_y,i = v_by + yaw_rate d_x,i`` (7.4),
    ``v_long,i = v_x,i cos(delta_i) + v_y,i sin(delta_i)`` (7.5).

    Parameters
    ----------
    v_bx_m_s, v_by_m_s, yaw_rate_rad_s : ndarray, shape (N,)
        Body velocity and yaw rate (EKF estimates), m/s and rad/s.
    positions_m : ndarray, shape (k, 2)
        Wheel (steering axis or contact line) positions ``d_i`` in the body frame, m.
    delta_rad : ndarray, shape (N, k), optional
        Steering angles; None for fixed wheels (skid-steer, delta = 0).

    Returns
    -------
    ndarray, shape (N, k), m/s

    Raises
    ------
    ShapeError
        Arrays of disagreeing shapes.
    EstimationError
        An argument that holds booleans (named).
    """
    refuse_booleans(EstimationError, v_bx_m_s=v_bx_m_s, v_by_m_s=v_by_m_s,
                    yaw_rate_rad_s=yaw_rate_rad_s, positions_m=positions_m, delta_rad=delta_rad)
    vx = np.asarray(v_bx_m_s, dtype=float)
    vy = np.asarray(v_by_m_s, dtype=float)
    r = np.asarray(yaw_rate_rad_s, dtype=float)
    p = np.asarray(positions_m, dtype=float)
    if p.ndim != 2 or p.shape[1] != 2:
        raise ShapeError(f"positions_m must have shape (k, 2), got {p.shape}")
    if not (vx.shape == vy.shape == r.shape) or vx.ndim != 1:
        raise ShapeError(f"v_bx, v_by, yaw_rate must share a shape (N,), got {vx.shape}, "
                         f"{vy.shape}, {r.shape}")
    shape = (vx.size, p.shape[0])
    if delta_rad is None:                  # fixed wheels: v_y,i does not enter (delta = 0)
        d, vy = np.zeros(shape), np.zeros_like(vy)
    else:
        d = np.asarray(delta_rad, dtype=float)
        if d.shape != shape:
            raise ShapeError(f"delta_rad must have shape {shape}, got {d.shape}")
    return wheel_rim_speed(vx[:, None], vy[:, None], r[:, None], p[None, :, 0], p[None, :, 1],
                           d)


def wheel_slip(rim_speed_m_s: np.ndarray, v_bx_m_s: np.ndarray, v_by_m_s: np.ndarray,
               yaw_rate_rad_s: np.ndarray, positions_m: np.ndarray,
               delta_rad: np.ndarray | None = None, *,
               dead_band_m_s: float = DEAD_BAND_M_S) -> np.ndarray:
    """Slip of every wheel over a run: eqs. 7.3-7.5 then :func:`sae_slip`.

    Parameters
    ----------
    rim_speed_m_s : ndarray, shape (N, k)
        Raw encoder ``omega_i r``, m/s, on the same clock as the velocities.
    v_bx_m_s, v_by_m_s, yaw_rate_rad_s : ndarray, shape (N,)
        Body velocity (m/s) and yaw rate (rad/s), EKF estimates.
    positions_m : ndarray, shape (k, 2)
        Wheel (steering axis or contact line) positions in the body frame, m.
    delta_rad : ndarray, shape (N, k), optional
        Steering angles, rad; None for fixed wheels.
    dead_band_m_s : float
        Dead band of :func:`sae_slip`, m/s (0.05 in seed 001 ch. 7.2.1).

    Returns
    -------
    ndarray, shape (N, k)
        SAE slip of each wheel, dimensionless, in [-1, 1] (NaN where an input is NaN or
        infinite).

    Raises
    ------
    ShapeError
        ``rim_speed_m_s`` does not have the shape ``(N, k)`` of the projected wheel
        velocities.
    EstimationError
        An argument that holds booleans (named): a mask given for a rim speed was a slip
        against 1 m/s.
    """
    refuse_booleans(EstimationError, rim_speed_m_s=rim_speed_m_s)
    v_long = wheel_longitudinal_velocity(v_bx_m_s, v_by_m_s, yaw_rate_rad_s, positions_m,
                                         delta_rad)
    rim = np.asarray(rim_speed_m_s, dtype=float)
    if rim.shape != v_long.shape:
        raise ShapeError(f"rim speeds must have shape {v_long.shape}, got {rim.shape}")
    return sae_slip(rim, v_long, dead_band_m_s=dead_band_m_s)


def skid_steer_side_slip(rim_speed_m_s: np.ndarray, v_bx_m_s: np.ndarray,
                         yaw_rate_rad_s: np.ndarray, track_m: float, *,
                         dead_band_m_s: float = DEAD_BAND_M_S) -> np.ndarray:
    """Slip of the two sides of a skid-steer vehicle: :func:`wheel_slip` with the body
    velocity moved to the geometric contact lines ``y = +B/2`` (left) and ``y = -B/2``
    (right), no lateral velocity, fixed wheels.

    Without an external velocity reference the forward speed is the mean wheel speed, so this
    is the part of each side's slip that shows in turning (scrub), not a common longitudinal
    slip.

    Parameters
    ----------
    rim_speed_m_s : ndarray, shape (N, 2)
        Raw left and right rim speeds ``vel_l``, ``vel_r``, m/s.
    v_bx_m_s : ndarray, shape (N,)
        Body forward speed (EKF estimate), m/s.
    yaw_rate_rad_s : ndarray, shape (N,)
        Yaw rate (EKF estimate), rad/s.
    track_m : float
        Geometric track width B, m (finite, > 0).
    dead_band_m_s : float
        Dead band of :func:`sae_slip`, m/s.

    Returns
    -------
    ndarray, shape (N, 2)
        Left, right slip, dimensionless.

    Raises
    ------
    ShapeError
        Arrays of disagreeing shapes.
    ConfigError
        ``track_m`` not a finite number > 0 (a negative one would swap the sides).
    EstimationError
        An argument that holds booleans (named).
    """
    config_positive("skid_steer_side_slip", track_m=track_m)
    refuse_booleans(EstimationError, rim_speed_m_s=rim_speed_m_s, v_bx_m_s=v_bx_m_s,
                    yaw_rate_rad_s=yaw_rate_rad_s)
    v = np.asarray(v_bx_m_s, dtype=float)
    return wheel_slip(rim_speed_m_s, v, np.zeros(v.shape), yaw_rate_rad_s,
                      skid_steer_contact_lines_m(track_m), dead_band_m_s=dead_band_m_s)


def skid_steer_contact_lines_m(track_m: float) -> np.ndarray:
    """Positions of a skid-steer vehicle's two sides in the body frame, the geometric contact
    lines ``(0, +B/2)`` (left) and ``(0, -B/2)`` (right) of :func:`skid_steer_side_slip`.

    Parameters
    ----------
    track_m : float
        Geometric track width B, m.

    Returns
    -------
    ndarray, shape (2, 2)
        ``d_i`` rows (x, y), m, as :func:`wheel_longitudinal_velocity` takes them.
    """
    half = 0.5 * float(track_m)
    return np.array([[0.0, half], [0.0, -half]])
