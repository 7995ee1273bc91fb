"""sim25 review: contracts between the simulator and the modules it shares quantities with.

Each test crosses a seam: the simulator's streams or truth against the function of
:mod:`terrain.vehicles` (or :mod:`terrain.terramechanics`) that defines the quantity, or a
batch stream against the closed loop's online view of the same samples.
"""

from __future__ import annotations

import importlib

import numpy as np
import pytest

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
