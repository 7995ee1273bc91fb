"""Physical invariants of the simulated sensors on short runs: noise levels and bias as
configured, the IMU's frame (gravity up on ``az``, a forward acceleration positive on ``ax``,
a left turn positive on ``wz``), each stream at its configured rate, and planted effects at
their off values changing nothing."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from terrain.sim import (PLANTED_EFFECTS, SCENARIO_NAMES, SensorSettings, SimConfig,
                         parse_effects, simulate)
from terrain.sim.dynamics import PhysicsResult
from terrain.sim.sensors import imu
from terrain.sim.simulate import stream_rates_hz
from terrain.terramechanics import get_terrain
from terrain.terramechanics.resistance import G_M_S2


def _physics(n: int, accel_x: float = 0.0) -> PhysicsResult:
    """A vehicle at rest (or accelerating at ``accel_x`` on the spot) on level ground."""
    z = np.zeros(n)
    return PhysicsResult(
        t_s=np.arange(n) * 0.01, pose=np.zeros((n, 3)), twist=np.zeros((n, 3)),
        accel_body=np.column_stack([np.full(n, accel_x), z]), omega=np.zeros((n, 2)),
        omega_cmd=np.zeros((n, 2)), slip_motor=np.zeros((n, 2)), delta=np.zeros((n, 2)),
        torque=np.zeros((n, 2)), pitch=z, roll=z, terrain_index=np.zeros(n, dtype=int),
        terrain_names=("ASPHALT",), speed_clipped_steps=np.zeros(2, dtype=int))


def test_imu_at_rest_has_the_configured_noise_gravity_up_and_the_planted_gyro_bias():
    settings = SensorSettings()
    t, data = imu(_physics(4001), (get_terrain("ASPHALT"),), settings, 0.03,
                  np.random.default_rng(0), 40.0)
    assert len(t) == 4001
    std = data.std(axis=0)
    np.testing.assert_allclose(std[:3], settings.gyro_noise_rad_s, rtol=0.05)
    np.testing.assert_allclose(std[3:], settings.accel_noise_m_s2, rtol=0.05)
    # at rest no vibration: wz's mean is the planted bias, wx and wy zero
    assert data[:, 2].mean() == pytest.approx(0.03, abs=3e-4)
    np.testing.assert_allclose(data[:, :2].mean(axis=0), 0.0, atol=3e-4)
    # specific force on level ground: +g on z (up), 0 in the plane, up to the per-run bias
    tol = 5 * settings.accel_bias_std_m_s2
    assert data[:, 5].mean() == pytest.approx(G_M_S2, abs=tol)
    np.testing.assert_allclose(data[:, 3:5].mean(axis=0), 0.0, atol=tol)
    # the accelerometer sees the body's acceleration: 1 m/s^2 forward reads +1 on ax
    _, moving = imu(_physics(4001, 1.0), (get_terrain("ASPHALT"),), settings, 0.0,
                    np.random.default_rng(0), 40.0)
    assert moving[:, 3].mean() - data[:, 3].mean() == pytest.approx(1.0, abs=1e-9)


def test_simulated_imu_frame_forward_acceleration_and_left_turn():
    run = simulate(SimConfig(vehicle="husky", terrains=("CONCRETE",), scenario="straight_accel",
                             duration_s=2.0, seed=3))
    imu_s, truth = run.streams["imu"], run.streams["truth"]
    ramp = ((imu_s.t_s > 0.3) & (imu_s.t_s < 0.85)).to_numpy()
    # the command ramps at 1 m/s^2; the true acceleration and the IMU agree on its sign
    assert np.gradient(truth.v_bx, truth.t_s)[ramp].mean() == pytest.approx(1.0, abs=0.05)
    assert imu_s.ax[ramp].mean() == pytest.approx(1.0, abs=0.3)
    run = simulate(SimConfig(vehicle="husky", terrains=("CONCRETE",), scenario="spin",
                             duration_s=2.0, seed=3))
    imu_s, truth = run.streams["imu"], run.streams["truth"]
    late = (imu_s.t_s > 1.0).to_numpy()
    # spin starts turning left (0.6 rad/s): yaw grows, the gyro reads positive wz
    assert truth.yaw.iloc[-1] > 0.3
    assert imu_s.wz[late].mean() == pytest.approx(truth.yaw_rate[late].mean(), abs=0.005)
    assert imu_s.wz[late].mean() > 0.4


@pytest.mark.parametrize("vehicle", ["husky", "agrimaro", "tracked"])
def test_every_stream_is_written_at_its_configured_rate(vehicle):
    run = simulate(SimConfig(vehicle=vehicle, scenario="random", duration_s=2.0, seed=0))
    rates = stream_rates_hz(vehicle)
    files = {"wheels": "pro"}
    for name, frame in run.streams.items():
        period = np.median(np.diff(frame.t_s))
        assert period == pytest.approx(1.0 / rates[files.get(name, name)], rel=1e-9), name


@pytest.mark.parametrize("vehicle, scenario", [("husky", "slope_turn"), ("agrimaro", "random")])
def test_effects_at_their_off_values_change_nothing_bit_for_bit(vehicle, scenario):
    off = {name: spec.off_value for name, spec in PLANTED_EFFECTS.items()}
    base = simulate(SimConfig(vehicle=vehicle, scenario=scenario, duration_s=1.0, seed=2))
    given = simulate(SimConfig(vehicle=vehicle, scenario=scenario, duration_s=1.0, seed=2,
                               effects=parse_effects([f"{k}={v}" for k, v in off.items()])))
    assert given.meta["active_effects"] == {}
    assert base.streams.keys() == given.streams.keys()
    for name in base.streams:
        pd.testing.assert_frame_equal(base.streams[name], given.streams[name], check_exact=True)


@pytest.mark.parametrize("scenario", SCENARIO_NAMES)
def test_the_seed_alone_decides_the_run(scenario):
    """The caches of simulated runs key on the configuration: the same seed must give the same
    run bit for bit, another seed another run (its noise at least)."""
    runs = [simulate(SimConfig(vehicle="tracked", scenario=scenario, duration_s=1.0, seed=s))
            for s in (4, 4, 5)]
    for name in runs[0].streams:
        pd.testing.assert_frame_equal(runs[0].streams[name], runs[1].streams[name],
                                      check_exact=True)
    assert not runs[0].streams["imu"].equals(runs[2].streams["imu"])
    assert not runs[0].streams["wheels"].equals(runs[2].streams["wheels"])
