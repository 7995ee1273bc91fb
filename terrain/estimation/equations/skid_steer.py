"""Skid-steer EKF equations: the one home of the 4-state model of
:mod:`terrain.estimation.skid_steer`.

State ``x = [v_bx, yaw_rate, b_g, ln(chi)]`` (m/s, rad/s, rad/s, 1). Process model: every state
a random walk (``f(x) = x``, ``F = I``). Measurements, with ``chi`` the ICR expansion factor
(Mandow et al., IROS 2007) and seed ``000_f24201ff985633bf.txt`` eq. 3 with
``eta_L = eta_R = 1/chi`` for the turning part::

    vel_l = v_bx - chi B yaw_rate / 2,   vel_r = v_bx + chi B yaw_rate / 2,   wz = yaw_rate + b_g

(the wheel rows are :func:`terrain.vehicles.skid_steer.side_speeds`, inlined into the kernel:
see :mod:`terrain.estimation.equations.agrimaro` for numba's cache and the test that guards
it).

The ``ln(chi)`` column of the wheel rows is zero while ``|yaw_rate|`` is below
``chi_min_yaw_rate_rad_s`` (``chi`` is then a consider parameter, see
:class:`~terrain.estimation.skid_steer.SkidSteerSettings`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from terrain.estimation.equations.evaluate import NO_INPUT, observation_pair, transition_pair
from terrain.vehicles.skid_steer import HUSKY, side_speeds

#: Number of states and of measurement rows.
N_STATES, N_ROWS = 4, 3


@dataclass(frozen=True)
class SkidSteerEquationParams:
    """Constants of the skid-steer measurement model.

    Parameters
    ----------
    track_m : float
        Geometric track width B, m (Husky 0.5708 m, public ``husky_description`` URDF).
    chi_min_yaw_rate_rad_s : float
        Yaw rate below which the wheel rows do not correct ``ln(chi)``, rad/s.
    """

    track_m: float = HUSKY.track_m
    chi_min_yaw_rate_rad_s: float = 0.05

    def as_array(self) -> np.ndarray:
        """The kernels' parameter vector ``p``.

        Returns
        -------
        ndarray, shape (2,)
            ``(B m, chi_min_yaw_rate rad/s)``.
        """
        return np.array([self.track_m, self.chi_min_yaw_rate_rad_s], dtype=np.float64)


@numba.njit(cache=True)
def transition_into(x, u, dt, p, fx, F):
    """Random walk: ``fx = x``, ``F = I``.

    Parameters
    ----------
    x : ndarray, shape (4,)
        State ``[v_bx, yaw_rate, b_g, ln(chi)]``.
    u : ndarray, shape (0,)
        Input (none).
    dt : float
        Step, s (unused: the model is a random walk).
    p : ndarray, shape (2,)
        :meth:`SkidSteerEquationParams.as_array` (unused).
    fx : ndarray, shape (4,)
        Output: ``f(x)``.
    F : ndarray, shape (4, 4)
        Output: ``df/dx``.
    """
    n = x.shape[0]
    for i in range(n):
        fx[i] = x[i]
        for j in range(n):
            F[i, j] = 0.0
        F[i, i] = 1.0


@numba.njit(cache=True)
def observation_into(x, p, hx, H):
    """ICR wheel model and gyro (see the module docstring), into ``hx`` and ``H``.

    Parameters
    ----------
    x : ndarray, shape (4,)
        State ``[v_bx, yaw_rate, b_g, ln(chi)]``.
    p : ndarray, shape (2,)
        :meth:`SkidSteerEquationParams.as_array`: ``(B m, chi_min_yaw_rate rad/s)``.
    hx : ndarray, shape (3,)
        Output: ``(vel_l m/s, vel_r m/s, wz rad/s)``.
    H : ndarray, shape (3, 4)
        Output: ``dh/dx``.
    """
    v, w, b, chi = x[0], x[1], x[2], math.exp(x[3])
    hx[0], hx[1] = side_speeds(v, w, p[0], chi)
    k = side_speeds(0.0, 1.0, p[0], chi)[1]       # d vel_r / d yaw_rate = chi B / 2
    hx[2] = w + b
    kw = k * w if abs(w) >= p[1] else 0.0
    H[0, 0], H[0, 1], H[0, 2], H[0, 3] = 1.0, -k, 0.0, -kw
    H[1, 0], H[1, 1], H[1, 2], H[1, 3] = 1.0, k, 0.0, kw
    H[2, 0], H[2, 1], H[2, 2], H[2, 3] = 0.0, 1.0, 1.0, 0.0


def f(x: np.ndarray, u: np.ndarray | None, dt: float,
      params: SkidSteerEquationParams = SkidSteerEquationParams()) -> np.ndarray:
    """Next state: ``x`` (random walk).

    Parameters
    ----------
    x : ndarray, shape (4,)
        State ``[v_bx m/s, yaw_rate rad/s, b_g rad/s, ln(chi)]``.
    u : None or ndarray, shape (0,)
        Input (none).
    dt : float
        Step, s.
    params : SkidSteerEquationParams
        Model constants (track width, chi yaw-rate threshold).

    Returns
    -------
    ndarray, shape (4,)
    """
    return transition_pair(transition_into, x, NO_INPUT, dt, params.as_array(),
                           N_STATES)[0]


def F(x: np.ndarray, u: np.ndarray | None, dt: float,
      params: SkidSteerEquationParams = SkidSteerEquationParams()) -> np.ndarray:
    """Jacobian of :func:`f`: the identity.

    Parameters
    ----------
    x : ndarray, shape (4,)
        State.
    u : None or ndarray, shape (0,)
        Input (none).
    dt : float
        Step, s.
    params : SkidSteerEquationParams
        Model constants (track width, chi yaw-rate threshold).

    Returns
    -------
    ndarray, shape (4, 4)
    """
    return transition_pair(transition_into, x, NO_INPUT, dt, params.as_array(),
                           N_STATES)[1]


def h(x: np.ndarray, params: SkidSteerEquationParams = SkidSteerEquationParams()) -> np.ndarray:
    """Measurement ``[vel_l, vel_r, wz]`` (m/s, m/s, rad/s).

    Parameters
    ----------
    x : ndarray, shape (4,)
        State ``[v_bx, yaw_rate, b_g, ln(chi)]``.
    params : SkidSteerEquationParams
        Model constants (track width, chi yaw-rate threshold).

    Returns
    -------
    ndarray, shape (3,)
    """
    return observation_pair(observation_into, x, params.as_array(), N_ROWS,
                            N_STATES)[0]


def H(x: np.ndarray, params: SkidSteerEquationParams = SkidSteerEquationParams()) -> np.ndarray:
    """Jacobian ``dh/dx`` of :func:`h`.

    Parameters
    ----------
    x : ndarray, shape (4,)
        State.
    params : SkidSteerEquationParams
        Model constants (track width, chi yaw-rate threshold).

    Returns
    -------
    ndarray, shape (3, 4)
    """
    return observation_pair(observation_into, x, params.as_array(), N_ROWS,
                            N_STATES)[1]


__all__ = ["SkidSteerEquationParams", "NO_INPUT", "transition_into", "observation_into",
           "f", "F", "h", "H"]
