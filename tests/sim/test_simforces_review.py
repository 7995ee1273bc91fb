"""Review of the simulator's force model, sensors, closed loop, digest and scenarios.

Each test pins a behaviour that a hand mutant of terrain/sim/{forces,sensors,closed_loop,
digest,scenarios}.py changed without any other test of tests/sim noticing (mutant ids in the
comments; the review's report lists them).
"""

import importlib
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

from terrain.errors import ConfigError
from terrain.sim import make_commands
from terrain.sim.closed_loop import OnlineSensors
from terrain.sim.digest import source_digest
from terrain.sim.dynamics import PlantSnapshot
from terrain.sim.forces import SLIDE_SPEED_M_S, contact_forces, contact_layout, velocity_maps
from terrain.sim.sensors import SensorSettings, gravity_specific_force, imu, vibration_pole
from terrain.sim.simulate import DEFAULT_SENSORS
from terrain.terramechanics.catalogue import get_terrain
from terrain.terramechanics.resistance import G_M_S2
from terrain.vehicles import HUSKY


def test_vibration_pole_is_the_corner_frequency_in_rad_s_over_the_rate():
    # kills S2 (f_c in Hz taken as rad/s, half the corner): the existing check compares
    # exp(-94) with exp(-47), both below pytest.approx's absolute tolerance of 1e-12
    for rate in (50.0, 100.0, 400.0):
        assert np.log(vibration_pole(rate, 15.0)) == pytest.approx(-2 * np.pi * 15.0 / rate,
                                                                   rel=1e-12)
    # the -3 dB point of the discrete filter y_k = a y_(k-1) + (1 - a) x_k sits near f_c
    a = vibration_pole(1000.0, 15.0)
    z = np.exp(2j * np.pi * 15.0 / 1000.0)
    gain = abs((1 - a) / (1 - a / z))
    assert gain == pytest.approx(1 / np.sqrt(2), rel=0.02)


@pytest.mark.parametrize("field", ["gyro_noise_rad_s", "accel_bias_std_m_s2",
                                   "current_quantum_a", "cam_outage_rate_hz"])
def test_a_negative_noise_level_resolution_or_outage_rate_is_refused(field):
    # kills S16 (the >= 0 check of the non-rate settings loosened to >= -1)
    with pytest.raises(ConfigError, match=f"sensor setting {field} must be finite and >= 0"):
        SensorSettings(**{field: -0.5})
    SensorSettings(**{field: 0.0})                      # 0: off, allowed


def _cam_snap(k, t):
    z2, z3 = np.zeros(2), np.zeros(3)
    return PlantSnapshot(k, t, z3, np.array([0.3, 0.0, 0.0]), z2, z3, z3, z3, z3, 0.0, 0.0, 0)


def test_online_camera_drops_exactly_the_samples_inside_each_outage_and_counts_them():
    # kills C2 (an outage held 0.05 s past its end) and C3 (dropped rows not counted):
    # at 30 Hz on a 100 Hz physics grid, an outage [0.5, 1.0) removes the samples due at
    # 0.5, 0.533, ..., 0.967 s (15 of them) and no other
    sensors = OnlineSensors("agrimaro", replace(DEFAULT_SENSORS["agrimaro"],
                                                cam_outage_rate_hz=0.0), 0, 2.0)
    assert sensors.outages == []
    sensors.outages = [(0.5, 1.0)]
    for k in range(201):
        sensors.record(_cam_snap(k, 0.01 * k))
    cam_t = sensors.take(2.0, np.zeros(3)).cam[:, 0]
    due = np.arange(61) / 30.0                       # the camera's nominal sample times
    taken = np.ceil(due * 100.0 - 1e-6) / 100.0      # the first physics step at or after
    inside = (taken >= 0.5) & (taken < 1.0)
    np.testing.assert_allclose(cam_t, taken[~inside], atol=1e-9)
    assert sensors.cam_rows_dropped == int(inside.sum()) == 15


def test_online_full_imu_carries_the_per_run_accelerometer_bias_on_az_too():
    # kills C8 (no z bias on the online full IMU; the batch IMU has one on all three axes):
    # without white noise and vibration, az at rest reads g + a constant bias whose spread
    # over runs is accel_bias_std_m_s2
    quiet = replace(DEFAULT_SENSORS["husky"], accel_noise_m_s2=0.0, gyro_noise_rad_s=0.0,
                    accel_bias_std_m_s2=0.1)
    z2, z3 = np.zeros(2), np.zeros(3)
    biases = []
    for seed in range(40):
        s = OnlineSensors("husky", quiet, seed, 1.0)
        for k in range(3):
            s.record(PlantSnapshot(k, 0.01 * k, z3, z3, z2, z2, z2, z2, z2, 0.0, 0.0, 0))
        az = s.take(0.02, np.zeros(2)).imu_full[:, 6]
        assert len(az) == 3 and np.ptp(az) == 0.0
        biases.append(az[0] - G_M_S2)
    assert np.std(biases) == pytest.approx(0.1, rel=0.4)


def test_online_steering_encoders_report_the_12_bit_resolution():
    # kills C10 (online steering angles not quantised, unlike the batch steer stream)
    q = DEFAULT_SENSORS["agrimaro"].steer_quantum_rad
    assert q == pytest.approx(2 * np.pi / 4096)
    delta = np.array([0.1234567, -0.5 * q + 1e-7, 3.3 * q])
    z2, z3 = np.zeros(2), np.zeros(3)
    s = OnlineSensors("agrimaro", DEFAULT_SENSORS["agrimaro"], 0, 1.0)
    s.record(PlantSnapshot(0, 0.0, z3, z3, z2, z3, delta, z3, z3, 0.0, 0.0, 0))
    steer = s.take(0.0, np.zeros(3)).steer
    np.testing.assert_allclose(steer[0, 1:], np.round(delta / q) * q, rtol=0, atol=1e-15)
    np.testing.assert_allclose(steer[0, 1:] / q, [np.round(0.1234567 / q), 0.0, 3.0])


def test_a_duration_shorter_than_half_a_physics_step_is_refused():
    # kills Sc4 (n < 1 instead of n < 2: 4 ms at 10 ms steps gave a single-sample command)
    with pytest.raises(ConfigError, match="shorter than one physics step"):
        make_commands("spin", 0.004, 0.01, np.random.default_rng(0), 1.0)
    assert len(make_commands("spin", 0.006, 0.01, np.random.default_rng(0), 1.0).t_s) == 2


@pytest.mark.parametrize("max_speed, track, match", [
    (-1.0, 0.0, "make_commands.max_speed_m_s must be"),
    (float("nan"), 0.0, "make_commands.max_speed_m_s must be"),
    (0.0, 0.0, "make_commands.max_speed_m_s must be"),
    (1.0, -0.5, "make_commands.track_m must be"),
    (1.0, float("nan"), "make_commands.track_m must be")])
def test_make_commands_refuses_a_speed_limit_or_track_that_is_not_a_finite_length(
        max_speed, track, match):
    # a speed limit of -1 m/s drove straight_accel backwards at -0.95 m/s, NaN drove it at
    # 1 m/s (min(1.0, nan) is 1.0); a negative track raised orchard's speed above the limit
    with pytest.raises(ConfigError, match=match):
        make_commands("straight_accel", 2.0, 0.01, np.random.default_rng(0), max_speed,
                      track_m=track)


@pytest.mark.parametrize("seed, duration, match", [
    (-1, 5.0, "OnlineSensors.seed must be an integer >= 0"),
    (1.5, 5.0, "OnlineSensors.seed must be an integer >= 0"),
    (0, -5.0, "OnlineSensors.duration_s must be"),
    (0, float("nan"), "OnlineSensors.duration_s must be")])
def test_online_sensors_refuse_a_bad_seed_or_duration_with_a_typed_error(seed, duration, match):
    # a seed of -1 was numpy's ValueError "expected non-negative integer", a duration of
    # -5 s or NaN its "lam < 0 or lam is NaN" (the camera outages' Poisson draw)
    with pytest.raises(ConfigError, match=match):
        OnlineSensors("agrimaro", DEFAULT_SENSORS["agrimaro"], seed, duration)
    # SimConfig's rule: a whole float is a seed, and the same seed gives the same draws
    assert (OnlineSensors("agrimaro", DEFAULT_SENSORS["agrimaro"], 3.0, 60.0).outages
            == OnlineSensors("agrimaro", DEFAULT_SENSORS["agrimaro"], 3, 60.0).outages)


def test_the_coulomb_lateral_friction_acts_on_the_transferred_normal_loads():
    # kills F23 (the Coulomb lateral law of v1 / rigid surfaces fed the static loads while
    # the longitudinal law had the transferred ones): sliding sideways at 0.1 m/s with the
    # front wheels carrying more load, each contact pulls -mu_lat N_i tanh(v / 0.02 m/s),
    # so the yaw moment is -mu_lat tanh(5) sum(x_i N_i), not 0 as with equal loads
    geo = HUSKY.contact_geometry()
    layout = contact_layout(geo, HUSKY.mass_kg, 0.0, 1.0)
    maps = velocity_maps(layout, np.zeros_like(layout.x_m))
    terrain = get_terrain("ASPHALT")
    x = layout.x_m
    loads = layout.normal_load_n * (1.0 + 0.4 * np.sign(x))       # sums to the weight
    assert loads.sum() == pytest.approx(layout.normal_load_n.sum())
    cf = contact_forces(layout, maps, terrain, np.array([0.0, 0.1, 0.0]), np.zeros(2),
                        normal_load_n=loads)
    slide = terrain.lateral_friction * np.tanh(0.1 / SLIDE_SPEED_M_S)
    assert cf.force[1] == pytest.approx(-slide * loads.sum(), rel=1e-9)
    assert cf.force[2] == pytest.approx(-slide * float(x @ loads), rel=1e-9)
    assert abs(cf.force[2]) > 10.0


def test_the_icr_expansion_moves_the_kinematic_lines_not_where_the_forces_act():
    # kills F24 (the longitudinal forces applied at the kinematic lines chi y): with the
    # ICR expansion chi = 1.5 the slip sees the contacts at chi y, but the traction acts
    # at the geometric contacts, M_z = -sum y_i N_i mu_i (Mandow et al. 2007)
    geo = HUSKY.contact_geometry()
    layout = contact_layout(geo, HUSKY.mass_kg, 0.0, 1.5)
    np.testing.assert_allclose(layout.y_kinematic_m, 1.5 * layout.y_m)
    maps = velocity_maps(layout, np.zeros_like(layout.x_m))
    cf = contact_forces(layout, maps, get_terrain("ASPHALT"), np.zeros(3),
                        np.array([-2.0, 2.0]))                 # spinning left on the spot
    f_long = layout.normal_load_n * cf.mu                       # at rest: no soil term
    assert cf.force[0] == pytest.approx(f_long.sum(), abs=1e-9)
    assert cf.force[2] == pytest.approx(-(layout.y_m * f_long).sum(), rel=1e-12)
    assert cf.force[2] > 50.0


def test_batch_imu_adds_the_gravity_specific_force_on_each_accelerometer_axis():
    # kills S19 (gravity subtracted on ay): standing still (no vibration: level 0) with the
    # right side 0.2 rad down and the nose 0.1 rad up, a noise-free IMU reads the specific
    # force of gravity, +g sin(roll)-ish on ay (the left axis points up the slope)
    n = 3
    phys = SimpleNamespace(t_s=np.array([0.0, 0.5, 1.0]), twist=np.zeros((n, 3)),
                           accel_body=np.zeros((n, 2)), pose=np.zeros((n, 3)),
                           pitch=np.full(n, 0.1), roll=np.full(n, 0.2),
                           terrain_index=np.zeros(n, dtype=int))
    quiet = SensorSettings(gyro_noise_rad_s=0.0, accel_noise_m_s2=0.0,
                           accel_bias_std_m_s2=0.0)
    t, data = imu(phys, (get_terrain("ASPHALT"),), quiet, 0.0, np.random.default_rng(0), 1.0)
    g_x, g_y, g_z = gravity_specific_force(np.full(len(t), 0.1), np.full(len(t), 0.2))
    np.testing.assert_allclose(data[:, 3:], np.column_stack([g_x, g_y, g_z]), atol=1e-12)
    assert (data[:, 4] > 0.19 * G_M_S2).all() and (data[:, 3] > 0.09 * G_M_S2).all()
    np.testing.assert_allclose(np.linalg.norm(data[:, 3:], axis=1), G_M_S2, rtol=1e-12)


def test_online_gyro_and_accelerometer_draw_their_own_noise():
    # kills C13 (wz reused ay's normal draw): at rest, the white noise of ax, ay and wz are
    # uncorrelated, each with its configured std per sample
    s = OnlineSensors("husky", DEFAULT_SENSORS["husky"], 0, 5.0)
    z2, z3 = np.zeros(2), np.zeros(3)
    for k in range(400):
        s.record(PlantSnapshot(k, 0.01 * k, z3, z3, z2, z2, z2, z2, z2, 0.0, 0.0, 0))
    imu = s.take(4.0, np.zeros(2)).imu
    assert len(imu) == 400
    corr = np.corrcoef(imu[:, 1:4].T)
    assert np.abs(corr[np.triu_indices(3, 1)]).max() < 0.2
    std = imu[:, 1:4].std(axis=0)
    sens = DEFAULT_SENSORS["husky"]
    np.testing.assert_allclose(std, [sens.accel_noise_m_s2, sens.accel_noise_m_s2,
                                     sens.gyro_noise_rad_s], rtol=0.15)


def test_online_full_imu_senses_gravity_on_ay_with_the_right_side_down():
    # kills C14 (gravity subtracted on the online ay): like the batch IMU, a roll of 0.2 rad
    # (right side down) reads g sin(0.2) on ay, the vibration-free view none
    quiet = replace(DEFAULT_SENSORS["husky"], accel_noise_m_s2=0.0, gyro_noise_rad_s=0.0,
                    accel_bias_std_m_s2=0.0)
    s = OnlineSensors("husky", quiet, 0, 1.0)
    z2, z3 = np.zeros(2), np.zeros(3)
    s.record(PlantSnapshot(0, 0.0, z3, z3, z2, z2, z2, z2, z2, 0.0, 0.2, 0))
    obs = s.take(0.0, np.zeros(2))
    g_x, g_y, g_z = gravity_specific_force(np.array([0.0]), np.array([0.2]))
    np.testing.assert_allclose(obs.imu_full[0, 4:], [g_x[0], g_y[0], g_z[0]], atol=1e-12)
    assert obs.imu_full[0, 5] == pytest.approx(G_M_S2 * np.sin(0.2), rel=1e-12)
    np.testing.assert_allclose(obs.imu[0, 1:3], 0.0, atol=1e-12)


def test_online_full_imu_shakes_when_turning_on_the_spot():
    # kills C15 (online vibration level without the yaw-rate term): spinning at 1 rad/s on
    # the spot the vibration level is sqrt(0.3 m/s / v_ref), as in the batch model
    quiet = replace(DEFAULT_SENSORS["husky"], accel_noise_m_s2=0.0, gyro_noise_rad_s=0.0,
                    accel_bias_std_m_s2=0.0)
    s = OnlineSensors("husky", quiet, 0, 5.0, terrains=("SNOW",))
    z2, z3 = np.zeros(2), np.zeros(3)
    spin = np.array([0.0, 0.0, 1.0])
    for k in range(500):
        s.record(PlantSnapshot(k, 0.01 * k, z3, spin, z2, z2, z2, z2, z2, 0.0, 0.0, 0))
    wx = s.take(5.0, np.zeros(2)).imu_full[50:, 1]
    snow = get_terrain("SNOW")
    expect = snow.vib_gyro_rad_s * np.sqrt(0.3 / snow.vib_speed_m_s)
    assert expect > 0
    assert wx.std() == pytest.approx(expect, rel=0.3)


def test_closed_loop_refuses_a_steered_vehicles_camera_faster_than_the_physics():
    # kills C18 (the camera left out of the rate check): a 200 Hz camera on 100 Hz physics
    # would deliver 100 Hz; the AgriMaRo's steering encoders and camera are checked too
    from terrain.sim.closed_loop import simulate_closed_loop
    from terrain.sim.simulate import SimConfig
    fast = replace(DEFAULT_SENSORS["agrimaro"], cam_rate_hz=200.0)
    config = SimConfig(vehicle="agrimaro", terrains=("GRASS",), scenario="spin",
                       duration_s=0.5, seed=0, sensors=fast)
    with pytest.raises(ConfigError, match="cam_rate_hz 200 Hz"):
        simulate_closed_loop(config, lambda observation: None)


def test_simulator_digest_follows_the_default_physics_version(monkeypatch):
    # kills D5 (the default physics version left out of the digest): SimConfig's default
    # physics decides every cached run that does not name one
    import terrain.sim.digest as digest
    from terrain.sim.digest import simulator_digest
    from terrain.sim.simulate import SimConfig
    before = simulator_digest("husky", ("SNOW",))
    monkeypatch.setattr(digest, "SimConfig", lambda: SimpleNamespace(physics="v2"))
    assert simulator_digest("husky", ("SNOW",)) != before
    monkeypatch.setattr(digest, "SimConfig", SimConfig)
    assert simulator_digest("husky", ("SNOW",)) == before


def test_source_digest_of_a_package_with_a_subpackage_sorting_first(tmp_path, monkeypatch):
    # the files of a package were made relative to the folder of the first one in sorted
    # order: a subpackage whose name sorts before "__init__.py" (upper case, "Models")
    # became that root, and the package's own files raised ValueError ("is not in the
    # subpath"); the root is the package's folder
    monkeypatch.syspath_prepend(str(tmp_path))
    pkg = tmp_path / "digest_probe_upper"
    (pkg / "Models").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "Models" / "__init__.py").write_text("")
    (pkg / "Models" / "tyre.py").write_text("K_S = 0.6\n")
    importlib.invalidate_caches()
    before = source_digest(["digest_probe_upper"])
    assert len(before) == 40
    (pkg / "Models" / "tyre.py").write_text("K_S = 0.7\n")
    assert source_digest(["digest_probe_upper"]) != before
