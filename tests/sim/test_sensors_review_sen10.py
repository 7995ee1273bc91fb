"""Review sen10 of the simulated sensors, scenarios and planted effects: values pinned to
their equations where the existing tests only checked an invariant."""

from __future__ import annotations

import math
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

from terrain.errors import ConfigError
from terrain.sim import DEFAULT_SENSORS, SimConfig, simulate
from terrain.sim.closed_loop import OnlineSensors, make_hook, simulate_closed_loop
from terrain.sim.simulate import simulate_with_physics
from terrain.sim.dynamics import PhysicsResult, PlantSnapshot
from terrain.sim.effects import Effects
from terrain.sim.sensors import (SensorSettings, coloured_noise, imu, sample_times,
                                 vibration_pole)
from terrain.terramechanics import get_terrain
from terrain.terramechanics.resistance import G_M_S2
from terrain.vehicles import get_vehicle


def test_vibration_pole_is_the_discrete_pole_of_the_corner_frequency():
    # a = exp(-2 pi f_c / f_s): the IMU's defaults (100 Hz, 15 Hz) give exp(-0.3 pi)
    assert vibration_pole(100.0, 15.0) == pytest.approx(math.exp(-0.3 * math.pi), rel=1e-12)
    assert vibration_pole(100.0, 15.0) == pytest.approx(0.38966, abs=1e-5)
    # at f_c = f_s / (2 pi) the pole is 1/e; f_c = 0 is the vibration off (pole 1)
    assert vibration_pole(2.0 * math.pi, 1.0) == pytest.approx(math.exp(-1.0), rel=1e-12)
    assert vibration_pole(100.0, 0.0) == 1.0


def test_coloured_noise_half_power_at_the_corner_frequency():
    # the shaped noise's spectrum |H(f)|^2 = (1 - a^2) / |1 - a e^{-j w}|^2 falls to half its
    # DC value near the corner (the discrete pole's -3 dB point, within 10 % at 5 Hz / 100 Hz)
    fs, fc = 100.0, 5.0
    a = vibration_pole(fs, fc)
    w = 2.0 * np.pi * fc / fs
    h_dc = 1.0 / (1.0 - a) ** 2
    h_fc = 1.0 / abs(1.0 - a * np.exp(-1j * w)) ** 2
    assert h_fc / h_dc == pytest.approx(0.5, abs=0.05)
    # and the filter is that transfer function: its impulse response decays by a per sample
    impulse = np.zeros((6, 1))
    impulse[0] = 1.0
    y, _ = coloured_noise(impulse, a)
    assert y[1:, 0] / y[:-1, 0] == pytest.approx(np.full(5, a), rel=1e-12)


def test_a_10_hz_channel_samples_on_every_tenth_step_of_a_100_hz_grid():
    # the 10 Hz wheel channel's 3rd sample is due at 3 * 0.1 = 0.30000000000000004 s, the
    # step at 30 * 0.01 = 0.3 s: the 1e-9 s tolerance takes it there, not one step late
    s = OnlineSensors("tracked", DEFAULT_SENSORS["tracked"], 0, 2.0)
    wheels = s.ch["wheels"]
    assert wheels.period_s == pytest.approx(0.1)
    steps = [k for k in range(201) if wheels.due(float(k * 0.01))]
    assert steps == list(range(0, 201, 10))


def test_online_wheel_filter_starts_at_the_first_count_rate_and_holds_a_constant():
    # the motor driver's filter (AgriMaRo: 0.12 s) starts at its first input, as the batch
    # first_order_filter's y = x_0. That input is the encoder's count rate, 0 at the first
    # step (no count has changed yet, encoder_count_rate), however fast the wheel turns:
    # this test pinned 5 rad/s there until the online encoder was aligned with the batch
    # model (2026-11-30); a wheel at 5 rad/s now reads 0, then rises through the filter to
    # 5 (1 - exp(-0.3 / 0.12)) = 4.59 rad/s at 0.3 s and holds the constant
    agrimaro = get_vehicle("agrimaro")
    assert agrimaro.motor.encoder_filter_s == pytest.approx(0.12)
    s = OnlineSensors("agrimaro", DEFAULT_SENSORS["agrimaro"], 0, 1.0)
    om = np.full(3, 5.0)
    for k in range(61):
        s.record(PlantSnapshot(k, k * 0.01, np.zeros(3), np.zeros(3), np.zeros(2), om,
                               np.zeros(3), om, np.zeros(3), 0.0, 0.0, 0))
    wheels = s.take(0.6, om).wheels
    assert len(wheels) == 31                      # 50 Hz over 0.6 s
    np.testing.assert_array_equal(wheels[0, 1:], 0.0)
    assert np.mean(wheels[15, 1:]) == pytest.approx(5.0 * (1 - math.exp(-2.5)), abs=0.5)
    assert np.mean(wheels[-5:, 1:]) == pytest.approx(5.0, abs=0.3)


def test_the_husky_wheel_stream_runs_at_borealtc_s_6_5_hz():
    rate = SensorSettings().wheel_rate_hz
    assert rate == pytest.approx(6.5, rel=1e-9)
    t = sample_times(60.0, rate)
    assert len(t) == 391 and t[-1] == pytest.approx(60.0, abs=1e-9)


def test_batch_imu_on_a_slope_reads_gravity_along_the_plane():
    # parked nose-up 0.2 rad and right side down 0.1 rad, noise, bias and vibration off:
    # the batch accelerometer reads the specific force g sin(pitch) on x (x points uphill),
    # g sin(roll) on y (y, left, points uphill) and g cos on z, as the online full IMU does
    n = 201
    z = np.zeros(n)
    phys = PhysicsResult(
        t_s=np.arange(n) * 0.01, pose=np.zeros((n, 3)), twist=np.zeros((n, 3)),
        accel_body=np.zeros((n, 2)), omega=np.zeros((n, 2)), omega_cmd=np.zeros((n, 2)),
        slip_motor=np.zeros((n, 2)), delta=np.zeros((n, 2)), torque=np.zeros((n, 2)),
        pitch=z + 0.2, roll=z, terrain_index=np.zeros(n, dtype=int),
        terrain_names=("ASPHALT",), speed_clipped_steps=np.zeros(2, dtype=int))
    quiet = SensorSettings(gyro_noise_rad_s=0.0, accel_noise_m_s2=0.0,
                           accel_bias_std_m_s2=0.0, vibration_bandwidth_hz=0.0)
    _, data = imu(phys, (get_terrain("ASPHALT"),), quiet, 0.0, np.random.default_rng(0), 2.0)
    np.testing.assert_allclose(data[:, 3], G_M_S2 * np.sin(0.2), rtol=1e-12)
    np.testing.assert_allclose(data[:, 4], 0.0, atol=1e-12)
    np.testing.assert_allclose(data[:, 5], G_M_S2 * np.cos(0.2), rtol=1e-12)
    _, data = imu(replace(phys, pitch=z, roll=z + 0.1), (get_terrain("ASPHALT"),), quiet, 0.0,
                  np.random.default_rng(0), 2.0)
    np.testing.assert_allclose(data[:, 3], 0.0, atol=1e-12)
    np.testing.assert_allclose(data[:, 4], G_M_S2 * np.sin(0.1), rtol=1e-12)


class _Quiet:
    """Sensors stand-in: records nothing, hands back the call time."""

    def record(self, snap):
        return None

    def take(self, t_s, omega_low_level):
        return t_s


def test_a_10_hz_controller_is_called_on_every_tenth_step_of_a_100_hz_grid():
    # the 3rd call is due at 3 * 0.1 = 0.30000000000000004 s, the step at 30 * 0.01 = 0.3 s
    calls = []
    hook = make_hook(_Quiet(), calls.append, 10.0)
    for k in range(201):
        hook(SimpleNamespace(t_s=float(k * 0.01), omega_low_level=None))
    assert calls == [float(k * 0.01) for k in range(0, 201, 10)]


def test_the_closed_loop_refuses_a_steering_encoder_or_camera_faster_than_the_physics():
    # the AgriMaRo's steering encoders and camera are sampled once per physics step at most
    for field in ("steer_rate_hz", "cam_rate_hz"):
        sensors = replace(DEFAULT_SENSORS["agrimaro"], **{field: 200.0})
        config = SimConfig(vehicle="agrimaro", duration_s=1.0, sensors=sensors)
        with pytest.raises(ConfigError, match=field):
            simulate_closed_loop(config, lambda obs: np.zeros(3), 50.0)


def test_online_camera_noise_is_independent_on_each_channel_with_its_own_std():
    # parked AgriMaRo, no outages: v_cx, v_cy, yaw_rate_c and yaw_c are pure noise, each its
    # own draw at its configured std (a shared draw made yaw_c a copy of yaw_rate_c's noise)
    settings = replace(DEFAULT_SENSORS["agrimaro"], cam_outage_rate_hz=0.0)
    s = OnlineSensors("agrimaro", settings, 3, 30.0)
    z3 = np.zeros(3)
    for k in range(3001):
        s.record(PlantSnapshot(k, k * 0.01, z3, z3, np.zeros(2), z3, z3, z3, z3, 0.0, 0.0, 0))
    cam = s.take(30.0, z3).cam
    assert len(cam) == 901
    std = cam[:, 1:].std(axis=0)
    np.testing.assert_allclose(std, [settings.cam_noise_m_s, settings.cam_noise_m_s,
                                     settings.cam_yaw_rate_noise_rad_s,
                                     settings.cam_yaw_noise_rad], rtol=0.1)
    corr = np.corrcoef(cam[:, 1:].T)
    assert np.all(np.abs(corr[np.triu_indices(4, 1)]) < 0.15)


def test_negative_planted_effects_are_active_and_the_off_values_are_not():
    # gyro_bias and current_offset take negative values: those are on (listed in a run's
    # metadata ``active_effects``) as much as positive ones; the off values are not
    on = Effects(gyro_bias=-0.1, current_offset=-2.0, icr_expansion=1.2)
    assert on.active() == {"gyro_bias": -0.1, "current_offset": -2.0, "icr_expansion": 1.2}
    assert Effects().active() == {}


def test_wheel_lag_holds_the_first_value_until_the_lag_has_passed():
    # a 1 s lag on a 1 m/s^2 ramp from rest: the wheel speeds read the t = 0 value (rest)
    # until t = 1 s
    base = SimConfig(scenario="straight_accel", duration_s=2.0, seed=2)
    lagged = simulate(replace(base, effects=Effects(wheel_lag=1.0))).streams["wheels"]
    plain = simulate(base).streams["wheels"]
    early = lagged["t_s"] < 1.0
    assert early.sum() == 7
    np.testing.assert_array_equal(lagged.loc[early, ["vel_l", "vel_r"]], 0.0)
    # after it, the ramp shows up one second late (the plain run is at 0.08 m/s by 0.15 s)
    assert plain["vel_l"].iloc[1] > 0.05
    assert np.all(np.diff(lagged.loc[~early, "vel_l"]) > 0) and lagged["vel_l"].iloc[7] > 0


@pytest.mark.slow
def test_the_steering_encoders_read_within_one_turn():
    # SensorSettings calls the steering encoder a 12-bit absolute encoder, whose reading lies
    # within one turn; until 2026-11-30 the steer stream reported the unwrapped module angle
    # (random scenario, seed 3: past pi at 14.92 s, 3.69 rad by 16 s, 11.48 rad by 60 s)
    sim = simulate_with_physics(SimConfig(vehicle="agrimaro", scenario="random",
                                          duration_s=16.0, seed=3))
    delta = sim.run.streams["steer"][["delta_1", "delta_2", "delta_3"]].to_numpy()
    assert np.all(delta >= -np.pi) and np.all(delta < np.pi)
    assert np.abs(sim.physics.delta).max() > np.pi         # a module did pass pi
    # the reading is the true angle within one turn, to the encoder's resolution
    t = sim.run.streams["steer"]["t_s"].to_numpy()
    true = np.column_stack([np.interp(t, sim.physics.t_s, sim.physics.delta[:, i])
                            for i in range(3)])
    q = DEFAULT_SENSORS["agrimaro"].steer_quantum_rad
    err = np.angle(np.exp(1j * (delta - true)))
    assert np.abs(err).max() <= 0.5 * q + 1e-9


@pytest.mark.slow
def test_the_agrimaro_estimate_is_as_good_when_its_modules_pass_pi():
    # the filter wraps the steering innovations and its pre-filter averages the encoder
    # unwrapped (ANGLE_ROWS): on a run whose modules pass pi, the estimate from the wrapped
    # encoders equals the one from the unwrapped angles the stream held before 2026-11-30
    from dataclasses import replace as dc_replace

    from terrain.estimation.agrimaro import estimate_agrimaro
    sim = simulate_with_physics(SimConfig(vehicle="agrimaro", scenario="random",
                                          duration_s=30.0, seed=3))
    run = sim.run
    steer = run.streams["steer"]
    unwrapped = steer.assign(**{c: np.unwrap(steer[c].to_numpy()) for c in
                                ("delta_1", "delta_2", "delta_3")})
    assert np.abs(unwrapped[["delta_1", "delta_2", "delta_3"]].to_numpy()).max() > 4.0
    old = dc_replace(run, streams={**run.streams, "steer": unwrapped})
    truth = run.streams["truth"]
    errors = []
    for r in (run, old):
        ekf = estimate_agrimaro(r)
        v = np.interp(truth["t_s"], ekf.t_s, ekf.state("v_bx"))
        errors.append(np.sqrt(np.mean((v - truth["v_bx"].to_numpy()) ** 2)))
    assert errors[0] == pytest.approx(errors[1], rel=1e-6, abs=1e-9)
    assert errors[0] < 0.1
