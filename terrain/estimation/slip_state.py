"""The first AgriMaRo EKF design with the wheel slips inside the state (seed
``001_59da564c4b2d6a48.txt`` ch. 4.3), kept to reproduce the thesis's finding about it.

State (eq. 4.18)::

    x = [X, Y, yaw, v_bx, v_by, yaw_rate, a_bx, a_by, s_1, s_2, s_3, delta_1, delta_2, delta_3]

Process model: eq. 4.36 (pose and velocities integrated, everything else a random walk),
with the Coriolis signs of eqs. 4.33-4.34 (the ones the thesis prints in ch. 4; see
:mod:`terrain.estimation.agrimaro` for why they are the right ones).

Measurements (eq. 4.28, ``accel="coriolis"``)::

    omega_i = v_w,i / ((1 - s_i) r)      v_w,i from eq. 4.20           (eq. 4.22)
              (v_w,i (1 + s_i) / r where the ground is the faster, eq. 7.2)
    ax = -yaw_rate v_by,  ay = yaw_rate v_bx                           (eqs. 4.26-4.27)
    wz = yaw_rate,  yaw_imu = yaw,  delta_i = delta_i

``accel="direct"`` measures ``a_bx, a_by`` directly (as in the final design, eq. 6.6) and
``camera=True`` appends the four T265 rows of eq. 6.6 (``v_cx, v_cy, yaw_rate_c, yaw_c``):
with them the velocity, and therefore the slip, becomes observable, which the ch. 4.3 sensor
set does not provide (wheel speed alone cannot tell velocity from slip).

The slip states are SAE slips, the simulator's truth slip: the wheel rows are
:func:`terrain.terramechanics.slip.rim_speed_from_slip` (eq. 4.22 as printed where the rim is
the faster, ``v_w (1 + s)`` of eq. 7.2 braking, the sign of ``v_w`` taken into account in
reverse; eq. 4.22 for every sign read a braking slip of -0.2 as -0.25 and flipped the sign in
reverse). A slip state beyond ``|s| = 0.95`` is read clipped there (no division by zero, no
rim turning against the ground), with no slip column in the Jacobian; the Jacobian is exact
inside that range.

Default tuning: P0 of eq. 4.38, R of eq. 4.40, Q of eq. 4.41, per filter step. Eq. 4.38
prints 13 values for 14 states and eq. 4.40 prints 11 for 10 measurements; the text (ch.
4.4.2-4.4.3) fixes the reading used here: P0 = 1e-6 for pose, velocities, yaw rate and slips,
1e-3 for the accelerations, 1e-1 for the steering angles; R = 1e-5 for every row except the
steering encoders (7.2e-5).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from terrain.errors import (ConfigError, config_flags, config_numbers, config_positive,
                            indexed)
from terrain.estimation.agrimaro import SENSOR_COLUMNS
from terrain.estimation.equations.agrimaro import (AgriMaRoEquationParams,
                                                   slip_state_observation_into, transition_into)
from terrain.estimation.model import KernelModel, diagonal_process_noise
from terrain.vehicles.swerve import AGRIMARO, AgriMaRoParams

STATE_NAMES: tuple[str, ...] = ("x", "y", "yaw", "v_bx", "v_by", "yaw_rate", "a_bx", "a_by",
                                "slip_1", "slip_2", "slip_3", "delta_1", "delta_2",
                                "delta_3")
#: Eq. 4.38, 4.40, 4.41 (see the module docstring for the reading of the misprints).
THESIS_P0_CH4 = (1e-6,) * 6 + (1e-3, 1e-3) + (1e-6,) * 3 + (1e-1,) * 3
THESIS_R_CH4 = (1e-5,) * 7 + (7.2e-5,) * 3
THESIS_Q_CH4 = (1e-8, 1e-8, 1e-8, 1e-6, 1e-6, 1e-5, 1e-3, 1e-3, 1e-5, 1e-5, 1e-5, 7.2e-5,
                7.2e-5, 7.2e-5)
#: Camera rows when ``camera=True`` (T265 noise of the simulator, seed 001 eq. 6.13 order).
CAMERA_R = (1e-4, 1e-4, 1e-4, 4e-6)
SLIP_FLOOR = 0.05


@dataclass(frozen=True)
class SlipStateModel(KernelModel):
    """14-state EKF with slip in the state (seed ``001_59da564c4b2d6a48.txt`` ch. 4.3); its
    equations are :mod:`terrain.estimation.equations.agrimaro`.

    Parameters
    ----------
    vehicle : AgriMaRoParams
        Geometry (ch. 7.2, 5.2.3).
    accel : {"coriolis", "direct"}
        Accelerometer rows: eqs. 4.26-4.27 (``-yaw_rate v_by``, ``yaw_rate v_bx``) or the
        acceleration states.
    camera : bool
        Append the T265 rows of eq. 6.6.
    p0_diag : tuple of 14 float
        Initial variances, SI units squared (default eq. 4.38).
    r_diag : tuple of 10 or 14 float, optional
        Measurement noise variances (default eq. 4.40 + ``CAMERA_R``).
    q_diag : tuple of 14 float
        Process noise variances (default eq. 4.41).
    q_per : {"step", "second"}
        As in :class:`~terrain.estimation.agrimaro.AgriMaRoEKFSettings`.

    Attributes
    ----------
    state_names : tuple of str
        :data:`STATE_NAMES` (14).
    measurement_names : tuple of str
        10 rows, 14 with the camera.
    angle_rows : tuple of int
        ``yaw_imu`` (6), the steering encoders ``delta_1..3`` (7-9, read within one turn)
        and, with the camera, ``yaw_c`` (13).

    Raises
    ------
    ConfigError
        Unknown ``accel`` or ``q_per``, ``camera`` not a boolean, a variance that is not a
        real number (text, a boolean), ``p0_diag``, ``q_diag`` or a given ``r_diag`` not a
        sequence (a number, None, text), ``r_diag`` of the wrong length or not finite and
        > 0, ``p0_diag`` / ``q_diag`` without 14 finite values >= 0.
    """

    vehicle: AgriMaRoParams = AGRIMARO
    accel: str = "coriolis"
    camera: bool = False
    p0_diag: tuple[float, ...] = THESIS_P0_CH4
    r_diag: tuple[float, ...] | None = None
    q_diag: tuple[float, ...] = THESIS_Q_CH4
    q_per: str = "step"
    state_names: tuple[str, ...] = field(default=STATE_NAMES, init=False)
    measurement_names: tuple[str, ...] = field(default=(), init=False)
    angle_rows: tuple[int, ...] = field(default=(6, 7, 8, 9), init=False)
    transition_kernel = staticmethod(transition_into)
    observation_kernel = staticmethod(slip_state_observation_into)

    def __post_init__(self) -> None:
        if self.accel not in ("coriolis", "direct"):
            raise ConfigError(f"accel must be 'coriolis' or 'direct', got {self.accel!r}")
        owner = "SlipStateModel"
        config_flags(owner, camera=self.camera)        # ("no" appended the camera rows)
        for label in ("p0_diag", "r_diag", "q_diag"):  # (float() took True and "0.1")
            values = getattr(self, label)
            if values is None and label == "r_diag":
                continue
            if isinstance(values, (str, bytes)) or np.ndim(values) != 1:
                # (a number or None was a bare TypeError "object of type 'float' has no len()")
                raise ConfigError(f"{owner}.{label} needs a sequence of variances, one per "
                                  f"{'state' if label != 'r_diag' else 'measurement row'}, "
                                  f"got {values!r:.80}")
            config_numbers(owner, **indexed(label, values))
        names = ["omega_1", "omega_2", "omega_3", "ax", "ay", "wz", "yaw_imu", "delta_1",
                 "delta_2", "delta_3"]
        if self.camera:
            names += ["v_cx", "v_cy", "yaw_rate_c", "yaw_c"]
            object.__setattr__(self, "angle_rows", (6, 7, 8, 9, 13))
        object.__setattr__(self, "measurement_names", tuple(names))
        r = self.r_diag if self.r_diag is not None else (
            THESIS_R_CH4 + (CAMERA_R if self.camera else ()))
        if len(r) != len(names) or not all(0.0 < float(v) < np.inf for v in r):
            raise ConfigError(f"r_diag needs {len(names)} finite values > 0, got {r}")
        object.__setattr__(self, "r_diag", tuple(float(v) for v in r))
        for label, values in (("p0_diag", self.p0_diag), ("q_diag", self.q_diag)):
            if len(values) != 14 or not all(0.0 <= float(v) < np.inf for v in values):
                raise ConfigError(f"{label} needs 14 finite values >= 0, got {values}")
            if not isinstance(values, tuple):   # the caller's array or list, frozen
                object.__setattr__(self, label, tuple(float(v) for v in values))
        if self.q_per not in ("step", "second"):
            raise ConfigError(f"q_per must be 'step' or 'second', got {self.q_per!r}")
        super().__post_init__()

    @property
    def equation_params(self) -> AgriMaRoEquationParams:
        """Constants of the model's equations (:mod:`terrain.estimation.equations.agrimaro`):
        the vehicle geometry, body-frame Coriolis signs, accelerometer and camera options."""
        return AgriMaRoEquationParams.from_vehicle(
            self.vehicle, coriolis_sign=1.0, accel_direct=self.accel == "direct",
            camera=self.camera, slip_floor=SLIP_FLOOR)

    @property
    def sensor_rows(self) -> Mapping[str, tuple[int, ...]]:
        """Sensor -> measurement rows (same sensors and columns as the 12-state model)."""
        rows = {"omega": (0, 1, 2), "imu": (3, 4, 5, 6), "steer": (7, 8, 9)}
        if self.camera:
            rows["cam"] = (10, 11, 12, 13)
        return rows

    def Q(self, dt: float) -> np.ndarray:
        """Process noise of one step, ``diag(q)`` or ``diag(q) dt`` (eq. 4.41).

        Parameters
        ----------
        dt : float
            Step, s (> 0).

        Returns
        -------
        ndarray, shape (14, 14)
        """
        return diagonal_process_noise(self.q_diag, self.q_per, dt)

    @property
    def R_diag(self) -> np.ndarray:
        """Measurement noise variances, shape (m,)."""
        return np.asarray(self.r_diag, dtype=float)

    @property
    def x0(self) -> np.ndarray:
        """Zero start (eq. 4.37), shape (14,)."""
        return np.zeros(14)

    @property
    def P0(self) -> np.ndarray:
        """Eq. 4.38, shape (14, 14)."""
        return np.diag(np.asarray(self.p0_diag, dtype=float))


#: Columns of each sensor (same as the 12-state model; the ``imu`` sensor still carries
#: ``ax, ay, wz, yaw_imu``).
SLIP_STATE_SENSOR_COLUMNS = SENSOR_COLUMNS


def noise_derived_slip_state_model(*, accel_std_m_s2: float = 0.8, omega_std_rad_s: float = 0.2,
                                   slip_psd: float = 0.05, camera: bool = True,
                                   vehicle: AgriMaRoParams = AGRIMARO) -> SlipStateModel:
    """The slip-in-state design with the final sensor set and a noise-derived tuning.

    Camera rows and direct accelerometer rows (as in eq. 6.6), the same noise levels as
    :func:`terrain.estimation.agrimaro.noise_derived_settings`; with the slip in the state
    the wheel rows only carry the encoder noise and lag (``omega_std_rad_s``), and each slip
    is a random walk of density ``slip_psd``.

    Parameters
    ----------
    accel_std_m_s2 : float
        Accelerometer noise, m/s^2.
    omega_std_rad_s : float
        Wheel-encoder noise, rad/s.
    slip_psd : float
        Random-walk density of each slip, 1/s.
    camera : bool
        Include the camera rows.
    vehicle : AgriMaRoParams
        Geometry.

    Returns
    -------
    SlipStateModel

    Raises
    ------
    ConfigError
        ``accel_std_m_s2`` or ``omega_std_rad_s`` not a finite number > 0 (a negative one
        was squared into a valid-looking variance), or a ``slip_psd`` that
        :class:`SlipStateModel` refuses.
    """
    config_positive("noise_derived_slip_state_model", accel_std_m_s2=accel_std_m_s2,
                    omega_std_rad_s=omega_std_rad_s)
    r = (omega_std_rad_s ** 2,) * 3 + (accel_std_m_s2 ** 2,) * 2 + (0.005 ** 2, 0.05 ** 2) + (
        5e-4 ** 2,) * 3 + ((1e-4, 1e-4, 1e-4, 4e-6) if camera else ())
    q = (1e-5, 1e-5, 1e-7, 1e-3, 1e-3, 4.0, 400.0, 400.0, slip_psd, slip_psd, slip_psd,
         1e-2, 1e-2, 1e-2)
    p0 = (1e-5,) * 8 + (1e-2,) * 3 + (1.5e-4,) * 3
    return SlipStateModel(vehicle=vehicle, accel="direct", camera=camera, p0_diag=p0,
                          r_diag=r, q_diag=q, q_per="second")
