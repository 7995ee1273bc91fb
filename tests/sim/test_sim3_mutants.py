"""Pins against hand mutants of the simulator that the earlier tests let live (review sim3)."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.sim.dynamics import integrate, wheel_commands
from terrain.terramechanics.catalogue import get_terrain
from terrain.vehicles import get_vehicle

AGRIMARO = get_vehicle("agrimaro")


def test_the_steering_turns_at_its_rate_limit_and_no_faster():
    # from rolling forward to crabbing sideways every module must turn by ~pi/2; at
    # steering_rate_rad_s (2.09 rad/s) that takes ~0.75 s, one rate-limited step of
    # rate * dt per physics step until the angle is reached
    dt, n = 0.01, 151
    t = np.arange(n) * dt
    cmd = np.zeros((n, 3))
    cmd[:50, 0] = 0.3
    cmd[50:, 1] = 0.3
    p = integrate(AGRIMARO, AGRIMARO.contact_geometry(), (get_terrain("ASPHALT"),), 1e9, t,
                  cmd, 0.0, 1.0)
    rate = AGRIMARO.steering_rate_rad_s
    step = np.abs(np.diff(p.delta, axis=0))
    assert step.max() == pytest.approx(rate * dt, rel=1e-9)
    target = wheel_commands(AGRIMARO, AGRIMARO.contact_geometry(), cmd)[1][-1]
    turn = np.abs(target - p.delta[49])
    # whole steps at the limit while the module slews, none faster
    slewing = np.count_nonzero(np.isclose(step, rate * dt, rtol=1e-9), axis=0)
    assert np.all(slewing == np.floor(turn / (rate * dt) + 1e-9))
    assert np.allclose(p.delta[-1], target, atol=1e-12)


def test_a_correction_that_drives_the_command_past_the_limit_is_clipped_and_counted():
    # the hook's correction is added from the step after its return; every step on which
    # low-level command + correction exceeds the motor's speed limit is clipped and counted
    husky = get_vehicle("husky")
    geo = husky.contact_geometry()
    wmax = husky.motor.max_wheel_speed_rad_s
    dt, n = 0.01, 201
    t = np.arange(n) * dt
    cmd = np.zeros((n, 3))
    cmd[:, 0] = np.minimum(t, 0.9)              # up to 0.9 of the 1 m/s limit
    low = wheel_commands(husky, geo, cmd)[0]
    corr = np.array([0.5 * wmax, -0.2 * wmax])
    p = integrate(husky, geo, (get_terrain("ASPHALT"),), 1e9, t, cmd, 0.0, 1.0,
                  hook=lambda snap: corr)
    wanted = low[1:] + corr
    assert p.correction_clipped_steps.tolist() == np.count_nonzero(
        np.abs(wanted) > wmax, axis=0).tolist()
    assert p.correction_clipped_steps[0] > 50 and p.correction_clipped_steps[1] == 0
    assert np.allclose(p.omega_cmd[1:], np.clip(wanted, -wmax, wmax))
    assert p.speed_clipped_steps.tolist() == [0, 0]    # the scenario's own command fits


def test_online_currents_are_rounded_to_the_current_quantum():
    # noise-free: each online current sample is the drive's report rounded to
    # current_quantum_a (0.01 A), as the batch stream
    from dataclasses import replace

    from terrain.sim import DEFAULT_SENSORS
    from terrain.sim.closed_loop import OnlineSensors
    from terrain.sim.dynamics import PlantSnapshot
    from terrain.sim.forces import reported_current_a
    from terrain.sim.sensors import quantise

    settings = replace(DEFAULT_SENSORS["agrimaro"], current_noise_a=0.0)
    assert settings.current_quantum_a == 0.01
    s = OnlineSensors("agrimaro", settings, 0, 1.0)
    torque = np.array([3.337, -1.261, 0.848])
    omega = np.array([2.0, -1.5, 0.7])
    z = np.zeros(3)
    s.record(PlantSnapshot(0, 0.0, z, z, np.zeros(2), omega, z, omega, torque))
    got = s.take(0.0, z).currents[0, 1:]
    want = quantise(np.abs(reported_current_a(AGRIMARO.motor, torque, omega)), 0.01)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    assert not np.allclose(want, np.round(want, 1))      # not on a coarser grid


def test_batch_currents_are_the_motor_currents_rounded_to_the_current_quantum():
    # noise off: the pro stream's currents are the motor currents at the wheel samples,
    # rounded to current_quantum_a (0.01 A)
    from dataclasses import replace

    from terrain.sim import DEFAULT_SENSORS, SimConfig, simulate_with_physics
    from terrain.sim.sensors import interp_columns, quantise
    from terrain.sim.simulate import motor_currents

    sensors = replace(DEFAULT_SENSORS["husky"], current_noise_a=0.0)
    cfg = SimConfig(vehicle="husky", scenario="random", duration_s=3.0, seed=2,
                    sensors=sensors)
    sim = simulate_with_physics(cfg)
    wheels = sim.run.streams["wheels"]
    cur = motor_currents(sim.physics, get_vehicle("husky"), cfg.effects, cfg.physics)
    want = quantise(np.abs(interp_columns(wheels["t_s"].to_numpy(), sim.physics.t_s, cur)),
                    0.01)
    got = wheels[["cur_l", "cur_r"]].to_numpy()
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    assert not np.allclose(got, np.round(got, 1))


def test_agrimaro_omega_stream_is_the_filtered_encoder_count_rate():
    # speed quantum 0: the omega stream is the count rate per physics step
    # (encoder_count_rate), through the driver's first-order filter (encoder_filter_s),
    # sampled at the wheel times
    from terrain.sim import SimConfig, simulate_with_physics
    from terrain.sim.sensors import encoder_count_rate, first_order_filter, interp_columns

    sim = simulate_with_physics(SimConfig(vehicle="agrimaro", scenario="random",
                                          duration_s=2.0, seed=4))
    motor, p = AGRIMARO.motor, sim.physics
    assert motor.encoder_filter_s > 0
    dt = float(p.t_s[1] - p.t_s[0])
    want = first_order_filter(encoder_count_rate(p.omega, dt, motor.encoder_counts_per_rev),
                              dt, motor.encoder_filter_s)
    om = sim.run.streams["omega"]
    want = interp_columns(om["t_s"].to_numpy(), p.t_s, want)
    np.testing.assert_allclose(om[["omega_1", "omega_2", "omega_3"]].to_numpy(), want,
                               rtol=0, atol=1e-12)
    assert np.abs(want).max() > 1.0


def test_physics_v2_leaves_the_steered_agrimaro_as_v1_on_a_soil():
    # v2's lateral soil model, load transfer and tyre law are the skid-steers' (no soil
    # contact, CoG height 0 and no tyre entry for the AgriMaRo): its v2 run is its v1 run
    from terrain.sim.dynamics import soil_contacts

    soil = (get_terrain("SANDY_LOAM"),)
    geo = AGRIMARO.contact_geometry()
    assert soil_contacts(AGRIMARO, geo, soil) == {}
    t = np.arange(101) * 0.01
    cmd = np.column_stack([np.minimum(t, 0.5), 0.2 * np.minimum(t, 0.5), 0.3 * t])
    v1, v2 = (integrate(AGRIMARO, geo, soil, 1e9, t, cmd, 0.0, 1.0, physics=ph)
              for ph in ("v1", "v2"))
    np.testing.assert_array_equal(v2.twist, v1.twist)
    np.testing.assert_array_equal(v2.torque, v1.torque)
