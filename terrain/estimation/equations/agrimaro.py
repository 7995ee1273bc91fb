"""AgriMaRo EKF equations (seed ``001_59da564c4b2d6a48.txt``): the one home of the process and
measurement models of both AgriMaRo designs.

Final design, ch. 6.1 (state eq. 6.1, 12 states; 14 measurement rows)::

    x = [X, Y, yaw, v_bx, v_by, yaw_rate, a_bx, a_by, delta_1, delta_2, delta_3, b_g]

Slip-in-state design, ch. 4.3 (state eq. 4.18, 14 states; 10 or 14 rows)::

    x = [X, Y, yaw, v_bx, v_by, yaw_rate, a_bx, a_by, s_1, s_2, s_3, delta_1, delta_2, delta_3]

Both share the process model (:func:`transition_into`): pose integrated with the body
velocities, velocities with the body accelerations and the Coriolis term of eqs. 4.33-4.34
(``sign = 1``; ``sign = -1`` reproduces eq. 6.2 as printed, see
:mod:`terrain.estimation.agrimaro`), every other state a random walk (eqs. 6.2 and 4.36).

Measurement rows (:func:`observation_into`, eq. 6.6)::

    omega_i   = ((v_bx - r y_i) cos d_i + (v_by + r x_i) sin d_i) / R_w     (eq. 4.20 / R_w)
    ax, ay    = a_bx, a_by;  wz = yaw_rate + b_g;  yaw_imu = yaw;  delta_i = delta_i
    v_cx, v_cy = v_bx - yaw_rate d_y, v_by + yaw_rate d_x;  yaw_rate_c = yaw_rate;  yaw_c = yaw

and the ch. 4.3 rows (:func:`slip_state_observation_into`, eq. 4.28): ``omega_i R_w`` the rim
speed of SAE slip ``s_i`` at ground speed ``v_w,i``
(:func:`terrain.terramechanics.slip.rim_speed_from_slip`: ``v_w,i / (1 - s_i)``, eq. 4.22,
where the rim is the faster, ``v_w,i (1 + s_i)``, eq. 7.2, where the ground is, the sign of
``v_w,i`` taken into account; ``|s_i|`` clipped at ``1 - slip_floor``), accelerometer
``-yaw_rate v_by, yaw_rate v_bx`` (eqs. 4.26-4.27) or the acceleration states, optional camera
rows of eq. 6.6. The vehicle kinematics are not written here: the wheel speed of eq. 4.20 is
:func:`terrain.vehicles.swerve.rim_speed_row` and the camera velocity
:func:`terrain.vehicles.swerve.point_velocity` (eq. 2.2 at ``d_cam``), shared by both designs
through :func:`_camera_rows`.

Numba's on-disk cache (``cache=True``) checks only the source file of the cached function,
not the files of the functions it calls: after an edit of :mod:`terrain.vehicles.swerve` a
kernel of this module could load a stale compiled copy. The helpers it calls are therefore
``register_jitable`` (inlined, no cache of their own), and
``tests/estimation/test_kernel_cache.py`` compares every cached kernel with its Python source
(``py_func``, which runs the current vehicle code); the compiled loop of
:mod:`terrain.estimation.fast` is checked against these kernels by
``tests/estimation/test_fast.py``. When the first test fails, delete the stale cache
(``find terrain -name '*.nbi' -delete -o -name '*.nbc' -delete``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
from numba.extending import register_jitable

from terrain.errors import ShapeError
from terrain.estimation.equations.evaluate import NO_INPUT, observation_pair, transition_pair
from terrain.terramechanics.slip import rim_speed_from_slip
from terrain.vehicles.swerve import (AGRIMARO, AgriMaRoParams, point_velocity, rim_speed_row,
                                     wheel_rim_speed)

#: Number of states of the final design (eq. 6.1) and of the slip-in-state design (eq. 4.18).
N_STATES_FINAL, N_STATES_SLIP = 12, 14
#: Measurement rows of the final design (eq. 6.6).
N_ROWS_FINAL = 14


@dataclass(frozen=True)
class AgriMaRoEquationParams:
    """Constants of the AgriMaRo process and measurement models.

    Parameters
    ----------
    coriolis_sign : float
        1 for the body-frame Coriolis signs of eqs. 4.33-4.34 (correct), -1 for eq. 6.2 as
        printed (seed 001; see :mod:`terrain.estimation.agrimaro`).
    wheel_positions_m : tuple of 3 (x, y)
        Steering-axis positions ``d_1..d_3`` in the body frame, m (seed 001 ch. 7.2).
    wheel_radius_m : float
        Rolling radius ``R_w``, m (:class:`~terrain.vehicles.swerve.AgriMaRoParams`).
    camera_lever_arm_m : tuple of 2 float
        T265 position ``(d_x, d_y)`` in the body frame, m (seed 001 ch. 5.2.3, eq. 6.6).
    accel_direct : bool
        Slip-in-state design only: accelerometer rows measure the acceleration states (as in
        eq. 6.6) instead of eqs. 4.26-4.27.
    camera : bool
        Slip-in-state design only: append the four camera rows of eq. 6.6.
    slip_floor : float
        Slip-in-state design only: the wheel rows read a slip state clipped to ``|s| <= 1 -
        slip_floor`` (a diverging estimate cannot divide by zero in ``1 / (1 - s)`` nor
        turn the rim against the ground), dimensionless.
    """

    coriolis_sign: float = 1.0
    wheel_positions_m: tuple[tuple[float, float], ...] = AGRIMARO.wheel_positions_m
    wheel_radius_m: float = AGRIMARO.wheel_radius_m
    camera_lever_arm_m: tuple[float, float] = (AGRIMARO.camera_lever_arm_m[0],
                                               AGRIMARO.camera_lever_arm_m[1])
    accel_direct: bool = False
    camera: bool = False
    slip_floor: float = 0.05

    @classmethod
    def from_vehicle(cls, vehicle: AgriMaRoParams = AGRIMARO, *, coriolis_sign: float = 1.0,
                     accel_direct: bool = False, camera: bool = False,
                     slip_floor: float = 0.05) -> AgriMaRoEquationParams:
        """The constants of ``vehicle``.

        Parameters
        ----------
        vehicle : AgriMaRoParams
            Geometry (wheel positions, radius, camera lever arm).
        coriolis_sign : float
            1 (eqs. 4.33-4.34) or -1 (eq. 6.2 as printed).
        accel_direct, camera : bool
            Slip-in-state design options (see the class).
        slip_floor : float
            ``1 -`` the largest ``|s|`` the wheel rows read, dimensionless.

        Returns
        -------
        AgriMaRoEquationParams
        """
        return cls(coriolis_sign=float(coriolis_sign),
                   wheel_positions_m=tuple((float(a), float(b))
                                           for a, b in vehicle.wheel_positions_m),
                   wheel_radius_m=float(vehicle.wheel_radius_m),
                   camera_lever_arm_m=(float(vehicle.camera_lever_arm_m[0]),
                                       float(vehicle.camera_lever_arm_m[1])),
                   accel_direct=bool(accel_direct), camera=bool(camera),
                   slip_floor=float(slip_floor))

    def as_array(self) -> np.ndarray:
        """The kernels' parameter vector ``p``.

        Returns
        -------
        ndarray, shape (13,)
            ``(sign, x_1, y_1, x_2, y_2, x_3, y_3, R_w, d_x, d_y, accel_direct, camera,
            slip_floor)`` (positions and radius in m, flags 0/1).
        """
        (x1, y1), (x2, y2), (x3, y3) = self.wheel_positions_m
        return np.array([self.coriolis_sign, x1, y1, x2, y2, x3, y3, self.wheel_radius_m,
                         self.camera_lever_arm_m[0], self.camera_lever_arm_m[1],
                         float(self.accel_direct), float(self.camera), self.slip_floor],
                        dtype=np.float64)

    @property
    def n_measurements_slip_state(self) -> int:
        """Rows of the slip-in-state design: 10, or 14 with the camera."""
        return 14 if self.camera else 10


# -- kernels (the one implementation) ---------------------------------------------------------

@numba.njit(cache=True)
def transition_into(x, u, dt, p, fx, F):
    """Process model and its Jacobian of both designs, written into ``fx`` and ``F``.

    ``x' = x`` except (eqs. 6.2 / 4.36 with the eq. 4.33-4.34 signs when ``p[0] = 1``)::

        X'    = X + dt (v_bx cos yaw - v_by sin yaw)
        Y'    = Y + dt (v_bx sin yaw + v_by cos yaw)
        yaw'  = yaw + dt yaw_rate
        v_bx' = v_bx + dt (a_bx + sign yaw_rate v_by)
        v_by' = v_by + dt (a_by - sign yaw_rate v_bx)

    Parameters
    ----------
    x : ndarray, shape (n,)
        State, n = 12 (eq. 6.1) or 14 (eq. 4.18); the first 8 entries are shared (m, rad,
        m/s, rad/s, m/s^2).
    u : ndarray, shape (0,)
        Input (none; the accelerations are states).
    dt : float
        Step, s.
    p : ndarray, shape (13,)
        :meth:`AgriMaRoEquationParams.as_array` (only ``p[0]``, the Coriolis sign, is read).
    fx : ndarray, shape (n,)
        Output: ``f(x)``.
    F : ndarray, shape (n, n)
        Output: ``df/dx``.
    """
    n = x.shape[0]
    yaw, vx, vy, w, ax, ay = x[2], x[3], x[4], x[5], x[6], x[7]
    c, s = math.cos(yaw), math.sin(yaw)
    sg = p[0]
    for i in range(n):
        fx[i] = x[i]
        for j in range(n):
            F[i, j] = 0.0
        F[i, i] = 1.0
    fx[0] += dt * (vx * c - vy * s)
    fx[1] += dt * (vx * s + vy * c)
    fx[2] += dt * w
    fx[3] += dt * (ax + sg * w * vy)
    fx[4] += dt * (ay - sg * w * vx)
    F[0, 2] = -dt * (vx * s + vy * c)
    F[0, 3] = dt * c
    F[0, 4] = -dt * s
    F[1, 2] = dt * (vx * c - vy * s)
    F[1, 3] = dt * s
    F[1, 4] = dt * c
    F[2, 5] = dt
    F[3, 4] = sg * dt * w
    F[3, 5] = sg * dt * vy
    F[3, 6] = dt
    F[4, 3] = -sg * dt * w
    F[4, 5] = -sg * dt * vx
    F[4, 7] = dt


@register_jitable
def _camera_rows(yaw, vx, vy, w, dx, dy, hx, H, r0, yaw_col):
    """The four T265 rows of eq. 6.6 from row ``r0``: ``v_b + Omega x d_cam`` (robot axes,
    :func:`~terrain.vehicles.swerve.point_velocity` at ``d_cam = (dx, dy)``), yaw rate and
    yaw; ``yaw_col`` is the state column of yaw."""
    hx[r0], hx[r0 + 1] = point_velocity(vx, vy, w, dx, dy)
    hx[r0 + 2] = w
    hx[r0 + 3] = yaw
    H[r0, 3] = 1.0
    H[r0 + 1, 4] = 1.0
    H[r0, 5], H[r0 + 1, 5] = point_velocity(0.0, 0.0, 1.0, dx, dy)
    H[r0 + 2, 5] = 1.0
    H[r0 + 3, yaw_col] = 1.0


@numba.njit(cache=True)
def observation_into(x, p, hx, H):
    """Measurement model of the final design (eq. 6.6) and its Jacobian, into ``hx`` and
    ``H``.

    Parameters
    ----------
    x : ndarray, shape (12,)
        State of eq. 6.1.
    p : ndarray, shape (13,)
        :meth:`AgriMaRoEquationParams.as_array`.
    hx : ndarray, shape (14,)
        Output: ``h(x)`` (rad/s, m/s^2, rad/s, rad, rad, m/s, rad/s, rad).
    H : ndarray, shape (14, 12)
        Output: ``dh/dx``.
    """
    yaw, vx, vy, w, ax, ay, bg = x[2], x[3], x[4], x[5], x[6], x[7], x[11]
    for i in range(14):
        for j in range(12):
            H[i, j] = 0.0
    rw = p[7]
    for i in range(3):                                           # eq. 4.20 / R_w
        vw, dvx, dvy, dw, dd = rim_speed_row(vx, vy, w, p[1 + 2 * i], p[2 + 2 * i], x[8 + i])
        hx[i] = vw / rw
        H[i, 3] = dvx / rw
        H[i, 4] = dvy / rw
        H[i, 5] = dw / rw
        H[i, 8 + i] = dd / rw
    hx[3] = ax
    hx[4] = ay
    hx[5] = w + bg
    hx[6] = yaw
    hx[7] = x[8]
    hx[8] = x[9]
    hx[9] = x[10]
    H[3, 6] = 1.0
    H[4, 7] = 1.0
    H[5, 5] = 1.0
    H[5, 11] = 1.0
    H[6, 2] = 1.0
    H[7, 8] = 1.0
    H[8, 9] = 1.0
    H[9, 10] = 1.0
    _camera_rows(yaw, vx, vy, w, p[8], p[9], hx, H, 10, 2)


@numba.njit(cache=True)
def slip_state_observation_into(x, p, hx, H):
    """Measurement model of the slip-in-state design (eq. 4.28, options in ``p``) and its
    Jacobian, into ``hx`` and ``H``.

    Parameters
    ----------
    x : ndarray, shape (14,)
        State of eq. 4.18 (slips ``s_i`` dimensionless).
    p : ndarray, shape (13,)
        :meth:`AgriMaRoEquationParams.as_array` (``p[10]`` accelerometer rows direct,
        ``p[11]`` camera rows, ``p[12]`` slip floor).
    hx : ndarray, shape (m,)
        Output, m = 10 or 14 (with the camera rows).
    H : ndarray, shape (m, 14)
        Output: ``dh/dx``; the slip column of a wheel is 0 where its slip is clipped.
    """
    yaw, vx, vy, w, ax, ay = x[2], x[3], x[4], x[5], x[6], x[7]
    m = hx.shape[0]
    for i in range(m):
        for j in range(14):
            H[i, j] = 0.0
    rw, floor = p[7], p[12]
    for i in range(3):
        # eq. 4.22 where the rim is the faster, eq. 7.2 where the ground is (the SAE slip of
        # the simulator's truth, braking and in reverse too), |s| clipped at 1 - floor
        s = x[8 + i]
        clipped = abs(s) > 1.0 - floor
        vw, dvx, dvy, dw, dd = rim_speed_row(vx, vy, w, p[1 + 2 * i], p[2 + 2 * i], x[11 + i])
        rim, k, d_slip = rim_speed_from_slip(vw, min(max(s, floor - 1.0), 1.0 - floor))
        k /= rw
        hx[i] = rim / rw
        H[i, 3] = dvx * k
        H[i, 4] = dvy * k
        H[i, 5] = dw * k
        H[i, 11 + i] = dd * k
        H[i, 8 + i] = 0.0 if clipped else d_slip / rw
    if p[10] == 0.0:                                             # eqs. 4.26-4.27
        hx[3] = -w * vy
        hx[4] = w * vx
        H[3, 4] = -w
        H[3, 5] = -vy
        H[4, 3] = w
        H[4, 5] = vx
    else:
        hx[3] = ax
        hx[4] = ay
        H[3, 6] = 1.0
        H[4, 7] = 1.0
    hx[5] = w
    hx[6] = yaw
    H[5, 5] = 1.0
    H[6, 2] = 1.0
    for i in range(3):
        hx[7 + i] = x[11 + i]
        H[7 + i, 11 + i] = 1.0
    if p[11] != 0.0:
        _camera_rows(yaw, vx, vy, w, p[8], p[9], hx, H, 10, 2)


# -- python-control style API -----------------------------------------------------------------

def _either_design(x: np.ndarray) -> np.ndarray:
    """``x`` when it is a state of either design (12 or 14 entries); the kernel reads entries
    0..7 and copies the rest without bounds checks, so anything else is a ShapeError."""
    if np.shape(x) not in ((N_STATES_FINAL,), (N_STATES_SLIP,)):
        raise ShapeError(f"an AgriMaRo state has shape ({N_STATES_FINAL},) or "
                         f"({N_STATES_SLIP},) (12 or 14 states), got {np.shape(x)}")
    return x


def f(x: np.ndarray, u: np.ndarray | None, dt: float,
      params: AgriMaRoEquationParams = AgriMaRoEquationParams()) -> np.ndarray:
    """Next state (eqs. 6.2 / 4.36 with the eq. 4.33-4.34 Coriolis signs).

    Parameters
    ----------
    x : ndarray, shape (n,)
        State, n = 12 (eq. 6.1) or 14 (eq. 4.18), SI units.
    u : None or ndarray, shape (0,)
        Input (the model has none).
    dt : float
        Step, s.
    params : AgriMaRoEquationParams
        Model constants (vehicle geometry, Coriolis sign).

    Returns
    -------
    ndarray, shape (n,)

    Raises
    ------
    ShapeError
        ``x`` not of 12 or 14 states.
    """
    return transition_pair(transition_into, _either_design(x), NO_INPUT, dt,
                           params.as_array())[0]


def F(x: np.ndarray, u: np.ndarray | None, dt: float,
      params: AgriMaRoEquationParams = AgriMaRoEquationParams()) -> np.ndarray:
    """Jacobian ``df/dx`` of :func:`f`.

    Parameters
    ----------
    x : ndarray, shape (n,)
        State, n = 12 or 14.
    u : None or ndarray, shape (0,)
        Input (none).
    dt : float
        Step, s.
    params : AgriMaRoEquationParams
        Model constants (vehicle geometry, Coriolis sign).

    Returns
    -------
    ndarray, shape (n, n)

    Raises
    ------
    ShapeError
        ``x`` not of 12 or 14 states.
    """
    return transition_pair(transition_into, _either_design(x), NO_INPUT, dt,
                           params.as_array())[1]


def h(x: np.ndarray, params: AgriMaRoEquationParams = AgriMaRoEquationParams()) -> np.ndarray:
    """Measurement of the final design (eq. 6.6).

    Parameters
    ----------
    x : ndarray, shape (12,)
        State of eq. 6.1.
    params : AgriMaRoEquationParams
        Model constants (vehicle geometry, Coriolis sign).

    Returns
    -------
    ndarray, shape (14,)
        Rows in the order of :data:`terrain.estimation.agrimaro.MEASUREMENT_NAMES`.
    """
    return observation_pair(observation_into, x, params.as_array(), N_ROWS_FINAL,
                            N_STATES_FINAL)[0]


def H(x: np.ndarray, params: AgriMaRoEquationParams = AgriMaRoEquationParams()) -> np.ndarray:
    """Jacobian ``dh/dx`` of :func:`h`.

    Parameters
    ----------
    x : ndarray, shape (12,)
        State of eq. 6.1.
    params : AgriMaRoEquationParams
        Model constants (vehicle geometry, Coriolis sign).

    Returns
    -------
    ndarray, shape (14, 12)
    """
    return observation_pair(observation_into, x, params.as_array(), N_ROWS_FINAL,
                            N_STATES_FINAL)[1]


__all__ = ["AgriMaRoEquationParams", "NO_INPUT", "wheel_rim_speed", "transition_into",
           "observation_into", "slip_state_observation_into", "f", "F", "h", "H"]
