"""Review sim11 of the simulator (terrain.sim) and the vehicles: physical invariants,
docstring claims and survivors of hand mutation."""

import numpy as np
import pytest

from terrain.errors import ConfigError, ShapeError
from terrain.sim.dynamics import integrate
from terrain.sim.scenarios import make_commands
from terrain.terramechanics.catalogue import get_terrain
from terrain.vehicles import get_vehicle


def test_random_omnidirectional_speed_is_capped_per_component_not_as_a_resultant():
    """make_commands' docstring said every scenario's speeds stay within 0.95 of the limit;
    the random scenario caps v_x and v_y each, so an omnidirectional run's body speed passes
    the limit itself (seed 2, 120 s: 1.008 of it), within 0.95 sqrt(1.25)."""
    cmd = make_commands("random", 120.0, 0.01, np.random.default_rng(2), 1.0,
                        omnidirectional=True)
    assert np.abs(cmd.twist[:, 0]).max() <= 0.95 + 1e-12
    assert np.abs(cmd.twist[:, 1]).max() <= 0.5 * 0.95 + 1e-12
    speed = np.hypot(cmd.twist[:, 0], cmd.twist[:, 1])
    assert speed.max() > 1.0
    assert speed.max() <= 0.95 * np.sqrt(1.25) + 1e-12


def test_agrimaro_driving_straight_on_level_ground_does_not_yaw():
    """A straight run on level ground has zero yaw rate. The AgriMaRo with no steering error
    (all units at 0), ramping at 1 m/s^2 to 1 m/s on TILES, turned left by 0.0025 rad in
    10 s (peak yaw rate 0.0034 rad/s, 2.3 cm to the left) while its mass sat at the body
    origin and its static loads were the wheel-triangle centroid's (fixed 2026-11-30: the
    mass sits at ContactGeometry.cog_m, AgriMaRoParams.cog_m); the Husky and the tracked
    vehicle stay at zero to rounding."""
    v = get_vehicle("agrimaro")
    t = np.arange(1001) * 0.01
    tw = np.zeros((len(t), 3))
    tw[:, 0] = np.minimum(t, 1.0)
    phys = integrate(v, v.contact_geometry(), (get_terrain("TILES"),), 25.0, t, tw, 0.0, 1.0,
                     np.zeros(3))
    assert np.all(phys.delta == 0.0)
    assert np.abs(phys.twist[:, 2]).max() < 1e-6


def test_husky_quanta_are_read_from_the_sensor_settings_not_the_vehicle():
    """HuskyParams.speed_quantum_m_s and current_quantum_a were documented as the resolution
    of the reported wheel speed and current, but no code reads them: the streams are rounded
    with the Husky's default SensorSettings, which hold the same values (pinned here, so the
    two records cannot drift apart unseen)."""
    from dataclasses import replace

    from terrain.sim.simulate import DEFAULT_SENSORS, SimConfig, simulate
    from terrain.vehicles.skid_steer import HUSKY

    assert DEFAULT_SENSORS["husky"].speed_quantum_m_s == HUSKY.speed_quantum_m_s
    assert DEFAULT_SENSORS["husky"].current_quantum_a == HUSKY.current_quantum_a
    coarse = replace(DEFAULT_SENSORS["husky"], speed_quantum_m_s=0.05)
    run = simulate(SimConfig(scenario="straight_accel", duration_s=3.0, sensors=coarse))
    vel = run.streams["wheels"][["vel_l", "vel_r"]].to_numpy()
    np.testing.assert_allclose(vel / 0.05, np.round(vel / 0.05), atol=1e-9)
    assert np.abs(vel).max() > 0.5


def test_online_encoder_matches_the_batch_model_from_a_moving_start():
    """The closed loop's encoder is documented as the batch model's (count rate per physics
    step, then the driver's filter). From a wheel already at 3 rad/s on the first step the
    batch model reports 0 then 0.51 rad/s at 0.04 s, the online one 3.0 then 2.66."""
    from terrain.sim.closed_loop import OnlineSensors
    from terrain.sim.dynamics import PlantSnapshot
    from terrain.sim.sensors import encoder_count_rate, first_order_filter
    from terrain.sim.simulate import DEFAULT_SENSORS

    s = OnlineSensors("agrimaro", DEFAULT_SENSORS["agrimaro"], 0, 2.0)
    motor = s.vehicle.motor
    omega = np.column_stack([np.linspace(3.0, 12.0, 101)] * 3)
    for k in range(101):
        s.record(PlantSnapshot(k, 0.01 * k, np.zeros(3), np.zeros(3), np.zeros(2), omega[k],
                               np.zeros(3), omega[k], np.zeros(3), 0.0, 0.0, 0))
    online = s.take(1.0, np.zeros(3)).wheels
    batch = first_order_filter(encoder_count_rate(omega, 0.01, motor.encoder_counts_per_rev),
                               0.01, motor.encoder_filter_s)
    np.testing.assert_allclose(online[:, 1:], batch[::2], atol=1e-9)


def test_a_skid_steer_refuses_a_lateral_velocity_command():
    """integrate took (v_x, v_y, yaw_rate) for every vehicle, but a skid-steer's inverse
    kinematics has no v_y: a Husky commanded 0.3 m/s sideways for 3 s stood still (pose 0,
    wheel commands 0) with nothing said. It is refused now, naming the first step; v_y 0
    runs as before and a steered vehicle still takes v_y."""
    v = get_vehicle("husky")
    t = np.arange(300) * 0.01
    tw = np.zeros((300, 3))
    tw[100:, 1] = 0.3
    with pytest.raises(ConfigError, match=r"v_y\) must be 0, got 0.3 m/s at step 100 "
                                          r"\(200 such steps\)"):
        integrate(v, v.contact_geometry(), (get_terrain("ASPHALT"),), 25.0, t, tw, 0.0, 1.0)
    tw[:, 1] = 0.0
    tw[:, 0] = 0.3
    phys = integrate(v, v.contact_geometry(), (get_terrain("ASPHALT"),), 25.0, t, tw, 0.0,
                     1.0)
    assert phys.pose[-1, 0] > 0.5
    a = get_vehicle("agrimaro")
    tw[:, :2] = [0.0, 0.3]
    phys = integrate(a, a.contact_geometry(), (get_terrain("ASPHALT"),), 25.0, t, tw, 0.0,
                     1.0, np.zeros(3))
    assert phys.pose[-1, 1] > 0.5


def test_orchard_turn_command_ramps_at_2_rad_s2():
    """The orchard's yaw-rate command is rate-limited at 2 rad/s^2 (its speed at 0.5 m/s^2):
    the Husky's first U-turn starts at 40 s (20 m at 0.5 m/s) and its yaw rate reaches
    v / R = 1/3 rad/s after 0.17 s, 0.02 rad/s a step at 100 Hz. A limit of 20 rad/s^2 in
    place of 2 passed every test (the turn then started in two steps)."""
    cmd = make_commands("orchard", 100.0, 0.01, np.random.default_rng(0), 1.0, track_m=0.5708)
    yaw_rate_step = np.diff(cmd.twist[:, 2]) / 0.01
    assert np.abs(yaw_rate_step).max() == pytest.approx(2.0, rel=1e-9)
    assert np.abs(np.diff(cmd.twist[:, 0]) / 0.01).max() == pytest.approx(0.5, rel=1e-9)
    first = int(np.flatnonzero(cmd.twist[:, 2] > 0.0)[0])
    assert cmd.t_s[first] == pytest.approx(40.0, abs=1e-9)
    np.testing.assert_allclose(cmd.twist[first:first + 20:5, 2], [0.02, 0.12, 0.22, 0.32],
                               atol=1e-12)
    np.testing.assert_allclose(cmd.twist[first + 17:first + 300, 2], 1.0 / 3.0, atol=1e-12)


@pytest.mark.parametrize("t_s", [0.5, np.float64(0.5), None, np.zeros((1, 5))])
def test_integrate_refuses_a_time_grid_that_is_not_one_dimensional(t_s):
    """A number or None as the time grid raised Python's bare TypeError ('object of type
    'float' has no len()') from the two-step check, which ran before the shape check; a
    (1, 5) array was called a grid of 1 step. Each is a ShapeError now; a grid of one time
    is still refused as too short."""
    v = get_vehicle("husky")
    with pytest.raises(ShapeError, match="t_s must be one-dimensional"):
        integrate(v, v.contact_geometry(), (get_terrain("ASPHALT"),), 25.0, t_s,
                  np.zeros((5, 3)), 0.0, 1.0)
    with pytest.raises(ConfigError, match="needs at least 2 steps to integrate, got 1"):
        integrate(v, v.contact_geometry(), (get_terrain("ASPHALT"),), 25.0, np.zeros(1),
                  np.zeros((1, 3)), 0.0, 1.0)


@pytest.mark.parametrize("rate_hz, bandwidth_hz, match", [
    (0.0, 15.0, "rate_hz"), (float("nan"), 15.0, "rate_hz"), (-100.0, 15.0, "rate_hz"),
    (100.0, -15.0, "bandwidth_hz"), (100.0, float("nan"), "bandwidth_hz"),
    (100.0, True, "bandwidth_hz")])
def test_vibration_pole_refuses_a_rate_or_corner_it_cannot_use(rate_hz, bandwidth_hz, match):
    """vibration_pole(0, 15) raised a bare ZeroDivisionError, and a negative corner gave a
    pole of 2.57 (at 100 Hz, -15 Hz) whose coloured noise was NaN without a word; the
    valid range is unchanged (0.38966 at 100 Hz / 15 Hz, 1 with the vibration off)."""
    from terrain.sim.sensors import vibration_pole

    with pytest.raises(ConfigError, match=f"vibration_pole.{match}"):
        vibration_pole(rate_hz, bandwidth_hz)
    assert vibration_pole(100.0, 15.0) == pytest.approx(np.exp(-2 * np.pi * 0.15), rel=1e-15)
    assert vibration_pole(100.0, 0.0) == 1.0


@pytest.mark.slow
def test_batch_camera_noise_has_its_std_on_each_channel():
    """The simulated T265 stream is the camera point's velocity, the yaw rate and the yaw
    plus white noise of std cam_noise_m_s, cam_noise_m_s, cam_yaw_rate_noise_rad_s and
    cam_yaw_noise_rad (0.01, 0.01, 0.01, 0.002 by default); twice the velocity noise on
    v_cx survived every test."""
    from terrain.sim.sensors import interp_columns
    from terrain.sim.simulate import SimConfig, simulate_with_physics

    sim = simulate_with_physics(SimConfig(vehicle="agrimaro", terrains=("TILES",),
                                          scenario="random", duration_s=90.0, seed=4))
    cam, phys = sim.run.streams["cam"], sim.physics
    s = interp_columns(cam["t_s"].to_numpy(), phys.t_s,
                       np.column_stack([phys.twist, phys.pose[:, 2]]))
    lever = get_vehicle("agrimaro").camera_lever_arm_m
    truth = np.column_stack([s[:, 0] - s[:, 2] * lever[1], s[:, 1] + s[:, 2] * lever[0],
                             s[:, 2], s[:, 3]])
    resid = cam[["v_cx", "v_cy", "yaw_rate_c", "yaw_c"]].to_numpy() - truth
    assert len(resid) > 2000
    np.testing.assert_allclose(resid.std(axis=0), [0.01, 0.01, 0.01, 0.002], rtol=0.06)
    np.testing.assert_allclose(resid.mean(axis=0), 0.0, atol=0.001)


def test_online_current_noise_has_its_std():
    """The closed loop's current sensor adds white noise of std current_noise_a (0.08 A) to
    the drive's report before the magnitude and the 0.01 A quantum; twice that noise
    survived every test. A Husky wheel pair at 5 rad/s with 20 N m of torque each (about
    8 A, far from the fold at 0 A), sampled on every step."""
    from dataclasses import replace

    from terrain.sim.closed_loop import OnlineSensors
    from terrain.sim.dynamics import PlantSnapshot
    from terrain.sim.forces import reported_current_a
    from terrain.sim.simulate import DEFAULT_SENSORS

    every_step = replace(DEFAULT_SENSORS["husky"], wheel_rate_hz=100.0)
    s = OnlineSensors("husky", every_step, 3, 30.0)
    omega, torque = np.full(2, 5.0), np.full(2, 20.0)
    for k in range(2000):
        s.record(PlantSnapshot(k, 0.01 * k, np.zeros(3), np.zeros(3), np.zeros(2), omega,
                               np.zeros(2), omega, torque, 0.0, 0.0, 0))
    cur = s.take(20.0, omega).currents[:, 1:]
    true = reported_current_a(s.vehicle.motor, torque, omega)
    assert len(cur) == 2000 and true.min() > 5.0
    np.testing.assert_allclose(cur.std(axis=0), 0.08, rtol=0.06)
    np.testing.assert_allclose(cur.mean(axis=0), true, atol=0.006)


def test_online_camera_outages_last_half_a_second_to_two_seconds():
    """The controller's camera outages are drawn as the batch model's: a Poisson number at
    cam_outage_rate_hz over the run, each starting uniformly in it and lasting a uniform
    0.5-2 s (mean 1.25 s); lengths of 0.5-1 s survived every test. At 1 outage a second
    over 2000 s: about 2000 outages."""
    from dataclasses import replace

    from terrain.sim.closed_loop import OnlineSensors
    from terrain.sim.simulate import DEFAULT_SENSORS

    often = replace(DEFAULT_SENSORS["agrimaro"], cam_outage_rate_hz=1.0)
    out = np.array(OnlineSensors("agrimaro", often, 5, 2000.0).outages)
    assert abs(len(out) - 2000) < 4 * np.sqrt(2000)
    length = out[:, 1] - out[:, 0]
    assert length.min() >= 0.5 and length.max() < 2.0
    assert length.mean() == pytest.approx(1.25, abs=0.03)
    assert length.max() > 1.95 and length.min() < 0.55
    assert out[:, 0].min() >= 0.0 and out[:, 0].max() < 2000.0
    assert out[:, 0].mean() == pytest.approx(1000.0, abs=40.0)


def test_online_full_imu_at_rest_has_the_white_noise_of_its_settings():
    """At rest the vibration band is silent (vibration_level 0), so the closed loop's full
    IMU reads white noise of std gyro_noise_rad_s on wx, wy, wz (0.005 rad/s) and
    accel_noise_m_s2 on ax, ay, az (0.05 m/s^2) about (0, 0, 0, bias, bias, g + bias);
    twice the noise on az survived every test."""
    from terrain.sim.closed_loop import OnlineSensors
    from terrain.sim.dynamics import PlantSnapshot
    from terrain.sim.simulate import DEFAULT_SENSORS
    from terrain.terramechanics.resistance import G_M_S2

    s = OnlineSensors("husky", DEFAULT_SENSORS["husky"], 7, 30.0, terrains=("GRASS",))
    for k in range(3000):
        s.record(PlantSnapshot(k, 0.01 * k, np.zeros(3), np.zeros(3), np.zeros(2),
                               np.zeros(2), np.zeros(2), np.zeros(2), np.zeros(2), 0.0, 0.0,
                               0))
    full = s.take(30.0, np.zeros(2)).imu_full[:, 1:]
    assert len(full) == 3000
    np.testing.assert_allclose(full.std(axis=0), [0.005] * 3 + [0.05] * 3, rtol=0.06)
    assert full[:, 5].mean() == pytest.approx(G_M_S2 + s.accel_bias_z, abs=0.004)
    np.testing.assert_allclose(full[:, 3:5].mean(axis=0), s.accel_bias, atol=0.004)


def test_icr_expansion_moves_only_a_skid_steers_kinematic_contact_lines():
    """contact_layout places the kinematic contact lines at chi y for a skid-steer only (the
    ICR expansion of Mandow et al.); a steered vehicle's wheels roll where they are.
    Applying chi to the steered vehicle too survived every test."""
    from terrain.sim.forces import contact_layout

    for name, scaled in (("husky", True), ("tracked", True), ("agrimaro", False)):
        g = get_vehicle(name).contact_geometry()
        lay = contact_layout(g, 100.0, 0.0, 1.5)
        want = 1.5 * g.positions_m[:, 1] if scaled else g.positions_m[:, 1]
        np.testing.assert_array_equal(lay.y_kinematic_m, want)
        np.testing.assert_array_equal(lay.y_m, g.positions_m[:, 1])


def test_integrate_refuses_an_icr_expansion_for_a_steered_vehicle():
    """integrate took chi for every vehicle, but applies it to skid-steers only: an
    AgriMaRo integrated with chi 1.5 gave the run of chi 1 with nothing said (SimConfig
    refuses the planted effect; integrate itself did not). It is refused now, as a steering
    offset for a vehicle that does not steer is; chi 1 runs as before."""
    a = get_vehicle("agrimaro")
    t = np.arange(200) * 0.01
    tw = np.zeros((200, 3))
    tw[:, 0], tw[:, 2] = np.minimum(t, 0.5), 0.3
    with pytest.raises(ConfigError, match="this vehicle steers, so chi 1.5 would change"):
        integrate(a, a.contact_geometry(), (get_terrain("GRASS"),), 25.0, t, tw, 0.0, 1.5,
                  np.zeros(3))
    phys = integrate(a, a.contact_geometry(), (get_terrain("GRASS"),), 25.0, t, tw, 0.0, 1.0,
                     np.zeros(3))
    assert phys.pose[-1, 2] > 0.3


def test_minimum_duration_is_exact_where_the_period_is_a_whole_number_of_steps():
    """A 2.3 Hz wheel stream on 230 Hz physics: its period is 100 steps, but 1 / 2.3 * 230
    is 100.00000000000001 in floating point; minimum_duration_s keeps the 1e-9 s tolerance
    of sample_times and asks for 100 steps (a plain ceil asked for 101 and survived every
    test), and a run of that length holds the two wheel samples the readers need."""
    from dataclasses import replace

    from terrain.sim.simulate import DEFAULT_SENSORS, SimConfig, minimum_duration_s, simulate

    slow = replace(DEFAULT_SENSORS["husky"], wheel_rate_hz=2.3)
    minimum, why = minimum_duration_s("husky", slow, 230.0)
    assert minimum == 100 / 230.0
    assert "100 physics steps" in why
    run = simulate(SimConfig(scenario="spin", duration_s=minimum, sensors=slow,
                             physics_rate_hz=230.0))
    assert len(run.streams["wheels"]) == 2
    with pytest.raises(ConfigError, match="too short"):
        SimConfig(scenario="spin", duration_s=99 / 230.0, sensors=slow, physics_rate_hz=230.0)


@pytest.mark.parametrize("vehicle, terrain, physics", [
    ("husky", "ASPHALT", "v1"), ("husky", "ASPHALT", "v2"), ("husky", "SANDY_LOAM", "v2"),
    ("tracked", "SNOW", "v2"), ("husky", "ICE", "v2")])
def test_a_skid_steer_reversing_through_a_turn_gives_the_mirrored_run(vehicle, terrain,
                                                                      physics):
    """Reversing symmetry on level ground: a skid-steer is symmetric front to back, so
    (v_x, r) -> (-v_x, -r) must give (-x, y, -yaw), each motor's speed, torque and slip
    negated and the same reported current. A sign slip in the motion resistance, the
    longitudinal load transfer or the braking-current report breaks it."""
    from terrain.sim.forces import reported_current_a

    veh = get_vehicle(vehicle)
    t = np.arange(0.0, 2.0, 0.01)
    v_x = 0.6 if vehicle == "husky" else 0.3
    fwd_cmd = np.zeros((len(t), 3))
    fwd_cmd[:, 0], fwd_cmd[:, 2] = np.minimum(t, v_x), np.minimum(t, 0.4)
    runs = [integrate(veh, veh.contact_geometry(), (get_terrain(terrain),), 25.0, t, cmd,
                      0.0, 1.0, physics=physics) for cmd in (fwd_cmd, -fwd_cmd)]
    fwd, back = runs
    assert abs(fwd.pose[-1, 2]) > 0.2 and fwd.pose[-1, 0] > 0.3
    np.testing.assert_allclose(back.pose, fwd.pose * [-1.0, 1.0, -1.0], atol=1e-9)
    np.testing.assert_allclose(back.twist, fwd.twist * [-1.0, 1.0, -1.0], atol=1e-9)
    np.testing.assert_allclose(back.omega, -fwd.omega, atol=1e-9)
    np.testing.assert_allclose(back.torque, -fwd.torque, atol=1e-7)
    np.testing.assert_allclose(back.slip_motor, -fwd.slip_motor, atol=1e-9)
    np.testing.assert_allclose(
        reported_current_a(veh.motor, back.torque, back.omega, physics),
        reported_current_a(veh.motor, fwd.torque, fwd.omega, physics), atol=1e-7)


def test_every_vehicle_s_static_loads_balance_at_its_centre_of_gravity():
    """One c.o.g.: the point the static load shares balance (ContactGeometry.cog_m, where the
    simulator puts the mass) is the AgriMaRo's assumed one (AgriMaRoParams.cog_m, the wheel
    triangle's centroid, 0.252 m right of the origin) and the origin for the skid-steers."""
    agrimaro = get_vehicle("agrimaro")
    np.testing.assert_allclose(agrimaro.contact_geometry().cog_m, agrimaro.cog_m, atol=1e-12)
    np.testing.assert_allclose(agrimaro.cog_m, [0.0, -0.252], atol=1e-12)
    for name in ("husky", "tracked"):
        np.testing.assert_array_equal(get_vehicle(name).contact_geometry().cog_m, 0.0)


def test_rigid_body_terms_are_newton_and_euler_at_the_centre_of_gravity():
    """M dV/dt = F + q(V) for the body-origin twist equals m a_G = F and
    I_G dr/dt = M_O - c x F at the c.o.g. (random values)."""
    from terrain.sim.forces import rigid_body_terms
    rng = np.random.default_rng(0)
    m, i_g = 150.0, 20.0
    c = rng.normal(size=2)
    v = rng.normal(size=3)
    f = rng.normal(size=3) * 100.0
    mass_matrix, transport = rigid_body_terms(m, i_g, c)
    q = m * v[2] * (transport @ v)
    dv = np.linalg.solve(mass_matrix, f + q)
    vx, vy, r = v
    a_g = np.array([dv[0] - r * vy - dv[2] * c[1] - r * r * c[0],
                    dv[1] + r * vx + dv[2] * c[0] - r * r * c[1]])
    np.testing.assert_allclose(m * a_g, f[:2], rtol=1e-10)
    assert i_g * dv[2] == pytest.approx(f[2] - (c[0] * f[1] - c[1] * f[0]), rel=1e-10)
