"""Skid-steer vehicles: Clearpath Husky A200 (4 wheels) and the Patako tracked test bed.

Kinematics (seed ``000_f24201ff985633bf.txt``, eqs. 1-5) extended with the ICR expansion
factor ``chi`` of the ICR-based skid-steer model (Mandow et al., "Experimental kinematics for
wheeled skid-steer mobile robots", IROS 2007): the contact lines of the two sides act as if
they were ``chi * B`` apart, so ``yaw_rate = (eta_R v_R - eta_L v_L) / (chi B)``. Seed 000
writes the track as ``2 d``; here ``B = 2 d``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numba.extending import register_jitable

from terrain.errors import ConfigError, EstimationError, ShapeError, config_positive
from terrain.vehicles.common import (ContactGeometry, MotorParams, check_fields, check_motor,
                                     float_arrays)


def _husky_motor() -> MotorParams:
    return MotorParams(
        torque_constant_nm_per_a=0.044, gear_ratio=78.71, efficiency=0.8, no_load_current_a=1.0,
        speed_time_constant_s=0.1, max_wheel_speed_rad_s=1.0 / 0.1651, encoder_filter_s=0.0,
        encoder_counts_per_rev=78_000, wheel_inertia_kg_m2=0.06,
        source=("Husky A200: two 24 V brushed DC motors, one per side, both wheels of a side "
                "chained together; top speed 1.0 m/s (Clearpath Husky datasheet). ASSUMED: "
                "gear ratio 78.71 and k_t = 0.044 N m/A (a 24 V motor of that class; with them "
                "a 1 m/s wheel speed is about 4500 motor rpm), gearbox efficiency 0.8, "
                "no-load current 1.0 A per side (the currents of the measured runs fall to "
                "about 1 A when the robot coasts). The reported speed is the instantaneous one "
                "(no driver filter) so the baseline simulator has no wheel-stream lag. "
                "wheel_inertia_kg_m2 0.06 ASSUMED: a 13 in wheel of 2.637 kg with principal "
                "inertias 0.025 and 0.044 kg m^2 (husky_description URDF, wheel.urdf.xacro) plus "
                "about 0.015 kg m^2 per wheel of motor rotor and gear train reflected through "
                "78.71:1 (a rotor of about 5e-6 kg m^2, shared by the two chained wheels). "
                "encoder_counts_per_rev 78000 ASSUMED (no source found): the order of a "
                "1024-cycle encoder on the motor shaft through the 78.71:1 gearbox (80600 "
                "cycles per wheel turn); a quantum of 8e-5 rad either way."))


def _inside(params, inner: str, outer: str) -> None:
    """Refuse a contact dimension ``inner`` not below the spacing ``outer`` of the contacts
    it belongs to (ConfigError naming ``Class.inner``): the contacts would overlap."""
    if not getattr(params, inner) < getattr(params, outer):
        owner = type(params).__name__
        raise ConfigError(f"{owner}.{inner} must be below {owner}.{outer} "
                          f"({getattr(params, outer)} m), or the contacts overlap, got "
                          f"{getattr(params, inner)} m (a length in cm or mm?)")


@dataclass(frozen=True)
class HuskyParams:
    """Clearpath Husky A200.

    Parameters
    ----------
    name : str
        Vehicle name.
    track_m : float
        Lateral distance between left and right wheel centres B, m (0.5708 m, public Husky
        description, ``husky_description`` URDF).
    wheelbase_m : float
        Front-rear axle distance, m (0.512 m, public Husky description).
    wheel_radius_m : float
        0.1651 m (13 in tyre, public Husky description; Clearpath datasheet 330 mm wheels).
    mass_kg : float
        50 kg (Clearpath Husky A200 datasheet, unloaded).
    yaw_inertia_kg_m2 : float
        ASSUMED ``m (L^2 + W^2) / 12`` of the 0.99 m x 0.67 m chassis (datasheet dimensions).
    motor : MotorParams
        Drive motor of each side / wheel (sources in ``MotorParams.source``).
    contact_length_m, contact_width_m : float
        ASSUMED tyre contact patch on firm ground, m.
    speed_quantum_m_s : float
        Resolution of the reported wheel speed, m/s: the borealtc ``pro_`` files hold
        multiples of 0.2 / 25.4 m/s. A record of the measured files only (written with the
        vehicle's parameters to a simulated run's metadata): the simulator rounds with
        :attr:`terrain.sim.sensors.SensorSettings.speed_quantum_m_s`, whose Husky default
        is the same value, so changing this field changes no stream.
    current_quantum_a : float
        Resolution of the reported current, A (two decimals in the measured files). A record
        only, as ``speed_quantum_m_s``: the simulator rounds with
        :attr:`terrain.sim.sensors.SensorSettings.current_quantum_a` (same default).
    wheels_per_motor : int
        Wheels turned by each motor, each of inertia ``motor.wheel_inertia_kg_m2``: 2 (one
        motor per side, both wheels of the side chained together, Clearpath Husky
        datasheet; see ``MotorParams.source``).
    """

    name: str = "husky"
    track_m: float = 0.5708
    wheelbase_m: float = 0.512
    wheel_radius_m: float = 0.1651
    mass_kg: float = 50.0
    yaw_inertia_kg_m2: float = 50.0 * (0.99 ** 2 + 0.67 ** 2) / 12.0
    motor: MotorParams = field(default_factory=_husky_motor)
    contact_length_m: float = 0.08
    contact_width_m: float = 0.11
    speed_quantum_m_s: float = 0.2 / 25.4
    current_quantum_a: float = 0.01
    wheels_per_motor: int = 2

    def __post_init__(self) -> None:
        """Refuse impossible values (:class:`~terrain.errors.ConfigError` naming the field):
        lengths, mass and inertia finite and > 0, quanta finite and >= 0, wheels per motor an
        integer >= 1, ``motor`` a :class:`MotorParams`, a contact patch narrower than the
        track and shorter than the wheelbase (the left and right, or front and rear,
        patches would overlap: a width given in cm, 11 for 0.11 m, was taken as 11 m)."""
        check_fields(self, positive=("track_m", "wheelbase_m", "wheel_radius_m", "mass_kg",
                                     "yaw_inertia_kg_m2", "contact_length_m",
                                     "contact_width_m"),
                     non_negative=("speed_quantum_m_s", "current_quantum_a"),
                     counts=("wheels_per_motor",))
        check_motor(self)
        _inside(self, "contact_width_m", "track_m")
        _inside(self, "contact_length_m", "wheelbase_m")

    def contact_geometry(self) -> ContactGeometry:
        """Four wheels at ``(+-L/2, +-B/2)``; motor 0 = left side (y > 0), motor 1 = right
        side; equal static loads.

        Returns
        -------
        ContactGeometry
            Contact positions (body frame, m), motor of each contact, static load shares.
        """
        a, b = self.wheelbase_m / 2.0, self.track_m / 2.0
        pos = np.array([[a, b], [-a, b], [a, -b], [-a, -b]])
        return ContactGeometry(positions_m=pos, motor_of_contact=np.array([0, 0, 1, 1]),
                               load_share=np.full(4, 0.25), steered=False,
                               wheel_radius_m=self.wheel_radius_m, motor_names=("left", "right"))


HUSKY = HuskyParams()


def _tracked_motor() -> MotorParams:
    return MotorParams(
        torque_constant_nm_per_a=0.03, gear_ratio=50.0, efficiency=0.7, no_load_current_a=0.4,
        speed_time_constant_s=0.1, max_wheel_speed_rad_s=0.5 / 0.05, encoder_filter_s=0.0,
        encoder_counts_per_rev=2048, wheel_inertia_kg_m2=0.01,
        source=("ASSUMED: seed 003 gives no drive data for the Patako test bed; small 24 V DC "
                "gear motors (k_t 0.03 N m/A, 50:1, efficiency 0.7 with track losses), "
                "0.5 m/s top speed (the seed's tests run at 0.05 m/s); wheel_inertia_kg_m2 0.01 "
                "per track: a track belt of about 1.5 kg moving at the 0.05 m sprocket radius "
                "(m r^2 = 0.004 kg m^2), sprocket and idlers (0.001) and a motor rotor of about "
                "2e-6 kg m^2 through 50:1 (0.005); encoder_counts_per_rev 2048: a 512-line "
                "encoder read in quadrature on the sprocket shaft."))


@dataclass(frozen=True)
class TrackedParams:
    """Patako skid-steer tracked test bed (seed 003, Table 2).

    Parameters
    ----------
    name : str
        Vehicle name.
    track_m : float
        Tread (distance between track centre lines) B, m: 0.393 m (Table 2).
    track_width_m : float
        Width b of each track, m: 0.150 m (Table 2).
    track_length_m : float
        Ground contact length l, m: 0.600 m (Table 2).
    cog_height_m : float
        0.150 m (Table 2).
    mass_kg : float
        25 kg (Table 2).
    slip_parameter_n : float
        Endo's turning slip exponent n = 0.847, identified on linoleum (Table 2, eq. 27).
    sprocket_radius_m : float
        ASSUMED 0.05 m.
    yaw_inertia_kg_m2 : float
        ``m (l^2 + B^2) / 12`` (uniform plate over the footprint).
    n_segments : int
        Contact points per track used to discretise the track-ground contact (a numerical
        choice; the turning resistance converges as it grows: with 0.2 m/s and 0.5 rad/s
        commanded on SANDY_LOAM the yaw rate after 8 s is 0.144 rad/s with 5 points, 0.140
        with 50; 1 point puts each track's contact at its centre, with no turning
        resistance: 0.460 rad/s; straight driving does not depend on it).
    motor : MotorParams
        Drive motor of each side / wheel (sources in ``MotorParams.source``).
    wheels_per_motor : int
        Rotating bodies of inertia ``motor.wheel_inertia_kg_m2`` turned by each motor: 1, the
        drive sprocket of its track (that inertia lumps sprocket, idlers and track).
    """

    name: str = "tracked"
    track_m: float = 0.393
    track_width_m: float = 0.150
    track_length_m: float = 0.600
    cog_height_m: float = 0.150
    mass_kg: float = 25.0
    slip_parameter_n: float = 0.847
    sprocket_radius_m: float = 0.05
    yaw_inertia_kg_m2: float = 25.0 * (0.6 ** 2 + 0.393 ** 2) / 12.0
    n_segments: int = 5
    motor: MotorParams = field(default_factory=_tracked_motor)
    wheels_per_motor: int = 1

    def __post_init__(self) -> None:
        """Refuse impossible values (:class:`~terrain.errors.ConfigError` naming the field):
        lengths, mass and inertia finite and > 0, CoG height and Endo's exponent finite and
        >= 0, segment and wheel counts integers >= 1, ``motor`` a :class:`MotorParams`, a
        track narrower than the tread (the two tracks would overlap)."""
        check_fields(self, positive=("track_m", "track_width_m", "track_length_m", "mass_kg",
                                     "sprocket_radius_m", "yaw_inertia_kg_m2"),
                     non_negative=("cog_height_m", "slip_parameter_n"),
                     counts=("n_segments", "wheels_per_motor"))
        check_motor(self)
        _inside(self, "track_width_m", "track_m")

    @property
    def wheel_radius_m(self) -> float:
        """Sprocket radius (the "wheel" radius of the drive), m."""
        return self.sprocket_radius_m

    @property
    def contact_length_m(self) -> float:
        """Contact length of one track, m."""
        return self.track_length_m

    @property
    def contact_width_m(self) -> float:
        """Contact width of one track, m."""
        return self.track_width_m

    def contact_geometry(self) -> ContactGeometry:
        """``n_segments`` points per track, evenly along its length; motor 0 = left; equal
        static loads.

        Returns
        -------
        ContactGeometry
            Contact positions (body frame, m), motor of each contact, static load shares.
        """
        n = self.n_segments
        xs = (np.arange(n) + 0.5) / n * self.track_length_m - self.track_length_m / 2.0
        b = self.track_m / 2.0
        pos = np.concatenate([np.column_stack([xs, np.full(n, b)]),
                              np.column_stack([xs, np.full(n, -b)])])
        return ContactGeometry(positions_m=pos,
                               motor_of_contact=np.repeat(np.array([0, 1]), n),
                               load_share=np.full(2 * n, 1.0 / (2 * n)), steered=False,
                               wheel_radius_m=self.sprocket_radius_m,
                               motor_names=("left", "right"))


TRACKED = TrackedParams()


def _broadcast(owner: str, **arrays: np.ndarray) -> list[np.ndarray]:
    """The arrays as floats broadcast to one shape (a single number stands for every
    sample); :class:`~terrain.errors.ShapeError` naming every shape when they do not
    broadcast (NumPy's bare ValueError before), :class:`~terrain.errors.EstimationError`
    naming an argument of booleans or of what is not numbers (:func:`float_arrays`)."""
    values = float_arrays(owner, **arrays)
    try:
        return np.broadcast_arrays(*values)
    except ValueError:
        raise ShapeError(f"{owner}: arrays of shapes that do not broadcast: " + ", ".join(
            f"{name} {v.shape}" for name, v in zip(arrays, values))) from None


def skid_steer_forward(v_left_m_s: np.ndarray, v_right_m_s: np.ndarray, track_m: float,
                       eta_left: np.ndarray | float = 1.0, eta_right: np.ndarray | float = 1.0,
                       chi: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Body speed and yaw rate of a skid-steer vehicle (seed 000 eqs. 2, 3 and 5).

    ``V_G = (eta_R v_R + eta_L v_L) / 2`` and ``Omega = (eta_R v_R - eta_L v_L) / (chi B)``,
    with ``eta = 1 - i`` (eq. 4) and the ICR expansion ``chi`` (1 = the ideal eq. 2).

    Parameters
    ----------
    v_left_m_s, v_right_m_s : ndarray, shape (n,)
        Wheel/track rim speeds ``omega r``, m/s.
    track_m : float
        B (= 2 d of seed 000), m.
    eta_left, eta_right : float or ndarray, shape (n,)
        Slip efficiencies (eq. 4), dimensionless.
    chi : float
        ICR expansion factor (>= 1 on real ground), dimensionless.

    Returns
    -------
    v_m_s : ndarray, shape (n,)
    yaw_rate_rad_s : ndarray, shape (n,)

    Raises
    ------
    ConfigError
        ``track_m`` or ``chi`` not a finite number > 0 (0 gave an infinite yaw rate, a
        negative one a yaw rate of the wrong sign; booleans refused).
    ShapeError
        Speeds and efficiencies of shapes that do not broadcast (a single number stands for
        every sample).
    EstimationError
        An array argument of booleans, or one that is not numbers (text), named.
    """
    config_positive("skid_steer_forward", track_m=track_m, chi=chi)
    vl, vr, el, er = _broadcast("skid_steer_forward", v_left_m_s=v_left_m_s,
                                v_right_m_s=v_right_m_s, eta_left=eta_left, eta_right=eta_right)
    return body_rates(el * vl, er * vr, track_m, chi)


@register_jitable
def body_rates(v_left_m_s, v_right_m_s, track_m, chi):
    """Body speed and yaw rate from the effective side speeds ``eta v`` (seed
    ``000_f24201ff985633bf.txt`` eqs. 2 and 5; ICR expansion ``chi`` of Mandow et al. 2007):
    ``V_G = (v_R + v_L) / 2``, ``Omega = (v_R - v_L) / (chi B)``; the inverse of
    :func:`side_speeds`. The one home of this relation: NumPy callers, the observer of
    :mod:`terrain.estimation.observer` and numba code call it.

    Parameters
    ----------
    v_left_m_s, v_right_m_s : float or ndarray
        Effective side speeds (rim speed times slip efficiency), m/s.
    track_m : float
        Track width B (= 2 d of seed 000), m.
    chi : float or ndarray
        ICR expansion factor, dimensionless (1 = ideal).

    Returns
    -------
    v_m_s : float or ndarray
        Body forward speed, m/s.
    yaw_rate_rad_s : float or ndarray
        Yaw rate, rad/s.
    """
    return 0.5 * (v_left_m_s + v_right_m_s), (v_right_m_s - v_left_m_s) / (chi * track_m)


def skid_steer_inverse(v_m_s: np.ndarray, yaw_rate_rad_s: np.ndarray, track_m: float,
                       chi: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Side speeds that give a body speed and yaw rate without slip (inverse of eq. 2).

    Parameters
    ----------
    v_m_s, yaw_rate_rad_s : ndarray, shape (n,)
        Body speed (m/s) and yaw rate (rad/s).
    track_m : float
        Track width B, m.
    chi : float
        ICR expansion factor, dimensionless (1 = ideal).

    Returns
    -------
    v_left_m_s, v_right_m_s : ndarray, shape (n,)

    Raises
    ------
    ConfigError
        ``track_m`` or ``chi`` not a finite number > 0 (a negative one swapped the inner and
        outer side; booleans refused).
    ShapeError
        ``v_m_s`` and ``yaw_rate_rad_s`` of shapes that do not broadcast.
    EstimationError
        An array argument of booleans, or one that is not numbers (text), named.
    """
    config_positive("skid_steer_inverse", track_m=track_m, chi=chi)
    v, w = _broadcast("skid_steer_inverse", v_m_s=v_m_s, yaw_rate_rad_s=yaw_rate_rad_s)
    return side_speeds(v, w, track_m, chi)


@register_jitable
def side_speeds(v_m_s, yaw_rate_rad_s, track_m, chi):
    """Left and right contact-line speeds of a rigid skid-steer body (the ICR model of
    Mandow et al. 2007; seed ``000_f24201ff985633bf.txt`` eq. 2 with ``B = 2 d`` when
    ``chi = 1``): ``v -+ chi B yaw_rate / 2``. The one home of this relation: NumPy callers
    and the numba kernels of :mod:`terrain.estimation.equations.skid_steer` call it.

    Parameters
    ----------
    v_m_s : float or ndarray
        Body forward speed, m/s.
    yaw_rate_rad_s : float or ndarray
        Yaw rate, rad/s.
    track_m : float
        Track width B, m.
    chi : float or ndarray
        ICR expansion factor, dimensionless (1 = ideal).

    Returns
    -------
    v_left_m_s, v_right_m_s : float or ndarray
        Speeds of the left and right contact lines, m/s.
    """
    half = 0.5 * chi * track_m * yaw_rate_rad_s
    return v_m_s - half, v_m_s + half


def skid_steer_pose_rates(yaw_rad: np.ndarray, v_m_s: np.ndarray,
                          yaw_rate_rad_s: np.ndarray) -> np.ndarray:
    """Unicycle pose rates (seed 000 eq. 1).

    Parameters
    ----------
    yaw_rad, v_m_s, yaw_rate_rad_s : ndarray, shape (n,)
        Heading (rad), body speed (m/s), yaw rate (rad/s).

    Returns
    -------
    ndarray, shape (n, 3)
        ``(x_dot, y_dot, yaw_dot)`` in the world frame, m/s and rad/s.

    Raises
    ------
    ShapeError
        Arrays of shapes that do not broadcast (a single number stands for every sample).
    EstimationError
        An array argument of booleans, or one that is not numbers (text), named.
    """
    yaw, v, w = _broadcast("skid_steer_pose_rates", yaw_rad=yaw_rad, v_m_s=v_m_s,
                           yaw_rate_rad_s=yaw_rate_rad_s)
    return np.stack([v * np.cos(yaw), v * np.sin(yaw), w], axis=-1)


def endo_slip_ratio_ratio(v_left_m_s: np.ndarray, v_right_m_s: np.ndarray,
                          n: float = TRACKED.slip_parameter_n) -> np.ndarray:
    """Endo's turning slip relation ``alpha_l / alpha_r = -sgn(v_r v_l) |v_r / v_l|^n``.

    Seed 003 eq. 27 (n = 0.847 for the Patako test bed, Table 2).

    Parameters
    ----------
    v_left_m_s, v_right_m_s : ndarray, shape (n,)
        Input track speeds, m/s (non-zero).
    n : float
        Endo's turning slip exponent (seed 003 eq. 27), dimensionless, finite and >= 0.

    Returns
    -------
    ndarray, shape (n,)
        Ratio of left to right slip ratio, dimensionless (NaN where a speed is NaN).

    Raises
    ------
    EstimationError
        A left track speed of exactly 0 (the ratio is undefined there: it was NaN with a
        RuntimeWarning), naming its index.
    ConfigError
        ``n`` not a finite number >= 0 (NaN, a boolean, a negative exponent).
    ShapeError
        The two speeds of shapes that do not broadcast.
    EstimationError
        An array argument of booleans, or one that is not numbers (text), named.
    """
    config_positive("endo_slip_ratio_ratio", allow_zero=True, n=n)
    vl, vr = _broadcast("endo_slip_ratio_ratio", v_left_m_s=v_left_m_s, v_right_m_s=v_right_m_s)
    standing = np.flatnonzero(vl == 0.0)
    if standing.size:
        raise EstimationError(f"endo_slip_ratio_ratio: v_left_m_s is 0 at index "
                              f"{int(standing[0])} ({standing.size} samples); the ratio "
                              f"|v_r / v_l|^n is undefined there")
    return -np.sign(vr * vl) * np.abs(vr / vl) ** n
