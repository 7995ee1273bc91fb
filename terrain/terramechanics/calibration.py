"""Calibration of terrain parameters against measurements (documented, reproducible).

* :func:`husky_hysteresis_for_current`: the torque-only rolling loss that makes the simulated
  Husky draw the measured mean straight-line current on a terrain.
* :func:`calibrate_janosi`: the Janosi-Hanamoto ``(mu_max, K/L)`` that reproduce a steady slip
  and a quasi-static acceleration slip (AgriMaRo straight-line test, seed 001 ch. 7.2.3).
* :func:`steady_slip`: the slip at which traction balances soil resistance plus an extra
  demand (quasi-static, flat ground).
"""

from __future__ import annotations

import math
import warnings

import numpy as np
from scipy.optimize import brentq, minimize_scalar

from terrain.errors import (ConfigError, DataWarning, config_fraction, config_numbers,
                            config_positive)
from terrain.terramechanics.resistance import (G_M_S2, HYSTERESIS_SPEED_M_S,
                                               soil_resistance_coefficient)
from terrain.terramechanics.traction import JanosiCurve, patch_mobilisation, traction_coefficient


def steady_slip(terrain, extra_demand: float = 0.0) -> float:
    """Slip where ``mu(s) = soil_resistance(s) + extra_demand``, on the driving side.

    A demand below ``-soil_resistance(0)`` (a downhill grade the soil resistance does not
    hold) needs no traction and gives 0: the braking slip that would hold the vehicle at a
    steady speed there (``s < 0``) is not sought.

    Parameters
    ----------
    terrain : TerrainParams
        Terrain (traction curve and soil resistance).
    extra_demand : float
        Further force demand over normal load (e.g. ``a / g`` when accelerating, the grade
        ``sin(pitch)`` on a slope).

    Returns
    -------
    float
        Slip in [0, 1]; 1.0 when the demand exceeds the available traction, 0.0 when the
        net demand is <= 0 (see above).

    Raises
    ------
    ConfigError
        An ``extra_demand`` that is not a real number (a boolean, text, ``None``) or not
        finite (NaN came out as 1.0, full spin).
    """
    config_numbers("steady_slip", extra_demand=extra_demand)
    if not math.isfinite(extra_demand):
        raise ConfigError(f"steady_slip: extra_demand must be finite, got {extra_demand}")
    f = lambda s: float(traction_coefficient(terrain.curve, s)  # noqa: E731
                        - soil_resistance_coefficient(terrain, s) - extra_demand)
    if f(0.0) >= 0.0:
        return 0.0
    grid = np.linspace(0.0, 1.0, 401)
    vals = np.array([f(s) for s in grid])
    above = np.nonzero(vals >= 0.0)[0]
    if len(above) == 0:
        # a peak between two grid points can still meet the demand: refine the best one
        j = int(np.argmax(vals))
        lo, hi = grid[max(j - 1, 0)], grid[min(j + 1, grid.size - 1)]
        top = minimize_scalar(lambda s: -f(s), bounds=(lo, hi), method="bounded",
                              options={"xatol": 1e-12})
        if not -top.fun >= 0.0:
            return 1.0
        return float(brentq(f, lo, float(top.x), xtol=1e-10))
    i = int(above[0])
    return float(brentq(f, grid[i - 1], grid[i], xtol=1e-10))


def husky_hysteresis_for_current(terrain, current_a: float, speed_m_s: float,
                                 husky=None) -> float:
    """Torque-only rolling loss giving a target per-side current in straight driving.

    At constant speed on flat ground each side supplies the torque
    ``r (W/2) (mu(s) + h tanh(omega r / 0.05 m/s))``, with ``mu(s)`` balancing the soil
    resistance and ``omega r = v / (1 - s)`` (the torque law of
    :func:`terrain.sim.forces.contact_torque_nm`), and draws
    ``I = I_0 tanh(omega / 0.05) + torque / (G k_t eta)`` (:class:`terrain.vehicles.MotorParams`).
    Solving for ``h`` gives the calibrated hysteresis coefficient.

    Parameters
    ----------
    terrain : TerrainParams
        Terrain to calibrate (its curve and soil resistance; hysteresis ignored).
    current_a : float
        Target mean current per side, A.
    speed_m_s : float
        Speed at which it was measured, m/s, > 0 (sets the smooth sign terms only: the loss
        model is otherwise speed-independent; at 0.2 m/s the loss term is 0.07 % short of
        its full value).
    husky : HuskyParams, optional
        Vehicle (default :data:`terrain.vehicles.HUSKY`).

    Returns
    -------
    float
        Hysteresis coefficient (dimensionless), >= 0.

    Raises
    ------
    ConfigError
        ``current_a`` or ``speed_m_s`` not a real number (text, ``None``, a boolean),
        ``current_a`` not finite (NaN gave hysteresis 0 without a word), or ``speed_m_s``
        not positive and finite (the loss has no sign to calibrate).

    Warns
    -----
    DataWarning
        ``current_a`` below what the Husky draws on the terrain with no hysteresis: a
        negative loss would be needed, 0 is returned (it was, without a word) and the
        message gives the current the simulated Husky draws instead.
    """
    from terrain.vehicles.skid_steer import HUSKY

    config_numbers("husky_hysteresis_for_current", current_a=current_a, speed_m_s=speed_m_s)
    if not math.isfinite(current_a):
        raise ConfigError(f"husky_hysteresis_for_current: current_a must be a finite current, "
                          f"A, got {current_a}")
    if not (math.isfinite(speed_m_s) and speed_m_s > 0.0):
        raise ConfigError(f"husky_hysteresis_for_current: speed_m_s must be positive and "
                          f"finite, got {speed_m_s}")

    h = HUSKY if husky is None else husky
    m = h.motor
    side_load = h.mass_kg * G_M_S2 / 2.0
    s = steady_slip(terrain)
    mu = float(traction_coefficient(terrain.curve, s))
    rim = speed_m_s / (1.0 - s) if s < 1.0 else math.inf
    # the motor law is affine in the torque: the current above its no-load part buys torque
    no_load = float(m.current_from_torque(0.0, rim / h.wheel_radius_m))
    nm_per_a = m.wheel_torque_per_amp_nm
    torque = (current_a - no_load) * nm_per_a
    if torque < h.wheel_radius_m * side_load * mu:
        # a negative loss would be needed: 0 is returned, as documented, but no longer
        # without a word (the simulated Husky then draws more than the target)
        floor_a = no_load + h.wheel_radius_m * side_load * mu / nm_per_a
        warnings.warn(f"husky_hysteresis_for_current: current_a {current_a} A is below the "
                      f"{floor_a:.4g} A per side the Husky draws on this terrain at "
                      f"{speed_m_s} m/s with no hysteresis (no-load current plus the traction "
                      f"balancing the soil resistance): hysteresis 0 assumed, the simulated "
                      f"current stays {floor_a:.4g} A", DataWarning, stacklevel=2)
        return 0.0
    return (torque / (h.wheel_radius_m * side_load) - mu) / np.tanh(rim / HYSTERESIS_SPEED_M_S)


def calibrate_janosi(soil_resistance: float, slip_steady: float, slip_accel: float,
                     accel_m_s2: float = 1.0) -> JanosiCurve:
    """Janosi-Hanamoto curve through a steady slip and a quasi-static acceleration slip.

    Solves ``mu_max g(s_ss / k) = f`` and ``mu_max g(s_acc / k) = f + a / g_0`` for
    ``(mu_max, k)``, ``g(x) = 1 - (1 - e^-x) / x``.

    Parameters
    ----------
    soil_resistance : float
        f, dimensionless.
    slip_steady, slip_accel : float
        Slips at constant speed and while accelerating at ``accel_m_s2``.
    accel_m_s2 : float
        Acceleration of the accelerating test, m/s^2 (1 in seed 001 ch. 7.2.3).

    Returns
    -------
    JanosiCurve

    Raises
    ------
    ConfigError
        ``soil_resistance`` or ``accel_m_s2`` not a finite value > 0, a slip outside
        (0, 1], or no solution: the ratio ``(f + a/g_0)/f`` must be below
        ``slip_accel / slip_steady`` (``g(s_acc/k) / g(s_ss/k)`` runs from 1 as ``k -> 0``
        to ``s_acc / s_ss`` as ``k -> inf``).
    """
    config_positive("calibrate_janosi", soil_resistance=soil_resistance, accel_m_s2=accel_m_s2)
    config_fraction("calibrate_janosi", slip_steady=slip_steady, slip_accel=slip_accel)
    g = lambda x: float(patch_mobilisation(x)[0])  # noqa: E731
    target = (soil_resistance + accel_m_s2 / G_M_S2) / soil_resistance
    if not target < slip_accel / slip_steady:
        raise ConfigError(
            f"calibrate_janosi: no Janosi-Hanamoto curve gives slip {slip_steady} at the "
            f"resistance {soil_resistance} and slip {slip_accel} at {accel_m_s2} m/s^2 more: "
            f"the demand ratio (f + a/g_0)/f = {target:.4g} must be below slip_accel / "
            f"slip_steady = {slip_accel / slip_steady:.4g}")
    excess = lambda k: g(slip_accel / k) / g(slip_steady / k) - target  # noqa: E731
    # the ratio runs from 1 (k -> 0) to slip_accel / slip_steady (k -> inf): widen the
    # bracket 1000-fold until it holds the root (a firm soil's k can lie below 1e-3)
    lo, hi = 1e-3, 1e3
    for _ in range(30):
        if excess(lo) >= 0.0:
            lo *= 1e-3
        elif excess(hi) <= 0.0:
            hi *= 1e3
        else:
            break
    else:
        raise ConfigError(f"calibrate_janosi: no Janosi-Hanamoto curve found for slip "
                          f"{slip_steady} at the resistance {soil_resistance} and slip "
                          f"{slip_accel} at {accel_m_s2} m/s^2 more (K/L outside "
                          f"[{lo:.3g}, {hi:.3g}])")
    k = brentq(excess, lo, hi)
    return JanosiCurve(soil_resistance / g(slip_steady / k), k,
                       "calibrated (calibrate_janosi)")
