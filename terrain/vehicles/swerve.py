"""AgriMaRo three-wheel swerve drive (seed ``001_59da564c4b2d6a48.txt``).

Kinematics of ch. 2.3.1 (eqs. 2.1-2.5) with the wheel positions of ch. 7.2, the T265 camera
lever arm and axis conventions of ch. 5.2.3 (eqs. 5.4) and the steering dead band of
ch. 6.1.1. Twists follow the thesis order ``V_b = [yaw_rate, v_x, v_y]`` (rad/s, m/s, m/s) in
the body frame (x forward, y left, z up).

Wheel numbering follows ch. 7.2 (``d_1 = [-0.5075, 0]``, ``d_2 = [0.5075, 0]``,
``d_3 = [0, -0.756]`` m). Eq. 2.3 numbers the two on-axis wheels the other way round
(wheel 1 at ``x = +w/2``); both give ``w = 1.015 m`` and ``t = 0.756 m``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numba
import numpy as np
from numba.extending import register_jitable

from terrain.errors import ConfigError, NonFiniteInputError, ShapeError, config_positive
from terrain.vehicles.common import (ContactGeometry, MotorParams, check_fields, check_motor,
                                     float_arrays, wrap_angle)

#: Rotation taking T265 tracking-frame vectors (x right, y up, z backward) to the robot frame
#: (x forward, y left, z up), seed 001 ch. 5.2.3.
R_ROBOT_FROM_T265_TRACKING = np.array([[0.0, 0.0, -1.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
R_ROBOT_FROM_T265_TRACKING.flags.writeable = False
#: Rotation taking T265 internal IMU vectors (x left, y up, z forward) to the robot frame.
R_ROBOT_FROM_T265_IMU = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
R_ROBOT_FROM_T265_IMU.flags.writeable = False


def _agrimaro_motor() -> MotorParams:
    return MotorParams(
        torque_constant_nm_per_a=2.0, gear_ratio=1.0, efficiency=0.85, no_load_current_a=0.6,
        speed_time_constant_s=0.08, max_wheel_speed_rad_s=1.6 / 0.165,
        encoder_filter_s=0.12, encoder_counts_per_rev=90, wheel_inertia_kg_m2=0.12,
        source=("UuMotor 48 V BLDC hub motor, max torque 60 N m (seed 001 ch. 2.2). ASSUMED "
                "G = 1: ch. 3.1.1 and 3.3.2 put the hub motor's RPM sensor on the motor shaft "
                "upstream of a gear reduction whose ratio tau was measured but is not given; "
                "only the product k_t G enters the current and power laws, so k_t = 2.0 N m/A "
                "is that product at the wheel (60 N m reached at 30 A, a typical 48 V hub-motor "
                "phase current); I_0 = 0.6 A; speed loop 0.08 s; ODrive Hall-encoder "
                "filter 0.12 s, the order of the phase delay of ch. 7.2.2; 90 counts/rev = "
                "15 pole pairs x 6 Hall states (per motor turn: with the reduction tau the "
                "wheel's quantum is tau times finer); speed limit 1.6 m/s at the rim (the thesis "
                "tests run at 1 m/s, ch. 7.2.3). wheel_inertia_kg_m2 0.12 ASSUMED: hub motor "
                "and 13 in tyre of about 6 kg with a radius of gyration of 0.14 m (wheel radius "
                "0.165 m)."))


@dataclass(frozen=True)
class AgriMaRoParams:
    """AgriMaRo geometry, mass and actuators.

    Parameters
    ----------
    name : str
        Vehicle name.
    wheel_positions_m : tuple of (x, y)
        Wheel (steering axis) positions d_1..d_3 in the body frame, m. Seed 001 ch. 7.2.
    wheel_radius_m : float
        Rolling radius r, m. ASSUMED 0.165 m: the thesis does not give it; a 13 in
        wheelbarrow tyre (ch. 2.2 "electric wheelbarrow" hub motor) has about 0.33 m diameter.
    mass_kg : float
        ASSUMED 150 kg: not given in the thesis; gantry frame with three 60 N m hub motors and
        steering units geared to a 25 N m design torque (ch. 2.2), built to carry "the
        operational payload".
    yaw_inertia_kg_m2 : float
        ASSUMED m (w^2 + t^2) / 12 for a plate spanning the wheel triangle.
    camera_lever_arm_m : tuple of float
        T265 position in the body frame, m (seed 001 ch. 5.2.3, ``d_cam``).
    steering_dead_band_rad : float
        Half width of the steering dead band, rad (seed 001 ch. 6.1.1: +-0.021 rad).
    steering_rate_rad_s : float
        Steering speed limit, rad/s (20 rpm, seed 001 ch. 2.2).
    motor : MotorParams
        Drive motor of each side / wheel (sources in ``MotorParams.source``).
    contact_length_m, contact_width_m : float
        Tyre contact patch (ASSUMED 0.10 m x 0.12 m).
    wheels_per_motor : int
        Wheels turned by each motor, each of inertia ``motor.wheel_inertia_kg_m2``: 1 (a hub
        motor in each wheel, seed 001 ch. 2.2).
    """

    name: str = "agrimaro"
    wheel_positions_m: tuple[tuple[float, float], ...] = ((-0.5075, 0.0), (0.5075, 0.0),
                                                          (0.0, -0.7560))
    wheel_radius_m: float = 0.165
    mass_kg: float = 150.0
    yaw_inertia_kg_m2: float = 150.0 * (1.015 ** 2 + 0.756 ** 2) / 12.0
    camera_lever_arm_m: tuple[float, float, float] = (0.6685, -0.26875, 0.0)
    steering_dead_band_rad: float = 0.021
    steering_rate_rad_s: float = 20.0 * 2.0 * np.pi / 60.0
    motor: MotorParams = field(default_factory=_agrimaro_motor)
    contact_length_m: float = 0.10
    contact_width_m: float = 0.12
    wheels_per_motor: int = 1

    def __post_init__(self) -> None:
        """Refuse impossible values (:class:`~terrain.errors.ConfigError` naming the field):
        three finite wheel positions (x, y), not all at one point, a finite 3-vector camera
        lever arm (numbers, not booleans or text; both stored as tuples of floats), radius,
        mass, inertia, steering rate and patch finite and > 0, dead band finite and >= 0,
        wheels per motor an integer >= 1, ``motor`` a :class:`MotorParams`."""
        for name, shape in (("wheel_positions_m", (3, 2)), ("camera_lever_arm_m", (3,))):
            value = getattr(self, name)
            try:
                arr = np.asarray(value, dtype=float)
                # a boolean converts to 1 or 0 (True was a wheel at x = 1 m), text to its
                # number (and stayed text in the field)
                flag = any(isinstance(v, (bool, np.bool_, str, bytes, np.str_, np.bytes_))
                           for v in np.asarray(value, dtype=object).ravel())
            except (TypeError, ValueError):
                arr, flag = None, False
            if arr is None or flag or arr.shape != shape or not np.isfinite(arr).all():
                raise ConfigError(f"AgriMaRoParams.{name} must be finite numbers of shape "
                                  f"{shape} (not booleans or text), got {value!r:.80}")
            # stored as tuples of floats: arrays made == ambiguous and the hash fail
            object.__setattr__(self, name, tuple(tuple(r) if isinstance(r, list) else r
                                                 for r in arr.tolist()))
        if not np.ptp(self.positions, axis=0).any():
            # all steering axes at one point: eq. 2.4 cannot give the yaw rate (H^+ gave 0)
            raise ConfigError(f"AgriMaRoParams.wheel_positions_m must hold at least two "
                              f"distinct positions, got {self.wheel_positions_m!r:.80}")
        check_fields(self, positive=("wheel_radius_m", "mass_kg", "yaw_inertia_kg_m2",
                                     "steering_rate_rad_s", "contact_length_m",
                                     "contact_width_m"),
                     non_negative=("steering_dead_band_rad",), counts=("wheels_per_motor",))
        check_motor(self)

    @property
    def positions(self) -> np.ndarray:
        """Wheel positions, shape (3, 2), m."""
        return np.asarray(self.wheel_positions_m, dtype=float)

    @property
    def cog_m(self) -> np.ndarray:
        """ASSUMED centre of gravity, shape (2,), m: centroid of the wheel triangle.

        The body origin lies on the edge between wheels 1 and 2, so a CoG there would leave
        wheel 3 unloaded; the centroid gives equal static loads (:meth:`contact_geometry`,
        whose ``cog_m``, the point those loads balance, is this one: the simulator puts
        the mass there).
        """
        return self.positions.mean(axis=0)

    def contact_geometry(self) -> ContactGeometry:
        """One contact per wheel (ch. 7.2 positions), one motor per wheel, equal static loads
        (the statics of the centre of gravity :attr:`cog_m`, the triangle's centroid).

        Returns
        -------
        ContactGeometry
            Contact positions (body frame, m), motor of each contact, static load shares.
        """
        return ContactGeometry(positions_m=self.positions, motor_of_contact=np.arange(3),
                               load_share=np.full(3, 1.0 / 3.0), steered=True,
                               wheel_radius_m=self.wheel_radius_m, motor_names=("1", "2", "3"))


AGRIMARO = AgriMaRoParams()


@register_jitable
def point_velocity(v_bx, v_by, yaw_rate, x_m, y_m):
    """Velocity of the body point ``(x_m, y_m)`` of a rigid body moving in the plane: seed 001
    eq. 2.2 (``h_i V_b``, the wheel steering axes, eqs. 7.3-7.4) and eq. 6.6 (the T265 point),
    i.e. ``v + Omega x d`` of :func:`robot_to_camera_velocity` with ``Omega = (0, 0,
    yaw_rate)``. The one home of this relation: NumPy callers (any broadcastable arrays) and
    the numba kernels of :mod:`terrain.estimation.equations` call it.

    Parameters
    ----------
    v_bx, v_by : float or ndarray
        Velocity of the body origin in the body frame, m/s.
    yaw_rate : float or ndarray
        Body yaw rate, rad/s.
    x_m, y_m : float or ndarray
        Position of the point in the body frame, m.

    Returns
    -------
    v_x, v_y : float or ndarray
        Velocity of the point in the body frame, ``(v_bx - yaw_rate y, v_by + yaw_rate x)``,
        m/s.
    """
    return v_bx - yaw_rate * y_m, v_by + yaw_rate * x_m


@register_jitable
def rim_speed_row(v_bx, v_by, yaw_rate, x_m, y_m, delta_rad):
    """Speed of the steering axis at ``(x_m, y_m)`` along the rolling direction of a wheel
    steered to ``delta_rad`` (seed 001 eq. 4.20; eqs. 7.3-7.5) and its partial derivatives.

    Parameters
    ----------
    v_bx, v_by : float
        Velocity of the body origin in the body frame, m/s.
    yaw_rate : float
        Body yaw rate, rad/s.
    x_m, y_m : float
        Steering-axis position in the body frame, m.
    delta_rad : float
        Steering angle, rad (0 for a fixed wheel).

    Returns
    -------
    v_w : float
        ``v_x cos(delta) + v_y sin(delta)`` with ``(v_x, v_y)`` of :func:`point_velocity`,
        m/s.
    dv_dvx, dv_dvy, dv_dyaw_rate, dv_ddelta : float
        Partial derivatives of ``v_w`` (1, 1, m, m/s per rad).
    """
    c, s = math.cos(delta_rad), math.sin(delta_rad)
    u, v = point_velocity(v_bx, v_by, yaw_rate, x_m, y_m)
    du_dw, dv_dw = point_velocity(0.0, 0.0, 1.0, x_m, y_m)
    return u * c + v * s, c, s, du_dw * c + dv_dw * s, -u * s + v * c


@numba.vectorize(cache=True)
def wheel_rim_speed(v_bx, v_by, yaw_rate, x_i, y_i, delta):
    """Velocity of a wheel's steering axis (or contact line) along its rolling direction:
    the body velocity moved to ``d_i = (x_i, y_i)`` and projected on ``delta`` (seed 001
    eq. 4.20, the same relation as eqs. 7.3-7.5); a NumPy ufunc (broadcasts).

    Parameters
    ----------
    v_bx, v_by : float or ndarray
        Body velocity, m/s.
    yaw_rate : float or ndarray
        Yaw rate, rad/s.
    x_i, y_i : float or ndarray
        Position of the wheel in the body frame, m.
    delta : float or ndarray
        Steering angle, rad (0 for fixed wheels).

    Returns
    -------
    float or ndarray
        ``(v_bx - yaw_rate y_i) cos delta + (v_by + yaw_rate x_i) sin delta``, m/s.
    """
    return rim_speed_row(v_bx, v_by, yaw_rate, x_i, y_i, delta)[0]


def h_matrix(positions_m: np.ndarray) -> np.ndarray:
    """Stacked rigid-body maps ``h_i`` of eq. 2.2 (the ``H`` of eq. 2.3).

    Parameters
    ----------
    positions_m : ndarray, shape (n, 2)
        Wheel positions in the body frame, m.

    Returns
    -------
    ndarray, shape (2 n, 3)
        Rows ``[-y_i, 1, 0]`` and ``[x_i, 0, 1]`` per wheel; ``H @ V_b`` gives the contact
        velocities ``[x_dot_1, y_dot_1, x_dot_2, ...]``.
    """
    p = np.asarray(positions_m, dtype=float)
    h = np.empty((2 * len(p), 3))
    for k, (yaw_rate, v_x, v_y) in enumerate(np.eye(3)):     # point_velocity is linear
        h[0::2, k], h[1::2, k] = point_velocity(v_x, v_y, yaw_rate, p[:, 0], p[:, 1])
    return h


def wheel_contact_velocity(positions_m: np.ndarray, twist: np.ndarray) -> np.ndarray:
    """Velocity of each wheel's steering axis from the body twist (eq. 2.2, eqs. 7.3-7.4).

    Parameters
    ----------
    positions_m : ndarray, shape (n_wheels, 2)
        Wheel (steering axis) positions in the body frame, m.
    twist : ndarray, shape (..., 3)
        ``[yaw_rate, v_x, v_y]`` (rad/s, m/s, m/s).

    Returns
    -------
    ndarray, shape (..., n_wheels, 2)
        ``(x_dot_i, y_dot_i)`` in the body frame, m/s.

    Raises
    ------
    ShapeError
        ``positions_m`` not of shape (n_wheels, 2) or ``twist`` not of shape (..., 3) (a
        fourth twist entry or a z coordinate was dropped without a word).
    EstimationError
        ``positions_m`` or ``twist`` holding booleans or what is not numbers (text),
        named (:func:`~terrain.vehicles.common.float_arrays`).
    """
    p, = float_arrays("wheel_contact_velocity", positions_m=positions_m)
    if p.ndim != 2 or p.shape[1] != 2:
        raise ShapeError(f"wheel_contact_velocity: positions_m must have shape (n_wheels, 2), "
                         f"one (x, y) per wheel, got {p.shape}")
    tw = _vectors3("wheel_contact_velocity", "twist [yaw_rate, v_x, v_y]", twist)
    vx, vy = point_velocity(tw[..., 1:2], tw[..., 2:3], tw[..., 0:1], p[:, 0], p[:, 1])
    return np.stack([vx, vy], axis=-1)


def _vectors3(owner: str, name: str, value) -> np.ndarray:
    """``value`` as floats of shape (..., 3) (a vector per sample); ShapeError naming
    ``owner`` and ``name`` otherwise (np.cross took two entries as ``(x, y, 0)``, the
    product and the indexing dropped a fourth without a word); EstimationError naming them
    for booleans or text (:func:`~terrain.vehicles.common.float_arrays`: ``True`` was 1 m/s,
    ``"a"`` NumPy's bare ValueError)."""
    a, = float_arrays(owner, **{name: value})
    if a.ndim == 0 or a.shape[-1] != 3:
        raise ShapeError(f"{owner}: {name} must have shape (..., 3), got {a.shape}")
    return a


def _finite(owner: str, name: str, a: np.ndarray, what: str, why: str) -> None:
    """NonFiniteInputError where ``a`` holds NaN or inf, naming ``owner``, ``name``, the count
    and the first one's value and index; ``what`` names the entries, ``why`` says what
    would have gone wrong."""
    bad = ~np.isfinite(a)
    if bad.any():
        first = tuple(int(i) for i in np.argwhere(bad)[0])
        raise NonFiniteInputError(f"{owner}: {name} holds {int(bad.sum())} non-finite {what} "
                                  f"(first {a[bad][0]!r} at index {first}); {why}")


def _check_swerve(owner: str, params) -> None:
    """ConfigError unless ``params`` is a swerve drive's :class:`AgriMaRoParams` (a
    skid-steer's parameters raised AttributeError 'positions')."""
    if not isinstance(params, AgriMaRoParams):
        raise ConfigError(f"{owner}: params must be AgriMaRoParams (a swerve drive), got "
                          f"{type(params).__name__}")


def swerve_forward(delta_rad: np.ndarray, omega_rad_s: np.ndarray,
                   params: AgriMaRoParams = AGRIMARO) -> np.ndarray:
    """Forward kinematics ``V_b = H^+ S(delta) omega`` (seed 001 eq. 2.4).

    Parameters
    ----------
    delta_rad : ndarray, shape (..., 3)
        Steering angles, rad.
    omega_rad_s : ndarray, shape (..., 3)
        Wheel angular speeds, rad/s.
    params : AgriMaRoParams
        Geometry (seed 001 ch. 7.2) and wheel radius.

    Returns
    -------
    ndarray, shape (..., 3)
        Least-squares twist ``[yaw_rate, v_x, v_y]`` (rad/s, m/s, m/s).

    Raises
    ------
    ShapeError
        ``delta_rad`` and ``omega_rad_s`` of different shapes, or a last axis that is not
        one entry per wheel (NumPy's bare broadcast or matmul ValueError before).
    NonFiniteInputError
        ``delta_rad`` or ``omega_rad_s`` holding NaN or inf, named with the count and the
        first index (the least squares spread one NaN wheel over the whole twist of its
        sample, without a word).
    EstimationError
        ``delta_rad`` or ``omega_rad_s`` holding booleans (``True`` was 1 rad) or what is
        not numbers (text), named.
    ConfigError
        ``params`` not an :class:`AgriMaRoParams` (a skid-steer's parameters).
    """
    _check_swerve("swerve_forward", params)
    d, w = float_arrays("swerve_forward", delta_rad=delta_rad, omega_rad_s=omega_rad_s)
    n_wheels = len(params.positions)
    if d.shape != w.shape or d.ndim == 0 or d.shape[-1] != n_wheels:
        raise ShapeError(f"swerve_forward: delta_rad {d.shape} and omega_rad_s {w.shape} must "
                         f"have one shape (..., {n_wheels}), one entry per wheel")
    for name, a in (("delta_rad", d), ("omega_rad_s", w)):
        _finite("swerve_forward", name, a, "entries",
                "the least-squares twist of that sample would be NaN")
    rw = params.wheel_radius_m * w
    s_omega = np.empty(d.shape[:-1] + (2 * d.shape[-1],))
    s_omega[..., 0::2] = rw * np.cos(d)       # eq. 2.1: s_i(delta_i) omega_i
    s_omega[..., 1::2] = rw * np.sin(d)
    h_pinv = np.linalg.pinv(h_matrix(params.positions))
    return s_omega @ h_pinv.T


def _previous_angles(delta_prev_rad, shape: tuple) -> np.ndarray:
    """``delta_prev_rad`` of :func:`swerve_inverse` broadcast to ``shape`` (ShapeError when
    it does not broadcast, NonFiniteInputError naming the count of NaN or inf angles)."""
    prev, = float_arrays("swerve_inverse", delta_prev_rad=delta_prev_rad)
    try:
        prev = np.broadcast_to(prev, shape)
    except ValueError:
        raise ShapeError(f"swerve_inverse: delta_prev_rad {prev.shape} must broadcast to the "
                         f"steering angles {shape}, one per unit") from None
    _finite("swerve_inverse", "delta_prev_rad", prev, "angles",
            "the solution closest to the previous angle is not defined")
    return prev


def swerve_inverse(twist: np.ndarray, params: AgriMaRoParams = AGRIMARO,
                   delta_prev_rad: np.ndarray | None = None,
                   min_speed_m_s: float = 1e-6) -> tuple[np.ndarray, np.ndarray]:
    """Inverse kinematics per swerve unit (seed 001 eq. 2.5).

    Of the two solutions ``k = 0, 1`` the one closest to ``delta_prev_rad`` is chosen (the
    one within +-pi/2 when no previous angle is given). A unit whose speed is below
    ``min_speed_m_s`` keeps its previous angle.

    Parameters
    ----------
    twist : ndarray, shape (..., 3)
        ``[yaw_rate, v_x, v_y]``.
    params : AgriMaRoParams
        Geometry (seed 001 ch. 7.2) and wheel radius.
    delta_prev_rad : ndarray, shape (..., 3), optional
        Previous steering angles, rad.
    min_speed_m_s : float
        Speed below which a unit keeps its previous angle, m/s (finite, >= 0).

    Returns
    -------
    delta_rad : ndarray, shape (..., 3)
        Steering angles, rad.
    omega_rad_s : ndarray, shape (..., 3)
        Wheel angular speeds, rad/s: contact speed over the wheel radius, negative on a
        flipped unit, 0 on a unit that keeps its angle.

    Raises
    ------
    ConfigError
        ``min_speed_m_s`` not a finite number >= 0 (NaN let no standing unit keep its
        angle; booleans refused), or ``params`` not an :class:`AgriMaRoParams`.
    ShapeError
        ``twist`` not of shape (..., 3) (:func:`wheel_contact_velocity`), or
        ``delta_prev_rad`` that does not broadcast to (..., 3).
    NonFiniteInputError
        ``delta_prev_rad`` holds NaN or inf (no solution is closest to it: the unit took
        the k = 0 angle, a standing unit kept NaN), or ``twist`` does (NaN steering angles
        and wheel speeds came back, and a NaN unit did not keep its angle).
    EstimationError
        ``twist`` or ``delta_prev_rad`` holding booleans or what is not numbers (text),
        named.
    """
    config_positive("swerve_inverse", allow_zero=True, min_speed_m_s=min_speed_m_s)
    _check_swerve("swerve_inverse", params)
    tw = _vectors3("swerve_inverse", "twist", twist)
    _finite("swerve_inverse", "twist", tw, "entries",
            "the steering angles and wheel speeds would be NaN")
    vel = wheel_contact_velocity(params.positions, tw)
    speed = np.hypot(vel[..., 0], vel[..., 1])
    delta0 = np.arctan2(vel[..., 1], vel[..., 0])
    prev = np.zeros_like(delta0) if delta_prev_rad is None else _previous_angles(
        delta_prev_rad, delta0.shape)
    delta1 = delta0 - np.pi * np.sign(delta0 + 1e-300)        # the k = 1 (flipped) solution
    use_flip = np.abs(wrap_angle(delta1 - prev)) < np.abs(wrap_angle(delta0 - prev))
    delta = np.where(use_flip, delta1, delta0)
    omega = np.where(use_flip, -speed, speed) / params.wheel_radius_m
    still = speed < min_speed_m_s
    delta = np.where(still, prev, delta)
    omega = np.where(still, 0.0, omega)
    return delta, omega


def camera_to_robot_velocity(v_camera_m_s: np.ndarray, omega_rad_s: np.ndarray,
                             lever_arm_m: np.ndarray = np.array(AGRIMARO.camera_lever_arm_m)
                             ) -> np.ndarray:
    """Poisson formula ``v_robot = v_camera - omega x d_cam`` (seed 001 eq. 5.4).

    Parameters
    ----------
    v_camera_m_s : ndarray, shape (..., 3)
        Velocity of the camera point, robot axes, m/s.
    omega_rad_s : ndarray, shape (..., 3)
        Body angular velocity, rad/s.
    lever_arm_m : ndarray, shape (3,)
        Camera position ``d_cam`` in the body frame, m (seed 001 ch. 5.2.3).

    Returns
    -------
    ndarray, shape (..., 3)
        Velocity of the body origin, m/s.

    Raises
    ------
    ShapeError
        As :func:`robot_to_camera_velocity`.
    EstimationError
        As :func:`robot_to_camera_velocity` (the negation of ``omega_rad_s`` raised NumPy's
        bare TypeError on booleans and text before).
    """
    w = _vectors3("camera_to_robot_velocity", "omega_rad_s", omega_rad_s)
    return robot_to_camera_velocity(v_camera_m_s, -w, lever_arm_m)


def robot_to_camera_velocity(v_robot_m_s: np.ndarray, omega_rad_s: np.ndarray,
                             lever_arm_m: np.ndarray = np.array(AGRIMARO.camera_lever_arm_m)
                             ) -> np.ndarray:
    """Velocity of the camera point, ``v_camera = v_robot + omega x d_cam`` (seed 001 eq. 5.4
    solved for ``v_camera``; :func:`camera_to_robot_velocity` is its inverse, the planar case
    is :func:`point_velocity`).

    Parameters
    ----------
    v_robot_m_s : ndarray, shape (..., 3)
        Velocity of the body origin, robot axes, m/s.
    omega_rad_s : ndarray, shape (..., 3)
        Body angular velocity, rad/s.
    lever_arm_m : ndarray, shape (3,)
        Camera position ``d_cam`` in the body frame, m (seed 001 ch. 5.2.3).

    Returns
    -------
    ndarray, shape (..., 3)

    Raises
    ------
    ShapeError
        A velocity or angular velocity not of shape (..., 3) or a lever arm not of shape
        (3,) (np.cross took two entries as ``(x, y, 0)``).
    EstimationError
        A velocity, angular velocity or lever arm holding booleans or what is not numbers
        (text), named.
    """
    v = _vectors3("robot_to_camera_velocity", "velocity", v_robot_m_s)
    w = _vectors3("robot_to_camera_velocity", "omega_rad_s", omega_rad_s)
    arm, = float_arrays("robot_to_camera_velocity", lever_arm_m=lever_arm_m)
    if arm.shape != (3,):
        raise ShapeError(f"robot_to_camera_velocity: lever_arm_m must have shape (3,), got "
                         f"{arm.shape}")
    return v + np.cross(w, arm)


def t265_tracking_to_robot(vectors: np.ndarray) -> np.ndarray:
    """Re-express T265 tracking-frame vectors in robot axes (seed 001 ch. 5.2.3).

    Tracking frame: x right, y up, z backward. Robot frame: x forward, y left, z up.

    Parameters
    ----------
    vectors : ndarray, shape (..., 3)
        Vectors in the T265 tracking frame (any unit).

    Returns
    -------
    ndarray, shape (..., 3)

    Raises
    ------
    ShapeError
        ``vectors`` not of shape (..., 3) (NumPy's bare matmul ValueError before).
    EstimationError
        ``vectors`` holding booleans or what is not numbers (text).
    """
    return _vectors3("t265_tracking_to_robot", "vectors", vectors) @ R_ROBOT_FROM_T265_TRACKING.T
