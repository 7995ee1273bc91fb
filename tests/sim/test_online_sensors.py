"""The closed loop's online IMU against the batch sensor model (terrain.sim.closed_loop)."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.sim.closed_loop import OnlineSensors, replay_observations
from terrain.sim.dynamics import PlantSnapshot
from terrain.sim.simulate import DEFAULT_SENSORS, SimConfig, simulate_with_physics
from terrain.terramechanics.resistance import G_M_S2

FULL = ("wx", "wy", "wz", "ax", "ay", "az")


def _steady_std(vehicle, terrain, seeds=range(6), duration=9.0, after_s=3.0):
    """Per-axis std of the batch IMU and of the online IMU (replayed on the same physics)
    over the steady part of straight_accel runs, pooled over the seeds."""
    batch, online = [], []
    for seed in seeds:
        sim = simulate_with_physics(SimConfig(vehicle=vehicle, terrains=(terrain,),
                                              scenario="straight_accel",
                                              duration_s=duration, seed=seed))
        b = sim.run.streams["imu"][["t_s", *FULL]].to_numpy()
        o = np.concatenate([obs.imu_full for obs in replay_observations(sim)])
        batch.append(b[b[:, 0] >= after_s, 1:])
        online.append(o[o[:, 0] >= after_s, 1:])
    return np.concatenate(batch).std(axis=0), np.concatenate(online).std(axis=0)


@pytest.mark.slow
@pytest.mark.parametrize("vehicle,terrain", [("husky", "SNOW"), ("husky", "ICE"),
                                             ("agrimaro", "GRASS")])
def test_online_imu_vibration_matches_the_batch_model(vehicle, terrain):
    """Same vibration functions, one online and one batch: the steady-speed std of every
    vibrating axis agrees within sampling error (36 s of 15 Hz coloured noise sampled at
    100 Hz, about 1600 independent samples: 1.8 % standard error; 8 % allowed; 20 other
    seeds gave ratios 0.975-1.012, no systematic bias)."""
    b_std, o_std = _steady_std(vehicle, terrain)
    for i, name in enumerate(FULL):
        if name == "wz":
            continue                                   # yaw rate: no vibration band
        assert o_std[i] == pytest.approx(b_std[i], rel=0.08), name


@pytest.mark.slow
def test_online_imu_vibration_follows_the_terrain_and_the_speed():
    """The online vibration is the terrain's: SNOW's wx std is several times ICE's; at
    standstill (start of straight_accel, speed 0) only white noise is left."""
    snow, _ = _steady_std("husky", "SNOW", seeds=(0,))
    ice, _ = _steady_std("husky", "ICE", seeds=(0,))
    assert snow[0] > 3 * ice[0]
    sim = simulate_with_physics(SimConfig(vehicle="husky", terrains=("SNOW",),
                                          scenario="straight_accel", duration_s=1.0, seed=0))
    full = np.concatenate([o.imu_full for o in replay_observations(sim)])
    moving = np.hypot(*sim.physics.twist[:, :2].T)
    still = full[:, 0] < sim.physics.t_s[np.argmax(moving > 1e-3)]
    assert still.sum() >= 2
    gyro = DEFAULT_SENSORS["husky"].gyro_noise_rad_s
    assert np.all(np.abs(full[still, 1]) < 5 * gyro)   # wx: noise only


def _snapshot(pitch, roll, terrain_index=0):
    z = np.zeros(2)
    return PlantSnapshot(0, 0.0, np.zeros(3), np.zeros(3), z, z, z, z, z, pitch, roll,
                         terrain_index)


def test_online_full_imu_senses_gravity_and_keeps_the_estimators_view():
    """On a slope the full IMU reads gravity (g sin(pitch) on x, g cos on z) like the batch
    model; the estimators' view (imu: ax, ay, wz) is the same sample without it."""
    sensors = OnlineSensors("husky", DEFAULT_SENSORS["husky"], 0, 1.0)   # no vibration
    sensors.record(_snapshot(0.2, 0.0))
    obs = sensors.take(0.0, np.zeros(2))
    (t, wx, wy, wz, ax, ay, az), = obs.imu_full
    (_, ax0, ay0, wz0), = obs.imu
    assert ax - ax0 == pytest.approx(G_M_S2 * np.sin(0.2), abs=1e-12)
    assert ay == pytest.approx(ay0, abs=1e-12) and wz == wz0
    assert az == pytest.approx(G_M_S2 * np.cos(0.2), abs=0.3)           # bias + noise
    assert obs.imu_full.shape == (1, 7) and obs.imu.shape == (1, 4)
    # the same draws on level ground: z loses g (1 - cos(pitch)), 0.196 m/s^2, which the
    # bias-and-noise bound above cannot tell from g itself
    level = OnlineSensors("husky", DEFAULT_SENSORS["husky"], 0, 1.0)
    level.record(_snapshot(0.0, 0.0))
    (_, _, _, _, ax_level, _, az_level), = level.take(0.0, np.zeros(2)).imu_full
    assert az - az_level == pytest.approx(-G_M_S2 * (1.0 - np.cos(0.2)), abs=1e-12)
    assert ax - ax_level == pytest.approx(G_M_S2 * np.sin(0.2), abs=1e-12)


def test_adding_the_full_imu_leaves_the_estimators_draws_unchanged():
    """The full IMU draws from a generator of its own: the estimators' IMU, wheel, current
    and camera samples are those of sensors without a vibrating terrain."""
    sim = simulate_with_physics(SimConfig(vehicle="agrimaro", terrains=("SNOW",),
                                          scenario="straight_accel", duration_s=1.0, seed=3))
    shaking = list(replay_observations(sim))
    cfg = sim.config
    quiet = OnlineSensors(cfg.vehicle, DEFAULT_SENSORS[cfg.vehicle], cfg.seed, cfg.duration_s,
                          cfg.physics)
    seen = []
    phys = sim.physics
    for k in range(len(phys.t_s)):
        quiet.record(PlantSnapshot(k, float(phys.t_s[k]), phys.pose[k], phys.twist[k],
                                   phys.accel_body[k], phys.omega[k], phys.delta[k],
                                   phys.omega_cmd[k], phys.torque[k]))
        if k % 2 == 0:
            seen.append(quiet.take(float(phys.t_s[k]), phys.omega_cmd[k]))
    for name in ("imu", "wheels", "currents", "cam"):
        a = np.concatenate([getattr(o, name) for o in shaking])
        b = np.concatenate([getattr(o, name) for o in seen])
        np.testing.assert_array_equal(a, b, err_msg=name)
    full_a = np.concatenate([o.imu_full for o in shaking])
    full_b = np.concatenate([o.imu_full for o in seen])
    assert np.std(full_a[full_a[:, 0] > 0.5, 4]) > 3 * np.std(full_b[full_b[:, 0] > 0.5, 4])


def test_a_sample_reads_the_first_physics_step_at_or_after_it():
    from terrain.sim.sensors import physics_step_index, sample_times
    t_phys = np.arange(0, 500) * 0.01        # 100 Hz grid, accumulated rounding
    t_imu = sample_times(4.99, 50.0)          # every other grid step, computed differently
    idx = physics_step_index(t_phys, t_imu)
    np.testing.assert_array_equal(idx, 2 * np.arange(len(t_imu)))   # on the grid: that step
    # between steps: the next one; before the first: the first; past the last: the last
    np.testing.assert_array_equal(physics_step_index(t_phys, [0.0149, -1.0, 4.985, 9.0]),
                                  [2, 0, 499, 499])


def test_closed_loop_takes_a_vehicle_name_in_any_case_like_simconfig():
    """SimConfig accepts "Husky" (get_vehicle takes any case), but simulate_closed_loop and
    replay_observations looked DEFAULT_SENSORS up by the name as given: KeyError 'Husky'."""
    from terrain.sim.closed_loop import simulate_closed_loop
    config = SimConfig(vehicle="Husky", terrains=("SNOW",), scenario="spin", duration_s=0.3,
                       seed=0)
    sim = simulate_with_physics(config)
    assert len(list(replay_observations(sim))) > 0
    closed = simulate_closed_loop(config, lambda observation: None)
    np.testing.assert_array_equal(closed.physics.twist, sim.physics.twist)
    assert config.vehicle == "husky"


def test_online_sensors_refuse_a_sensor_faster_than_the_physics():
    """The online sensors sample once per physics step at most: with 50 Hz physics (allowed,
    50-1000 Hz) the 100 Hz IMU came out at 50 Hz (101 rows for 2 s against the batch
    stream's 201), silently. Now a ConfigError names the sensor."""
    from terrain.errors import ConfigError
    from terrain.sim.closed_loop import simulate_closed_loop
    config = SimConfig(vehicle="husky", terrains=("ASPHALT",), scenario="spin",
                       duration_s=0.5, seed=0, physics_rate_hz=50.0)
    sim = simulate_with_physics(config)
    with pytest.raises(ConfigError, match="imu_rate_hz 100 Hz"):
        list(replay_observations(sim))
    with pytest.raises(ConfigError, match="imu_rate_hz 100 Hz"):
        simulate_closed_loop(config, lambda observation: None)
    fine = simulate_with_physics(SimConfig(vehicle="husky", terrains=("ASPHALT",),
                                           scenario="spin", duration_s=0.5, seed=0))
    imu = np.concatenate([o.imu for o in replay_observations(fine)])
    assert len(imu) == len(fine.run.streams["imu"])


def test_a_controller_faster_than_the_physics_is_refused():
    """The hook runs once per physics step, so a controller asked for 500 Hz over 100 Hz
    physics was called 101 times in 1 s (every 10 ms, the physics rate), silently; the
    replay yielded at 100 Hz too. Now both refuse it, naming the two rates."""
    from terrain.errors import ConfigError
    from terrain.sim.closed_loop import simulate_closed_loop
    config = SimConfig(vehicle="husky", terrains=("ASPHALT",), scenario="straight_accel",
                       duration_s=1.0, seed=0)
    with pytest.raises(ConfigError, match="control_rate_hz 500 Hz.*100 Hz"):
        simulate_closed_loop(config, lambda observation: None, control_rate_hz=500.0)
    sim = simulate_with_physics(config)
    with pytest.raises(ConfigError, match="control_rate_hz 500 Hz.*100 Hz"):
        list(replay_observations(sim, control_rate_hz=500.0))
    with pytest.raises(ConfigError, match="control_rate_hz 101 Hz"):   # just above it
        list(replay_observations(sim, control_rate_hz=101.0))
    calls = []
    simulate_closed_loop(config, lambda observation: calls.append(observation.t_s),
                         control_rate_hz=100.0)
    assert len(calls) == 101


def test_a_controller_correction_of_the_wrong_shape_or_not_finite_is_a_typed_error():
    """A controller that returned NaN made the next step fail on "cannot convert float NaN
    to integer" (the travelled distance had turned NaN), and one that returned three values
    for the Husky's two motors NumPy's "cannot reshape" ValueError. Both are now the
    project's typed errors naming the step and its time."""
    from terrain.errors import NonFiniteInputError, ShapeError
    from terrain.sim.closed_loop import simulate_closed_loop
    config = SimConfig(vehicle="husky", terrains=("ASPHALT",), scenario="straight_accel",
                       duration_s=1.0, seed=0)
    with pytest.raises(NonFiniteInputError, match=r"step 52 \(t = 0.520 s\)"):
        simulate_closed_loop(config, lambda o: np.array([np.nan, 0.0]) if o.t_s > 0.5
                             else np.zeros(2))
    with pytest.raises(ShapeError, match=r"3 values for 2 motors"):
        simulate_closed_loop(config, lambda o: np.zeros(3))
    closed = simulate_closed_loop(config, lambda o: [0.0, 0.0])
    assert np.isfinite(closed.physics.twist).all()


@pytest.mark.slow
def test_the_closed_loop_run_records_the_camera_outages_its_controller_saw():
    """The online camera draws its outages from a generator of its own, so a closed-loop
    controller lost the camera at other times than the run's metadata (the logged streams'
    draws) said, and its dropped rows were counted nowhere: AgriMaRo GRASS straight_accel
    seed 9, 20 s, the controller has no camera from 18.37 to 19.61 s while ``cam_outages_s``
    is [] and ``cam_rows_dropped`` 0 (seed 5 until 2026-11-30, whose run's generator plants
    an outage of its own since the steering offsets stopped drawing from it). The metadata
    now also lists the controller's outages and counts the camera rows they removed."""
    from terrain.sim.closed_loop import simulate_closed_loop

    cfg = SimConfig(vehicle="agrimaro", terrains=("GRASS",), scenario="straight_accel",
                    duration_s=20.0, seed=9)
    seen = []
    sim = simulate_closed_loop(cfg, lambda obs: seen.append(obs) or np.zeros(3), 50.0)
    assert sim.run.meta["cam_outages_s"] == [] and sim.run.meta["cam_rows_dropped"] == 0
    outages = sim.run.meta["controller_cam_outages_s"]
    assert len(outages) == 1 and outages[0][0] == pytest.approx(18.37, abs=0.01)
    cam_t = np.concatenate([obs.cam[:, 0] for obs in seen])
    start, end = outages[0]
    assert not np.any((cam_t >= start) & (cam_t < end))
    dropped = sim.run.meta["controller_cam_rows_dropped"]
    rate = DEFAULT_SENSORS["agrimaro"].cam_rate_hz
    assert abs(dropped - (end - start) * rate) <= 1
    assert dropped + len(cam_t) == len(np.arange(0.0, 20.0 + 1e-9, 1.0 / rate))
    husky = simulate_closed_loop(SimConfig(terrains=("GRASS",), duration_s=2.0),
                                 lambda obs: np.zeros(2), 50.0)
    assert "controller_cam_outages_s" not in husky.run.meta     # no camera on the Husky


def test_online_sensors_with_a_resolution_of_zero_report_unquantised_values():
    """A resolution of 0 means no quantisation (:func:`terrain.sim.sensors.quantise`, the
    batch model): the online steering encoders divided by it and reported NaN (all 303 rows
    of a 2 s AgriMaRo run), the batch stream the true angles."""
    from dataclasses import replace

    settings = replace(DEFAULT_SENSORS["agrimaro"], steer_quantum_rad=0.0,
                       current_quantum_a=0.0)
    sim = simulate_with_physics(SimConfig(vehicle="agrimaro", terrains=("ASPHALT",),
                                          duration_s=2.0, seed=1, sensors=settings))
    obs = list(replay_observations(sim))
    steer = np.concatenate([o.steer for o in obs])
    currents = np.concatenate([o.currents for o in obs])
    assert len(steer) > 50 and np.isfinite(steer).all()
    assert np.isfinite(currents).all()
    k = np.searchsorted(sim.physics.t_s, steer[:, 0] - 1e-9)
    np.testing.assert_allclose(steer[:, 1:], sim.physics.delta[k], atol=1e-12)


def _snap(k, t, omega, torque=(0.0, 0.0, 0.0), twist=(0.0, 0.0, 0.0), yaw=0.0):
    om = np.asarray(omega, dtype=float)
    return PlantSnapshot(k, t, np.array([0.0, 0.0, yaw]), np.asarray(twist, dtype=float),
                         np.zeros(2), om, np.zeros(om.size), om, np.asarray(torque, float),
                         0.0, 0.0, 0)


def test_online_camera_encoders_and_currents_from_known_snapshots():
    """Noise-free AgriMaRo sensors on hand-made plant states: the camera reads the velocity
    at its mount, ``(vx - w l_y, vy + w l_x)``; the encoder's driver filter is first order,
    ``f <- a f + (1 - a) omega`` with ``a = exp(-dt / tau)``; the drive reports current
    magnitudes, also for a braking (negative) torque."""
    from dataclasses import replace

    from terrain.sim.forces import reported_current_a
    from terrain.vehicles import get_vehicle

    quiet = replace(DEFAULT_SENSORS["agrimaro"], gyro_noise_rad_s=0.0, accel_noise_m_s2=0.0,
                    accel_bias_std_m_s2=0.0, current_noise_a=0.0, current_quantum_a=0.0,
                    speed_quantum_m_s=1e-9, cam_noise_m_s=0.0, cam_yaw_rate_noise_rad_s=0.0,
                    cam_yaw_noise_rad=0.0, cam_outage_rate_hz=0.0)
    veh = get_vehicle("agrimaro")
    s = OnlineSensors("agrimaro", quiet, 0, 1.0)
    torque = np.array([-20.0, 5.0, -3.0])
    s.record(_snap(0, 0.0, [0.0, 0.0, 0.0], torque, (1.0, 0.2, 0.5), 0.1))
    obs = s.take(0.0, np.zeros(3))
    lx, ly = veh.camera_lever_arm_m[:2]
    np.testing.assert_allclose(obs.cam[0, 1:], [1.0 - 0.5 * ly, 0.2 + 0.5 * lx, 0.5, 0.1])
    expect = np.abs(reported_current_a(veh.motor, torque, np.zeros(3), "v1"))
    assert (expect > 0).all()
    np.testing.assert_allclose(obs.currents[0, 1:], expect)
    dt, tau, f = 0.01, veh.motor.encoder_filter_s, np.zeros(3)
    for k in range(1, 3):                   # a step of the wheel speed to 6 rad/s
        s.record(_snap(k, k * dt, [6.0, 6.0, 6.0]))
        a = np.exp(-dt / tau)
        f = a * f + (1 - a) * 6.0
    s.ch["wheels"].next_t = 0.0             # sample the filter now
    s.record(_snap(3, 3 * dt, [6.0, 6.0, 6.0]))
    f = np.exp(-dt / tau) * f + (1 - np.exp(-dt / tau)) * 6.0
    np.testing.assert_allclose(s.take(0.03, np.zeros(3)).wheels[-1, 1:], f, rtol=1e-6)
    # at zero torque the drive's noise is reported as a magnitude too, never negative
    noisy = OnlineSensors("agrimaro", replace(quiet, current_noise_a=0.08), 0, 1.0)
    for k in range(60):
        noisy.record(_snap(k, k * dt, [0.0, 0.0, 0.0]))
    cur = noisy.take(0.6, np.zeros(3)).currents[:, 1:]
    assert cur.size >= 60 and (cur >= 0).all() and (cur > 0).any()


def test_replaying_a_run_gives_the_observations_its_controller_saw():
    """A controller that corrects nothing leaves the run as the open loop's; replaying that
    run (:func:`replay_observations`) must hand over what the controller received, every
    sample and the low-level command of the step about to be applied (the ramp of
    ``straight_accel`` changes it at every step)."""
    from terrain.sim.closed_loop import simulate_closed_loop

    cfg = SimConfig(vehicle="husky", terrains=("ICE",), scenario="straight_accel",
                    duration_s=1.0, seed=3)
    seen = []
    sim = simulate_closed_loop(cfg, lambda obs: seen.append(obs) or np.zeros(2))
    replayed = list(replay_observations(sim))
    assert len(replayed) == len(seen) == 51
    assert np.ptp([o.omega_low_level[0] for o in seen]) > 0
    for a, b in zip(seen, replayed):
        assert a.t_s == b.t_s
        for name in a._fields[1:]:
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)


@pytest.mark.parametrize("dt, omega", [(0.01, 20.0), (0.005, 40.0)])
def test_online_encoder_counts_the_trapezoid_of_the_wheel_angle(dt, omega):
    """Without a speed quantum the encoder counts whole increments of the wheel angle, the
    angle integrated by the trapezoid rule: a wheel going from 0 to 20 rad/s in one 0.01 s
    step turns 0.1 rad, one 4 deg count (the rectangle rule's 0.2 rad would be two); so does
    one going to 40 rad/s in a 0.005 s step (200 Hz physics), whose count rate is the count
    over that step. The driver's filter is taken out (``encoder_filter_s`` 0) to read the
    counts themselves."""
    from dataclasses import replace

    from terrain.vehicles import get_vehicle

    s = OnlineSensors("agrimaro", DEFAULT_SENSORS["agrimaro"], 0, 1.0)
    veh = get_vehicle("agrimaro")
    s.vehicle = replace(veh, motor=replace(veh.motor, encoder_filter_s=0.0))
    q = veh.motor.encoder_quantum_rad
    assert 0.1 / q == pytest.approx(1.43, abs=0.01)
    s.record(_snap(0, 0.0, [0.0, 0.0, 0.0]))
    s.ch["wheels"].next_t = 0.0
    s.record(_snap(1, dt, [omega] * 3))
    np.testing.assert_allclose(s.take(dt, np.zeros(3)).wheels[-1, 1:], q / dt)


def test_online_encoder_reads_a_steady_wheel_speed_on_average():
    """A wheel turning at 10 rad/s turns 1.43 counts a physics step: the filtered count
    rates the wheel samples report over the second half second average to 10 rad/s (the
    previous step's speed enters the trapezoid of the angle, not 0)."""
    s = OnlineSensors("agrimaro", DEFAULT_SENSORS["agrimaro"], 0, 2.0)
    for k in range(101):
        s.record(_snap(k, 0.01 * k, [10.0] * 3))
    wheels = s.take(1.0, np.zeros(3)).wheels
    assert len(wheels) == 51                       # 50 Hz
    late = wheels[wheels[:, 0] > 0.5, 1:]
    np.testing.assert_allclose(late.mean(axis=0), 10.0, atol=0.3)


def test_online_currents_are_quantised_and_draw_from_their_own_generator():
    """The currents are reported at their resolution ``current_quantum_a``, and their noise
    has its own generator: sampling them at another rate leaves the IMU and camera samples
    of the same seed unchanged, draw for draw."""
    from dataclasses import replace

    views = []
    for wheel_rate_hz in (50.0, 10.0):
        s = OnlineSensors("agrimaro", replace(DEFAULT_SENSORS["agrimaro"],
                                              wheel_rate_hz=wheel_rate_hz), 3, 1.0)
        for k in range(51):
            s.record(_snap(k, 0.01 * k, [5.0] * 3, torque=(2.0, 2.0, 2.0),
                           twist=(0.5, 0.0, 0.1)))
        views.append(s.take(0.5, np.zeros(3)))
    assert len(views[0].currents) != len(views[1].currents)
    steps = views[0].currents[:, 1:] / DEFAULT_SENSORS["agrimaro"].current_quantum_a
    np.testing.assert_allclose(steps, np.round(steps), atol=1e-6)
    np.testing.assert_array_equal(views[0].imu, views[1].imu)
    np.testing.assert_array_equal(views[0].cam, views[1].cam)


def test_online_encoder_is_the_batch_encoder_model_sample_for_sample():
    """A wheel speeding up from 0 to 12 rad/s: the online encoder (count rate per physics
    step, then the motor driver's filter) reports at 50 Hz what the batch model
    (:func:`encoder_count_rate`, :func:`first_order_filter`) computes for the same steps."""
    from terrain.sim.sensors import encoder_count_rate, first_order_filter

    s = OnlineSensors("agrimaro", DEFAULT_SENSORS["agrimaro"], 0, 2.0)
    motor = s.vehicle.motor
    omega = np.column_stack([np.linspace(0.0, 12.0, 101)] * 3)
    for k in range(101):
        s.record(_snap(k, 0.01 * k, omega[k]))
    online = s.take(1.0, np.zeros(3)).wheels
    batch = first_order_filter(encoder_count_rate(omega, 0.01, motor.encoder_counts_per_rev),
                               0.01, motor.encoder_filter_s)
    assert motor.encoder_filter_s > 0.01
    np.testing.assert_allclose(online[:, 1:], batch[::2], atol=1e-9)


def test_online_accelerometer_carries_a_constant_per_run_bias():
    """Without white noise the online IMU at rest reads its per-run accelerometer bias on
    ax and ay: constant within a run, of std ``accel_bias_std_m_s2`` across seeds (as the
    batch model)."""
    from dataclasses import replace

    quiet = replace(DEFAULT_SENSORS["husky"], accel_noise_m_s2=0.0, gyro_noise_rad_s=0.0)
    biases = []
    for seed in range(40):
        s = OnlineSensors("husky", quiet, seed, 1.0)
        for k in range(3):
            s.record(_snapshot(0.0, 0.0))
            s.ch["imu"].next_t = 0.0
        imu = s.take(0.0, np.zeros(2)).imu
        assert np.ptp(imu[:, 1:3], axis=0).max() == 0.0
        biases.append(imu[0, 1:3])
    np.testing.assert_allclose(np.std(biases, axis=0), quiet.accel_bias_std_m_s2, rtol=0.4)
