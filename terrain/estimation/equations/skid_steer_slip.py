"""Skid-steer EKF with per-side longitudinal slip: the one home of the 8-state model of
:mod:`terrain.estimation.skid_steer_slip`.

State ``x = [v_bx, yaw_rate, b_g, ln(chi), s_1, s_2, a_x, pitch]`` (m/s, rad/s, rad/s, 1, 1, 1,
m/s^2, rad); side 1 = left, 2 = right (the simulator's numbering).

Process (constant acceleration for the forward speed, every other state a random walk)::

    v_bx' = v_bx + a_x dt,   all others unchanged

Measurements: the wheel and gyro rows of :mod:`terrain.estimation.equations.skid_steer`
(ICR model, Mandow et al. 2007; seed ``000_f24201ff985633bf.txt`` eq. 3), evaluated by calling
:func:`terrain.estimation.equations.skid_steer.observation_into`, give the ground speed of each
side's contact line ``g_i = v_bx -+ chi B yaw_rate / 2``; the rim speed is the one whose SAE
slip over that ground speed is ``s_i`` (seed ``001_59da564c4b2d6a48.txt`` eqs. 7.1-7.2 solved
for ``omega r``, :func:`terrain.terramechanics.slip.rim_speed_from_slip`: ``g / (1 - s)`` in
traction, ``g (1 + s)`` in braking, driving forward)::

    vel_l = rim(g_l, s_1),   vel_r = rim(g_r, s_2),   wz = yaw_rate + b_g
    slip_1 = s_1,  slip_2 = s_2                     (pseudo-measurement of a slip model)
    ax = a_x + g sin(pitch),   az = g cos(pitch)    (accelerometer specific force, body axes)

The accelerometer rows are the specific force of a rigid body with nose-up pitch (seed
``003_557e4138a8e06c5e.txt`` eq. 10 uses the same grade term ``m g sin(theta)``); centripetal
and vertical accelerations are left in the measurement noise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from terrain.estimation.equations import skid_steer as _base
from terrain.estimation.equations.evaluate import NO_INPUT, observation_pair, transition_pair
from terrain.terramechanics.resistance import G_M_S2
from terrain.terramechanics.slip import rim_speed_from_slip
from terrain.vehicles.skid_steer import HUSKY

#: Number of states and measurement rows.
N_STATES, N_MEASUREMENTS = 8, 7
#: Standard gravity, m/s^2 (ISO 80000-3): the terramechanics' ``G_M_S2``, which the
#: simulator's accelerometer uses (one value; this module kept a copy of its own).
STANDARD_GRAVITY_M_S2 = G_M_S2
#: Largest |slip| the rim equation takes (``1 - s`` stays >= 0.05); a state beyond it is
#: clipped there, with no slip column in the Jacobian, dimensionless.
MAX_SLIP = 0.95


@dataclass(frozen=True)
class SkidSteerSlipEquationParams:
    """Constants of the slip-augmented skid-steer model.

    Parameters
    ----------
    track_m : float
        Geometric track width B, m (Husky 0.5708 m, public ``husky_description`` URDF).
    chi_min_yaw_rate_rad_s : float
        Yaw rate below which the wheel rows do not correct ``ln(chi)``, rad/s (as in
        :class:`~terrain.estimation.equations.skid_steer.SkidSteerEquationParams`).
    gravity_m_s2 : float
        Gravity, m/s^2 (standard gravity).
    """

    track_m: float = HUSKY.track_m
    chi_min_yaw_rate_rad_s: float = 0.05
    gravity_m_s2: float = STANDARD_GRAVITY_M_S2

    def as_array(self) -> np.ndarray:
        """The kernels' parameter vector ``p``.

        Returns
        -------
        ndarray, shape (3,)
            ``(B m, chi_min_yaw_rate rad/s, g m/s^2)``; its first two entries are the
            parameter vector of :mod:`terrain.estimation.equations.skid_steer`.
        """
        return np.array([self.track_m, self.chi_min_yaw_rate_rad_s, self.gravity_m_s2],
                        dtype=np.float64)


@numba.njit(cache=True)
def transition_into(x, u, dt, p, fx, F):
    """``v_bx += a_x dt``, the rest unchanged, into ``fx`` and ``F``.

    Parameters
    ----------
    x : ndarray, shape (8,)
        State (module docstring).
    u : ndarray, shape (0,)
        Input (none).
    dt : float
        Step, s.
    p : ndarray, shape (3,)
        :meth:`SkidSteerSlipEquationParams.as_array` (unused).
    fx : ndarray, shape (8,)
        Output: ``f(x)``.
    F : ndarray, shape (8, 8)
        Output: ``df/dx``.
    """
    n = x.shape[0]
    for i in range(n):
        fx[i] = x[i]
        for j in range(n):
            F[i, j] = 0.0
        F[i, i] = 1.0
    fx[0] = x[0] + x[6] * dt
    F[0, 6] = dt


@numba.njit(cache=True)
def observation_into(x, p, hx, H):
    """Wheel, gyro, slip pseudo-measurement and accelerometer rows (module docstring).

    Parameters
    ----------
    x : ndarray, shape (8,)
        State ``[v_bx, yaw_rate, b_g, ln(chi), s_1, s_2, a_x, pitch]``.
    p : ndarray, shape (3,)
        :meth:`SkidSteerSlipEquationParams.as_array`.
    hx : ndarray, shape (7,)
        Output: ``(vel_l, vel_r m/s, wz rad/s, slip_1, slip_2, ax, az m/s^2)``.
    H : ndarray, shape (7, 8)
        Output: ``dh/dx``.
    """
    xb = np.empty(4)
    for i in range(4):
        xb[i] = x[i]
    pb = np.empty(2)
    pb[0], pb[1] = p[0], p[1]
    hb = np.empty(3)
    Hb = np.empty((3, 4))
    _base.observation_into(xb, pb, hb, Hb)        # ground speeds of the sides, gyro
    for i in range(7):
        for j in range(8):
            H[i, j] = 0.0
    for side in range(2):
        s = x[4 + side]
        clipped = abs(s) > MAX_SLIP
        rim, k, d_slip = rim_speed_from_slip(hb[side], min(max(s, -MAX_SLIP), MAX_SLIP))
        hx[side] = rim
        for j in range(4):
            H[side, j] = Hb[side, j] * k
        H[side, 4 + side] = 0.0 if clipped else d_slip
    hx[2] = hb[2]
    for j in range(4):
        H[2, j] = Hb[2, j]
    hx[3], hx[4] = x[4], x[5]
    H[3, 4], H[4, 5] = 1.0, 1.0
    g, th = p[2], x[7]
    hx[5] = x[6] + g * math.sin(th)
    hx[6] = g * math.cos(th)
    H[5, 6], H[5, 7] = 1.0, g * math.cos(th)
    H[6, 7] = -g * math.sin(th)


def f(x: np.ndarray, u: np.ndarray | None, dt: float,
      params: SkidSteerSlipEquationParams = SkidSteerSlipEquationParams()) -> np.ndarray:
    """Next state (:func:`transition_into`).

    Parameters
    ----------
    x : ndarray, shape (8,)
        State.
    u : None or ndarray, shape (0,)
        Input (none).
    dt : float
        Step, s.
    params : SkidSteerSlipEquationParams
        Model constants.

    Returns
    -------
    ndarray, shape (8,)
    """
    return transition_pair(transition_into, x, NO_INPUT, dt, params.as_array(),
                           N_STATES)[0]


def F(x: np.ndarray, u: np.ndarray | None, dt: float,
      params: SkidSteerSlipEquationParams = SkidSteerSlipEquationParams()) -> np.ndarray:
    """Jacobian of :func:`f`.

    Parameters
    ----------
    x : ndarray, shape (8,)
        State.
    u : None or ndarray, shape (0,)
        Input (none).
    dt : float
        Step, s.
    params : SkidSteerSlipEquationParams
        Model constants.

    Returns
    -------
    ndarray, shape (8, 8)
    """
    return transition_pair(transition_into, x, NO_INPUT, dt, params.as_array(),
                           N_STATES)[1]


def h(x: np.ndarray,
      params: SkidSteerSlipEquationParams = SkidSteerSlipEquationParams()) -> np.ndarray:
    """Measurement ``[vel_l, vel_r, wz, slip_1, slip_2, ax, az]``.

    Parameters
    ----------
    x : ndarray, shape (8,)
        State.
    params : SkidSteerSlipEquationParams
        Model constants.

    Returns
    -------
    ndarray, shape (7,)
    """
    return observation_pair(observation_into, x, params.as_array(), N_MEASUREMENTS,
                            N_STATES)[0]


def H(x: np.ndarray,
      params: SkidSteerSlipEquationParams = SkidSteerSlipEquationParams()) -> np.ndarray:
    """Jacobian ``dh/dx`` of :func:`h`.

    Parameters
    ----------
    x : ndarray, shape (8,)
        State.
    params : SkidSteerSlipEquationParams
        Model constants.

    Returns
    -------
    ndarray, shape (7, 8)
    """
    return observation_pair(observation_into, x, params.as_array(), N_MEASUREMENTS,
                            N_STATES)[1]


__all__ = ["SkidSteerSlipEquationParams", "N_STATES", "N_MEASUREMENTS", "STANDARD_GRAVITY_M_S2",
           "MAX_SLIP", "transition_into", "observation_into", "f", "F", "h",
           "H"]
