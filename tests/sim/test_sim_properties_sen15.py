"""Property-based checks of the simulator's sensor streams, scenarios and run assembly
(review sen15): rates and timestamps for any duration and seed, noiseless sensors that read
the true signal, seeds, mirror symmetry, command limits and the write/read round trip."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import example, given, settings, strategies as st

from terrain.errors import ConfigError
from terrain.io.measured import read_folder_run
from terrain.io.writer import write_run
from terrain.sim import SimConfig, simulate
from terrain.sim.effects import Effects
from terrain.sim.scenarios import SCENARIO_NAMES, make_commands
from terrain.sim.sensors import SensorSettings, imu, interp_columns, sample_times
from terrain.sim.simulate import (DEFAULT_SENSORS, minimum_duration_s, simulate_with_physics,
                                  stream_rates_hz)
from terrain.terramechanics.catalogue import get_terrain
from terrain.vehicles import VEHICLE_NAMES

FILE_OF = {"wheels": "pro"}
#: every noise, bias, vibration and outage off
QUIET = dict(gyro_noise_rad_s=0.0, accel_noise_m_s2=0.0, accel_bias_std_m_s2=0.0,
             vibration_bandwidth_hz=0.0, current_noise_a=0.0, cam_noise_m_s=0.0,
             cam_yaw_rate_noise_rad_s=0.0, cam_yaw_noise_rad=0.0, cam_outage_rate_hz=0.0)


@pytest.mark.slow
@settings(max_examples=25, deadline=None)
@given(vehicle=st.sampled_from(VEHICLE_NAMES), scenario=st.sampled_from(SCENARIO_NAMES),
       steps=st.integers(16, 400), seed=st.integers(0, 2**31 - 1))
def test_every_stream_has_its_rate_and_increasing_times_for_any_duration_and_seed(
        vehicle, scenario, steps, seed):
    duration = steps / 100.0
    if duration < minimum_duration_s(vehicle)[0]:
        return
    run = simulate(SimConfig(vehicle=vehicle, scenario=scenario, duration_s=duration,
                             seed=seed, terrains=("ASPHALT",)))
    rates = stream_rates_hz(vehicle)
    assert run.meta["duration_s"] == pytest.approx(duration, abs=1e-12)
    for name, frame in run.streams.items():
        rate = rates[FILE_OF.get(name, name)]
        t = frame["t_s"].to_numpy(float)
        assert t[-1] <= duration + 1e-9
        if name == "cam":   # outages drop rows: the rest lie on the camera's grid
            grid = sample_times(duration, rate)
            assert np.all(np.isin(t, grid)) and np.all(np.diff(t) > 0)
            assert len(t) + run.meta["cam_rows_dropped"] == len(grid)
            continue
        assert t[0] == 0.0
        assert len(t) == math.floor(duration * rate + 1e-9) + 1, name
        assert np.allclose(np.diff(t), 1.0 / rate, rtol=0, atol=1e-9), name
        assert len(t) >= 2
        assert np.all(np.isfinite(frame.drop(columns=[c for c in frame if c == "terrain"])
                                  .to_numpy(float))), name


@pytest.mark.slow
@settings(max_examples=15, deadline=None)
@given(vehicle=st.sampled_from(VEHICLE_NAMES), scenario=st.sampled_from(SCENARIO_NAMES),
       seed=st.integers(0, 2**31 - 1))
def test_a_seed_reproduces_a_run_bit_for_bit_and_another_seed_changes_every_noisy_stream(
        vehicle, scenario, seed):
    cfg = dict(vehicle=vehicle, scenario=scenario, duration_s=2.0)
    a = simulate(SimConfig(seed=seed, **cfg))
    b = simulate(SimConfig(seed=seed, **cfg))
    c = simulate(SimConfig(seed=seed + 1, **cfg))
    assert a.meta == b.meta
    for name in a.streams:
        assert a.streams[name].equals(b.streams[name]), name
    for name, cols in {"imu": ["wx", "wy", "wz", "ax", "ay", "az"],
                       "wheels": ["cur_l", "cur_r"]}.items():
        for col in cols:
            assert not np.array_equal(a.streams[name][col], c.streams[name][col]), (name, col)


def _quiet_sensors(vehicle, **extra):
    base = DEFAULT_SENSORS[vehicle]
    return SensorSettings(**{**{f: getattr(base, f) for f in base.__dataclass_fields__},
                             **QUIET, **extra})


@pytest.mark.slow
@settings(max_examples=12, deadline=None)
@given(vehicle=st.sampled_from(VEHICLE_NAMES), scenario=st.sampled_from(SCENARIO_NAMES),
       seed=st.integers(0, 1000), bias=st.floats(-0.5, 0.5))
def test_noiseless_sensors_read_the_true_signal(vehicle, scenario, seed, bias):
    sensors = _quiet_sensors(vehicle, current_quantum_a=0.0, steer_quantum_rad=0.0)
    sim = simulate_with_physics(SimConfig(vehicle=vehicle, scenario=scenario, duration_s=3.0,
                                          seed=seed, sensors=sensors,
                                          effects=Effects(gyro_bias=bias)))
    run, phys = sim.run, sim.physics
    t = run.streams["imu"]["t_s"].to_numpy()
    true = interp_columns(t, phys.t_s, np.column_stack([phys.twist[:, 2], phys.pitch,
                                                        phys.roll]))
    assert np.array_equal(run.streams["imu"]["wz"], true[:, 0] + bias)
    assert np.all(run.streams["imu"]["wx"] == 0) and np.all(run.streams["imu"]["wy"] == 0)
    g_z = 9.80665 * np.cos(np.hypot(true[:, 1], true[:, 2]))
    assert np.allclose(run.streams["imu"]["az"], g_z, rtol=0, atol=1e-12)
    from terrain.sim.simulate import motor_currents
    from terrain.vehicles import get_vehicle
    tw = run.streams["wheels"]["t_s"].to_numpy()
    cur = np.abs(interp_columns(tw, phys.t_s, motor_currents(
        phys, get_vehicle(vehicle), Effects(gyro_bias=bias), "v1")))
    assert np.array_equal(run.streams["wheels"][["cur_l", "cur_r"]].to_numpy(), cur[:, :2])
    if "cam" in run.streams:
        cam = run.streams["cam"]
        assert run.meta["cam_rows_dropped"] == 0
        tc = cam["t_s"].to_numpy()
        s = interp_columns(tc, phys.t_s, np.column_stack([phys.twist, phys.pose[:, 2]]))
        assert np.array_equal(cam["yaw_rate_c"], s[:, 2])
        assert np.array_equal(cam["yaw_c"], s[:, 3])
        ts = run.streams["steer"]["t_s"].to_numpy()
        assert np.array_equal(run.streams["steer"][["delta_1", "delta_2", "delta_3"]]
                              .to_numpy(), interp_columns(ts, phys.t_s, phys.delta))


@pytest.mark.slow
@settings(max_examples=10, deadline=None)
@given(vehicle=st.sampled_from(VEHICLE_NAMES), seed=st.integers(0, 1000))
def test_noiseless_reported_speeds_are_the_true_ones_to_their_quantum(vehicle, seed):
    sensors = _quiet_sensors(vehicle)
    run = simulate(SimConfig(vehicle=vehicle, scenario="random", duration_s=3.0, seed=seed,
                             sensors=sensors))
    q = sensors.speed_quantum_m_s
    vel = run.streams["wheels"][["vel_l", "vel_r"]].to_numpy()
    if q > 0:
        steps = vel / q
        assert np.allclose(steps, np.round(steps), rtol=0, atol=1e-6)
    cur = run.streams["wheels"][["cur_l", "cur_r"]].to_numpy()
    cq = sensors.current_quantum_a
    assert np.allclose(cur / cq, np.round(cur / cq), rtol=0, atol=1e-6)
    assert np.all(cur >= 0)


def _fake_physics(rng, n=400, mirrored=False):
    t = np.arange(n) * 0.01
    s = -1.0 if mirrored else 1.0
    twist = np.column_stack([0.5 + 0.1 * np.sin(t), s * 0.2 * np.cos(3 * t), s * 0.4 * np.sin(t)])
    accel = np.column_stack([0.3 * np.cos(2 * t), s * 0.7 * np.sin(5 * t)])
    pose = np.column_stack([t, s * t ** 2, s * 0.2 * t])
    return SimpleNamespace(t_s=t, twist=twist, accel_body=accel, pose=pose,
                           pitch=0.1 * np.sin(t), roll=s * 0.15 * np.cos(t),
                           terrain_index=np.zeros(n, dtype=int))


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), bias=st.floats(-0.5, 0.5))
def test_a_mirrored_motion_gives_the_mirrored_noiseless_imu(seed, bias):
    """Mirroring left and right (y, yaw, roll negated) negates wx, wz - bias and ay."""
    terrains = (get_terrain("ASPHALT"),)
    sensors = SensorSettings(**QUIET)
    t, a = imu(_fake_physics(None), terrains, sensors, bias, np.random.default_rng(seed), 3.0)
    _, b = imu(_fake_physics(None, mirrored=True), terrains, sensors, -bias,
               np.random.default_rng(seed), 3.0)
    assert np.allclose(a * [-1, 1, -1, 1, -1, 1], b, rtol=0, atol=1e-12)
    assert np.all(np.diff(t) > 0)


@settings(max_examples=25, deadline=None)
@given(name=st.sampled_from(SCENARIO_NAMES), duration=st.floats(0.05, 30.0),
       rate=st.sampled_from([50.0, 100.0, 200.0, 1000.0]), vmax=st.floats(0.01, 5.0),
       omni=st.booleans(), track=st.floats(0.0, 1.5), seed=st.integers(0, 2**31 - 1))
def test_scenario_commands_start_at_rest_and_respect_the_speed_and_rate_limits(
        name, duration, rate, vmax, omni, track, seed):
    dt = 1.0 / rate
    if round(duration / dt) < 1:
        return
    c = make_commands(name, duration, dt, np.random.default_rng(seed), vmax,
                      omnidirectional=omni, track_m=track)
    assert np.all(np.diff(c.t_s) > 0) and c.t_s[0] == 0.0
    assert c.t_s[-1] == pytest.approx(round(duration / dt) * dt)
    assert np.all(np.isfinite(c.twist))
    # from rest: the first command is one rate-limited step from 0 at most
    assert np.all(np.abs(c.twist[0]) <= 2.0 * dt + 1e-12)
    assert np.all(np.abs(c.twist[:, 0]) <= 0.95 * vmax + 1e-12)
    assert np.all(np.abs(c.twist[:, 1]) <= 0.95 * 0.5 * vmax + 1e-12)
    if not omni:
        assert np.all(c.twist[:, 1] == 0)
    # acceleration limits: 1 m/s^2 (straight_accel), 0.8 m/s^2 (random), 0.5 (others)
    limits = {"straight_accel": 1.0, "random": 0.8}
    acc = np.abs(np.diff(c.twist[:, :2], axis=0)) / dt
    assert np.all(acc <= limits.get(name, 0.5) + 1e-6)
    yaw_acc = np.abs(np.diff(c.twist[:, 2])) / dt
    assert np.all(yaw_acc <= {"orchard": 2.0, "slope_turn": 1.0}.get(name, 1.5) + 1e-6)


@pytest.mark.slow
@settings(max_examples=8, deadline=None)
@given(vehicle=st.sampled_from(VEHICLE_NAMES), scenario=st.sampled_from(SCENARIO_NAMES),
       seed=st.integers(0, 2**31 - 1),
       terrains=st.sampled_from([("ASPHALT",), ("ASPHALT", "SNOW")]))
def test_simulate_write_read_is_a_round_trip_of_every_stream_and_meta_field(
        tmp_path_factory, vehicle, scenario, seed, terrains):
    run = simulate(SimConfig(vehicle=vehicle, scenario=scenario, duration_s=1.5, seed=seed,
                             terrains=terrains, segment_length_m=0.3))
    out = tmp_path_factory.mktemp("rt")
    paths = write_run(run, out)
    back = read_folder_run(paths["meta"].parent)
    assert set(back.streams) == set(run.streams)
    for name, frame in run.streams.items():
        got = back.streams[name]
        assert sorted(got.columns) == sorted(frame.columns), name   # reader's order
        assert len(got) == len(frame), name
        for col in frame:
            if col == "terrain":
                assert list(got[col].astype(str)) == list(frame[col]), name
            else:
                assert np.allclose(got[col].to_numpy(float), frame[col].to_numpy(float),
                                   rtol=5e-9, atol=1e-12), (name, col)
    written = json.loads(json.dumps(run.meta))
    for key, value in written.items():
        assert back.meta[key] == value, key
    assert back.vehicle == run.vehicle and back.terrain == run.terrain


@pytest.mark.slow
@settings(max_examples=15, deadline=None)
@example(vehicle="husky", wheel=100.0, imu_rate=100.0, cam=1.0, steer=1.0, truth=100.0,
         physics=50.0)      # every Husky stream faster than the physics: one step, 3 samples
@given(vehicle=st.sampled_from(VEHICLE_NAMES), wheel=st.floats(0.5, 120.0),
       imu_rate=st.floats(0.5, 400.0), cam=st.floats(0.5, 60.0), steer=st.floats(0.5, 60.0),
       truth=st.floats(0.5, 200.0), physics=st.sampled_from([50.0, 100.0, 250.0, 1000.0]))
def test_the_minimum_duration_gives_two_samples_of_every_stream_and_one_step_less_is_refused(
        vehicle, wheel, imu_rate, cam, steer, truth, physics):
    sensors = replace(DEFAULT_SENSORS[vehicle], wheel_rate_hz=wheel, imu_rate_hz=imu_rate,
                      cam_rate_hz=cam, steer_rate_hz=steer, truth_rate_hz=truth,
                      cam_outage_rate_hz=0.0)
    minimum, _ = minimum_duration_s(vehicle, sensors, physics)
    run = simulate(SimConfig(vehicle=vehicle, scenario="spin", duration_s=minimum,
                             sensors=sensors, physics_rate_hz=physics))
    fewest = min(len(f) for f in run.streams.values())
    assert fewest >= 2
    if minimum > 1.0 / physics:
        # more than one physics step: the slowest period is longer than a step, so the
        # run ends before its third sample (one step, the least a run takes, can hold
        # more: every stream at 100 Hz under 50 Hz physics gives 3)
        assert fewest == 2
        with pytest.raises(ConfigError, match="too short"):
            SimConfig(vehicle=vehicle, scenario="spin", duration_s=minimum - 1.0 / physics,
                      sensors=sensors, physics_rate_hz=physics)


@pytest.mark.slow
@settings(max_examples=6, deadline=None)
@given(vehicle=st.sampled_from(VEHICLE_NAMES), physics=st.sampled_from(["v1", "v2"]),
       v=st.floats(0.05, 0.6), r=st.floats(-0.6, 0.6), vy=st.floats(-0.15, 0.15))
def test_a_mirrored_command_gives_the_mirrored_motion_wheels_and_currents(vehicle, physics,
                                                                          v, r, vy):
    """Skid-steer: left-right mirror ``(v_x, r) -> (v_x, -r)`` gives ``(x, -y, -yaw)`` and
    the left and right motors swapped. AgriMaRo (wheels 1 and 2 at ``x = -+0.5075``,
    wheel 3 on ``x = 0``): fore-aft mirror ``(v_x, v_y, r) -> (-v_x, v_y, -r)`` gives
    ``(-x, y, -yaw)`` and wheels 1 and 2 swapped, each speed negated."""
    from terrain.sim.dynamics import integrate
    from terrain.sim.simulate import motor_currents
    from terrain.vehicles import get_vehicle

    veh = get_vehicle(vehicle)
    geo = veh.contact_geometry()
    t = np.arange(0.0, 1.5, 0.01)
    cmd = np.zeros((len(t), 3))
    cmd[:, 0], cmd[:, 2] = np.minimum(t, v), r * np.sin(2.0 * t)
    if geo.steered:
        cmd[:, 1] = vy * np.sin(t)
        flip, order, sign = np.array([-1.0, 1.0, -1.0]), [1, 0, 2], -1.0
    else:
        flip, order, sign = np.array([1.0, -1.0, -1.0]), [1, 0], 1.0
    a, b = (integrate(veh, geo, (get_terrain("GRASS"),), 25.0, t, c, 0.0, 1.0, None,
                      physics=physics) for c in (cmd, cmd * flip))
    np.testing.assert_allclose(b.pose, a.pose * flip, atol=1e-9)
    np.testing.assert_allclose(b.twist, a.twist * flip, atol=1e-9)
    np.testing.assert_allclose(b.omega[:, order], sign * a.omega, atol=1e-9)
    cur_a, cur_b = (motor_currents(p, veh, Effects(), physics) for p in (a, b))
    np.testing.assert_allclose(cur_b[:, order], cur_a, atol=1e-7)
