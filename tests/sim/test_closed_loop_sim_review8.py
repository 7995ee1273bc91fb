"""Eighth review pass of the simulated closed loop's online sensors
(terrain.sim.closed_loop): the camera outages' ends."""

from __future__ import annotations

import numpy as np

from terrain.sim.closed_loop import OnlineSensors
from terrain.sim.dynamics import PlantSnapshot
from terrain.sim.simulate import DEFAULT_SENSORS


def test_a_camera_outage_is_half_open_dropping_its_start_keeping_its_end():
    """The outages are ``[start, end)`` (module docstring, ``controller_cam_outages_s``): with
    one from the 4th to the 7th camera sample time (30 Hz), the samples at the 4th, 5th and
    6th are dropped and counted, the one at the 7th is delivered."""
    sensors = OnlineSensors("agrimaro", DEFAULT_SENSORS["agrimaro"], 0, 1.0)
    period = 1.0 / DEFAULT_SENSORS["agrimaro"].cam_rate_hz
    sensors.outages = [(3 * period, 6 * period)]
    z = np.zeros(3)
    for k in range(9):
        sensors.record(PlantSnapshot(k, k * period, np.zeros(3), np.zeros(3), np.zeros(2), z,
                                     z, z, z, 0.0, 0.0, 0))
    cam = sensors.take(9 * period, z).cam
    np.testing.assert_allclose(cam[:, 0], np.array([0, 1, 2, 6, 7, 8]) * period)
    assert sensors.cam_rows_dropped == 3


def test_the_full_imus_accelerometer_carries_a_bias_on_every_axis():
    """Noise-free sensors with a bias std of 0.2 m/s^2, level and at rest, no terrain (no
    vibration band): the full IMU reads ``ax, ay`` = their bias draws and ``az`` = gravity's
    specific force plus its own bias draw, a constant offset as on a real accelerometer."""
    from dataclasses import replace

    from terrain.sim.sensors import gravity_specific_force

    quiet = replace(DEFAULT_SENSORS["husky"], gyro_noise_rad_s=0.0, accel_noise_m_s2=0.0,
                    accel_bias_std_m_s2=0.2)
    sensors = OnlineSensors("husky", quiet, 3, 1.0)
    z = np.zeros(2)
    for k in range(3):
        sensors.record(PlantSnapshot(k, 0.01 * k, np.zeros(3), np.zeros(3), np.zeros(2), z, z,
                                     z, z, 0.0, 0.0, 0))
    full = sensors.take(0.03, z).imu_full
    g = np.asarray(gravity_specific_force(0.0, 0.0), dtype=float)
    assert abs(sensors.accel_bias_z) > 1e-3
    np.testing.assert_allclose(full[:, 4], g[0] + sensors.accel_bias[0], atol=1e-12)
    np.testing.assert_allclose(full[:, 5], g[1] + sensors.accel_bias[1], atol=1e-12)
    np.testing.assert_allclose(full[:, 6], g[2] + sensors.accel_bias_z, atol=1e-12)
