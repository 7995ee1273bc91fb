"""sim25 review: contracts between the simulator and the modules it shares quantities with.

Each test crosses a seam: the simulator's streams or truth against the function of
:mod:`terrain.vehicles` (or :mod:`terrain.terramechanics`) that defines the quantity, or a
batch stream against the closed loop's online view of the same samples.
"""

from __future__ import annotations

import importlib

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from terrain.sim import SensorSettings, SimConfig, simulate_with_physics
from terrain.sim.closed_loop import replay_observations
from terrain.vehicles import get_vehicle, point_velocity

# the modules (terrain.sim's ``simulate`` attribute is the function of that name)
simulate_module = importlib.import_module("terrain.sim.simulate")
closed_loop = importlib.import_module("terrain.sim.closed_loop")

QUIET_CAMERA = SensorSettings(wheel_rate_hz=50.0, speed_quantum_m_s=0.0,
                              current_quantum_a=0.01, cam_noise_m_s=0.0,
                              cam_yaw_rate_noise_rad_s=0.0, cam_yaw_noise_rad=0.0,
                              cam_outage_rate_hz=0.0)


@pytest.fixture(scope="module")
def agrimaro_turning():
    return simulate_with_physics(SimConfig(vehicle="agrimaro", terrains=("ASPHALT",),
                                           scenario="spin", duration_s=6.0, seed=4,
                                           sensors=QUIET_CAMERA))


def _spy(monkeypatch, module):
    """Count the calls of ``module.point_velocity`` (the simulator's camera point must come
    from the one home of ``v + Omega x d``, :func:`terrain.vehicles.point_velocity`)."""
    calls = []

    def spy(*args):
        calls.append(args)
        return point_velocity(*args)

    monkeypatch.setattr(module, "point_velocity", spy, raising=True)
    return calls


def test_the_batch_camera_velocity_is_the_vehicles_point_velocity(monkeypatch,
                                                                  agrimaro_turning):
    """The ``cam`` stream without noise is the velocity of the camera point that
    :func:`terrain.vehicles.point_velocity` gives for the truth at the camera's times (the
    relation the AgriMaRo EKF's h(x) uses), computed by that function, not by a copy."""
    calls = _spy(monkeypatch, simulate_module)
    sim = simulate_with_physics(agrimaro_turning.config)
    assert calls, "simulate computed the camera point's velocity with its own copy of eq. 5.4"
    cam = sim.run.streams["cam"]
    phys = sim.physics
    lever = get_vehicle("agrimaro").camera_lever_arm_m
    vx, vy, r = (np.interp(cam["t_s"], phys.t_s, phys.twist[:, j]) for j in range(3))
    want_x, want_y = point_velocity(vx, vy, r, lever[0], lever[1])
    np.testing.assert_array_equal(cam["v_cx"], want_x)
    np.testing.assert_array_equal(cam["v_cy"], want_y)
    assert np.ptp(r) > 0.1        # the run turns: the lever arm matters


def test_the_online_camera_velocity_is_the_vehicles_point_velocity(monkeypatch,
                                                                   agrimaro_turning):
    """The closed loop's camera rows are :func:`terrain.vehicles.point_velocity` of the
    plant at the row's step, computed by that function; they equal the batch stream's rows
    at the same times (the camera's 30 Hz samples that fall on a physics step)."""
    calls = _spy(monkeypatch, closed_loop)
    obs = list(replay_observations(agrimaro_turning, 50.0))
    assert calls, "the online camera computed its velocity with its own copy of eq. 5.4"
    cam = np.vstack([o.cam for o in obs if len(o.cam)])
    phys = agrimaro_turning.physics
    k = np.searchsorted(phys.t_s, cam[:, 0])
    lever = get_vehicle("agrimaro").camera_lever_arm_m
    want_x, want_y = point_velocity(phys.twist[k, 0], phys.twist[k, 1], phys.twist[k, 2],
                                    lever[0], lever[1])
    np.testing.assert_array_equal(cam[:, 1], want_x)
    np.testing.assert_array_equal(cam[:, 2], want_y)
    batch = agrimaro_turning.run.streams["cam"]
    on_step = np.isin(np.round(batch["t_s"].to_numpy(), 9), np.round(cam[:, 0], 9))
    common = np.isin(np.round(cam[:, 0], 9), np.round(batch["t_s"].to_numpy(), 9))
    assert on_step.sum() > 10
    np.testing.assert_allclose(cam[common, 1], batch["v_cx"].to_numpy()[on_step],
                               rtol=0, atol=1e-12)
    np.testing.assert_allclose(cam[common, 2], batch["v_cy"].to_numpy()[on_step],
                               rtol=0, atol=1e-12)


# --- the truth's slip is the slip module's definition -------------------------------------

@pytest.mark.parametrize("vehicle, scenario", [("husky", "orchard"), ("tracked", "random"),
                                               ("agrimaro", "random")])
def test_the_truth_slip_is_what_the_slip_module_computes_from_the_truth(vehicle, scenario):
    """``slip_i`` of the truth is the SAE slip :mod:`terrain.slip.core` computes from the
    true rim speeds and body motion (skid-steer: the sides at ``+-B/2``; swerve: each wheel's
    steering axis along its true steering angle), with no dead band; the simulator's speed
    floor (0.02 m/s) only matters below it, so the moving samples are compared."""
    from terrain.slip.core import skid_steer_side_slip, wheel_slip

    sim = simulate_with_physics(SimConfig(vehicle=vehicle, terrains=("SNOW",),
                                          scenario=scenario, duration_s=12.0, seed=1))
    p, v = sim.physics, get_vehicle(vehicle)
    geometry = v.contact_geometry()
    rim = p.omega * geometry.wheel_radius_m
    if geometry.steered:
        want = wheel_slip(rim, p.twist[:, 0], p.twist[:, 1], p.twist[:, 2],
                          geometry.positions_m, p.delta, dead_band_m_s=0.0)
    else:
        want = skid_steer_side_slip(rim, p.twist[:, 0], p.twist[:, 2], v.track_m,
                                    dead_band_m_s=0.0)
    moving = np.abs(rim).min(axis=1) > 0.05
    assert moving.sum() > 500 and np.abs(p.slip_motor[moving]).max() > 0.01
    np.testing.assert_allclose(p.slip_motor[moving], want[moving], rtol=0, atol=1e-12)
    truth = sim.run.streams["truth"]
    k = np.searchsorted(p.t_s, truth["t_s"].to_numpy() - 1e-9)
    for i in range(geometry.n_motors):
        np.testing.assert_array_equal(truth[f"slip_{i + 1}"], p.slip_motor[k, i])


# --- a simulated left turn reads like a measured one ---------------------------------------

def _left_turn_signs(run) -> tuple[float, float, float, float]:
    """Correlation of ``wz`` with ``vel_r - vel_l`` at the wheel times, the smallest current,
    the mean ``az`` (m/s^2) and the mean ``|wz|`` (rad/s) of a run."""
    imu, wheels = run.streams["imu"], run.streams["wheels"]
    wz = np.interp(wheels["t_s"], imu["t_s"], imu["wz"])
    turn = (wheels["vel_r"] - wheels["vel_l"]).to_numpy()
    corr = float(np.corrcoef(wz, turn)[0, 1])
    cur = float(wheels[["cur_l", "cur_r"]].to_numpy().min())
    return corr, cur, float(imu["az"].mean()), float(np.abs(imu["wz"]).mean())


@pytest.mark.slow
def test_a_simulated_left_turn_has_the_signs_of_a_measured_left_turn(borealtc_runs):
    """BorealTC's Husky turns left (``vel_r > vel_l``) with ``wz > 0``, reports current
    magnitudes (>= 0) and reads ``az = +g`` at rest; the simulated Husky's files follow
    the same conventions (gyro z up, right minus left, currents as magnitudes even while
    braking, specific force z up)."""
    measured = next(r for r in borealtc_runs if r.run_id == "borealtc/ASPHALT/00")
    m_corr, m_cur, m_az, _ = _left_turn_signs(measured)
    assert m_corr > 0.8 and m_cur >= 0.0 and 9.6 < m_az < 10.0      # the data's conventions
    sim = simulate_with_physics(SimConfig(vehicle="husky", terrains=("ASPHALT",),
                                          scenario="orchard", duration_s=60.0, seed=2))
    s_corr, s_cur, s_az, s_wz = _left_turn_signs(sim.run)
    assert s_corr > 0.8 and s_cur >= 0.0 and 9.6 < s_az < 10.0 and s_wz > 0.05
    # and the orchard's first U-turn is a left turn: positive yaw rate, the pose turning
    # counter-clockwise (y grows while heading +x)
    p = sim.physics
    first = np.flatnonzero(np.abs(p.twist[:, 2]) > 0.1)[0]
    assert p.twist[first, 2] > 0 and p.omega[first, 1] > p.omega[first, 0]
    assert p.pose[first + 100, 1] > p.pose[first, 1]


# --- the IMU's gravity is the integrator's gravity -----------------------------------------

@settings(max_examples=200, deadline=None)
@given(slope=st.floats(-0.6, 0.6), yaw=st.floats(-10.0, 10.0))
def test_the_imu_senses_the_specific_force_the_integrator_applies(slope, yaw):
    """On the plane of a scenario (rising along world +x), the accelerometer's gravity
    (:func:`terrain.sim.sensors.gravity_specific_force` of the truth's pitch and roll,
    :func:`terrain.sim.dynamics.slope_attitude`) is the in-plane specific force of the
    gravity the integrator applies at rest (:func:`terrain.sim.forces.specific_force_m_s2`
    of :func:`terrain.sim.forces.gravity_force`), and ``az`` is ``g cos(slope)``."""
    from terrain.sim.dynamics import slope_attitude
    from terrain.sim.forces import gravity_force, specific_force_m_s2
    from terrain.sim.sensors import gravity_specific_force
    from terrain.terramechanics.resistance import G_M_S2

    pitch, roll = slope_attitude(slope, yaw)
    g_x, g_y, g_z = gravity_specific_force(np.array([pitch]), np.array([roll]))
    mass = 50.0
    want = specific_force_m_s2(np.zeros(2), gravity_force(mass, slope, yaw), mass)
    np.testing.assert_allclose([g_x[0], g_y[0]], want, rtol=0, atol=1e-9)
    assert g_z[0] == pytest.approx(G_M_S2 * np.cos(slope), abs=1e-12)


# --- terrain simulate's files read back with the simulator's values -------------------------

@pytest.mark.slow
def test_a_mixed_agrimaro_run_reads_back_with_the_simulators_values(tmp_path):
    """Every stream (camera rows missing in outages, the per-sample terrain labels of a
    MIXED run included) and every metadata field the simulator wrote come back from
    :func:`terrain.io.measured.read_runs_dir` with the simulator's names and values (to
    the files' printed digits); the outage shows as the camera's gap."""
    from terrain.io.measured import read_runs_dir
    from terrain.io.writer import write_run

    sim = simulate_with_physics(SimConfig(vehicle="agrimaro", terrains=("ASPHALT", "SNOW"),
                                          scenario="random", duration_s=12.0, seed=8,
                                          segment_length_m=1.0))
    # (seed 8: an outage at 1.57-2.64 s; seed 1's, at 11.80 s, ran past the end of the run
    # once the steering offsets stopped drawing from the run's generator, 2026-11-30)
    run = sim.run
    assert run.meta["cam_outages_s"], "the seed should plant a camera outage"
    write_run(run, tmp_path)
    (back,) = read_runs_dir(tmp_path, "sim")
    assert (back.dataset, back.terrain, back.vehicle) == ("sim", "MIXED", "agrimaro")
    assert set(back.streams) == set(run.streams)
    for name, frame in run.streams.items():
        got = back.streams[name]
        assert set(got.columns) == set(frame.columns), name
        assert len(got) == len(frame), name
        for col in frame.columns:
            if frame[col].dtype.kind == "f":
                np.testing.assert_allclose(got[col], frame[col], rtol=1e-7, atol=1e-6,
                                           err_msg=f"{name}.{col}")
            else:
                assert list(got[col].astype(str)) == list(frame[col].astype(str)), name
    assert set(run.streams["truth"]["terrain"]) == {"ASPHALT", "SNOW"}
    for key, value in run.meta.items():
        assert back.meta[key] == value, key
    (start, end), = run.meta["cam_outages_s"]
    (g0, g1), = back.meta["gaps"]["cam"]
    assert g0 < start and end <= g1 + 1e-6


# --- the closed loop's encoder and the logged omega stream ---------------------------------

def test_the_online_encoder_reports_the_logged_omega_stream_from_the_first_sample(
        agrimaro_turning):
    """The AgriMaRo's encoder (speed quantum 0: count rate, driver filter) at 50 Hz on a
    100 Hz physics grid: the closed loop's wheel rows and the logged ``omega`` stream are the
    same samples, so they hold the same speeds from the first on."""
    obs = list(replay_observations(agrimaro_turning, 50.0))
    online = np.vstack([o.wheels for o in obs if len(o.wheels)])
    logged = agrimaro_turning.run.streams["omega"]
    n = min(len(online), len(logged))
    assert n > 100
    np.testing.assert_array_equal(online[:n, 0], logged["t_s"].to_numpy()[:n])
    np.testing.assert_allclose(online[:n, 1:], logged[["omega_1", "omega_2", "omega_3"]]
                               .to_numpy()[:n], rtol=0, atol=1e-9)
