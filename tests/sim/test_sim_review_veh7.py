"""Review veh7: pinned values of the simulator's vibration pole and of the planted-effect
ranges (each line's mutant survived the existing tests)."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import ConfigError
from terrain.sim.effects import Effects
from terrain.sim.sensors import vibration_pole


def test_vibration_pole_is_the_discrete_first_order_pole_of_the_corner_frequency():
    # a = exp(-2 pi f_c / f_s): 15 Hz at 100 Hz -> exp(-0.3 pi) = 0.38966; the -3 dB corner
    # of y_k = a y_(k-1) + (1 - a) x_k is at about f_c for f_c << f_s (1 Hz at 1 kHz)
    assert vibration_pole(100.0, 15.0) == pytest.approx(np.exp(-0.3 * np.pi), rel=1e-12)
    assert vibration_pole(100.0, 15.0) == pytest.approx(0.38966, abs=1e-5)
    a = vibration_pole(1000.0, 1.0)
    z = np.exp(2j * np.pi * 1.0 / 1000.0)
    gain = abs((1.0 - a) / (1.0 - a / z))
    assert gain == pytest.approx(1.0 / np.sqrt(2.0), rel=1e-3)
    assert vibration_pole(100.0, 0.0) == 1.0       # bandwidth 0: the vibration is off


def test_icr_expansion_below_one_is_refused():
    # chi < 1 would put the contact lines inside the track (a vehicle turning faster than
    # ideal differential drive); the range is [1, 20]
    assert Effects(icr_expansion=1.0).active() == {}
    assert Effects(icr_expansion=20.0).active() == {"icr_expansion": 20.0}
    for bad in (0.99, 20.5):
        with pytest.raises(ConfigError, match="icr_expansion"):
            Effects(icr_expansion=bad)


def test_slope_turn_stays_within_a_speed_limit_below_its_slow_segment():
    from terrain.sim.scenarios import make_commands

    # max speed 0.04 m/s: vmax 0.038; the 0.05 m/s segment ran above the limit
    c = make_commands("slope_turn", 30.0, 0.01, np.random.default_rng(0), 0.04)
    assert c.twist[:, 0].max() <= 0.95 * 0.04 + 1e-12
    # the default limits keep the seed 003 speeds: 0.2 m/s, then 0.05 m/s from t = 10 s
    c = make_commands("slope_turn", 30.0, 0.01, np.random.default_rng(0), 1.0)
    assert c.twist[900, 0] == pytest.approx(0.2, rel=1e-12)
    assert c.twist[1900, 0] == pytest.approx(0.05, rel=1e-12)


@pytest.mark.parametrize("bad", [float("nan"), -1.0, float("inf"), True])
def test_sample_times_refuses_an_impossible_duration(bad):
    from terrain.sim.sensors import sample_times

    # NaN and inf raised NumPy's bare ValueError from arange, -1 s gave no sample at all
    with pytest.raises(ConfigError, match="duration_s"):
        sample_times(bad, 100.0)


def test_sample_times_include_the_last_time_on_the_grid():
    from terrain.sim.sensors import sample_times

    np.testing.assert_allclose(sample_times(0.3, 10.0), [0.0, 0.1, 0.2, 0.3], atol=1e-12)
    np.testing.assert_array_equal(sample_times(0.0, 10.0), [0.0])


def _standing_on_a_slope(n: int, pitch: float, roll: float):
    """A vehicle standing on an inclined plane (pitch nose-up, roll right side down), rad."""
    from terrain.sim.dynamics import PhysicsResult

    z = np.zeros(n)
    return PhysicsResult(
        t_s=np.arange(n) * 0.01, pose=np.zeros((n, 3)), twist=np.zeros((n, 3)),
        accel_body=np.zeros((n, 2)), omega=np.zeros((n, 2)), omega_cmd=np.zeros((n, 2)),
        slip_motor=np.zeros((n, 2)), delta=np.zeros((n, 2)), torque=np.zeros((n, 2)),
        pitch=np.full(n, pitch), roll=roll + z, terrain_index=np.zeros(n, dtype=int),
        terrain_names=("ASPHALT",), speed_clipped_steps=np.zeros(2, dtype=int))


@pytest.mark.parametrize("pitch, roll", [(0.2, 0.0), (0.0, 0.3), (-0.1, 0.0)])
def test_imu_at_rest_on_a_slope_reads_gravity_along_the_plane(pitch, roll):
    from terrain.sim.sensors import SensorSettings, imu
    from terrain.terramechanics import get_terrain
    from terrain.terramechanics.resistance import G_M_S2

    # no noise, no bias: the specific force of a standing vehicle is -g in body axes:
    # nose up by 0.2 rad -> ax = +g sin(0.2) = 1.949 m/s^2 (gravity pulls it back, the
    # accelerometer reads the reaction forward); right side down by 0.3 rad -> the left
    # side (+y) is up: ay = +g sin(0.3) = 2.899 m/s^2; az = g cos(slope)
    quiet = SensorSettings(gyro_noise_rad_s=0.0, accel_noise_m_s2=0.0,
                           accel_bias_std_m_s2=0.0)
    _, data = imu(_standing_on_a_slope(101, pitch, roll), (get_terrain("ASPHALT"),), quiet,
                  0.0, np.random.default_rng(0), 1.0)
    np.testing.assert_allclose(data[:, 3], G_M_S2 * np.sin(pitch), atol=1e-9)
    np.testing.assert_allclose(data[:, 4], G_M_S2 * np.sin(roll), atol=1e-9)
    np.testing.assert_allclose(data[:, 5], G_M_S2 * np.cos(np.hypot(pitch, roll)),
                               atol=1e-9)
