"""AgriMaRo 12-state EKF: the final design of seed ``001_59da564c4b2d6a48.txt`` ch. 6.1.

State (eq. 6.1), body frame x forward, y left, z up; world frame of the start pose::

    x = [X, Y, yaw, v_bx, v_by, yaw_rate, a_bx, a_by, delta_1, delta_2, delta_3, b_g]
         m  m  rad  m/s   m/s   rad/s     m/s^2 m/s^2 rad      rad      rad      rad/s

Process model (eqs. 6.2, 4.30-4.35): pose integrated with the body velocities, velocities with
the body accelerations, everything else a random walk.

**Coriolis convention (settled here).** The accelerometer measures the inertial acceleration
expressed in body axes (gravity removed on level ground), ``a = dv/dt|_body + Omega x v``
(eq. 4.23), i.e. ``a_bx = dv_bx/dt - yaw_rate v_by`` and ``a_by = dv_by/dt + yaw_rate v_bx``
(eqs. 4.24-4.25). With ``a_b`` in the state measured directly by the accelerometer (eq. 6.6,
rows 4-5) the velocity update must therefore be

    v_bx' = v_bx + T (a_bx + yaw_rate v_by)        (eq. 4.33)
    v_by' = v_by + T (a_by - yaw_rate v_bx)        (eq. 4.34)

Eq. 6.2 prints the opposite signs (``a_bx - yaw_rate v_by``, ``a_by + yaw_rate v_bx``), which
would double the centripetal term instead of cancelling it: in a steady turn (``dv/dt = 0``,
``a_by = yaw_rate v_bx``) eq. 6.2 predicts ``dv_by/dt = 2 yaw_rate v_bx``. The simulator
(:mod:`terrain.sim.dynamics`, ``accel_body``) uses eq. 4.23 and the IMU outputs it, and the
tests show that the one-step prediction error against simulated ground truth is at round-off
level with the eq. 4.33-4.34 signs and of the order ``2 T yaw_rate v`` with the eq. 6.2 signs
(``coriolis="eq6.2"`` reproduces them for that comparison).

Measurements (eqs. 6.3 and 6.6), 14 rows in four sensor groups::

    omega  omega_1..3     wheel speeds, ((v_bx - r y_i) cos d_i + (v_by + r x_i) sin d_i) / R_w
    imu    ax, ay         a_bx, a_by
           wz             yaw_rate + b_g                                           (eq. 4.47)
           yaw_imu        yaw (the integral of wz: the IMU has no magnetometer, ch. 4.5.3)
    steer  delta_1..3     delta_i
    cam    v_cx, v_cy     T265 velocity at its mount, robot axes: v_b + Omega x d_cam
                          = (v_bx - yaw_rate d_y, v_by + yaw_rate d_x)             (eq. 6.6)
           yaw_rate_c     yaw_rate
           yaw_c          yaw

The lever arm is inside h(x) (ch. 6.1), so the filter correlates yaw-rate errors with the
camera velocity. Note that eq. 6.5 prints ``v_cam = v_B - omega x r_cam`` while eq. 6.6 (and
eq. 5.4, ``v_robot = v_camera - omega x d_cam``) give ``v_cam = v_B + omega x d_cam``; eq. 6.6
is implemented (it is what the simulator's camera outputs).

Defaults: P0 of eq. 6.9, R of eq. 6.13 and Q of eq. 6.14 (the final tuning; the thesis gives
Q per filter step and does not state its filter rate, so Q is applied per step of the run
grid), EMA pre-filter of eq. 6.12 with the ch. 7.2.2 changes (camera alpha = 0.2, encoders
unfiltered). :func:`noise_derived_settings` gives a tuning derived from sensor noise levels
and process noise densities instead (used for the NEES / NIS consistency tests).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from types import MappingProxyType
from typing import TYPE_CHECKING, Mapping

import numpy as np
from scipy.integrate import cumulative_trapezoid

from terrain.errors import (ConfigError, DataFormatError, config_numbers, config_positive,
                            duplicated, indexed)
from terrain.estimation.ekf import Gate
from terrain.estimation.equations.agrimaro import (AgriMaRoEquationParams, observation_into,
                                                   transition_into)
from terrain.estimation.model import KernelModel, StateSpaceModel, diagonal_process_noise
from terrain.estimation.prefilter import ema_filter
from terrain.estimation.result import EKFResult
from terrain.estimation.runner import (SensorSamples, check_rate_hz, check_sensor_names,
                                       check_time_offsets, clock_rate_hz, make_grid,
                                       run_filter, stream_samples)
from terrain.run import TIME, Run
from terrain.vehicles import get_vehicle
from terrain.vehicles.swerve import AGRIMARO, AgriMaRoParams

if TYPE_CHECKING:
    from terrain.estimation.fast import FastKernel

STATE_NAMES: tuple[str, ...] = ("x", "y", "yaw", "v_bx", "v_by", "yaw_rate", "a_bx", "a_by",
                                "delta_1", "delta_2", "delta_3", "gyro_bias")
MEASUREMENT_NAMES: tuple[str, ...] = ("omega_1", "omega_2", "omega_3", "ax", "ay", "wz",
                                      "yaw_imu", "delta_1", "delta_2", "delta_3", "v_cx",
                                      "v_cy", "yaw_rate_c", "yaw_c")
#: Rows of :data:`MEASUREMENT_NAMES` that are angles (``yaw_imu``, the steering encoders
#: ``delta_1..3``, absolute encoders read within one turn, and ``yaw_c``), rad: wrapped in the
#: innovation and averaged unwrapped by the pre-filter (:func:`ema_filter`).
ANGLE_ROWS: tuple[int, ...] = (6, 7, 8, 9, 13)
SENSOR_ROWS: Mapping[str, tuple[int, ...]] = MappingProxyType(
    {"omega": (0, 1, 2), "imu": (3, 4, 5, 6), "steer": (7, 8, 9), "cam": (10, 11, 12, 13)})
#: Columns of each sensor in a :class:`~terrain.run.Run` (stream, columns); ``yaw_imu`` is
#: derived from ``wz`` by :func:`agrimaro_samples`.
SENSOR_COLUMNS: Mapping[str, tuple[str, tuple[str, ...]]] = MappingProxyType({
    "omega": ("omega", ("omega_1", "omega_2", "omega_3")),
    "imu": ("imu", ("ax", "ay", "wz", "yaw_imu")),
    "steer": ("steer", ("delta_1", "delta_2", "delta_3")),
    "cam": ("cam", ("v_cx", "v_cy", "yaw_rate_c", "yaw_c")),
})

#: Eq. 6.9 (P0), eq. 6.13 (R) and eq. 6.14 (Q), in the order of STATE_NAMES /
#: MEASUREMENT_NAMES.
THESIS_P0 = (1e-5, 1e-5, 1e-5, 1e-5, 1e-5, 1e-5, 1e-5, 1e-5, 1.5e-4, 1.5e-4, 1.5e-4, 1e-4)
THESIS_R = (0.05, 0.05, 0.05, 0.001, 0.001, 0.001, 0.01, 1e-5, 1e-5, 1e-5, 5e-5, 5e-5, 0.001,
            5e-4)
THESIS_Q = (0.5, 0.5, 0.08, 0.08, 0.08, 0.15, 0.12, 0.12, 0.002, 0.002, 0.002, 0.002)
#: Pre-filter of eq. 6.12 (alpha 0.1) with the ch. 7.2.2 changes: encoders unfiltered, camera
#: alpha 0.2.
THESIS_EMA: tuple[tuple[str, float], ...] = (("omega", 0.0), ("imu", 0.1), ("steer", 0.1),
                                             ("cam", 0.2))
CORIOLIS_CONVENTIONS = ("body", "eq6.2")


@dataclass(frozen=True)
class AgriMaRoEKFSettings:
    """Tuning of the AgriMaRo EKF.

    Parameters
    ----------
    p0_diag : tuple of 12 float
        Initial variances (SI units squared), default eq. 6.9.
    r_diag : tuple of 14 float
        Measurement noise variances, default eq. 6.13.
    q_diag : tuple of 12 float
        Process noise variances, default eq. 6.14.
    q_per : {"step", "second"}
        ``step``: ``q_diag`` is added at every filter step (the thesis's discrete tuning);
        ``second``: ``q_diag`` is a density and ``Q = diag(q) dt``.
    coriolis : {"body", "eq6.2"}
        Sign convention of the velocity update (see the module docstring); ``body`` is
        correct, ``eq6.2`` reproduces the printed eq. 6.2 for comparison.
    ema_alpha : tuple of (sensor, alpha)
        EMA pre-filter coefficient per sensor (eq. 6.12); missing sensors are not filtered.
    name : str
        Label of the tuning.

    Raises
    ------
    ConfigError
        Wrong number of values, a value that is not a real number (text, a boolean),
        non-finite or negative variances (``r_diag`` must be > 0), unknown ``q_per`` /
        ``coriolis``, ``ema_alpha`` not a sequence of ``(sensor, alpha)`` pairs (a dict
        included) or naming a sensor twice, or an EMA entry with an unknown sensor or an
        alpha outside [0, 1).
    """

    p0_diag: tuple[float, ...] = THESIS_P0
    r_diag: tuple[float, ...] = THESIS_R
    q_diag: tuple[float, ...] = THESIS_Q
    q_per: str = "step"
    coriolis: str = "body"
    ema_alpha: tuple[tuple[str, float], ...] = THESIS_EMA
    name: str = "thesis"

    def __post_init__(self) -> None:
        owner = "AgriMaRoEKFSettings"
        for label, values, size in (("p0_diag", self.p0_diag, 12), ("r_diag", self.r_diag, 14),
                                    ("q_diag", self.q_diag, 12)):
            if np.ndim(values) == 1:     # (float() took True as 1 and the text "0.5")
                config_numbers(owner, **indexed(label, values))
            v = np.asarray(values, dtype=float)
            if v.shape != (size,) or not np.isfinite(v).all():
                raise ConfigError(f"{label} needs {size} finite values, got {values}")
            if label == "r_diag" and (v <= 0).any():
                raise ConfigError(f"{label} must be > 0 (R positive definite), got {values}")
            if (v < 0).any():
                raise ConfigError(f"{label} must be >= 0, got {values}")
            if not isinstance(values, tuple):   # the caller's array or list, frozen
                object.__setattr__(self, label, tuple(v.tolist()))
        if self.q_per not in ("step", "second"):
            raise ConfigError(f"q_per must be 'step' or 'second', got {self.q_per!r}")
        if self.coriolis not in CORIOLIS_CONVENTIONS:
            raise ConfigError(f"unknown coriolis convention {self.coriolis!r}; valid: "
                              f"{', '.join(CORIOLIS_CONVENTIONS)}")
        # (a dict, one bare pair or a triple was a bare ValueError 'too many values to unpack')
        pairs = (not isinstance(self.ema_alpha, (str, bytes, Mapping))
                 and all(isinstance(e, (tuple, list)) and len(e) == 2 for e in self.ema_alpha))
        if not pairs:
            raise ConfigError(f"{owner}.ema_alpha must be (sensor, alpha) pairs, e.g. "
                              f"(('cam', 0.2),), got {self.ema_alpha!r}")
        for sensor, alpha in self.ema_alpha:
            config_numbers(owner, **{f"ema_alpha[{sensor!r}]": alpha})
            if not isinstance(sensor, str) or sensor not in SENSOR_ROWS \
                    or not 0.0 <= float(alpha) < 1.0:
                raise ConfigError(f"bad EMA entry ({sensor!r}, {alpha}); sensors "
                                  f"{list(SENSOR_ROWS)}, alpha in [0, 1)")
        if not (isinstance(self.ema_alpha, tuple)
                and all(isinstance(e, tuple) for e in self.ema_alpha)):
            # the caller's lists, frozen (an alpha written after the checks reached the EMA)
            object.__setattr__(self, "ema_alpha", tuple(tuple(e) for e in self.ema_alpha))
        repeated = duplicated([sensor for sensor, _ in self.ema_alpha])
        if repeated:    # (the last alpha of a sensor was used without a word)
            raise ConfigError(f"{owner}.ema_alpha gives sensor(s) {repeated} more than once "
                              f"(one alpha per sensor), got {self.ema_alpha!r}")

    def alpha(self, sensor: str) -> float:
        """EMA coefficient of one sensor (eq. 6.12).

        Parameters
        ----------
        sensor : str
            A key of :data:`SENSOR_ROWS`.

        Returns
        -------
        float
            In [0, 1); 0 (no filtering) when the sensor is not listed.
        """
        return float(dict(self.ema_alpha).get(sensor, 0.0))


def noise_derived_settings(*, accel_std_m_s2: float = 0.8, gyro_std_rad_s: float = 0.005,
                           cam_vel_std_m_s: float = 0.01, cam_yaw_rate_std_rad_s: float = 0.01,
                           cam_yaw_std_rad: float = 0.002, steer_std_rad: float = 5e-4,
                           omega_std_rad_s: float = 2.5, imu_yaw_std_rad: float = 0.05,
                           jerk_psd: float = 400.0, yaw_accel_psd: float = 4.0,
                           velocity_psd: float = 1e-3, position_psd: float = 1e-5,
                           yaw_psd: float = 1e-7,
                           steer_rate_psd: float = 1e-2, bias_psd: float = 1e-8,
                           p0_diag: tuple[float, ...] = THESIS_P0,
                           coriolis: str = "body") -> AgriMaRoEKFSettings:
    """A tuning derived from sensor noise levels and process noise densities.

    ``R`` holds the variance of each sensor; ``Q = diag(q) dt`` with white-noise densities
    (jerk for ``a_b``, angular acceleration for the yaw rate, steering rate...). The wheel
    rows carry the unmodelled slip: 0.15 (the largest steady slip of the terrain catalogue)
    times 6 rad/s (1 m/s on the 0.165 m wheel) is 0.9 rad/s, but slip is a slowly varying
    error, not white noise, so averaging many wheel samples does not reduce it; with
    0.9 rad/s the filter is overconfident during camera outages (mean NEES 26 for 12 s grass
    runs with an outage), the default 2.5 rad/s keeps the mean NEES below the state dimension
    (conservative: below the lower bound of its time average on the thesis's straight runs,
    docs/estimation_validation.md). The zero-slip wheel model of eq. 6.6 then hardly pulls the
    velocity towards the rim speed. No EMA pre-filter (it colours the noise). Used for the
    consistency tests.

    Parameters
    ----------
    accel_std_m_s2, gyro_std_rad_s, cam_vel_std_m_s, cam_yaw_rate_std_rad_s,
    cam_yaw_std_rad, steer_std_rad, omega_std_rad_s, imu_yaw_std_rad : float
        Measurement noise standard deviations (SI units).
    jerk_psd, yaw_accel_psd, velocity_psd, position_psd, yaw_psd, steer_rate_psd, bias_psd : float
        Process noise densities ((unit/s)^2 s).
    p0_diag : tuple of 12 float
        Initial variances (SI units squared), default eq. 6.9.
    coriolis : {"body", "eq6.2"}
        Coriolis sign convention (see the module docstring).

    Returns
    -------
    AgriMaRoEKFSettings

    Raises
    ------
    ConfigError
        A standard deviation not a finite number > 0 (a negative one was squared into a
        valid-looking variance), or a density or ``p0_diag`` that
        :class:`AgriMaRoEKFSettings` refuses.
    """
    config_positive("noise_derived_settings", accel_std_m_s2=accel_std_m_s2,
                    gyro_std_rad_s=gyro_std_rad_s, cam_vel_std_m_s=cam_vel_std_m_s,
                    cam_yaw_rate_std_rad_s=cam_yaw_rate_std_rad_s,
                    cam_yaw_std_rad=cam_yaw_std_rad, steer_std_rad=steer_std_rad,
                    omega_std_rad_s=omega_std_rad_s, imu_yaw_std_rad=imu_yaw_std_rad)
    r = (omega_std_rad_s ** 2,) * 3 + (accel_std_m_s2 ** 2,) * 2 + (
        gyro_std_rad_s ** 2, imu_yaw_std_rad ** 2) + (steer_std_rad ** 2,) * 3 + (
        cam_vel_std_m_s ** 2,) * 2 + (cam_yaw_rate_std_rad_s ** 2, cam_yaw_std_rad ** 2)
    q = (position_psd, position_psd, yaw_psd, velocity_psd, velocity_psd, yaw_accel_psd, jerk_psd,
         jerk_psd, steer_rate_psd, steer_rate_psd, steer_rate_psd, bias_psd)
    return AgriMaRoEKFSettings(p0_diag=tuple(p0_diag), r_diag=r, q_diag=q, q_per="second",
                               coriolis=coriolis, ema_alpha=(), name="noise-derived")


@dataclass(frozen=True)
class AgriMaRoModel(KernelModel):
    """The 12-state / 14-measurement model of seed ``001_59da564c4b2d6a48.txt`` ch. 6.1
    (eqs. 6.1-6.6); its equations are :mod:`terrain.estimation.equations.agrimaro`.

    Parameters
    ----------
    vehicle : AgriMaRoParams
        Wheel positions ``d_i`` (ch. 7.2), rolling radius and camera lever arm ``d_cam``
        (ch. 5.2.3).
    settings : AgriMaRoEKFSettings
        Tuning (P0, R, Q, Coriolis convention, pre-filter).

    Attributes
    ----------
    state_names : tuple of str
        :data:`STATE_NAMES` (12).
    measurement_names : tuple of str
        :data:`MEASUREMENT_NAMES` (14).
    angle_rows : tuple of int
        Rows 6 (``yaw_imu``) and 13 (``yaw_c``), wrapped in the innovation.
    """

    vehicle: AgriMaRoParams = AGRIMARO
    settings: AgriMaRoEKFSettings = field(default_factory=AgriMaRoEKFSettings)
    state_names: tuple[str, ...] = field(default=STATE_NAMES, init=False)
    measurement_names: tuple[str, ...] = field(default=MEASUREMENT_NAMES, init=False)
    angle_rows: tuple[int, ...] = field(default=ANGLE_ROWS, init=False)
    transition_kernel = staticmethod(transition_into)
    observation_kernel = staticmethod(observation_into)

    @property
    def equation_params(self) -> AgriMaRoEquationParams:
        """Constants of the model's equations (:mod:`terrain.estimation.equations.agrimaro`):
        the vehicle geometry and the Coriolis sign of ``settings``."""
        return AgriMaRoEquationParams.from_vehicle(self.vehicle, coriolis_sign=self._sign)

    @property
    def sensor_rows(self) -> Mapping[str, tuple[int, ...]]:
        """Sensor -> measurement rows."""
        return SENSOR_ROWS

    @property
    def _sign(self) -> float:
        return 1.0 if self.settings.coriolis == "body" else -1.0

    def Q(self, dt: float) -> np.ndarray:
        """Process noise of one step: ``diag(q)`` per step or ``diag(q) dt`` (eq. 6.14).

        Parameters
        ----------
        dt : float
            Step, s (> 0).

        Returns
        -------
        ndarray, shape (12, 12)
        """
        return diagonal_process_noise(self.settings.q_diag, self.settings.q_per, dt)

    @property
    def R_diag(self) -> np.ndarray:
        """Measurement noise variances, shape (14,)."""
        return np.asarray(self.settings.r_diag, dtype=float)

    @property
    def x0(self) -> np.ndarray:
        """Zero start (eq. 6.7), shape (12,)."""
        return np.zeros(12)

    @property
    def P0(self) -> np.ndarray:
        """Initial covariance (eq. 6.9), shape (12, 12)."""
        return np.diag(np.asarray(self.settings.p0_diag, dtype=float))

    def fast_kernel(self) -> FastKernel | None:
        """This model's kernels for the compiled loop of :mod:`terrain.estimation.fast` (the
        same functions :meth:`transition` and :meth:`observation` call, with the ``Q`` of
        :meth:`Q`); None for subclasses, which may change them.

        Returns
        -------
        FastKernel or None
        """
        if type(self) is not AgriMaRoModel:
            return None
        return self.kernel_for_fast_loop(self.settings.q_diag, self.settings.q_per)


def agrimaro_samples(run: Run, settings: AgriMaRoEKFSettings = AgriMaRoEKFSettings(),
                     time_offsets_s: Mapping[str, float] | None = None,
                     vehicle: AgriMaRoParams = AGRIMARO) -> dict[str, SensorSamples]:
    """Sensor samples of an AgriMaRo run for :func:`~terrain.estimation.run_filter`.

    * ``omega``: stream ``omega`` (``omega_1..3``, rad/s); without it, wheels 1 and 2 from the
      ``wheels`` stream (``vel_l``/``vel_r`` divided by the wheel radius), wheel 3 missing;
    * ``imu``: ``ax, ay, wz`` and ``yaw_imu``, the trapezoidal integral of ``wz`` from the
      first IMU sample (the drifting yaw of a magnetometer-less IMU, seed 001 ch. 4.5.3);
      a non-finite ``wz`` is left out of the integral (the trapezoid spans the gap) and
      its sample's ``yaw_imu`` is NaN;
    * ``steer``: ``delta_1..3``; ``cam``: ``v_cx, v_cy, yaw_rate_c, yaw_c``.

    Missing streams are left out (the filter runs on the others). The EMA pre-filter of
    ``settings`` is applied per sensor (eq. 6.12), then ``time_offsets_s[sensor]`` is subtracted
    from that sensor's timestamps (lag compensation, see :mod:`terrain.slip`).

    Parameters
    ----------
    run : Run
        AgriMaRo run (streams ``imu`` and any of ``omega``/``wheels``, ``steer``, ``cam``).
    settings : AgriMaRoEKFSettings
        Its ``ema_alpha`` sets the pre-filter.
    time_offsets_s : Mapping[str, float], optional
        Sensor -> latency subtracted from its timestamps, s.
    vehicle : AgriMaRoParams
        Wheel radius for the ``wheels`` fallback, m.

    Returns
    -------
    dict
        Sensor name -> :class:`SensorSamples`.

    Raises
    ------
    DataFormatError
        The run has no IMU stream (the filter's clock); MissingColumnError (a
        DataFormatError) when a stream it reads lacks a column (run, stream and columns
        named).
    TimeStepError
        A stream's timestamps not finite and strictly increasing (run, stream and the first
        such sample named).
    ConfigError
        A key of ``time_offsets_s`` that is not a sensor of :data:`SENSOR_ROWS`, or a
        latency that is not a finite real number (a boolean, None, an array, NaN, inf;
        :func:`~terrain.estimation.runner.check_time_offsets`); a run whose ``vehicle`` is
        not the AgriMaRo (``husky``, ``tracked``: their ``wheels`` stream holds two sides,
        not wheels 1 and 2) or unknown.
    """
    if "imu" not in run.streams:
        raise DataFormatError("an AgriMaRo run needs an imu stream", run.source)
    offsets = check_time_offsets(time_offsets_s, SENSOR_ROWS)
    if not isinstance(get_vehicle(run.vehicle), AgriMaRoParams):
        # (a Husky's left and right sides were read as wheels 1 and 2 of the swerve drive,
        # on its axle line, and filtered without a word)
        raise ConfigError(f"run {run.run_id}: vehicle {run.vehicle!r} is not the AgriMaRo, "
                          "whose three steered wheels the AgriMaRo filter reads (a skid-steer "
                          "run's filter: terrain.estimation.skid_steer.estimate_skid_steer)")
    out: dict[str, SensorSamples] = {}
    for sensor, (stream, cols) in SENSOR_COLUMNS.items():
        frame = run.streams.get(stream)
        if frame is None and sensor == "omega" and "wheels" in run.streams:
            stream = "wheels"
            w = run.streams["wheels"]
            run.require_columns(stream, ("vel_l", "vel_r"))
            t = w[TIME].to_numpy(dtype=float)
            vals = np.column_stack([w["vel_l"].to_numpy(dtype=float) / vehicle.wheel_radius_m,
                                    w["vel_r"].to_numpy(dtype=float) / vehicle.wheel_radius_m,
                                    np.full(len(w), np.nan)])
        elif frame is None:
            continue
        else:
            run.require_columns(stream, [c for c in cols if c != "yaw_imu"])
            t = frame[TIME].to_numpy(dtype=float)
            if sensor == "imu":
                wz = frame["wz"].to_numpy(dtype=float)
                # a non-finite wz is left out of the integral (it spans the gap), and its
                # own yaw_imu is NaN like its wz (the filter skips and counts the sample)
                ok = np.isfinite(wz)
                yaw = np.full(wz.shape, np.nan)
                if ok.any():
                    yaw[ok] = cumulative_trapezoid(wz[ok], t[ok], initial=0.0)
                vals = np.column_stack([frame["ax"].to_numpy(float), frame["ay"].to_numpy(float),
                                        wz, yaw])
            else:
                vals = frame[list(cols)].to_numpy(dtype=float)
        angles = [j for j, name in enumerate(SENSOR_COLUMNS[sensor][1])
                  if MEASUREMENT_NAMES.index(name) in ANGLE_ROWS]
        vals = ema_filter(vals, settings.alpha(sensor), angles)
        out[sensor] = stream_samples(run.run_id, stream, t - float(offsets.get(sensor, 0.0)),
                                     vals)
    return out


def estimate_agrimaro(run: Run, settings: AgriMaRoEKFSettings = AgriMaRoEKFSettings(), *,
                      rate_hz: float | None = None, gate: Gate | None = None,
                      time_offsets_s: Mapping[str, float] | None = None,
                      vehicle: AgriMaRoParams = AGRIMARO, sensors: tuple[str, ...] | None = None,
                      store_covariance: bool = False,
                      model: StateSpaceModel | None = None, engine: str = "auto") -> EKFResult:
    """Run the AgriMaRo EKF over a run.

    Parameters
    ----------
    run : Run
        AgriMaRo run with an ``imu`` stream and any of ``omega``/``wheels``, ``steer``,
        ``cam``.
    settings : AgriMaRoEKFSettings
        Tuning and pre-filter (default: the thesis's, eqs. 6.9, 6.12-6.14).
    rate_hz : float, optional
        Filter rate, Hz (default: the IMU rate). The grid spans the IMU stream, its
        timestamps less ``time_offsets_s["imu"]``.
    gate : Gate, optional
        Per-sensor chi-square gating.
    time_offsets_s : Mapping[str, float], optional
        Per-sensor latency subtracted from its timestamps, s.
    vehicle : AgriMaRoParams
        Geometry (seed 001 ch. 7.2, 5.2.3).
    sensors : tuple of str, optional
        Use only these sensors, keys of the model's ``sensor_rows`` (e.g. to simulate a
        camera outage).
    store_covariance : bool
        Keep full covariances (NEES).
    model : StateSpaceModel, optional
        Another model over the same sensors (e.g.
        :class:`~terrain.estimation.slip_state.SlipStateModel`); default
        ``AgriMaRoModel(vehicle, settings)``. ``settings`` still sets the pre-filter.
    engine : {"auto", "numba", "numpy"}
        Run loop of :func:`~terrain.estimation.run_filter` (``auto``: compiled when the model
        has a kernel, as ``AgriMaRoModel`` does).

    Returns
    -------
    EKFResult
        ``meta`` records the settings name, the Coriolis convention, EMA and offsets.

    Raises
    ------
    DataFormatError
        No IMU stream or one of fewer than 2 samples, or a stream lacks a column
        (MissingColumnError); the run and the stream named.
    TimeStepError
        A stream's timestamps not finite and strictly increasing (run and stream named).
    ConfigError, ShapeError, CovarianceError
        ``rate_hz`` outside ``[MIN_RATE_HZ, MAX_RATE_HZ]`` (:func:`~terrain.estimation.runner.
        check_rate_hz`); a name in ``sensors`` or ``time_offsets_s`` that is not a sensor of
        the model (:func:`~terrain.estimation.runner.check_sensor_names`), or a latency that
        is not a real number; a run whose ``vehicle`` is not the AgriMaRo
        (:func:`agrimaro_samples`); from
        :func:`~terrain.estimation.run_filter` (bad engine, shapes, or an innovation
        covariance that is not positive definite).
    """
    model = model if model is not None else AgriMaRoModel(vehicle=vehicle, settings=settings)
    if sensors is not None:
        check_sensor_names("sensors", sensors, model.sensor_rows)
    samples = agrimaro_samples(run, settings, time_offsets_s, vehicle)
    samples = {k: v for k, v in samples.items()
               if k in model.sensor_rows and (sensors is None or k in sensors)}
    t_imu = run.streams["imu"][TIME].to_numpy(dtype=float)
    if t_imu.size < 2:
        raise DataFormatError(f"run {run.run_id}: stream 'imu' has {t_imu.size} "
                              f"sample{'' if t_imu.size == 1 else 's'}; the filter's clock "
                              "needs 2 or more", run.source)
    rate = check_rate_hz(rate_hz)
    rate = clock_rate_hz(t_imu) if rate is None else rate
    # the IMU stream as the filter reads it, its latency subtracted (the recorded times put
    # the first corrected samples before the grid, counted outside, and ran on past the last)
    t_imu = t_imu - float(dict(time_offsets_s or {}).get("imu", 0.0))
    grid = make_grid(float(t_imu[0]), float(t_imu[-1]), rate)
    result = run_filter(model, grid, samples, gate=gate, store_covariance=store_covariance,
                        engine=engine)
    result.meta.update(model=type(model).__name__, settings=settings.name,
                       coriolis=settings.coriolis, ema_alpha=dict(settings.ema_alpha),
                       time_offsets_s=dict(time_offsets_s or {}))
    return result
