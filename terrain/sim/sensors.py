"""Sensor models: each stream sampled at its own rate from the physics ground truth.

All functions are pure: they take the :class:`~terrain.sim.dynamics.PhysicsResult`, settings
and a :class:`numpy.random.Generator`, and return arrays.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np
from scipy.signal import lfilter

from terrain.errors import ConfigError, config_numbers, config_positive
from terrain.run import step_index
from terrain.terramechanics.resistance import G_M_S2
from terrain.vehicles.common import wrap_angle

#: sampling-rate fields of :class:`SensorSettings`, Hz
RATE_FIELDS = ("imu_rate_hz", "wheel_rate_hz", "steer_rate_hz", "cam_rate_hz", "truth_rate_hz")


@dataclass(frozen=True)
class SensorSettings:
    """Rates and noise levels of the simulated sensors.

    Parameters
    ----------
    imu_rate_hz, wheel_rate_hz, steer_rate_hz, cam_rate_hz, truth_rate_hz : float
        Sampling rates, Hz. Husky defaults follow borealtc: IMU 100 Hz; wheels 6.5 Hz
        (all 55 BorealTC ``pro_`` files, ``/work/shared/data/borealtc``, step by
        ``1 / 6.5 = 0.153846 s``: median step 0.15384615 s in every file; until 2026-11-30
        the default was ``1 / 0.1538 s = 6.502 Hz``). The AgriMaRo's steering (50 Hz) and
        camera (30 Hz) rates are ASSUMED: seed 001 gives none.
    gyro_noise_rad_s : float
        White noise std of each gyro axis per sample, rad/s (0.005 ASSUMED: no datasheet of
        the robots' IMUs is among the sources, nor are the noise levels below).
    accel_noise_m_s2 : float
        White noise std of each accelerometer axis per sample, m/s^2 (0.05 ASSUMED).
    accel_bias_std_m_s2 : float
        Std of the constant per-run accelerometer bias, m/s^2 (0.02 ASSUMED; the z gyro has
        no baseline bias: ``gyro_bias`` is a named effect).
    vibration_bandwidth_hz : float
        Corner frequency of the first-order filter shaping terrain vibration, Hz (15
        ASSUMED); 0 turns the vibration off (pole 1, scale ``sqrt(1 - pole^2) = 0``).
    current_noise_a : float
        White noise std of the motor current sensor, A (0.08 ASSUMED).
    current_quantum_a, speed_quantum_m_s : float
        Resolution of reported current (A) and wheel rim speed (m/s); 0: no rounding of the
        current, while a speed quantum of 0 switches the wheel speed to the motor encoder's
        count rate per physics step (:func:`encoder_count_rate`, the vehicle's
        ``encoder_counts_per_rev``: the AgriMaRo's default), in the batch model and the
        closed loop's online sensors alike.
    steer_quantum_rad : float
        Steering encoder resolution (12-bit absolute encoder ASSUMED), rad.
    cam_noise_m_s, cam_yaw_rate_noise_rad_s, cam_yaw_noise_rad : float
        T265 velocity (m/s), yaw-rate (rad/s) and yaw (rad) noise std (0.01, 0.01, 0.002
        ASSUMED).
    cam_outage_rate_hz : float
        Rate of visual-odometry outages (Poisson), 1/s; each lasts 0.5-2 s (rows dropped)
        (one a minute and the durations ASSUMED).

    Raises
    ------
    ConfigError
        A rate not finite and > 0, another setting not finite and >= 0, or a setting that
        is not a real number (text, None, a boolean).
    """

    imu_rate_hz: float = 100.0
    wheel_rate_hz: float = 6.5
    steer_rate_hz: float = 50.0
    cam_rate_hz: float = 30.0
    truth_rate_hz: float = 100.0
    gyro_noise_rad_s: float = 0.005
    accel_noise_m_s2: float = 0.05
    accel_bias_std_m_s2: float = 0.02
    vibration_bandwidth_hz: float = 15.0
    current_noise_a: float = 0.08
    current_quantum_a: float = 0.01
    speed_quantum_m_s: float = 0.2 / 25.4
    steer_quantum_rad: float = 2.0 * np.pi / 4096
    cam_noise_m_s: float = 0.01
    cam_yaw_rate_noise_rad_s: float = 0.01
    cam_yaw_noise_rad: float = 0.002
    cam_outage_rate_hz: float = 1.0 / 60.0

    def __post_init__(self) -> None:
        """Refuse a rate that is not finite and > 0 or a noise level, resolution or outage
        rate that is not finite and >= 0 (:class:`~terrain.errors.ConfigError` naming the
        field)."""
        config_numbers("SensorSettings", **{f.name: getattr(self, f.name) for f in fields(self)})
        for name in RATE_FIELDS:
            value = float(getattr(self, name))
            if not (math.isfinite(value) and value > 0):
                raise ConfigError(f"sensor setting {name} must be a finite rate > 0 Hz, "
                                  f"got {getattr(self, name)}")
        for f in fields(self):
            if f.name in RATE_FIELDS:
                continue
            value = float(getattr(self, f.name))
            if not (math.isfinite(value) and value >= 0):
                raise ConfigError(f"sensor setting {f.name} must be finite and >= 0, got "
                                  f"{getattr(self, f.name)}")


def sample_times(duration_s: float, rate_hz: float) -> np.ndarray:
    """Sample times ``0, 1/rate, ...`` up to ``duration_s``.

    Parameters
    ----------
    duration_s : float
        Last time (inclusive, within 1e-9 s), s (finite, >= 0).
    rate_hz : float
        Sampling rate, Hz (> 0).

    Returns
    -------
    ndarray, shape (n,)
        Times, s.

    Raises
    ------
    ConfigError
        ``rate_hz`` not a finite rate > 0 (0 was a ZeroDivisionError), or ``duration_s``
        not a finite time >= 0 (NaN raised NumPy's bare ValueError, a negative one gave no
        sample).
    """
    config_positive("sample_times", rate_hz=rate_hz)
    config_positive("sample_times", allow_zero=True, duration_s=duration_s)
    return np.arange(0.0, duration_s + 1e-9, 1.0 / rate_hz)


def physics_step_index(t_phys_s: np.ndarray, t_s: np.ndarray) -> np.ndarray:
    """Physics step each sample time reads: the first step at or after it.

    A sample at ``t`` takes the state of the first physics step whose time is ``>= t``,
    within :func:`terrain.run.clock_slack` (1 ns on the simulator's clocks, which start at
    0 s; so a sample on the grid reads that step despite rounding); samples past
    the last step read the last one (:func:`terrain.run.step_index`, clipped, the rule the
    filters place their measurements by). The ground truth, the terrain labels and the
    closed-loop logs place their samples by it (the open-loop simulator's sensor streams
    instead interpolate the physics linearly at their nominal times, :func:`interp_columns`).

    Parameters
    ----------
    t_phys_s : ndarray, shape (n,)
        Physics step times, s, increasing (``n >= 1``).
    t_s : ndarray, shape (m,)
        Sample times, s.

    Returns
    -------
    ndarray of int, shape (m,)
        Step index in ``0 .. n - 1``.
    """
    return step_index(t_phys_s, t_s, clip=True)


def interp_columns(t_new: np.ndarray, t: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Linear interpolation of each column of ``values`` at new times.

    Parameters
    ----------
    t_new : ndarray, shape (m,)
        Times to interpolate at, s.
    t : ndarray, shape (n,)
        Increasing times of ``values``, s.
    values : ndarray, shape (n,) or (n, k)
        Samples (any unit).

    Returns
    -------
    ndarray, shape (m, k)
        Interpolated samples (held constant outside ``t``).
    """
    v = values.reshape(len(t), -1)
    return np.column_stack([np.interp(t_new, t, v[:, j]) for j in range(v.shape[1])])


def vibration_pole(rate_hz: float, bandwidth_hz: float) -> float:
    """Pole of the first-order filter that shapes the terrain vibration.

    ``a = exp(-2 pi f_c / f_s)``: the discrete pole of a first-order low-pass with corner
    frequency ``f_c`` sampled at ``f_s``.

    Parameters
    ----------
    rate_hz : float
        Sampling rate ``f_s`` of the IMU, Hz (> 0).
    bandwidth_hz : float
        Corner frequency ``f_c`` (:attr:`SensorSettings.vibration_bandwidth_hz`), Hz
        (>= 0).

    Returns
    -------
    float
        Pole ``a`` in (0, 1]: 1 for ``f_c = 0`` (the vibration off: :func:`coloured_noise`
        scales its input by ``sqrt(1 - a^2) = 0``).

    Raises
    ------
    ConfigError
        ``rate_hz`` not a finite number > 0 (0 was a ZeroDivisionError) or ``bandwidth_hz``
        not a finite number >= 0 (a negative corner gave a pole above 1 and NaN noise from
        :func:`coloured_noise`, NaN a NaN pole); booleans and text refused.
    """
    config_positive("vibration_pole", rate_hz=rate_hz)
    config_positive("vibration_pole", allow_zero=True, bandwidth_hz=bandwidth_hz)
    return float(np.exp(-2.0 * np.pi * bandwidth_hz / rate_hz))


def coloured_noise(white: np.ndarray, pole: float, state: np.ndarray | None = None
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Unit-variance first-order low-pass noise from white noise, along axis 0.

    ``y_k = a y_(k-1) + sqrt(1 - a^2) w_k`` (stationary variance 1 for unit white noise
    ``w``), started from ``state`` (``y_(-1)``; zeros when None, as the batch model starts).
    The batch IMU filters a whole run at once; the online IMU of the closed loop calls it one
    sample at a time, carrying ``state``.

    Parameters
    ----------
    white : ndarray, shape (n, k)
        Standard normal draws, one row per IMU sample, one column per vibration axis.
    pole : float
        Filter pole ``a`` (:func:`vibration_pole`).
    state : ndarray, shape (k,), optional
        Previous output ``y_(-1)``; None: zeros.

    Returns
    -------
    y : ndarray, shape (n, k)
        Coloured noise, unit variance once stationary.
    last : ndarray, shape (k,)
        ``y`` of the last row (the state for the next call).
    """
    w = white * np.sqrt(1.0 - pole * pole)
    if state is None:
        y = lfilter([1.0], [1.0, -pole], w, axis=0)
    else:
        y, _ = lfilter([1.0], [1.0, -pole], w, axis=0, zi=pole * np.asarray(state)[None])
    return y, y[-1].copy()


def vibration_level(speed_m_s: np.ndarray, yaw_rate_rad_s: np.ndarray,
                    vib_speed_m_s: np.ndarray) -> np.ndarray:
    """Scale of the terrain vibration with the motion: ``sqrt(min(|v| + 0.3 |r|, 3) / v_ref)``.

    Parameters
    ----------
    speed_m_s : ndarray, shape (n,)
        Chassis speed ``|v|``, m/s.
    yaw_rate_rad_s : ndarray, shape (n,)
        Yaw rate ``r``, rad/s (turning on the spot shakes too).
    vib_speed_m_s : ndarray, shape (n,)
        Terrain's reference speed ``v_ref`` of its vibration levels
        (``TerrainParams.vib_speed_m_s``), m/s.

    Returns
    -------
    ndarray, shape (n,)
        Dimensionless level (1 at ``v_ref`` straight ahead; capped at ``3 m/s``).
    """
    return np.sqrt(np.minimum(speed_m_s + 0.3 * np.abs(yaw_rate_rad_s), 3.0) / vib_speed_m_s)


def vibration_signals(coloured: np.ndarray, level: np.ndarray, vib_gyro_rad_s: np.ndarray,
                      vib_accel_m_s2: np.ndarray) -> np.ndarray:
    """Terrain vibration added to the IMU axes ``wx, wy, ax, ay, az``.

    Each axis is its own unit coloured noise (:func:`coloured_noise`) times the terrain's
    vibration std (catalogue ``vib_gyro_rad_s`` for the gyro axes, ``vib_accel_m_s2`` for the
    accelerometer axes) times the motion's :func:`vibration_level`.

    Parameters
    ----------
    coloured : ndarray, shape (n, 5)
        Unit coloured noise of ``wx, wy, ax, ay, az``.
    level : ndarray, shape (n,)
        :func:`vibration_level`.
    vib_gyro_rad_s : ndarray, shape (n,)
        Terrain's gyro vibration std at ``v_ref``, rad/s.
    vib_accel_m_s2 : ndarray, shape (n,)
        Terrain's accelerometer vibration std at ``v_ref``, m/s^2.

    Returns
    -------
    ndarray, shape (n, 5)
        Vibration of ``wx, wy`` (rad/s) and ``ax, ay, az`` (m/s^2).
    """
    out = np.empty(coloured.shape)
    for j in range(2):
        out[:, j] = vib_gyro_rad_s * level * coloured[:, j]
    for j in range(2, 5):
        out[:, j] = vib_accel_m_s2 * level * coloured[:, j]
    return out


def gravity_specific_force(pitch_rad: np.ndarray, roll_rad: np.ndarray
                           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Gravity part of the accelerometer's specific force on an inclined plane, body axes.

    With inclination ``theta = hypot(pitch, roll)`` and ``psi = atan2(-roll, pitch)``, the
    uphill direction measured from x towards the right (the uphill direction in body axes is
    ``-psi``: right side down puts the uphill side on the left, +y, at ``psi = -pi/2``):
    ``g_x = g sin(theta) cos(psi)``, ``g_y = -g sin(theta) sin(psi)``, ``g_z = g cos(theta)``
    (x forward, y left, z up; pitch nose-up positive, roll right side down positive), so the
    accelerometer reads ``+g sin`` along the uphill direction.

    Parameters
    ----------
    pitch_rad : ndarray, shape (n,)
        Nose-up inclination, rad.
    roll_rad : ndarray, shape (n,)
        Right-side-down inclination, rad.

    Returns
    -------
    g_x, g_y, g_z : ndarray, shape (n,)
        m/s^2.
    """
    pitch_rad, roll_rad = np.asarray(pitch_rad, float), np.asarray(roll_rad, float)
    slope_sin = np.sin(np.hypot(pitch_rad, roll_rad))
    heading_up = np.arctan2(-roll_rad, pitch_rad) if np.any(slope_sin) \
        else np.zeros(np.shape(slope_sin))
    g_x = G_M_S2 * slope_sin * np.cos(heading_up)
    g_y = -G_M_S2 * slope_sin * np.sin(heading_up)
    g_z = G_M_S2 * np.cos(np.hypot(pitch_rad, roll_rad))
    return g_x, g_y, g_z


def first_order_filter(x: np.ndarray, dt_s: float, tau_s: float) -> np.ndarray:
    """Discrete first-order low-pass (EMA) along axis 0; identity when ``tau_s`` <= 0.

    ``y_k = a y_(k-1) + (1 - a) x_k``, ``a = exp(-dt / tau)``, started at ``y = x_0`` (the
    motor driver's speed filter, the ODrive effect of seed 001 ch. 7.2.2).

    Parameters
    ----------
    x : ndarray, shape (n, ...)
        Samples at a fixed step (any unit).
    dt_s : float
        Sample step, s.
    tau_s : float
        Time constant, s.

    Returns
    -------
    ndarray, shape (n, ...)
        Filtered samples.
    """
    if tau_s <= 0:
        return x
    a = np.exp(-dt_s / tau_s)
    zi = (x[:1] * a)
    y, _ = lfilter([1.0 - a], [1.0, -a], x, axis=0, zi=zi)
    return y


def imu(phys, terrains, settings: SensorSettings, gyro_bias_rad_s: float,
        rng: np.random.Generator, duration_s: float) -> tuple[np.ndarray, np.ndarray]:
    """IMU at the vehicle origin, body axes x forward, y left, z up.

    Gyro: ``wz = yaw_rate + gyro_bias + noise``; ``wx, wy``: terrain vibration + noise.
    Accelerometer: specific force ``a_body - g_body`` (gravity along the inclined plane and
    ``g cos(slope)`` on z, :func:`gravity_specific_force`), terrain vibration
    (:func:`vibration_signals`: std from the catalogue, scaled by :func:`vibration_level`,
    shaped by :func:`coloured_noise`), a constant per-run bias and white noise. The closed
    loop's online IMU (:class:`terrain.sim.closed_loop.OnlineSensors`) calls the same
    functions sample by sample.

    Parameters
    ----------
    phys : PhysicsResult
        Ground truth at the physics rate.
    terrains : tuple of TerrainParams
        Terrains of the run, indexed by ``phys.terrain_index`` (vibration levels).
    settings : SensorSettings
        IMU rate, noise levels and vibration bandwidth.
    gyro_bias_rad_s : float
        Planted ``gyro_bias`` effect, rad/s.
    rng : numpy.random.Generator
        Noise source of the run.
    duration_s : float
        Duration of the run, s.

    Returns
    -------
    t_s : ndarray, shape (n,)
    data : ndarray, shape (n, 6)
        ``wx, wy, wz`` (rad/s), ``ax, ay, az`` (m/s^2).
    """
    t = sample_times(duration_s, settings.imu_rate_hz)
    n = len(t)
    cols = np.column_stack([phys.twist, phys.accel_body, phys.pose[:, 2], phys.pitch,
                            phys.roll, phys.terrain_index])
    s = interp_columns(t, phys.t_s, cols)
    vx, vy, r, abx, aby, yaw, pitch, roll = (s[:, i] for i in range(8))
    ti = phys.terrain_index[physics_step_index(phys.t_s, t)]
    vib_a = np.array([terrains[i].vib_accel_m_s2 for i in range(len(terrains))])[ti]
    vib_g = np.array([terrains[i].vib_gyro_rad_s for i in range(len(terrains))])[ti]
    v_ref = np.array([terrains[i].vib_speed_m_s for i in range(len(terrains))])[ti]
    level = vibration_level(np.hypot(vx, vy), r, v_ref)
    vib, _ = coloured_noise(rng.standard_normal((n, 5)), vibration_pole(
        settings.imu_rate_hz, settings.vibration_bandwidth_hz))
    vib = vibration_signals(vib, level, vib_g, vib_a)
    g_x, g_y, g_z = gravity_specific_force(pitch, roll)
    bias = rng.normal(0.0, settings.accel_bias_std_m_s2, 3)
    noise = rng.standard_normal((n, 6))
    data = np.empty((n, 6))
    data[:, 0] = vib[:, 0] + settings.gyro_noise_rad_s * noise[:, 0]
    data[:, 1] = vib[:, 1] + settings.gyro_noise_rad_s * noise[:, 1]
    data[:, 2] = r + gyro_bias_rad_s + settings.gyro_noise_rad_s * noise[:, 2]
    data[:, 3] = abx + g_x + vib[:, 2] + bias[0] + settings.accel_noise_m_s2 * noise[:, 3]
    data[:, 4] = aby + g_y + vib[:, 3] + bias[1] + settings.accel_noise_m_s2 * noise[:, 4]
    data[:, 5] = g_z + vib[:, 4] + bias[2] + settings.accel_noise_m_s2 * noise[:, 5]
    return t, data


def steering_encoder(delta_rad: np.ndarray, quantum_rad: float) -> np.ndarray:
    """Reading of an absolute steering encoder: the module angle within one turn, quantised.

    The encoder (12-bit absolute ASSUMED, :class:`SensorSettings`) reads the shaft position
    in one turn, not the turns the module has made: ``wrap_angle(quantise(delta))``,
    in [-pi, pi) (:func:`terrain.vehicles.common.wrap_angle`, the project's convention;
    a reading already in that range is returned as it is, not re-rounded).
    Consumers that interpolate or average the angle unwrap it (the AgriMaRo filters wrap
    the steering innovations and the pre-filter averages them unwrapped,
    :data:`terrain.estimation.agrimaro.ANGLE_ROWS`).

    Parameters
    ----------
    delta_rad : ndarray, any shape
        True (unwrapped) steering angles, rad.
    quantum_rad : float
        Encoder resolution, rad (0: no quantisation).

    Returns
    -------
    ndarray
        Same shape, rad, in [-pi, pi).
    """
    d = quantise(np.asarray(delta_rad, dtype=float), quantum_rad)
    return np.where((d >= -np.pi) & (d < np.pi), d, wrap_angle(d))


def quantise(x: np.ndarray, quantum: float) -> np.ndarray:
    """Round to the sensor resolution ``quantum`` (no-op when <= 0).

    Parameters
    ----------
    x : ndarray
        Values (any unit).
    quantum : float
        Resolution, in the unit of ``x``.

    Returns
    -------
    ndarray
        Rounded values, same shape.
    """
    return x if quantum <= 0 else np.round(x / quantum) * quantum


def encoder_count_rate(omega: np.ndarray, dt_s: float, counts_per_rev: int) -> np.ndarray:
    """Wheel speed as an incremental encoder sees it: count differences per physics step.

    The true wheel angle (integral of ``omega``) is quantised to whole counts and
    differentiated, so the reported speed is unbiased on average but jumps by
    ``2 pi / (counts_per_rev dt_s)``; the motor driver's filter
    (:func:`first_order_filter`, the ODrive effect of seed 001 ch. 7.2.2) then smooths it.

    Parameters
    ----------
    omega : numpy.ndarray
        ``(n_steps, n_wheels)`` true wheel speed, rad/s, at the physics rate.
    dt_s : float
        Physics step, s.
    counts_per_rev : int
        Encoder counts per wheel revolution.

    Returns
    -------
    numpy.ndarray
        ``(n_steps, n_wheels)`` count-rate speed, rad/s.
    """
    quantum = 2.0 * np.pi / counts_per_rev
    angle = np.vstack([np.zeros((1, omega.shape[1])),
                       np.cumsum(0.5 * (omega[1:] + omega[:-1]) * dt_s, axis=0)])
    counts = np.floor(angle / quantum)
    rate = np.diff(counts, axis=0, prepend=counts[:1]) * quantum / dt_s
    return rate
