"""Physical invariants of the simulated sensors on short runs: noise levels and bias as
configured, the IMU's frame (gravity up on ``az``, a forward acceleration positive on ``ax``,
a left turn positive on ``wz``), each stream at its configured rate, and planted effects at
their off values changing nothing."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from terrain.sim import (PLANTED_EFFECTS, SCENARIO_NAMES, SensorSettings, SimConfig,
                         parse_effects, simulate)
from terrain.sim.dynamics import PhysicsResult
from terrain.sim.sensors import (coloured_noise, encoder_count_rate, first_order_filter,
                                 gravity_specific_force, imu, quantise, sample_times,
                                 vibration_level, vibration_pole, vibration_signals)
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


#: every rate distinct, so that a stream sampled at another stream's rate shows
DISTINCT_RATES = SensorSettings(imu_rate_hz=80.0, wheel_rate_hz=20.0, steer_rate_hz=40.0,
                                cam_rate_hz=25.0, truth_rate_hz=50.0)


@pytest.mark.parametrize("sensors", [None, DISTINCT_RATES])
@pytest.mark.parametrize("vehicle", ["husky", "agrimaro", "tracked"])
def test_every_stream_is_written_at_its_configured_rate(vehicle, sensors):
    run = simulate(SimConfig(vehicle=vehicle, scenario="random", duration_s=2.0, seed=0,
                             sensors=sensors))
    rates = stream_rates_hz(vehicle, sensors)
    assert run.meta["rates_hz"] == {"physics": 100.0, **rates}
    files = {"wheels": "pro"}
    for name, frame in run.streams.items():
        period = np.median(np.diff(frame.t_s))
        assert period == pytest.approx(1.0 / rates[files.get(name, name)], rel=1e-9), name
    if sensors is not None:
        assert rates["truth"] == 50.0 and rates["pro"] == 20.0


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


def test_gravity_specific_force_points_uphill_in_body_axes_with_magnitude_g():
    # nose up by 0.2 rad: the accelerometer reads +g sin on x (x points uphill), g cos on z
    g_x, g_y, g_z = gravity_specific_force(np.array([0.2]), np.array([0.0]))
    np.testing.assert_allclose([g_x[0], g_y[0], g_z[0]],
                               [G_M_S2 * np.sin(0.2), 0.0, G_M_S2 * np.cos(0.2)], atol=1e-12)
    # right side down by 0.2 rad: y (left) points uphill, so +g sin on y
    g_x, g_y, g_z = gravity_specific_force(np.array([0.0]), np.array([0.2]))
    np.testing.assert_allclose([g_x[0], g_y[0], g_z[0]],
                               [0.0, G_M_S2 * np.sin(0.2), G_M_S2 * np.cos(0.2)], atol=1e-12)
    # any inclination: magnitude g, tilt from z of hypot(pitch, roll), in-plane part along
    # the uphill direction (pitch, roll)
    pitch, roll = np.array([0.1, -0.3, 0.25]), np.array([0.2, 0.05, -0.15])
    g_x, g_y, g_z = gravity_specific_force(pitch, roll)
    np.testing.assert_allclose(np.sqrt(g_x ** 2 + g_y ** 2 + g_z ** 2), G_M_S2, rtol=1e-12)
    np.testing.assert_allclose(g_z, G_M_S2 * np.cos(np.hypot(pitch, roll)), rtol=1e-12)
    np.testing.assert_allclose(g_x * roll, g_y * pitch, atol=1e-12)
    assert np.all(g_x * pitch > 0)


def test_vibration_level_is_one_at_the_reference_speed_and_capped_at_3_m_s():
    v_ref = np.full(4, 0.5)
    level = vibration_level(np.array([0.5, 0.0, 5.0, 0.0]), np.array([0.0, -1.0, 0.0, 20.0]),
                            v_ref)
    # straight at v_ref: 1; turning on the spot at 1 rad/s counts as 0.3 m/s; both capped
    np.testing.assert_allclose(level, np.sqrt([1.0, 0.3 / 0.5, 3.0 / 0.5, 3.0 / 0.5]),
                               rtol=1e-12)


def test_vibration_pole_decays_at_the_corner_frequency_whatever_the_rate():
    # a first-order low-pass with corner f_c decays by exp(-2 pi f_c) per second
    for rate in (50.0, 100.0, 400.0):
        per_second = vibration_pole(rate, 15.0) ** rate
        assert per_second == pytest.approx(np.exp(-2 * np.pi * 15.0), rel=1e-9)


def test_coloured_noise_has_unit_variance_lag_one_correlation_the_pole_and_streams():
    pole = vibration_pole(100.0, 15.0)
    white = np.random.default_rng(1).standard_normal((200_000, 2))
    y, last = coloured_noise(white, pole)
    assert y[1000:].std() == pytest.approx(1.0, rel=0.02)
    rho = np.corrcoef(y[1000:-1, 0], y[1001:, 0])[0, 1]
    assert rho == pytest.approx(pole, abs=0.01)
    # one sample at a time, carrying the state, gives the batch output
    state, rows = None, []
    for k in range(50):
        row, state = coloured_noise(white[k:k + 1], pole, state)
        rows.append(row[0])
    np.testing.assert_allclose(np.array(rows), y[:50], rtol=1e-12, atol=1e-15)
    np.testing.assert_array_equal(last, y[-1])


def test_vibration_signals_scale_gyro_and_accelerometer_axes_by_their_own_std():
    coloured = np.ones((3, 5))
    out = vibration_signals(coloured, np.array([1.0, 2.0, 0.5]), np.full(3, 0.01),
                            np.full(3, 0.3))
    np.testing.assert_allclose(out[:, :2], 0.01 * np.array([[1, 1], [2, 2], [0.5, 0.5]]))
    np.testing.assert_allclose(out[:, 2:], 0.3 * np.array([[1, 1, 1], [2, 2, 2], [.5, .5, .5]]))


def test_first_order_filter_holds_a_constant_and_reaches_63_percent_after_tau():
    dt, tau = 0.001, 0.05
    np.testing.assert_allclose(first_order_filter(np.full((100, 2), 3.0), dt, tau), 3.0,
                               rtol=1e-12)
    step = np.r_[0.0, np.ones(200)]
    y = first_order_filter(step, dt, tau)
    assert y[round(tau / dt)] == pytest.approx(1.0 - np.exp(-1.0), rel=1e-9)
    assert first_order_filter(step, dt, 0.0) is step


def test_quantise_rounds_to_the_nearest_step_both_signs():
    np.testing.assert_allclose(quantise(np.array([0.7, -0.7, 0.2, 1.49]), 1.0),
                               [1.0, -1.0, 0.0, 1.0])
    x = np.array([0.123])
    assert quantise(x, 0.0) is x


def test_encoder_count_rate_integrates_to_the_true_wheel_angle():
    dt, counts = 0.01, 100_000
    t = np.arange(101) * dt
    omega = np.column_stack([np.full(101, 2.0), 3.0 * t])   # constant, and a ramp
    rate = encoder_count_rate(omega, dt, counts)
    quantum = 2 * np.pi / counts
    # the rate sums to the counted angle: 2 rad, and 3 T^2 / 2 = 1.5 rad (trapezoid, exact)
    np.testing.assert_allclose(rate.sum(axis=0) * dt, [2.0, 1.5], atol=quantum)
    # and each step is a whole number of counts per step
    np.testing.assert_allclose(np.round(rate * dt / quantum), rate * dt / quantum, atol=1e-6)


def test_sample_times_include_the_duration_despite_rounding():
    t = sample_times(1.0, 10.0)
    assert len(t) == 11 and t[-1] == pytest.approx(1.0)
    assert len(sample_times(0.3, 10.0)) == 4


def test_imu_reads_lateral_acceleration_on_ay_and_terrain_vibration_on_every_shaken_axis():
    n = 20001
    phys = _physics(n)
    gravel = get_terrain("GRAVEL")
    # driving straight at the terrain's reference speed with 0.5 m/s^2 to the left
    phys = PhysicsResult(**{**phys.__dict__,
                            "twist": np.column_stack([np.full(n, gravel.vib_speed_m_s),
                                                      np.zeros((n, 2))]),
                            "accel_body": np.column_stack([np.zeros(n), np.full(n, 0.5)]),
                            "terrain_names": ("GRAVEL",)})
    settings = SensorSettings(accel_bias_std_m_s2=0.0)
    _, data = imu(phys, (gravel,), settings, 0.0, np.random.default_rng(2), 200.0)
    assert data[:, 4].mean() == pytest.approx(0.5, abs=0.02)
    # level 1: each shaken axis has the catalogue std on top of the white noise
    expect_g = np.hypot(gravel.vib_gyro_rad_s, settings.gyro_noise_rad_s)
    expect_a = np.hypot(gravel.vib_accel_m_s2, settings.accel_noise_m_s2)
    np.testing.assert_allclose(data[:, :2].std(axis=0), expect_g, rtol=0.05)
    np.testing.assert_allclose(data[:, 3:].std(axis=0), expect_a, rtol=0.05)
    assert data[:, 2].std() == pytest.approx(settings.gyro_noise_rad_s, rel=0.05)


@pytest.mark.parametrize("field", ["imu_rate_hz", "wheel_rate_hz", "cam_rate_hz"])
def test_a_sensor_rate_of_zero_is_refused(field):
    from terrain.errors import ConfigError
    with pytest.raises(ConfigError, match=field):
        SensorSettings(**{field: 0.0})
    SensorSettings(**{"cam_outage_rate_hz": 0.0})       # a level of 0 is allowed


def test_current_offset_goes_to_the_right_motor_if_positive_and_the_left_if_negative():
    from terrain.sim.simulate import motor_currents
    from terrain.vehicles import HUSKY
    phys = _physics(5)
    base = motor_currents(phys, HUSKY, parse_effects([]))
    plus = motor_currents(phys, HUSKY, parse_effects(["current_offset=0.7"]))
    minus = motor_currents(phys, HUSKY, parse_effects(["current_offset=-0.7"]))
    np.testing.assert_allclose(plus - base, [[0.0, 0.7]] * 5, atol=1e-12)
    np.testing.assert_allclose(minus - base, [[0.7, 0.0]] * 5, atol=1e-12)


def test_turning_resistance_adds_the_same_tanh_current_to_both_sides_in_either_turn():
    """``value tanh(|yaw_rate| / 0.1 rad/s)`` (the module's table) on both motors, left and
    right turns alike, whatever the forward speed; nothing while driving straight."""
    from dataclasses import replace

    from terrain.sim.effects import TURN_RATE_SCALE_RAD_S
    from terrain.sim.simulate import motor_currents
    from terrain.vehicles import HUSKY
    assert TURN_RATE_SCALE_RAD_S == 0.1
    r = np.array([0.0, 0.1, -0.1, 0.05, -1.0])
    twist = np.column_stack([np.full(5, 1.2), np.zeros(5), r])    # 1.2 m/s forward
    phys = replace(_physics(5), twist=twist)
    extra = (motor_currents(phys, HUSKY, parse_effects(["turning_resistance=3"]))
             - motor_currents(phys, HUSKY, parse_effects([])))
    expected = 3.0 * np.tanh(np.abs(r) / 0.1)            # 0, 2.28, 2.28, 1.39, 3.0 A
    np.testing.assert_allclose(extra, np.column_stack([expected, expected]), atol=1e-12)


def test_grade_resistance_adds_value_times_abs_pitch_to_both_sides_up_and_down():
    """``value |pitch|`` on both motors: a slope never lowers the current, climbing or
    descending."""
    from dataclasses import replace

    from terrain.sim.simulate import motor_currents
    from terrain.vehicles import HUSKY
    pitch = np.array([0.0, 0.2, -0.2, 0.05])
    phys = replace(_physics(4), pitch=pitch)
    extra = (motor_currents(phys, HUSKY, parse_effects(["grade_resistance=40"]))
             - motor_currents(phys, HUSKY, parse_effects([])))
    np.testing.assert_allclose(extra, [[0.0, 0.0], [8.0, 8.0], [8.0, 8.0], [2.0, 2.0]],
                               atol=1e-12)


def test_wheel_lag_delays_every_wheel_stream_speeds_and_currents_alike():
    """The wheel streams at time t hold the values of t - lag (the module's table): the pro_
    speeds and currents and AgriMaRo's ``omega`` and ``cur``. At 50 Hz a 0.5 s lag is 25
    samples; with the current noise off the lagged run is the unlagged one shifted by
    exactly that, the first 0.5 s holding the start's values."""
    from dataclasses import replace

    from terrain.sim.simulate import DEFAULT_SENSORS
    sensors = replace(DEFAULT_SENSORS["agrimaro"], current_noise_a=0.0)
    assert sensors.wheel_rate_hz == 50.0
    cfg = dict(vehicle="agrimaro", scenario="random", duration_s=4.0, seed=3, sensors=sensors)
    base = simulate(SimConfig(**cfg))
    late = simulate(SimConfig(**cfg, effects=parse_effects(["wheel_lag=0.5"])))
    for stream in ("wheels", "omega", "cur"):
        b, lagged = base.streams[stream], late.streams[stream]
        assert np.array_equal(lagged.t_s, b.t_s)         # stamped on the same clock
        for column in b.columns.drop("t_s"):
            moved = np.abs(lagged[column] - b[column]).max()
            assert moved > 0.1, f"{stream}.{column} not lagged"
            np.testing.assert_allclose(lagged[column].to_numpy()[25:],
                                       b[column].to_numpy()[:-25], atol=1e-9,
                                       err_msg=f"{stream}.{column}")


def test_imu_axes_draw_their_own_noise_and_their_own_accelerometer_bias():
    # at rest there is no vibration: each axis is its white noise, the accelerometer axes
    # plus their bias; axes sharing a draw would read the same noise or the same bias
    settings = SensorSettings()
    _, data = imu(_physics(4001), (get_terrain("ASPHALT"),), settings, 0.0,
                  np.random.default_rng(0), 40.0)
    corr = np.corrcoef(data.T)
    assert np.abs(corr[~np.eye(6, dtype=bool)]).max() < 0.1
    # without white noise the accelerometer reads its constant per-run bias exactly, and
    # the three axes' biases are three draws of std accel_bias_std_m_s2
    quiet = SensorSettings(gyro_noise_rad_s=0.0, accel_noise_m_s2=0.0)
    biases = []
    for seed in range(40):
        _, d = imu(_physics(11), (get_terrain("ASPHALT"),), quiet, 0.0,
                   np.random.default_rng(seed), 0.1)
        np.testing.assert_array_equal(d[:, :3], 0.0)
        assert np.ptp(d[:, 3:], axis=0).max() < 1e-12
        biases.append(d[0, 3:] - [0.0, 0.0, G_M_S2])
    biases = np.array(biases)
    assert np.abs(np.corrcoef(biases.T)[~np.eye(3, dtype=bool)]).max() < 0.5
    np.testing.assert_allclose(biases.std(axis=0), quiet.accel_bias_std_m_s2, rtol=0.4)


def test_batch_imu_vibration_follows_the_terrain_of_each_sample():
    # first half on asphalt driving forward, second on snow sliding sideways (AgriMaRo), at
    # 0.23 m/s (snow's reference speed): wx's std is each terrain's gyro vibration at the
    # level of the speed, plus the white noise
    n = 8001
    snow = np.arange(n) >= n // 2
    phys = replace(_physics(n), twist=np.column_stack([0.23 * ~snow, 0.23 * snow, np.zeros(n)]),
                   terrain_index=snow.astype(int),
                   terrain_names=("ASPHALT", "SNOW"))
    terrains = (get_terrain("ASPHALT"), get_terrain("SNOW"))
    settings = SensorSettings()
    t, data = imu(phys, terrains, settings, 0.0, np.random.default_rng(1), 80.0)
    level = vibration_level(np.array([0.23]), np.array([0.0]),
                            np.array([ter.vib_speed_m_s for ter in terrains]))
    for half, ter, lev in zip((t < 39.0, t > 41.0), terrains, level):
        want = np.hypot(ter.vib_gyro_rad_s * lev, settings.gyro_noise_rad_s)
        assert data[half, 0].std() == pytest.approx(want, rel=0.1)
