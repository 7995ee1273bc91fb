"""Feed-forward slip limit: a wheel may not outrun the ground speed its terrain can give.

The feedback controller (:mod:`terrain.control.traction`) acts on the *estimated* slip, which
reaches it late during a start-up: the AgriMaRo's encoder driver filter (0.12 s, seed 001
ch. 7.2.2) and the Husky's 6.5 Hz wheel stream make the measured wheel speed lag, and the
peak slip of a start on ice is over within 0.5 s (docs/control_validation.md). This module is
the latency remedy: a limit computed from the robot's own command and the terrain's curve,
with no estimate of the slip in it.

With the wheel slip held at the traction target ``s_t`` on flat ground the net pull of the
terrain is ``(mu(s_t) - rho(s_t)) N`` (gross traction minus slip-producing soil resistance,
the balance of :func:`terrain.terramechanics.steady_slip`), so the chassis accelerates at most
at ``a_max = g (mu(s_t) - rho(s_t))`` (:func:`traction_acceleration_limit`). A reference
ground speed that grows at ``a_max`` from the estimated one, never beyond the commanded rim
speed, gives each wheel the speed limit ``omega_lim = v_ref / (r (1 - s_t))`` (SAE traction
slip ``s = 1 - v / (omega r)``, seed 001 eq. 7.1) (:func:`feedforward_step`). Once the
limit binds, the estimate may lift the reference no faster than ``a_max`` either (rate-limited
release): a lagging slip estimate overstates the ground speed ``omega r (1 - s)`` during a
start-up, and lifting the reference to it released the limit in steps.

Limits: ``a_max`` assumes flat ground (on a grade the real acceleration is lower and the
feedback controller has to catch the rest) and the mass of the vehicle on its wheels (no
drawbar load); the reference is only as good as the terrain decision.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from terrain.errors import (ConfigError, DataFormatError, ImplausibleValueError, ShapeError,
                            config_numbers, holds_booleans, refuse_unreal)
from terrain.terramechanics import TerrainParams, traction_coefficient
from terrain.terramechanics.resistance import G_M_S2, soil_resistance_coefficient
from terrain.terramechanics.slip import rim_speed_from_slip


def traction_acceleration_limit(terrain: TerrainParams, slip: float) -> float:
    """Largest chassis acceleration with the wheel slip held at ``slip`` on flat ground.

    ``a = g (mu(s) - rho(s))``: gross traction coefficient
    (:func:`terrain.terramechanics.traction_coefficient`) minus slip-producing soil resistance
    (:func:`terrain.terramechanics.soil_resistance_coefficient`), times g (quasi-static
    traction balance; Wong, *Theory of Ground Vehicles*, 4th ed., ch. 4.2, net thrust =
    thrust - motion resistance).

    Parameters
    ----------
    terrain : TerrainParams
        Catalogue entry.
    slip : float
        Held slip magnitude, dimensionless, in [0, 1].

    Returns
    -------
    float
        Acceleration, m/s^2; negative when the soil resistance exceeds the traction there
        (the robot cannot accelerate at that slip).

    Raises
    ------
    ConfigError
        ``terrain`` not a :class:`TerrainParams` (a name: pass ``get_terrain(name)``);
        ``slip`` not a real number (text, ``None``, a boolean; named) or its magnitude not
        in [0, 1] (NaN included).
    """
    if not isinstance(terrain, TerrainParams):   # a name: AttributeError 'str' ... 'curve'
        raise ConfigError(f"traction_acceleration_limit needs a catalogue entry "
                          f"(TerrainParams, get_terrain(name)), got {type(terrain).__name__} "
                          f"{terrain!r:.60}")
    config_numbers("traction_acceleration_limit", slip=slip)
    s = abs(float(slip))
    if not s <= 1.0:   # NaN fails: a NaN limit; beyond 1 the curve is read past full spin
        raise ConfigError(f"traction_acceleration_limit: slip must be a slip magnitude in "
                          f"[0, 1], got {slip}")
    return G_M_S2 * float(traction_coefficient(terrain.curve, s)
                          - soil_resistance_coefficient(terrain, s))


class FeedForward(NamedTuple):
    """Result of one feed-forward step.

    Attributes
    ----------
    correction_rad_s : ndarray, shape (n,)
        Wheel speed correction that brings each wheel down to its limit, rad/s (0 where the
        command is below it; opposite in sign to the command otherwise).
    v_ref_m_s : ndarray, shape (n,)
        Reference ground speed magnitude of each unit after the step, m/s.
    omega_limit_rad_s : ndarray, shape (n,)
        Wheel speed magnitude limit, rad/s.
    engaged : ndarray of bool, shape (n,)
        Whether the limit binds (the command is above it); pass it to the next step.
    """

    correction_rad_s: np.ndarray
    v_ref_m_s: np.ndarray
    omega_limit_rad_s: np.ndarray
    engaged: np.ndarray


def feedforward_step(v_ref_m_s: np.ndarray, v_est_m_s: np.ndarray,
                     omega_low_level_rad_s: np.ndarray, accel_limit_m_s2: float,
                     target_slip: float, wheel_radius_m: float, dt_s: float,
                     engaged: np.ndarray | None = None) -> FeedForward:
    """One step of the feed-forward slip limit (module docstring).

    ``v_ref <- max(v_lift, min(v_ref + max(a_max, 0) dt, |omega_ll| r))``;
    ``omega_lim = v_ref / (r (1 - s_t))`` (the rim speed of the SAE slip ``s_t`` at the
    ground speed ``v_ref``, :func:`terrain.terramechanics.slip.rim_speed_from_slip`, over
    ``r``); the correction lowers ``|omega_ll|`` to
    ``omega_lim`` where it is above, keeping its sign. The estimate lifts the reference,
    ``v_lift = |v_est|``, except where the limit was ``engaged`` at the previous step: there
    ``v_lift = min(|v_est|, v_ref + max(a_max, 0) dt)``, so an engaged limit is released no
    faster than the terrain can accelerate the robot. Reason: during a start-up the slip
    estimate lags the true slip, so the ground speed derived from it (``omega r (1 - s)``)
    runs ahead of the true one; lifting the reference to it released the limit in steps at
    each wheel sample and let the wheels spin up again (Husky, fused estimate, SNOW: peak
    slip 0.346 with control against 0.328 without, docs/control_validation.md).

    Parameters
    ----------
    v_ref_m_s : ndarray, shape (n,)
        Reference ground speed magnitudes of the previous step, m/s (0 at rest).
    v_est_m_s : ndarray, shape (n,)
        Estimated longitudinal ground speed of each unit, m/s (NaN counts as 0).
    omega_low_level_rad_s : ndarray, shape (n,)
        Low-level wheel speed command, rad/s.
    accel_limit_m_s2 : float
        ``a_max`` of :func:`traction_acceleration_limit`, m/s^2.
    target_slip : float
        Traction target slip magnitude ``s_t``, dimensionless, in [0, 1).
    wheel_radius_m : float
        Wheel radius r, m (> 0).
    dt_s : float
        Time since the previous step, s (>= 0).
    engaged : ndarray of bool, shape (n,), optional
        ``engaged`` of the previous step's result; None: not engaged anywhere (the estimate
        lifts the reference freely).

    Returns
    -------
    FeedForward

    Raises
    ------
    ShapeError
        ``v_ref_m_s``, ``v_est_m_s`` or ``engaged`` not of the command's shape ``(n,)``
        (named, with both shapes; NumPy broadcast a ``(1,)`` reference to every wheel).
    ConfigError
        ``|target_slip|`` not a finite value below 1 (at 1 no ground speed limits the wheel:
        it was clipped to 0.99 without a word), ``wheel_radius_m`` not finite and > 0
        (an infinite radius gave a limit of 0: the wheel stopped), ``dt_s``
        negative or not finite, ``accel_limit_m_s2`` not finite (a NaN reference never
        limits), or one of these not a real number (text, ``None``, a boolean; named).
    ImplausibleValueError
        A non-finite ``omega_low_level_rad_s`` or ``v_ref_m_s`` (named): the wheel's
        reference would become NaN, its limit never bind again (a non-finite estimate
        counts as 0, as before).
    DataFormatError
        ``omega_low_level_rad_s``, ``v_est_m_s`` or ``v_ref_m_s`` holding booleans or values
        that are not real numbers (text, a ragged list; named), or ``engaged`` that is not
        booleans (0.5, ``"no"``: read by truthiness).
    """
    try:
        if any(isinstance(x, (bool, np.bool_))   # float(True) is 1: dt_s=True was a second
               for x in (accel_limit_m_s2, target_slip, wheel_radius_m, dt_s)):
            raise TypeError("a boolean")
        s_t, radius, dt_s = abs(float(target_slip)), float(wheel_radius_m), float(dt_s)
        a_max = float(accel_limit_m_s2)
    except (TypeError, ValueError):   # the slow path names the argument
        config_numbers("feedforward_step", accel_limit_m_s2=accel_limit_m_s2,
                       target_slip=target_slip, wheel_radius_m=wheel_radius_m, dt_s=dt_s)
        raise
    # NaN fails each; an infinite radius gave a limit of 0 rad/s: every wheel stopped
    if not (s_t < 1.0 and 0.0 < radius < math.inf and 0.0 <= dt_s < math.inf):
        raise ConfigError(f"feedforward_step: need |target_slip| < 1, a finite "
                          f"wheel_radius_m > 0 and a finite dt_s >= 0, got {target_slip}, "
                          f"{wheel_radius_m}, {dt_s}")
    if not math.isfinite(a_max):   # a NaN reference never binds, and stays NaN for good
        raise ConfigError(f"feedforward_step: accel_limit_m_s2 must be finite, got "
                          f"{accel_limit_m_s2}")
    for name, x in (("omega_low_level_rad_s", omega_low_level_rad_s),
                    ("v_est_m_s", v_est_m_s), ("v_ref_m_s", v_ref_m_s)):
        if holds_booleans(x):   # a boolean command was 1 rad/s
            raise DataFormatError(f"feedforward_step: {name} must hold real numbers, got a "
                                  f"boolean {x!r:.60}", column=name)
    try:
        omega = np.asarray(omega_low_level_rad_s, dtype=float)
        v_est = np.asarray(v_est_m_s, dtype=float)
        v_ref = np.asarray(v_ref_m_s, dtype=float)
    except (TypeError, ValueError):   # text: numpy's message named no input
        refuse_unreal("feedforward_step", ("v_est_m_s", "v_ref_m_s"),
                      omega_low_level_rad_s=omega_low_level_rad_s, v_est_m_s=v_est_m_s,
                      v_ref_m_s=v_ref_m_s)
        raise
    if engaged is not None and np.asarray(engaged).dtype != bool:   # read by truthiness
        raise DataFormatError(f"feedforward_step: engaged must be the booleans of the "
                              f"previous step's result, got {engaged!r:.60}", column="engaged")
    n = omega.shape
    if v_ref.shape != n or v_est.shape != n or (
            engaged is not None and np.shape(engaged) != n):
        _refuse_shapes(n, v_ref_m_s=v_ref, v_est_m_s=v_est, engaged=engaged)
    for name, values in (("omega_low_level_rad_s", omega), ("v_ref_m_s", v_ref)):
        if not np.all(np.isfinite(values)):   # a NaN reference never binds, and stays NaN
            raise ImplausibleValueError(
                f"feedforward_step: {name} holds a non-finite value {values.tolist()}; the "
                "limit of that wheel would be lost for good", column=name)
    rim = np.abs(omega) * radius
    v_est = np.nan_to_num(np.abs(v_est), nan=0.0, posinf=0.0)   # non-finite: 0
    grown = v_ref + max(a_max, 0.0) * dt_s
    lift = v_est if engaged is None else np.where(engaged, np.minimum(v_est, grown), v_est)
    v_ref = np.maximum(lift, np.minimum(grown, rim))
    # rim speed at the target slip per unit ground speed (linear in v at fixed slip, v >= 0)
    limit = v_ref * (rim_speed_from_slip(1.0, s_t)[0] / radius)
    over = np.abs(omega) > limit
    corr = np.where(over, np.sign(omega) * (limit - np.abs(omega)), 0.0)
    return FeedForward(corr, v_ref, limit, over)


def _refuse_shapes(n: tuple, **arrays) -> None:
    """Raise a :class:`~terrain.errors.ShapeError` naming each array of ``arrays`` whose
    shape is not the command's ``n``; the slow path, run only once a shape differs."""
    bad = [f"{name} has shape {np.shape(a)}" for name, a in arrays.items()
           if a is not None and np.shape(a) != n]
    raise ShapeError(f"feedforward_step: {', '.join(bad)}, the command omega_low_level_rad_s "
                     f"{n}: one entry per drive unit")
