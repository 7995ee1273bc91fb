"""Slip-compensated dead reckoning of a skid-steer vehicle.

Plain wheel odometry (seed 000 eqs. 1-5 with ``eta = 1``)::

    v = (v_L + v_R) / 2,   yaw_rate = (v_R - v_L) / B

Compensated: each side's ground speed from its rim speed and slip, inverting the SAE slip of
:func:`terrain.terramechanics.slip.sae_slip` with
:func:`terrain.terramechanics.slip.ground_speed_from_slip` (a braking slip below
:data:`BRAKING_SLIP_FLOOR` is held there, counted and warned about), and the turning
factor ``chi`` (ICR expansion with the turning slip lumped in; seed 000 eq. 5 with
Mandow et al. 2007)::

    v = (v_L' + v_R') / 2,  yaw_rate = (v_R - v_L) / (chi B),  lateral velocity v_y

(``v_y``: the sideways sliding on a slope, which wheel speeds cannot see; learned).

Heading from the gyro instead (``yaw_rate_rad_s``): the yaw rate is the measured one, not
the wheels' (a skid-steer vehicle's wheel yaw rate overstates its turning by ``chi`` ~ 1.5-3,
the dominant error of wheel odometry through headland turns).

The pose is integrated with the midpoint heading (as the simulator does).
"""

from __future__ import annotations

import warnings

import numpy as np

from terrain.errors import (ConfigError, DataWarning, EstimationError, NonFiniteInputError,
                            ShapeError, TimeStepError, config_positive, first_items,
                            refuse_booleans)
from terrain.run import times_out_of_order
from terrain.terramechanics.slip import ground_speed_from_slip

#: braking slip at which a compensated ground speed is held: the inverse grows as
#: ``1 / (1 + s)``, so a window whose slip is -1 (a locked or nearly stopped rim under a
#: moving vehicle) would give an unbounded speed
BRAKING_SLIP_FLOOR = -0.95


def dead_reckon(t_s: np.ndarray, v_left_m_s: np.ndarray, v_right_m_s: np.ndarray,
                track_m: float, slip_left: np.ndarray | None = None,
                slip_right: np.ndarray | None = None, chi: np.ndarray | float = 1.0,
                lateral_m_s: np.ndarray | float = 0.0,
                yaw_rate_rad_s: np.ndarray | None = None) -> np.ndarray:
    """Pose from wheel speeds, optionally slip-compensated (module docstring).

    Parameters
    ----------
    t_s : ndarray, shape (N,)
        Strictly increasing times, s.
    v_left_m_s, v_right_m_s : ndarray, shape (N,)
        Side rim speeds, m/s.
    track_m : float
        Track B, m.
    slip_left, slip_right : float or ndarray, shape (N,), optional
        SAE slip of each side (None = 0, plain odometry); a slip below
        :data:`BRAKING_SLIP_FLOOR` (in the rim's direction) is taken as that floor and one
        above 1 as 1 (ground speed 0), and the samples so held are counted in a
        :class:`~terrain.errors.DataWarning`.
    chi : float or ndarray, shape (N,)
        Turning factor, > 0 (1 = plain odometry); not used with ``yaw_rate_rad_s``.
    lateral_m_s : float or ndarray, shape (N,)
        Lateral body velocity (sideways sliding), m/s (0 = plain odometry).
    yaw_rate_rad_s : ndarray, shape (N,), optional
        Measured yaw rate (gyro z at the wheel times), rad/s: the heading is integrated from
        it and ``chi`` is not used; None = the wheels' yaw rate.

    Returns
    -------
    ndarray, shape (N, 3)
        ``x, y`` (m, start frame) and yaw (rad), starting at 0.

    Raises
    ------
    EstimationError
        An argument of numbers (times, speeds, slips, ``chi``, ``lateral_m_s``, yaw rate)
        that holds booleans (a mask given for a speed was integrated as 1 m/s); it is named.
    ShapeError
        Inconsistent lengths (times, speeds, slips, ``chi``, ``lateral_m_s``, yaw rate), or
        no sample.
    TimeStepError
        Times not finite or not strictly increasing (the first such sample and the count
        are named).
    NonFiniteInputError
        A speed, slip, ``chi``, lateral velocity or yaw rate sample that is NaN or infinite
        (the pose would be NaN from it on); the message names the argument and counts them.
    ConfigError
        ``track_m`` not a finite number > 0 (:func:`terrain.errors.config_positive`: text,
        booleans and inf refused too) or a ``chi`` sample not > 0, where the yaw rate comes
        from the wheels.
    """
    # (a mask given for a speed was integrated as 1 m/s)
    refuse_booleans(EstimationError, "dead_reckon", t_s=t_s, v_left_m_s=v_left_m_s,
                    v_right_m_s=v_right_m_s, slip_left=slip_left, slip_right=slip_right,
                    chi=chi, lateral_m_s=lateral_m_s, yaw_rate_rad_s=yaw_rate_rad_s)
    t = np.asarray(t_s, dtype=float)
    vl = np.asarray(v_left_m_s, dtype=float)
    vr = np.asarray(v_right_m_s, dtype=float)
    if not (t.shape == vl.shape == vr.shape) or t.ndim != 1:
        raise ShapeError(f"t, v_left, v_right must share a shape (N,), got {t.shape}, "
                         f"{vl.shape}, {vr.shape}")
    if t.size == 0:
        raise ShapeError("dead_reckon: no sample (the pose starts at the first one)")
    bad = times_out_of_order(t)
    if bad.size:    # the first offending sample and the count, as resample names them
        i = int(bad[0])
        what = ("not finite" if not np.isfinite(t[i])
                else "before the previous one" if t[i] < t[i - 1]
                else "not after the previous one")
        raise TimeStepError(f"dead_reckon: t_s must be finite and strictly increasing: t_s "
                            f"sample {i} ({t[i]:.6g} s) is {what}, {bad.size} such sample(s) "
                            "in all")
    if yaw_rate_rad_s is None:      # inf made the wheels' yaw rate 0: a turn driven straight
        config_positive("dead_reckon", track_m=track_m)
    _finite("v_left_m_s", vl)
    _finite("v_right_m_s", vr)
    gl = vl if slip_left is None else _ground_speed(vl, _per_sample("slip_left", slip_left,
                                                                    t.shape))
    gr = vr if slip_right is None else _ground_speed(vr, _per_sample("slip_right", slip_right,
                                                                     t.shape))
    v = 0.5 * (gl + gr)
    vy = _per_sample("lateral_m_s", lateral_m_s, t.shape)
    if yaw_rate_rad_s is None:
        k = _per_sample("chi", chi, t.shape)
        bad = np.flatnonzero(~(k > 0))
        if bad.size:     # 0 divided the yaw rate (NaN pose), < 0 turned the other way
            raise ConfigError(f"dead_reckon: chi must be > 0 (it divides the wheels' yaw "
                              f"rate), got {k[bad[0]]:g} at {bad.size} of {k.size} samples "
                              f"({first_items(bad.tolist(), word='sample')})")
        yaw_rate = (vr - vl) / (k * track_m)
    else:
        yaw_rate = np.asarray(yaw_rate_rad_s, dtype=float)
        if yaw_rate.shape != t.shape:
            raise ShapeError(f"yaw_rate_rad_s must have shape {t.shape}, got {yaw_rate.shape}")
        _finite("yaw_rate_rad_s", yaw_rate)
    yaw_rate = np.broadcast_to(yaw_rate, t.shape)
    dt = np.diff(t)
    # trapezoidal in the speeds, midpoint heading
    w_mid = 0.5 * (yaw_rate[:-1] + yaw_rate[1:])
    yaw = np.concatenate([[0.0], np.cumsum(w_mid * dt)])
    mid = yaw[:-1] + 0.5 * dt * w_mid
    v_mid = 0.5 * (v[:-1] + v[1:])
    vy_mid = 0.5 * (vy[:-1] + vy[1:])
    c, s = np.cos(mid), np.sin(mid)
    x = np.concatenate([[0.0], np.cumsum((v_mid * c - vy_mid * s) * dt)])
    y = np.concatenate([[0.0], np.cumsum((v_mid * s + vy_mid * c) * dt)])
    return np.column_stack([x, y, yaw])


def _per_sample(name: str, value, shape: tuple[int, ...]) -> np.ndarray:
    """``value`` (a float or one value per sample) as an array of ``shape``; ShapeError
    naming ``name`` for another length."""
    x = np.asarray(value, dtype=float)
    if x.ndim and x.shape != shape:
        raise ShapeError(f"dead_reckon: {name} must be a float or have shape {shape}, got "
                         f"{x.shape}")
    return _finite(name, np.broadcast_to(x, shape))


def _finite(name: str, x: np.ndarray) -> np.ndarray:
    """``x``, refused by ``name`` (NonFiniteInputError) when a sample is NaN or infinite: the
    integrated pose would be NaN from that sample on."""
    bad = np.flatnonzero(~np.isfinite(x))
    if bad.size:
        raise NonFiniteInputError(
            f"dead_reckon: {name} has {bad.size} of {x.size} samples NaN or infinite "
            f"({first_items(bad.tolist(), word='sample')}): the pose would be NaN from the "
            "first on")
    return x


def _ground_speed(rim_m_s: np.ndarray, slip: np.ndarray) -> np.ndarray:
    """Side ground speed from its rim speed and slip, braking slip held at
    :data:`BRAKING_SLIP_FLOOR` and traction slip at 1 (each counted, warned)."""
    q = np.where(rim_m_s < 0, -1.0, 1.0) * np.asarray(slip, dtype=float)
    held = q < BRAKING_SLIP_FLOOR
    if held.any():
        warnings.warn(f"dead_reckon: {int(held.sum())} of {held.size} slips below "
                      f"{BRAKING_SLIP_FLOOR} (braking) taken as {BRAKING_SLIP_FLOOR}: the "
                      "ground speed 1 / (1 + s) would be unbounded", DataWarning, stacklevel=3)
    spun = q > 1.0
    if spun.any():
        warnings.warn(f"dead_reckon: {int(spun.sum())} of {spun.size} slips above 1 taken as "
                      "1 (ground speed 0): the SAE slip saturates at 1 (sae_slip)",
                      DataWarning, stacklevel=3)
    q = np.clip(q, BRAKING_SLIP_FLOOR, 1.0)
    return ground_speed_from_slip(rim_m_s, np.where(rim_m_s < 0, -q, q))
