"""Per-wheel traction controller of seed ``001_59da564c4b2d6a48.txt`` ch. 8.3.2.

One step covers all drive units (the wheels of the AgriMaRo; the two sides of a
skid-steer Husky or tracked vehicle, which run the same logic per side with the side's slip
from the slip estimator):

1. slip ``s = (omega r - v_long) / max(|omega r|, |v_long|)`` (eqs. 8.4-8.5, via
   :func:`terrain.slip.sae_slip`);
2. per-wheel enable: the error is 0 below ``wheel_speed_threshold_m_s`` (0.05 m/s in ch. 8.3.2;
   the wheel's speed is ``max(|omega r|, |v_long|)``, the slip's own dead band of ch. 7.2.1);
   the correction reaches the motors only while the chassis speed exceeds
   ``chassis_speed_threshold_m_s`` (0.05 m/s);
3. ``Power_state = a_local v_long`` (eq. 8.6) against ``power_threshold_m2_s3``: traction,
   braking or steady; ``s_desired = sgn(v_long) s_target`` (eqs. 8.7-8.9);
4. ``e = s_desired - s`` (eq. 8.1), PID (eq. 8.2), ``omega_cmd = omega_low_level + PID_out``
   (eq. 8.3).

Beyond the thesis (their settings in :class:`TractionControlConfig`):

* anti-windup by conditional integration: while the output is saturated in the direction of
  the error the integral grows only up to the value that just reaches the limit, and it always
  stays within the room the output has at that step (the output limit, the wheel speed limit,
  the command's half-line and, with ``one_sided``, the limiter's side; widened to hold 0),
  clamped there before and after integrating. So a traction -> braking change starts the
  braking correction from an integral of 0, not from the traction integral unwinding at
  ``ki e dt`` (AgriMaRo gains 5 / 10: 15 steps with no correction for a locking wheel after
  1 s of traction, when the integral was clamped to the static +-limit only);
* output saturation: ``|PID_out| <= output_fraction * omega_max``, the command stays within
  ``[-omega_max, omega_max]`` and never crosses zero (slip control modulates the wheel speed,
  it never reverses a wheel nor moves one the low level holds still); where these conflict
  (a low-level command beyond ``omega_max``) the wheel speed limit and the half-line win;
* one-sided limiting (``one_sided``, default): the correction only ever moves the wheel speed
  towards the ground speed, so the robot is never driven faster than commanded;
* derivative on the measured slip (no kick when the target switches between traction, braking
  and steady), through a first-order low-pass filter of time constant ``derivative_tau_s``;
* bumpless transfer: when disabled (chassis too slow) the last correction decays with
  ``release_tau_s`` instead of jumping to 0, and on enable the integral starts from the held
  correction (with ``ki > 0``), so only the proportional and derivative action on the current
  error is added, never a stale or reset integral;
* safe output: a non-finite input (or a non-finite entry of a unit's memory in the state,
  one restored from a log or built by hand) or an estimate older than ``max_input_age_s``
  (or with a negative age: stamped after the step, clocks that disagree;
  :func:`age_is_fresh`, the rule of the decision age too) gives
  ``omega_cmd = omega_low_level`` (no correction; clipped to ``+-omega_max`` like every
  command) at once and resets that wheel's state.

Why not simple-pid (2.0.1) for the building blocks: its windup guard clamps the integral to
the output limits. That is acceptable for a fixed limit, not here: the room left for the
correction changes every step (it depends on ``omega_low_level`` and the wheel speed limit,
and on the limiter's side), and an integral allowed to reach the whole static limit keeps the
output saturated long after the error reverses (``tests/control``: after the same saturated
history it still asks for > 4 rad/s where only 0.2 rad/s of room is left; ours releases at
once). It also has no derivative filter, a NaN input enters its integral for good, and its
state lives in an object timed by a monotonic clock unless ``dt`` is passed, not in a record a
simulator can step. It is the reference of ``benchmarks/bench_control.py`` and of a test that
our PID core equals it where neither saturates.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from terrain.errors import (ConfigError, DataFormatError, ImplausibleValueError, ShapeError,
                            config_flags, config_integer, config_numbers, holds_booleans,
                            refuse_unreal)
from terrain.slip import sae_slip
from terrain.vehicles import contact_geometry, get_vehicle

#: Operating modes of a wheel (``TractionOutput.mode``).
BRAKING, STEADY, TRACTION = -1, 0, 1


@dataclass(frozen=True)
class TractionControlConfig:
    """Gains, thresholds and limits of the traction controller.

    Parameters
    ----------
    kp : float
        Proportional gain, rad/s per unit slip error (1.0 in Table 8.1).
    ki : float
        Integral gain, rad/s per (unit slip error x s).
    kd : float
        Derivative gain on the measured slip, rad/s per (unit slip / s).
    wheel_radius_m : float
        Rolling radius r, m (1.0 in Table 8.1).
    omega_max_rad_s : float
        Wheel speed limit of the drive, rad/s.
    output_fraction : float
        ``|PID_out| <= output_fraction * omega_max_rad_s`` (dimensionless, (0, 1]).
    wheel_speed_threshold_m_s : float
        Per-wheel enabling threshold on ``max(|omega r|, |v_long|)``, m/s (0.05, ch. 8.3.2).
    chassis_speed_threshold_m_s : float
        Enabling threshold on the chassis speed magnitude, m/s (0.05, ch. 8.3.2).
    power_threshold_m2_s3 : float
        ``accel_threshold`` of ch. 8.3.2 on ``Power_state = a_local v_long``, m^2/s^3; the
        thesis gives no value: 0.02 ASSUMED (0.04 m/s^2 at 0.5 m/s, above the noise of the
        estimated acceleration).
    derivative_tau_s : float
        Time constant of the derivative's low-pass filter, s (> 0).
    release_tau_s : float
        Time constant with which the correction decays while disabled, s (> 0).
    max_input_age_s : float
        Slip / velocity estimates older than this (or with a negative age) give the safe
        output, s (:func:`age_is_fresh`).
    one_sided : bool
        True (default): a slip *limiter*, as traction control / ABS: in traction and steady
        driving the correction may only slow the wheel below ``omega_low_level``, in braking
        only speed it up, so the robot never goes faster than commanded. Steady driving is
        then limited at the *traction* target: the steady target (the slip that balances the
        resistances) is a set point for the two-sided regulation only; as a limit it stops any
        acceleration that ``Power_state`` has not detected yet, and with a measured
        acceleration the wheel stays locked in "steady" (the toy loop on ICE of
        ``tests/control`` crept to 0.8 m/s in 4 s instead of 1 m/s). False: the thesis's
        two-sided regulation (Table 8.1, case 1B speeds a wheel that slips less than the
        target up beyond the low-level command; while accelerating, ``Power_state`` stays
        positive, so this feeds back on itself until the output saturates).

    Raises
    ------
    ConfigError
        A setting that is not a real number (text, ``None``, a boolean, a list) or a
        ``one_sided`` that is not a boolean, named; a non-finite setting; a negative gain or
        threshold; a radius, speed limit, time constant or input age limit not > 0; an
        ``output_fraction`` outside (0, 1].
    """

    kp: float = 1.0
    ki: float = 0.0
    kd: float = 0.0
    wheel_radius_m: float = 1.0
    omega_max_rad_s: float = 100.0
    output_fraction: float = 0.5
    wheel_speed_threshold_m_s: float = 0.05
    chassis_speed_threshold_m_s: float = 0.05
    power_threshold_m2_s3: float = 0.02
    derivative_tau_s: float = 0.05
    release_tau_s: float = 0.2
    max_input_age_s: float = 0.1
    one_sided: bool = True

    def __post_init__(self) -> None:
        numeric = {f: getattr(self, f) for f in self.__dataclass_fields__ if f != "one_sided"}
        config_numbers("TractionControlConfig", **numeric)
        config_flags("TractionControlConfig", one_sided=self.one_sided)
        bad = {f: v for f, v in numeric.items() if not math.isfinite(float(v))}
        if bad:
            raise ConfigError("traction control settings must be finite, got "
                              + ", ".join(f"{f}={v}" for f, v in bad.items()))
        if min(self.kp, self.ki, self.kd) < 0.0:
            raise ConfigError(f"gains must be >= 0, got kp={self.kp}, ki={self.ki}, kd={self.kd}")
        positive = ("wheel_radius_m", "omega_max_rad_s", "derivative_tau_s", "release_tau_s",
                    "max_input_age_s")
        bad = [f"{f}={numeric[f]}" for f in positive if numeric[f] <= 0.0]
        if bad:
            raise ConfigError("wheel radius, speed limit, time constants and input age limit "
                              f"must be > 0, got {', '.join(bad)}")
        if not 0.0 < self.output_fraction <= 1.0:
            raise ConfigError(f"output_fraction must be in (0, 1], got {self.output_fraction}")
        thresholds = ("wheel_speed_threshold_m_s", "chassis_speed_threshold_m_s",
                      "power_threshold_m2_s3")
        bad = [f"{f}={numeric[f]}" for f in thresholds if numeric[f] < 0.0]
        if bad:
            raise ConfigError(f"thresholds must be >= 0, got {', '.join(bad)}")


def config_for_vehicle(vehicle: str, **settings: float) -> tuple[TractionControlConfig, int]:
    """Controller settings for a catalogued vehicle: its rolling radius and wheel speed limit.

    Parameters
    ----------
    vehicle : str
        ``agrimaro`` (3 steered wheels, one unit each), ``husky`` or ``tracked`` (two sides,
        one unit each), see :func:`terrain.vehicles.get_vehicle`.
    **settings : float or bool
        Any other :class:`TractionControlConfig` field (gains, thresholds...).

    Returns
    -------
    config : TractionControlConfig
        ``wheel_radius_m`` and ``omega_max_rad_s`` from the vehicle's contact geometry and
        motor (:class:`terrain.vehicles.MotorParams`); ``wheel_speed_threshold_m_s`` the
        larger of the thesis's 0.05 m/s and :func:`encoder_resolution_speed_m_s` of its
        encoder (AgriMaRo 0.384 m/s, Husky 0.05 m/s) unless given in ``settings``.
    n_units : int
        Number of drive units (motors).

    Raises
    ------
    ConfigError
        Unknown vehicle, an unknown setting or ``wheel_radius_m`` / ``omega_max_rad_s``
        (the vehicle's) in ``settings``, named, or invalid settings.
    """
    params = get_vehicle(vehicle)
    fields = TractionControlConfig.__dataclass_fields__
    for name in settings:
        if name not in fields:
            raise ConfigError(f"unknown traction control setting {name!r}; the settings are "
                              f"{', '.join(fields)}")
        if name in ("wheel_radius_m", "omega_max_rad_s"):
            raise ConfigError(f"{name} comes from the vehicle {vehicle}'s geometry and motor; "
                              "build a TractionControlConfig for other values")
    geometry = contact_geometry(params)
    threshold = max(TractionControlConfig.wheel_speed_threshold_m_s,
                    encoder_resolution_speed_m_s(params.motor, geometry.wheel_radius_m))
    cfg = TractionControlConfig(wheel_radius_m=geometry.wheel_radius_m,
                                omega_max_rad_s=params.motor.max_wheel_speed_rad_s,
                                **{"wheel_speed_threshold_m_s": threshold, **settings})
    return cfg, geometry.n_motors


#: Slip resolution below which the controller does not act on a wheel: one encoder count per
#: time constant of the driver's speed filter may be at most this fraction of the wheel speed
#: (dimensionless; see :func:`encoder_resolution_speed_m_s`).
ENCODER_SLIP_RESOLUTION = 0.25


def encoder_resolution_speed_m_s(motor, wheel_radius_m: float,
                                 slip_resolution: float = ENCODER_SLIP_RESOLUTION) -> float:
    """Rim speed below which the measured wheel speed cannot resolve ``slip_resolution``.

    The drive reports a count rate smoothed by a first-order filter of time constant ``tau``
    (:func:`terrain.sim.sensors.encoder_count_rate`, seed 001 ch. 7.2.2), so one count more
    or less within ``tau`` moves the reported speed by ``q / tau`` (``q = 2 pi / N``, N counts
    per revolution), and the slip computed from it (eqs. 8.4-8.5) by ``q / (tau omega)``. Below
    ``v = r q / (tau slip_resolution)`` that error exceeds ``slip_resolution``: the slip there
    is the encoder's noise. Measured on the AgriMaRo's 90-count Hall encoders on the 15 deg
    ``slope_turn`` (0.05-0.2 m/s): with the thesis's 0.05 m/s threshold the controller acted
    in 16 % of the enabled steps where the true slip was above its target in 3.7 %, and
    braked wheels to a true slip of -0.4 (``docs/control_validation.md``, "Other
    scenarios").

    Parameters
    ----------
    motor : MotorParams
        Drive with ``encoder_counts_per_rev`` and ``encoder_filter_s`` (s).
    wheel_radius_m : float
        Rolling radius r, m (finite, > 0).
    slip_resolution : float
        Largest tolerated slip error of one count (dimensionless, finite, > 0;
        :data:`ENCODER_SLIP_RESOLUTION`: 4 counts per filter time constant).

    Returns
    -------
    float
        Rim speed, m/s; 0 for a drive without a speed filter (``encoder_filter_s`` 0: no
        averaging time is known, the thesis's threshold applies): AgriMaRo 0.384 m/s
        (r 0.165 m, 90 counts, 0.12 s), Husky 0.

    Raises
    ------
    ConfigError
        ``slip_resolution`` or the wheel radius not a real number (text, ``None``, a
        boolean; named), or not finite and > 0; ``motor`` without ``encoder_filter_s`` and
        ``encoder_quantum_rad`` (None, a vehicle name).
    """
    config_numbers("encoder_resolution_speed_m_s", wheel_radius_m=wheel_radius_m,
                   slip_resolution=slip_resolution)
    if not (0 < slip_resolution < math.inf and 0 < wheel_radius_m < math.inf):  # NaN fails
        raise ConfigError(f"slip_resolution and wheel_radius_m must be finite and > 0, got "
                          f"{slip_resolution}, {wheel_radius_m}")
    try:
        tau = float(motor.encoder_filter_s)
        if tau <= 0:
            return 0.0
        quantum = motor.encoder_quantum_rad
    except AttributeError:   # None, a vehicle's name
        raise ConfigError(f"encoder_resolution_speed_m_s: motor must be a drive "
                          f"(MotorParams, get_vehicle(name).motor), got "
                          f"{type(motor).__name__} {motor!r:.60}") from None
    return float(wheel_radius_m) * quantum / (tau * float(slip_resolution))


@dataclass(frozen=True)
class SlipTargets:
    """Target slip magnitudes for forward driving (sign from ``sgn(v_long)``, eqs. 8.7-8.9).

    Any object with these three attributes works, e.g. a
    :class:`~terrain.control.desired_slip.DesiredSlip` row of the table. It unpacks as
    ``traction, braking, steady = targets`` (as a plain tuple does): it is also the record
    the live service's target providers return (:mod:`terrain.serving.targets`).

    Parameters
    ----------
    traction : float
        Target while accelerating, in (0, 1] (dimensionless, SAE slip: wheel faster than the
        ground).
    braking : float
        Target while braking, in [-1, 0) (wheel slower than the ground).
    steady : float
        Target while cruising, in [0, 1].

    Raises
    ------
    ConfigError
        A target that is not a real number, or outside its range (:func:`check_slip_targets`),
        named with its value.
    """

    traction: float
    braking: float
    steady: float

    def __post_init__(self) -> None:
        check_slip_targets("SlipTargets", self.traction, self.braking, self.steady)

    def __iter__(self):
        """The three targets in order ``traction, braking, steady`` (tuple unpacking)."""
        return iter((self.traction, self.braking, self.steady))


def check_slip_targets(owner: str, traction: float, braking: float, steady: float) -> None:
    """Refuse slip targets of the wrong sign or beyond the SAE slip's range.

    The targets are magnitudes for forward driving in the SAE convention of eqs. 8.4-8.5
    (seed 001 ch. 8.3.2; the sign for reversing comes from ``sgn(v_long)``, eqs. 8.7-8.9):
    a traction target is positive (wheel faster than the ground), a braking target negative,
    a steady target not negative (Table 8.1: +0.1, -0.15), each within [-1, 1], the range of
    the SAE slip. A traction target of the wrong sign makes the one-sided limiter slow a wheel
    that does not slip; NaN never matches a slip, so the controller would never act.

    Parameters
    ----------
    owner : str
        Name of the record, for the message (``"SlipTargets"``, ``"DesiredSlip"``).
    traction : float
        Traction target, dimensionless, must be in (0, 1].
    braking : float
        Braking target, dimensionless, must be in [-1, 0).
    steady : float
        Steady target, dimensionless, must be in [0, 1].

    Raises
    ------
    ConfigError
        A target that is not a real number, or outside its range, named with its value.
    """
    config_numbers(owner, traction=traction, braking=braking, steady=steady)
    checks = (("traction", traction, 0.0 < traction <= 1.0, "in (0, 1]"),
              ("braking", braking, -1.0 <= braking < 0.0, "in [-1, 0)"),
              ("steady", steady, 0.0 <= steady <= 1.0, "in [0, 1]"))
    for name, value, ok, rule in checks:
        if not ok:   # NaN fails each comparison
            raise ConfigError(f"{owner}.{name} must be {rule} (SAE slip magnitude for forward "
                              "driving: traction > 0, braking < 0; the sign for reversing "
                              f"comes from sgn(v_long)), got {value}")


def age_is_fresh(age_s: float, max_age_s: float) -> bool:
    """Whether an input of age ``age_s`` may be trusted: finite and in ``[0, max_age_s]``.

    The one rule of the control layer for the age of an estimate
    (:func:`traction_control_step`) and of a terrain decision
    (:func:`terrain.control.desired_slip.select_target`). A negative age is an input stamped
    after the time it is used at: clocks that disagree, so the stamp, and the age, cannot be
    trusted (a clock error is distrusted, not read as "fresh").

    Parameters
    ----------
    age_s : float or None
        Time since the input was made, s (None: not known).
    max_age_s : float
        Oldest trusted age, s (>= 0; the age equal to it is trusted).

    Returns
    -------
    bool
        False for an age that is older, negative, not finite (NaN, +-inf) or None.

    Raises
    ------
    ConfigError
        ``age_s`` not a real number or None (text, a boolean: ``True`` was an age of 1 s, an
        array), or ``max_age_s`` not a real number, or not finite and >= 0 (NaN made every
        input stale, inf none), named.
    """
    if type(age_s) is float and type(max_age_s) is float and 0.0 <= max_age_s < math.inf:
        return math.isfinite(age_s) and 0.0 <= age_s <= max_age_s   # (the step's every call)
    config_numbers("age_is_fresh", optional=("age_s",), age_s=age_s, max_age_s=max_age_s)
    if not 0.0 <= max_age_s < math.inf:
        raise ConfigError(f"age_is_fresh.max_age_s must be a finite age >= 0 s, got "
                          f"{max_age_s}")
    return age_s is not None and math.isfinite(age_s) and 0.0 <= age_s <= max_age_s


class TractionState(NamedTuple):
    """Controller memory between steps, one entry per drive unit (arrays of shape (n,)).

    An immutable record (a named tuple: cheap to build at every control step).

    Parameters
    ----------
    integral : ndarray, shape (n,)
        Integral term, rad/s.
    slip_prev : ndarray, shape (n,)
        Measured slip of the previous step (dimensionless; meaningful where ``slip_valid``).
    slip_valid : ndarray of bool, shape (n,)
        Whether ``slip_prev`` was measured above the wheel speed threshold.
    derivative : ndarray, shape (n,)
        Filtered derivative of the measured slip, 1/s.
    correction : ndarray, shape (n,)
        Correction applied at the previous step, rad/s.
    active : ndarray of bool, shape (n,)
        Whether the correction was applied by the PID at the previous step.
    """

    integral: np.ndarray
    slip_prev: np.ndarray
    slip_valid: np.ndarray
    derivative: np.ndarray
    correction: np.ndarray
    active: np.ndarray

    @classmethod
    def zeros(cls, n: int) -> "TractionState":
        """Initial state: no memory, no correction.

        Parameters
        ----------
        n : int
            Number of drive units (wheels, or sides of a skid-steer vehicle).

        Returns
        -------
        TractionState

        Raises
        ------
        ConfigError
            ``n`` not an integer >= 1 (``True``, 2.5, text, None: bare NumPy errors; 0: a
            state the step refuses).
        """
        config_integer("TractionState.zeros n", n, 1)
        z = np.zeros(n)
        no = np.zeros(n, dtype=bool)
        return cls(z, z, no, z, z, no)


class TractionOutput(NamedTuple):
    """Result of one controller step, one entry per drive unit (arrays of shape (n,)).

    An immutable record (a named tuple: cheap to build at every control step).

    Parameters
    ----------
    omega_cmd_rad_s : ndarray, shape (n,)
        Final wheel speed command ``omega_low_level + PID_out`` (eq. 8.3), rad/s, always
        within ``[-omega_max, omega_max]``; ``omega_low_level`` where ``safe`` (the
        controller adds nothing; a low-level command beyond ``omega_max`` is still clipped to
        it); a non-finite ``omega_low_level`` is refused (:func:`traction_control_step`).
    correction_rad_s : ndarray, shape (n,)
        ``PID_out`` actually applied (saturated, or decaying while disabled), rad/s; beyond
        the output limit only where the low-level command exceeds ``omega_max`` by more.
    slip : ndarray, shape (n,)
        Measured SAE slip (eq. 8.4; NaN where the input is not finite).
    desired_slip : ndarray, shape (n,)
        Signed target (eqs. 8.7-8.9).
    error : ndarray, shape (n,)
        ``desired - slip`` (eq. 8.1), 0 below the wheel speed threshold.
    mode : ndarray of int, shape (n,)
        :data:`TRACTION`, :data:`BRAKING` or :data:`STEADY` from ``Power_state``.
    enabled : ndarray of bool, shape (n,)
        Whether the PID output was applied.
    safe : ndarray of bool, shape (n,)
        Whether the safe output (no correction) was forced by stale or non-finite input (or
        a non-finite entry of that unit's memory in the state).
    """

    omega_cmd_rad_s: np.ndarray
    correction_rad_s: np.ndarray
    slip: np.ndarray
    desired_slip: np.ndarray
    error: np.ndarray
    mode: np.ndarray
    enabled: np.ndarray
    safe: np.ndarray


def traction_control_step(config: TractionControlConfig, state: TractionState,
                          targets: SlipTargets, omega_low_level_rad_s: np.ndarray,
                          omega_meas_rad_s: np.ndarray, v_long_m_s: np.ndarray,
                          a_local_m_s2: np.ndarray, chassis_speed_m_s: float, dt_s: float,
                          input_age_s: float = 0.0, slip: np.ndarray | None = None
                          ) -> tuple[TractionOutput, TractionState]:
    """One step of the ch. 8.3.2 traction controller (pure: returns the new state).

    Parameters
    ----------
    config : TractionControlConfig
    state : TractionState
        Memory of the previous step (:meth:`TractionState.zeros` at start), arrays (n,).
    targets : SlipTargets or DesiredSlip
        Target slip magnitudes of the current terrain (desired-slip table row).
    omega_low_level_rad_s : ndarray, shape (n,)
        Wheel speed from the low-level kinematic control, rad/s.
    omega_meas_rad_s : ndarray, shape (n,)
        Raw encoder wheel speed, rad/s (ch. 7.2: not the EKF-filtered one).
    v_long_m_s : ndarray, shape (n,)
        Estimated longitudinal velocity of each wheel centre (eq. 7.5), m/s.
    a_local_m_s2 : ndarray, shape (n,)
        Longitudinal acceleration of each wheel centre, m/s^2.
    chassis_speed_m_s : float
        Magnitude of the chassis velocity, m/s (>= 0; NaN: the safe output).
    dt_s : float
        Time since the previous step, s (> 0); zero, negative or non-finite -> the safe
        output, which clears the memory (a repeated time stamp restarts the integral;
        :class:`terrain.control.closed_loop.TractionLoop` floors repeated times at 1 us
        and passes a time that went back on as it is).
    input_age_s : float
        Age of the slip / velocity estimates, s; not in ``[0, max_input_age_s]``
        (:func:`age_is_fresh`: older, negative or non-finite) -> the safe output.
    slip : ndarray, shape (n,), optional
        Measured slip per unit from an estimator (skid-steer: the fused slip estimate of each
        side, dimensionless); None: computed from ``omega_meas_rad_s`` and ``v_long_m_s`` with
        :func:`terrain.slip.sae_slip` (eqs. 8.4-8.5).

    Returns
    -------
    output : TractionOutput
    state : TractionState
        Memory for the next step.

    Raises
    ------
    ConfigError
        ``config`` not a :class:`TractionControlConfig` (a dict of settings, None);
        ``targets`` without the attributes ``traction``, ``braking``, ``steady`` (a plain
        tuple, None), named; a ``state`` that is not a :class:`TractionState` of NumPy
        arrays (lists read back from a log, None); a record's target that is not a real
        number (text, ``None``, a boolean) or finite and outside its range
        (:func:`check_slip_targets`; a non-finite target gives the safe output).
    ShapeError
        An input array's shape, or a field of ``state``, differs from the state's integral
        ``(n,)`` (named in the message); a state of no drive unit or not one-dimensional.
    DataFormatError
        An input that is not a real number (text, ``None`` for a scalar, a complex
        scalar, a boolean or an array of booleans), named.
    ImplausibleValueError
        A non-finite ``omega_low_level_rad_s``: the command the correction is added to
        (a non-finite measurement or estimate only suspends the correction, as before);
        a negative ``chassis_speed_m_s`` (a signed speed, not a magnitude).
    """
    if not isinstance(config, TractionControlConfig):   # a bare AttributeError further down
        _refuse_config(config, "traction control step")
    cfg = config
    _refuse_booleans(omega_low_level_rad_s=omega_low_level_rad_s,
                     omega_meas_rad_s=omega_meas_rad_s, v_long_m_s=v_long_m_s,
                     a_local_m_s2=a_local_m_s2, chassis_speed_m_s=chassis_speed_m_s,
                     dt_s=dt_s, input_age_s=input_age_s, slip=slip)
    try:
        omega_ll = np.asarray(omega_low_level_rad_s, dtype=float)
        omega = np.asarray(omega_meas_rad_s, dtype=float)
        v = np.asarray(v_long_m_s, dtype=float)
        acc = np.asarray(a_local_m_s2, dtype=float)
        chassis_speed_m_s, dt_s = float(chassis_speed_m_s), float(dt_s)
        input_age_s = float(input_age_s)
        if slip is not None:
            slip = np.asarray(slip, dtype=float)
    except (TypeError, ValueError):
        refuse_unreal("traction control step", ("slip",),
                      omega_low_level_rad_s=omega_low_level_rad_s,
                      omega_meas_rad_s=omega_meas_rad_s, v_long_m_s=v_long_m_s,
                      a_local_m_s2=a_local_m_s2, chassis_speed_m_s=chassis_speed_m_s,
                      dt_s=dt_s, input_age_s=input_age_s, slip=slip)
        raise
    if chassis_speed_m_s < 0.0:   # a signed speed: never enabled while reversing
        raise ImplausibleValueError(
            f"traction control step: chassis_speed_m_s is the magnitude of the chassis "
            f"velocity, got {chassis_speed_m_s}", column="chassis_speed_m_s")
    try:
        t_traction, t_braking, t_steady = targets.traction, targets.braking, targets.steady
    except AttributeError:   # a plain tuple (it unpacks as SlipTargets does), None, a number
        raise ConfigError(f"traction control step: targets must be a SlipTargets or a "
                          f"desired-slip table row (attributes traction, braking, steady), "
                          f"got {type(targets).__name__} {targets!r:.60}") from None
    try:   # a SlipTargets or a DesiredSlip was checked when made; any other record was not
        in_range = (0.0 < t_traction <= 1.0 and -1.0 <= t_braking < 0.0
                    and 0.0 <= t_steady <= 1.0)
    except TypeError:   # text, None
        in_range = False
    if not in_range or isinstance(t_traction, (bool, np.bool_)) \
            or isinstance(t_steady, (bool, np.bool_)):   # True passes as a target of 1
        _check_record_targets(t_traction, t_braking, t_steady)
    radius = cfg.wheel_radius_m
    global_ok = (math.isfinite(chassis_speed_m_s) and math.isfinite(dt_s) and dt_s > 0.0
                 and age_is_fresh(input_age_s, cfg.max_input_age_s)
                 and math.isfinite(t_traction) and math.isfinite(t_braking)
                 and math.isfinite(t_steady))
    try:   # lists (a state read back from a log) or another record: a bare AttributeError
        n = state.integral.shape
        same = (state.slip_prev.shape == n and state.slip_valid.shape == n
                and state.derivative.shape == n and state.correction.shape == n
                and state.active.shape == n)
    except AttributeError:
        raise ConfigError(f"traction control step: state must be a TractionState of NumPy "
                          f"arrays (TractionState.zeros(n), or the state a step returned), "
                          f"got {type(state).__name__} {state!r:.80}") from None
    if len(n) != 1 or n[0] == 0:   # (an IndexError or a TypeError further down)
        raise ShapeError(f"traction control step: the state's integral must hold one entry "
                         f"per drive unit, shape (n,) with n >= 1, got {n}")
    # zip below stops at the shortest array: a state field of another length dropped wheels
    if not same:
        bad = [f"{k} {np.shape(a)}" for k, a in zip(state._fields, state) if np.shape(a) != n]
        raise ShapeError(f"traction control step: the state's integral has {n} drive units, "
                         f"its {', '.join(bad)}")
    arrays = {"omega_low_level_rad_s": omega_ll, "omega_meas_rad_s": omega, "v_long_m_s": v,
              "a_local_m_s2": acc}
    if slip is not None:
        arrays["slip"] = slip
    bad = [f"{k} {a.shape}" for k, a in arrays.items() if a.shape != n]
    if bad:
        raise ShapeError(f"traction control step: the state has {n} drive units, got "
                         + ", ".join(bad))
    if slip is None:
        slip = sae_slip(omega * radius, v,                                       # eqs. 8.4-8.5
                        dead_band_m_s=cfg.wheel_speed_threshold_m_s)
    chassis_on = global_ok and chassis_speed_m_s > cfg.chassis_speed_threshold_m_s
    dt = dt_s if global_ok else 1.0
    alpha = dt / (cfg.derivative_tau_s + dt)
    decay = math.exp(-dt / cfg.release_tau_s)
    limit = cfg.output_fraction * cfg.omega_max_rad_s
    w_max, thr_w, thr_p = cfg.omega_max_rad_s, cfg.wheel_speed_threshold_m_s, \
        cfg.power_threshold_m2_s3
    kp, ki_dt, kd, one_sided = cfg.kp, cfg.ki * dt, cfg.kd, cfg.one_sided
    rows = []
    for ll, wm, vl, al, sl, i_prev, s_prev, s_valid, d_prev, c_prev, act in zip(
            omega_ll.tolist(), omega.tolist(), v.tolist(), acc.tolist(), slip.tolist(),
            state.integral.tolist(), state.slip_prev.tolist(), state.slip_valid.tolist(),
            state.derivative.tolist(), state.correction.tolist(), state.active.tolist()):
        if not math.isfinite(ll):
            # a correction added to a NaN command is a NaN motor command: refuse it
            raise ImplausibleValueError(
                f"traction control step: omega_low_level_rad_s holds a non-finite "
                f"wheel-speed command {omega_ll.tolist()}; the controller corrects a "
                "command, it cannot make one up", column="omega_low_level_rad_s")
        rs = wm * radius
        # a non-finite memory (a state restored from a log, built by hand) is no input either:
        # a NaN integral or held correction was a NaN command, a NaN derivative stayed for good
        ok = global_ok and math.isfinite(ll + rs + vl + al + sl + i_prev + d_prev + c_prev
                                         + (s_prev if s_valid else 0.0))
        if not ok:  # safe output: no correction (only the wheel speed limit), memory dropped
            cmd = min(max(ll, -w_max), w_max)
            rows.append((cmd, cmd - ll, sl, 0.0, 0.0, STEADY, False, True,
                         0.0, 0.0, False, 0.0, 0.0, False))
            continue
        power = al * vl                                                   # eq. 8.6
        if power > thr_p:
            mode, target = TRACTION, t_traction                           # eq. 8.7
        elif power < -thr_p:
            mode, target = BRAKING, t_braking                             # eq. 8.8
        else:                                                             # eq. 8.9
            mode, target = STEADY, (t_traction if one_sided else t_steady)
        desired = target if vl > 0.0 else (-target if vl < 0.0 else 0.0)   # sgn(v_long)
        use = max(abs(rs), abs(vl)) >= thr_w
        error = desired - sl if use else 0.0                              # eq. 8.1
        # output limits: |PID_out| <= limit, command in the low level's half-line
        room_hi = (w_max if ll > 0.0 else 0.0) - ll
        hi = min(limit, room_hi)
        lo = max(-limit, (-w_max if ll < 0.0 else 0.0) - ll)
        if one_sided:  # limiter: only towards the ground speed (less |slip|)
            # braking speeds the wheel up only where the ground moves the command's way;
            # against it (ll v_long < 0) the ground speed lies beyond 0: slow it there too
            slow_down = (mode != BRAKING or ll * vl < 0.0) == (ll > 0.0)
            hi, lo = (min(hi, 0.0), lo) if slow_down else (hi, max(lo, 0.0))
        # no room left (|omega_ll| beyond omega_max + limit, or beyond omega_max against the
        # limiter's side): the wheel speed limit and the half-line win, on either sign
        hi = min(max(hi, lo), room_hi)
        lo = min(lo, hi)
        # derivative on the measured slip, low-pass filtered
        if use:
            raw_d = (sl - s_prev) / dt if s_valid else 0.0
            deriv = d_prev + alpha * (raw_d - d_prev)
        else:
            deriv = 0.0
        # bumpless enable: a unit becoming active starts its integral from the held correction
        integral = i_prev if act else (c_prev if ki_dt > 0.0 else 0.0)
        # the room moves (a mode change flips the limiter's side, the command moves the wheel
        # speed limit): an integral beyond this step's room is dropped before integrating,
        # so it never has to unwind through a range the output cannot reach. The room of the
        # integral always holds 0: a command above omega_max forces a correction (hi < 0)
        # that the clamp of the output gives, not the integral.
        i_lo, i_hi = min(lo, 0.0), max(hi, 0.0)
        integral = min(max(integral, i_lo), i_hi)
        p_term, d_term = kp * error, -kd * deriv
        candidate = integral + ki_dt * error
        unsat = p_term + candidate + d_term
        if unsat > hi and error > 0.0:      # anti-windup: integrate only up to the limit
            integral = min(candidate, max(integral, hi - p_term - d_term))
        elif unsat < lo and error < 0.0:
            integral = max(candidate, min(integral, lo - p_term - d_term))
        else:
            integral = candidate
        integral = min(max(integral, i_lo), i_hi)
        if chassis_on:
            correction = min(max(p_term + integral + d_term, lo), hi)     # eq. 8.2
        else:  # bumpless disable: the held correction decays
            correction = min(max(c_prev * decay, lo), hi)
            integral = correction
        rows.append((ll + correction, correction, sl, desired, error, mode, chassis_on, False,
                     integral, sl if use else 0.0, use, deriv, correction, chassis_on))
    table = np.array(rows, dtype=float).T          # (14, n): one conversion for all fields
    out = TractionOutput(table[0], table[1], table[2], table[3], table[4],
                         table[5].astype(int), table[6] > 0.5, table[7] > 0.5)
    new_state = TractionState(table[8], table[9], table[10] > 0.5, table[11], table[12],
                              table[13] > 0.5)
    return out, new_state


def _check_record_targets(traction, braking, steady) -> None:
    """Refuse the targets of a record that is not a :class:`SlipTargets` as
    :func:`check_slip_targets` refuses a :class:`SlipTargets`' (a traction target of the
    wrong sign made the one-sided limiter slow a wheel that grips, text stopped on a bare
    TypeError, ``True`` was a target of 1); the slow path, run only once a target is out of
    its range or a boolean. A non-finite target is not known: the step gives its safe output
    for it, as before, so only the finite ones are held to their range."""
    config_numbers("traction control step targets", traction=traction, braking=braking,
                   steady=steady)
    known = [(v if math.isfinite(v) else stand_in)   # stand-ins inside each range
             for v, stand_in in ((traction, 0.5), (braking, -0.5), (steady, 0.5))]
    check_slip_targets("traction control step targets", *known)


def _refuse_config(config, owner: str) -> None:
    """Raise the :class:`ConfigError` of a ``config`` that is not a
    :class:`TractionControlConfig` (a dict of its settings, None: a bare AttributeError on
    ``wheel_radius_m`` at the first step)."""
    raise ConfigError(f"{owner}: config must be a TractionControlConfig (or "
                      f"config_for_vehicle(name)[0]), got {type(config).__name__} "
                      f"{config!r:.60}")


def _refuse_booleans(**inputs) -> None:
    """Raise a :class:`~terrain.errors.DataFormatError` naming the first input that is a
    boolean or holds booleans: ``float(True)`` is 1, so ``dt_s=True`` integrated over a whole
    second and a boolean array was a command of 1 rad/s."""
    for name, x in inputs.items():
        if holds_booleans(x):
            raise DataFormatError(f"traction control step: {name} must hold real numbers, "
                                  f"got a boolean {x!r:.60}", column=name)


class TractionController:
    """Stateful wrapper of :func:`traction_control_step` for a running robot or simulator.

    Parameters
    ----------
    config : TractionControlConfig
    n_units : int
        Number of drive units: wheels (AgriMaRo: 3), or sides of a skid-steer vehicle (2).

    Raises
    ------
    ConfigError
        ``config`` not a :class:`TractionControlConfig`; ``n_units`` not an integer >= 1
        (2.5 or True included).
    """

    def __init__(self, config: TractionControlConfig, n_units: int) -> None:
        if not isinstance(config, TractionControlConfig):   # (it failed at the first step)
            _refuse_config(config, "TractionController")
        config_integer("TractionController n_units", n_units, 1)
        self.config = config
        self.n_units = int(n_units)
        self.state = TractionState.zeros(self.n_units)

    def reset(self) -> None:
        """Forget the memory (integral, derivative, held correction)."""
        self.state = TractionState.zeros(self.n_units)

    def step(self, targets: SlipTargets, omega_low_level_rad_s: np.ndarray,
             omega_meas_rad_s: np.ndarray, v_long_m_s: np.ndarray, a_local_m_s2: np.ndarray,
             chassis_speed_m_s: float, dt_s: float, input_age_s: float = 0.0,
             slip: np.ndarray | None = None) -> TractionOutput:
        """Advance one step; parameters as :func:`traction_control_step`.

        Parameters
        ----------
        targets : SlipTargets or DesiredSlip
        omega_low_level_rad_s : ndarray, shape (n_units,)
            rad/s.
        omega_meas_rad_s : ndarray, shape (n_units,)
            rad/s.
        v_long_m_s : ndarray, shape (n_units,)
            m/s.
        a_local_m_s2 : ndarray, shape (n_units,)
            m/s^2.
        chassis_speed_m_s : float
            m/s.
        dt_s : float
            s.
        input_age_s : float
            s.
        slip : ndarray, shape (n_units,), optional
            Estimated slip per unit (dimensionless); None: from the wheel speeds.

        Returns
        -------
        TractionOutput
        """
        out, self.state = traction_control_step(
            self.config, self.state, targets, omega_low_level_rad_s, omega_meas_rad_s,
            v_long_m_s, a_local_m_s2, chassis_speed_m_s, dt_s, input_age_s, slip)
        return out
