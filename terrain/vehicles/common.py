"""Parameter types shared by all vehicles (motors, ground-contact geometry) and the angle
convention (:func:`wrap_angle`) that the vehicles, the simulator and the filters share."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba.extending import overload, register_jitable

from terrain.errors import (ConfigError, EstimationError, config_flags, config_integer,
                            config_positive, duplicated, first_non_number_cell,
                            real_number, refuse_booleans)


@register_jitable
def _wrapped(angle_rad):
    """``angle_rad`` wrapped to [-pi, pi) (:func:`wrap_angle`'s one formula, which compiles
    inside numba code too)."""
    wrapped = (angle_rad + np.pi) % (2.0 * np.pi) - np.pi
    return wrapped - 2.0 * np.pi * (wrapped >= np.pi)


def wrap_angle(angle_rad):
    """Wrap angles to [-pi, pi), the heading and steering-angle convention of the project.

    The one definition: the EKF's angle innovations (python and compiled loops), the
    adaptive observer's heading error, the swerve inverse kinematics and the simulator's
    steering actuator call it. Compiles inside numba code (an ``overload`` of the same
    formula, without the checks of the arguments, which numba types).

    Parameters
    ----------
    angle_rad : float or ndarray, any shape
        Angles, rad: a real number, an array (or pandas object) of numbers, or a list of
        numbers (converted to an array). NaN stays NaN; an infinite angle gives NaN. A
        Python float and a float array pass on one type test (it runs at every step).

    Returns
    -------
    float or ndarray
        Same shape, rad, in [-pi, pi): ``a - 2 pi k`` for the integer k that puts it there.
        The floating-point remainder of a sum just below 0 rounds up to 2 pi (``-1e-17``
        from -pi gives +pi); that case is moved to -pi, so +pi is never returned.

    Raises
    ------
    EstimationError
        ``angle_rad`` a boolean or holding booleans (``True`` was the angle 1.0 rad), None,
        text, or anything else that is not real numbers (:func:`float_arrays`; None and text
        were a bare TypeError), naming ``angle_rad``.
    """
    kind = type(angle_rad)
    if not (kind is float or kind is np.float64
            or (kind is np.ndarray and angle_rad.dtype.kind == "f")):
        angle_rad = _real_angles(angle_rad)
    return _wrapped(angle_rad)


def _real_angles(angle_rad):
    """``angle_rad`` as :func:`wrap_angle` computes with it: an array or pandas object of
    (non-boolean) numbers or a real number as it is, anything else through
    :func:`float_arrays` (which refuses booleans, None and text, naming ``angle_rad``)."""
    kind = getattr(getattr(angle_rad, "dtype", None), "kind", None)
    if kind is not None and kind in "iuf" or real_number(angle_rad):
        return angle_rad
    angles, = float_arrays("wrap_angle", angle_rad=angle_rad)
    return angles


@overload(wrap_angle)
def _wrap_angle_compiled(angle_rad):
    """:func:`wrap_angle` inside numba code (its arguments are typed by numba)."""
    return lambda angle_rad: _wrapped(angle_rad)


def float_arrays(owner: str, **arrays) -> list[np.ndarray]:
    """The kinematics' array arguments as float arrays, each refusal naming its argument.

    Parameters
    ----------
    owner : str
        The refusing function, for the message.
    **arrays
        Argument name -> array-like of numbers (any shape), in order.

    Returns
    -------
    list of ndarray
        ``np.asarray(value, dtype=float)`` of each, in the order given.

    Raises
    ------
    EstimationError
        An argument that holds booleans (``True`` was a speed of 1 m/s, in a list of
        numbers too), text or bytes (``"0.5"`` was parsed as 0.5, ``"a"`` raised NumPy's
        bare ValueError that named none), ``None`` or pandas' ``NA`` (NumPy's NaN: a
        missing value is no value here), complex numbers (an array of them lost its
        imaginary part with a mere ``ComplexWarning``), dates or durations (a
        ``datetime64`` array was read as days since 1970), or that does not convert to
        numbers (a ragged list): :func:`_first_non_number`.
    """
    refuse_booleans(EstimationError, owner, **arrays)
    out = []
    for name, value in arrays.items():
        try:
            array = np.asarray(value)
            # (a list of numbers may hide a boolean: NumPy made True 1.0)
            if array.dtype.kind not in "iuf" or isinstance(value, (list, tuple)):
                bad = _first_non_number(value, array)
                if bad is not None:
                    raise ValueError(bad)
            out.append(np.asarray(array, dtype=float))
        except (TypeError, ValueError) as err:
            raise EstimationError(f"{owner}: {name} must hold numbers, got "
                                  f"{value!r:.60} ({err})") from None
    return out


def _first_non_number(value, array: np.ndarray) -> str | None:
    """What in ``value`` (``array`` its ``np.asarray``) is not a real number, for the
    message, or None: an array whose dtype holds none (text, bytes, complex, dates,
    durations), else the first entry of an object array or of a list or tuple (a boolean
    among numbers converts to float) that :func:`terrain.errors.first_non_number_cell`
    refuses with ``allow_missing=False``: the rule the readers' data columns share
    (:func:`terrain.io.align.first_non_number`), except that a missing entry (``None``,
    ``NA``) is refused here, where NumPy read it as NaN and a data column counts it as a
    missing sample."""
    kind = array.dtype.kind
    if kind not in "iufO":
        return f"{array.dtype} is not a real number"
    cells = (array if kind == "O" else np.asarray(value, dtype=object)).ravel()
    # (a list keeps a 0-d array as one: its value is judged)
    cells = [c.item() if isinstance(c, np.ndarray) and c.ndim == 0 else c for c in cells]
    k = first_non_number_cell(cells, allow_missing=False)
    if k is None:
        return None
    return f"{type(cells[k]).__name__} {cells[k]!r:.30} at index {k} is not a real number"


def check_fields(params, positive: tuple = (), non_negative: tuple = (),
                 counts: tuple = ()) -> None:
    """Refuse impossible values of a parameter dataclass when it is built.

    Parameters
    ----------
    params : dataclass instance
        The parameters (its class name prefixes each message).
    positive : tuple of str
        Fields that must be finite real numbers > 0 (a mass, a radius, a time constant).
    non_negative : tuple of str
        Fields that must be finite real numbers >= 0 (0 = off, or none).
    counts : tuple of str
        Fields that must be integers >= 1.

    Raises
    ------
    ConfigError
        The first offending field, named ``Class.field``, with the value given.
    """
    owner = type(params).__name__
    config_positive(owner, **{name: getattr(params, name) for name in positive})
    config_positive(owner, allow_zero=True,
                    **{name: getattr(params, name) for name in non_negative})
    for name in counts:
        config_integer(f"{owner}.{name}", getattr(params, name), 1)


def check_motor(vehicle) -> None:
    """Refuse a vehicle whose ``motor`` is not a :class:`MotorParams`.

    Parameters
    ----------
    vehicle : dataclass instance
        Vehicle parameters with a ``motor`` field.

    Raises
    ------
    ConfigError
        ``motor`` of another type, named ``Class.motor``.
    """
    if not isinstance(vehicle.motor, MotorParams):
        raise ConfigError(f"{type(vehicle).__name__}.motor must be MotorParams, got "
                          f"{type(vehicle.motor).__name__}")


@dataclass(frozen=True)
class MotorParams:
    """Speed-controlled drive motor (one per side or per wheel).

    The motor current follows the DC-motor torque law
    ``I = I_0 tanh(omega / 0.05 rad/s) + T / (G k_t eta)`` (torque constant ``k_t``, gear
    ratio ``G``, gearbox efficiency ``eta``, no-load current ``I_0``; the sign of the wheel
    speed ``omega`` smoothed over 0.05 rad/s, :meth:`current_from_torque`).

    Parameters
    ----------
    torque_constant_nm_per_a : float
        Motor torque constant k_t, N m/A (motor side of the gearbox).
    gear_ratio : float
        Motor turns per wheel turn.
    efficiency : float
        Gearbox efficiency, in (0, 1].
    no_load_current_a : float
        Current drawn at zero load torque (friction of motor, gearbox, chain), A.
    speed_time_constant_s : float
        First-order time constant of the closed speed loop, s.
    max_wheel_speed_rad_s : float
        Wheel speed limit (commands are clipped), rad/s.
    encoder_filter_s : float
        Time constant of the driver's low-pass filter on the reported wheel speed, s
        (0 = the reported speed is the instantaneous one).
    encoder_counts_per_rev : int
        Encoder resolution at the wheel, counts per wheel revolution (quantisation).
    wheel_inertia_kg_m2 : float
        Rotational inertia of a wheel with its drive, about its axle, kg m^2.
    source : str
        Where the numbers come from.
    """

    torque_constant_nm_per_a: float
    gear_ratio: float
    efficiency: float
    no_load_current_a: float
    speed_time_constant_s: float
    max_wheel_speed_rad_s: float
    encoder_filter_s: float
    encoder_counts_per_rev: int
    wheel_inertia_kg_m2: float
    source: str

    def __post_init__(self) -> None:
        """Refuse impossible values (:class:`~terrain.errors.ConfigError` naming the field):
        constant, ratio, speed limit and speed-loop time constant finite and > 0, efficiency
        in (0, 1], no-load current, filter time constant and inertia finite and >= 0,
        encoder counts an integer >= 1."""
        check_fields(self, positive=("torque_constant_nm_per_a", "gear_ratio", "efficiency",
                                     "speed_time_constant_s", "max_wheel_speed_rad_s"),
                     non_negative=("no_load_current_a", "encoder_filter_s",
                                   "wheel_inertia_kg_m2"),
                     counts=("encoder_counts_per_rev",))
        if self.efficiency > 1.0:
            raise ConfigError(f"MotorParams.efficiency must be in (0, 1], got "
                              f"{self.efficiency!r}")

    @property
    def encoder_quantum_rad(self) -> float:
        """Wheel angle of one encoder count, ``2 pi / encoder_counts_per_rev``, rad."""
        return 2.0 * np.pi / float(self.encoder_counts_per_rev)

    def current_from_torque(self, wheel_torque_nm: np.ndarray,
                            omega_rad_s: np.ndarray) -> np.ndarray:
        """Motor current from the wheel torque it delivers.

        Parameters
        ----------
        wheel_torque_nm : ndarray, shape (...)
            Torque at the wheel (after the gearbox), N m.
        omega_rad_s : ndarray, shape (...)
            Wheel angular speed, rad/s: the no-load current is ``I_0 tanh(omega / 0.05)``
            (its sign, smoothed; 76 % of ``I_0`` at 0.05 rad/s, 0 at standstill).

        Returns
        -------
        ndarray, shape (...)
            Signed motor current, A.

        Raises
        ------
        EstimationError
            An argument holding booleans (``True`` was a torque of 1 N m) or what is not
            numbers (text), named (:func:`float_arrays`).
        """
        torque, omega = float_arrays("MotorParams.current_from_torque",
                                     wheel_torque_nm=wheel_torque_nm, omega_rad_s=omega_rad_s)
        return (self.no_load_current_a * self.rotation_direction(omega)
                + torque / self.wheel_torque_per_amp_nm)

    @property
    def wheel_torque_per_amp_nm(self) -> float:
        """Wheel torque per ampere of motor current, ``G k_t eta``, N m/A (the torque term
        of :meth:`current_from_torque` is ``T / (G k_t eta)``)."""
        return self.gear_ratio * self.torque_constant_nm_per_a * self.efficiency

    @staticmethod
    def rotation_direction(omega_rad_s: np.ndarray) -> np.ndarray:
        """The sign of the wheel speed, smoothed over 0.05 rad/s: ``tanh(omega / 0.05)``
        (dimensionless, in [-1, 1]; 0 at standstill), which the no-load current follows.

        Parameters
        ----------
        omega_rad_s : ndarray, shape (...)
            Wheel angular speed, rad/s.

        Returns
        -------
        ndarray, shape (...)

        Raises
        ------
        EstimationError
            ``omega_rad_s`` holding booleans or what is not numbers (text).
        """
        omega, = float_arrays("MotorParams.rotation_direction", omega_rad_s=omega_rad_s)
        return np.tanh(omega / 0.05)

    def drive_power_w(self, current_a: np.ndarray, omega_rad_s: np.ndarray) -> np.ndarray:
        """Electrical power a PWM drive delivers to the motor, W.

        The back-EMF ``k_t G |omega|`` (SI units: the back-EMF constant equals ``k_t``)
        times the current magnitude: with no winding resistance in this motor law, that is
        what the drive's duty cycle passes from the bus. While the motor drives (torque and
        speed of one sign) that is ``|omega T| / eta`` plus the no-load loss
        ``k_t G |omega| I_0 |tanh(omega / 0.05)|``; while it brakes (opposite signs) the two
        terms of :meth:`current_from_torque` cancel in part, ``k_t G |omega| |I_0
        tanh(omega / 0.05) + T / (G k_t eta)|``, still counted as drawn (no regeneration).
        The bus current times the bus voltage is larger by ``V_bus / (k_t G |omega|)`` (it
        ignores the duty cycle).

        Parameters
        ----------
        current_a : ndarray, shape (...)
            Motor current (signed or magnitude), A.
        omega_rad_s : ndarray, shape (...)
            Wheel angular speed, rad/s; broadcast with ``current_a``.

        Returns
        -------
        ndarray, shape (...)
            Power, W (>= 0).

        Raises
        ------
        EstimationError
            An argument holding booleans (``True`` was a current of 1 A) or what is not
            numbers (text), named (:func:`float_arrays`).
        """
        current, omega = float_arrays("MotorParams.drive_power_w", current_a=current_a,
                                      omega_rad_s=omega_rad_s)
        return self.torque_constant_nm_per_a * self.gear_ratio * np.abs(omega) * np.abs(current)


def drive_inertia_kg_m2(vehicle) -> float:
    """Rotational inertia one drive motor turns, at the wheel, kg m^2.

    ``MotorParams.wheel_inertia_kg_m2`` times the vehicle's ``wheels_per_motor`` (its
    physical wheels or sprocket, not its contact points: a track discretised into segments
    still turns one sprocket).

    Parameters
    ----------
    vehicle : HuskyParams or TrackedParams or AgriMaRoParams
        Vehicle (``motor``, ``wheels_per_motor``).

    Returns
    -------
    float
        Inertia, kg m^2.

    Raises
    ------
    ConfigError
        ``vehicle`` not a vehicle's parameters (no :class:`MotorParams` ``motor`` or no
        ``wheels_per_motor``: None or a bare MotorParams raised AttributeError).
    """
    if (not isinstance(getattr(vehicle, "motor", None), MotorParams)
            or not hasattr(vehicle, "wheels_per_motor")):
        raise ConfigError(f"drive_inertia_kg_m2: vehicle must be a vehicle's parameters "
                          f"(HuskyParams, TrackedParams or AgriMaRoParams), got "
                          f"{type(vehicle).__name__}")
    return float(vehicle.motor.wheel_inertia_kg_m2) * int(vehicle.wheels_per_motor)


def _numbers(owner: str, name: str, value) -> np.ndarray:
    """``value`` as a float array; a ConfigError naming ``owner.name`` for what is not
    numbers (text, which NumPy would parse, None, which it would make NaN)."""
    arr = np.asarray(value) if value is not None else np.asarray([None])
    if arr.dtype.kind not in "iuf":
        raise ConfigError(f"{owner}.{name} must hold numbers, got {value!r:.80}")
    return arr.astype(float, copy=False)


@dataclass(frozen=True)
class ContactGeometry:
    """Ground contact of a vehicle as a set of points in the body frame.

    The body frame is x forward, y left, z up (REP-103), origin at the vehicle's reference
    point (centre of rotation used by the kinematics). The arrays are kept as read-only
    copies of those given (float, and int64 motor indices).

    Parameters
    ----------
    positions_m : ndarray, shape (n_contacts, 2)
        Contact point positions (x, y), m.
    motor_of_contact : ndarray of int, shape (n_contacts,)
        Index of the drive motor turning each contact (several contacts share a motor on a
        skid-steer side or along a track).
    load_share : ndarray, shape (n_contacts,)
        Static share of the vehicle weight on each contact (sums to 1).
    steered : bool
        Whether contacts are steerable (swerve) or fixed along x (skid-steer).
    wheel_radius_m : float
        Rolling radius of wheels / drive sprockets, m.
    motor_names : tuple of str
        Name of each motor (``left``, ``right`` or ``1``, ``2``, ``3``).

    Raises
    ------
    ConfigError
        Named ``ContactGeometry.<field>``: ``positions_m`` not finite numbers of shape
        ``(c, 2)`` with ``c >= 1``; ``motor_of_contact`` not integers of shape ``(c,)`` in
        ``[0, n_motors)`` with every motor driving at least one contact (an index past the
        motors was an IndexError in the simulator's first step, a motor without contacts a
        NaN slip); ``load_share`` not finite numbers >= 0 of shape ``(c,)`` summing to 1
        (shares summing to 2 doubled every normal load and force of a run without a word);
        ``steered`` not ``True`` or ``False``; ``wheel_radius_m`` not a finite length > 0;
        ``motor_names`` not a non-empty tuple of distinct names.
    """

    positions_m: np.ndarray
    motor_of_contact: np.ndarray
    load_share: np.ndarray
    steered: bool
    wheel_radius_m: float
    motor_names: tuple[str, ...]

    def __post_init__(self) -> None:
        owner = "ContactGeometry"
        names = self.motor_names
        if not (isinstance(names, tuple) and names and all(isinstance(x, str) for x in names)
                and not duplicated(names)):
            raise ConfigError(f"{owner}.motor_names must be a non-empty tuple of distinct "
                              f"motor names, got {names!r:.80}")
        config_flags(owner, steered=self.steered)
        config_positive(owner, wheel_radius_m=self.wheel_radius_m)
        refuse_booleans(ConfigError, **{f"{owner}.positions_m": self.positions_m,
                                        f"{owner}.load_share": self.load_share})
        pos = _numbers(owner, "positions_m", self.positions_m)
        if pos.ndim != 2 or pos.shape[1] != 2 or not len(pos) or not np.isfinite(pos).all():
            raise ConfigError(f"{owner}.positions_m must be finite (x, y) positions of shape "
                              f"(n_contacts, 2), m, got shape {pos.shape}: {pos.tolist()!s:.80}")
        n_c = len(pos)
        motors = np.asarray(self.motor_of_contact)
        if (motors.shape != (n_c,) or motors.dtype.kind not in "iu"
                or not ((motors >= 0) & (motors < len(names))).all()
                or len(np.unique(motors)) != len(names)):
            raise ConfigError(f"{owner}.motor_of_contact must hold one motor index in "
                              f"[0, {len(names)}) per contact ({n_c}), every motor driving at "
                              f"least one, got {self.motor_of_contact!r:.80}")
        share = _numbers(owner, "load_share", self.load_share)
        if (share.shape != (n_c,) or not np.isfinite(share).all() or (share < 0).any()
                or abs(float(share.sum()) - 1.0) > 1e-9):
            raise ConfigError(f"{owner}.load_share must hold one finite share >= 0 per contact "
                              f"({n_c}), summing to 1 (the weight), got "
                              f"{self.load_share!r:.80}")
        # the checked values, as read-only copies: the caller's arrays (or lists) stayed the
        # fields, so changing them afterwards changed a frozen, checked geometry
        for name, value in (("positions_m", pos), ("motor_of_contact", motors.astype(np.int64)),
                            ("load_share", share)):
            value = np.array(value, copy=True)
            value.flags.writeable = False
            object.__setattr__(self, name, value)

    @property
    def n_motors(self) -> int:
        """Number of drive motors."""
        return len(self.motor_names)

    @property
    def cog_m(self) -> np.ndarray:
        """Centre of gravity (x, y) in the body frame, shape (2,), m: the point the static
        load shares balance, ``sum_i share_i p_i`` (statics on level ground: the weight
        acts where the static loads put it). The simulator's rigid-body dynamics put the
        mass there (:func:`terrain.sim.dynamics.integrate`). Components within 1e-12 m of
        the origin are 0 (a symmetric layout's rounding)."""
        cog = self.load_share @ self.positions_m
        cog[np.abs(cog) < 1e-12] = 0.0
        return cog
