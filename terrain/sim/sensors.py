"""Sensor models: each stream sampled at its own rate from the physics ground truth.

All functions are pure: they take the :class:`~terrain.sim.dynamics.PhysicsResult`, settings
and a :class:`numpy.random.Generator`, and return arrays.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import lfilter

from terrain.terramechanics.resistance import G_M_S2


@dataclass(frozen=True)
class SensorSettings:
    """Rates and noise levels of the simulated sensors.

    Parameters
    ----------
    imu_rate_hz, wheel_rate_hz, steer_rate_hz, cam_rate_hz, truth_rate_hz : float
        Sampling rates, Hz. Husky defaults follow borealtc (IMU 100 Hz, wheels 6.5 Hz).
    gyro_noise_rad_s : float
        White noise std of each gyro axis per sample, rad/s.
    accel_noise_m_s2 : float
        White noise std of each accelerometer axis per sample, m/s^2.
    accel_bias_std_m_s2 : float
        Std of the constant per-run accelerometer bias, m/s^2 (the z gyro has no baseline
        bias: ``gyro_bias`` is a named effect).
    vibration_bandwidth_hz : float
        Corner frequency of the first-order filter shaping terrain vibration.
    current_noise_a : float
        White noise std of the motor current sensor, A.
    current_quantum_a, speed_quantum_m_s : float
        Resolution of reported current and wheel speed.
    steer_quantum_rad : float
        Steering encoder resolution (12-bit absolute encoder ASSUMED), rad.
    cam_noise_m_s, cam_yaw_rate_noise_rad_s, cam_yaw_noise_rad : float
        T265 velocity, yaw-rate and yaw noise std.
    cam_outage_rate_hz : float
        Rate of visual-odometry outages (Poisson), 1/s; each lasts 0.5-2 s (rows dropped).
    """

    imu_rate_hz: float = 100.0
    wheel_rate_hz: float = 1.0 / 0.1538
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


def sample_times(duration_s: float, rate_hz: float) -> np.ndarray:
    """Sample times ``0, 1/rate, ...`` up to ``duration_s``.

    Parameters
    ----------
    duration_s : float
        Last time (inclusive, within 1e-9 s), s.
    rate_hz : float
        Sampling rate, Hz (> 0).

    Returns
    -------
    ndarray, shape (n,)
        Times, s.
    """
    return np.arange(0.0, duration_s + 1e-9, 1.0 / rate_hz)


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


def _coloured(rng: np.random.Generator, n: int, k: int, rate_hz: float,
              bandwidth_hz: float) -> np.ndarray:
    """Unit-variance first-order low-pass noise, shape (n, k)."""
    a = np.exp(-2.0 * np.pi * bandwidth_hz / rate_hz)
    w = rng.standard_normal((n, k)) * np.sqrt(1.0 - a * a)
    return lfilter([1.0], [1.0, -a], w, axis=0)


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
    ``g cos(slope)`` on z), terrain vibration (std from the catalogue, scaled by
    ``sqrt(|v| / v_ref)``), a constant per-run bias and white noise.

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
    ti = phys.terrain_index[np.clip(np.searchsorted(phys.t_s, t), 0, len(phys.t_s) - 1)]
    vib_a = np.array([terrains[i].vib_accel_m_s2 for i in range(len(terrains))])[ti]
    vib_g = np.array([terrains[i].vib_gyro_rad_s for i in range(len(terrains))])[ti]
    v_ref = np.array([terrains[i].vib_speed_m_s for i in range(len(terrains))])[ti]
    level = np.sqrt(np.minimum(np.hypot(vx, vy) + 0.3 * np.abs(r), 3.0) / v_ref)
    vib = _coloured(rng, n, 5, settings.imu_rate_hz, settings.vibration_bandwidth_hz)
    slope_sin = np.sin(np.hypot(pitch, roll))
    heading_up = np.arctan2(-roll, pitch) if np.any(slope_sin) else np.zeros(n)
    g_x = G_M_S2 * slope_sin * np.cos(heading_up)
    g_y = -G_M_S2 * slope_sin * np.sin(heading_up)
    g_z = G_M_S2 * np.cos(np.hypot(pitch, roll))
    bias = rng.normal(0.0, settings.accel_bias_std_m_s2, 3)
    noise = rng.standard_normal((n, 6))
    data = np.empty((n, 6))
    data[:, 0] = vib_g * level * vib[:, 0] + settings.gyro_noise_rad_s * noise[:, 0]
    data[:, 1] = vib_g * level * vib[:, 1] + settings.gyro_noise_rad_s * noise[:, 1]
    data[:, 2] = r + gyro_bias_rad_s + settings.gyro_noise_rad_s * noise[:, 2]
    data[:, 3] = abx + g_x + vib_a * level * vib[:, 2] + bias[0] + settings.accel_noise_m_s2 * noise[:, 3]
    data[:, 4] = aby + g_y + vib_a * level * vib[:, 3] + bias[1] + settings.accel_noise_m_s2 * noise[:, 4]
    data[:, 5] = g_z + vib_a * level * vib[:, 4] + bias[2] + settings.accel_noise_m_s2 * noise[:, 5]
    return t, data


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
