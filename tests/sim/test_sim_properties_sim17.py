"""Physical invariants of the simulator as properties (sim17 review).

* time-shift invariance: a run that stands still for some steps before its commands start
  is the run without the wait, shifted by it (the vehicle at rest stays exactly at rest);
  moving the whole time grid (``t_s + T``) changes nothing but the rounding of the step;
* the AgriMaRo (three-wheel swerve drive) is symmetric under the front/back mirror ``x ->
  -x`` of its wheels (seed 001 ch. 7.2: wheels 1 and 2 at ``x = -+0.5075``, wheel 3 at
  ``x = 0``): the mirrored command ``(-v_x, v_y, -yaw_rate)`` gives the mirrored run, wheel 1
  and wheel 2 swapping speeds (reversed) and steering angles (negated), wheel 3 reversed;
* on a grade with no command the vehicle never climbs: facing uphill it does not move
  uphill, and the motors hold it with a torque that pushes uphill;
* a driven wheel on level ground with positive slip (rim faster than the ground) has a
  positive traction coefficient and asks its motor for a positive torque;
* a closed-loop hook that never corrects gives the open-loop run bit for bit
  (:func:`integrate`'s docstring);
* the controller's observations are the same samples whatever its rate: the rows of the
  calls of :func:`replay_observations` at one rate, concatenated, are those at another.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from terrain.sim import SimConfig
from terrain.sim.closed_loop import replay_observations
from terrain.sim.dynamics import integrate
from terrain.sim.forces import (contact_forces, contact_layout, contact_torque_nm,
                                velocity_maps)
from terrain.sim.simulate import simulate_with_physics
from terrain.terramechanics.catalogue import TERRAIN_NAMES, get_terrain
from terrain.vehicles import AGRIMARO, HUSKY, TRACKED

VEHICLES = {"husky": HUSKY, "tracked": TRACKED, "agrimaro": AGRIMARO}
FIELDS = ("pose", "twist", "accel_body", "omega", "omega_cmd", "slip_motor", "delta",
          "torque", "pitch", "roll", "terrain_index")


def _ramp(t, v, vy, r, start=0.0):
    """Commands ramping from 0 at ``start`` to ``(v, vy, r)`` over 0.5 s."""
    s = np.clip((t - start) / 0.5, 0.0, 1.0)
    return np.column_stack([v * s, vy * s, r * s])


def _integrate(vehicle, terrain, t, twist, slope=0.0, physics="v1", hook=None):
    veh = VEHICLES[vehicle]
    return integrate(veh, veh.contact_geometry(), (get_terrain(terrain),), np.inf, t, twist,
                     slope, 1.0, hook=hook, physics=physics)


@pytest.mark.slow
@settings(max_examples=10, deadline=None)
@given(vehicle=st.sampled_from(sorted(VEHICLES)), terrain=st.sampled_from(TERRAIN_NAMES),
       physics=st.sampled_from(("v1", "v2")), wait=st.integers(1, 40),
       v=st.floats(-0.8, 0.8), r=st.floats(-0.8, 0.8))
def test_a_run_that_waits_at_rest_is_the_run_shifted_by_the_wait(
        vehicle, terrain, physics, wait, v, r):
    dt = 0.01
    t = np.arange(121) * dt
    vy = 0.3 * v if vehicle == "agrimaro" else 0.0
    base = _integrate(vehicle, terrain, t, _ramp(t, v, vy, r), physics=physics)
    t_long = np.arange(121 + wait) * dt
    late = _integrate(vehicle, terrain, t_long, _ramp(t_long, v, vy, r, start=wait * dt),
                      physics=physics)
    for name in FIELDS:
        got, want = getattr(late, name), getattr(base, name)
        # the wait: exactly at rest
        assert np.all(got[:wait] == 0), name
        np.testing.assert_allclose(got[wait:], want, rtol=1e-9, atol=1e-9, err_msg=name)


@pytest.mark.slow
@settings(max_examples=8, deadline=None)
@given(vehicle=st.sampled_from(sorted(VEHICLES)), offset=st.floats(-1000.0, 1000.0),
       v=st.floats(-0.8, 0.8), r=st.floats(-0.8, 0.8))
def test_moving_the_time_grid_changes_nothing_but_the_rounding(vehicle, offset, v, r):
    t = np.arange(101) * 0.01
    vy = 0.3 * v if vehicle == "agrimaro" else 0.0
    twist = _ramp(t, v, vy, r)
    base = _integrate(vehicle, "ASPHALT", t, twist)
    moved = _integrate(vehicle, "ASPHALT", t + offset, twist)
    np.testing.assert_array_equal(moved.t_s, t + offset)
    for name in FIELDS:
        np.testing.assert_allclose(getattr(moved, name), getattr(base, name), rtol=1e-6,
                                   atol=1e-6, err_msg=name)


@pytest.mark.slow
@settings(max_examples=10, deadline=None)
@given(terrain=st.sampled_from(TERRAIN_NAMES), physics=st.sampled_from(("v1", "v2")),
       v=st.floats(-0.8, 0.8), vy=st.floats(-0.5, 0.5), r=st.floats(-0.8, 0.8))
def test_the_swerve_drive_mirrored_front_to_back_gives_the_mirrored_run(
        terrain, physics, v, vy, r):
    # not at a tie of eq. 2.5: a unit whose target is 90 deg from its angle (a contact
    # velocity along y, at the start from delta = 0) takes the k = 0 solution either way,
    # which is no mirror image (a spin in place: wheels 1 and 2 both roll forward)
    assume(abs(v) > 0.02 and abs(v + 0.756 * r) > 0.02)
    t = np.arange(151) * 0.01
    run = _integrate("agrimaro", terrain, t, _ramp(t, v, vy, r), physics=physics)
    mir = _integrate("agrimaro", terrain, t, _ramp(t, -v, vy, -r), physics=physics)
    np.testing.assert_allclose(mir.twist, run.twist * [-1, 1, -1], rtol=0, atol=1e-9)
    np.testing.assert_allclose(mir.pose, run.pose * [-1, 1, -1], rtol=0, atol=1e-9)
    np.testing.assert_allclose(mir.accel_body, run.accel_body * [-1, 1], rtol=0, atol=1e-7)
    swap = [1, 0, 2]
    np.testing.assert_allclose(mir.omega, -run.omega[:, swap], rtol=0, atol=1e-9)
    np.testing.assert_allclose(mir.delta, -run.delta[:, swap], rtol=0, atol=1e-9)
    np.testing.assert_allclose(mir.slip_motor, -run.slip_motor[:, swap], rtol=0, atol=1e-9)
    tol = 1e-9 * (1.0 + np.abs(run.torque).max())
    np.testing.assert_allclose(mir.torque, -run.torque[:, swap], rtol=0, atol=tol)


@pytest.mark.slow
@settings(max_examples=12, deadline=None)
@given(vehicle=st.sampled_from(sorted(VEHICLES)), terrain=st.sampled_from(TERRAIN_NAMES),
       physics=st.sampled_from(("v1", "v2")), slope=st.floats(0.02, 0.3))
def test_with_no_command_on_a_grade_the_vehicle_never_climbs(vehicle, terrain, physics, slope):
    t = np.arange(201) * 0.01
    p = _integrate(vehicle, terrain, t, np.zeros((len(t), 3)), slope=slope, physics=physics)
    # the plane rises along world +x and the vehicle starts facing that way (yaw 0)
    assert np.all(p.pose[:, 0] <= 1e-12)
    assert np.all(p.twist[:, 0] <= 1e-12)
    # the motors, commanded to 0 rad/s, push back uphill (a forward torque) once it rolls
    rolling = p.twist[:, 0] < -1e-6
    assert np.all(p.torque[rolling].sum(axis=1) > 0)


@settings(max_examples=100, deadline=None)
@given(vehicle=st.sampled_from(("husky", "tracked")), terrain=st.sampled_from(TERRAIN_NAMES),
       v=st.floats(0.0, 1.5), excess=st.floats(1e-3, 1.0))
def test_a_wheel_faster_than_the_ground_pulls_forward(vehicle, terrain, v, excess):
    veh = VEHICLES[vehicle]
    layout = contact_layout(veh.contact_geometry(), veh.mass_kg, 0.0, 1.0)
    maps = velocity_maps(layout, np.zeros_like(layout.x_m))
    ter = get_terrain(terrain)
    omega = np.full(2, (v + excess) / layout.wheel_radius_m)     # straight, positive slip
    c = contact_forces(layout, maps, ter, np.array([v, 0.0, 0.0]), omega)
    assert np.all(c.mu > 0)
    assert np.all(contact_torque_nm(layout, ter, c.mu, c.rim_speed_m_s) > 0)
    # and the mirror case: a wheel slower than the ground (braking) pulls back
    c = contact_forces(layout, maps, ter, np.array([v + excess, 0.0, 0.0]),
                       np.full(2, v / layout.wheel_radius_m))
    assert np.all(c.mu < 0)


@pytest.mark.parametrize("vehicle", sorted(VEHICLES))
def test_a_hook_that_never_corrects_gives_the_open_loop_run_bit_for_bit(vehicle):
    t = np.arange(151) * 0.01
    vy = 0.2 if vehicle == "agrimaro" else 0.0
    twist = _ramp(t, 0.6, vy, 0.4)
    seen = []
    base = _integrate(vehicle, "SANDY_LOAM", t, twist)
    hooked = _integrate(vehicle, "SANDY_LOAM", t, twist, hook=lambda snap: seen.append(snap.step))
    assert seen == list(range(len(t)))
    for name in FIELDS:
        np.testing.assert_array_equal(getattr(hooked, name), getattr(base, name), name)


@pytest.fixture(scope="module")
def short_runs():
    return {v: simulate_with_physics(SimConfig(vehicle=v, terrains=("GRASS",),
                                               scenario="random", duration_s=3.0, seed=5))
            for v in ("husky", "agrimaro")}


@pytest.mark.slow
@settings(max_examples=6, deadline=None)
@given(vehicle=st.sampled_from(("husky", "agrimaro")),
       rates=st.tuples(*(st.sampled_from((100.0, 50.0, 20.0, 10.0, 7.0, 3.0, 1.0)),) * 2))
def test_the_controller_sees_the_same_samples_at_any_call_rate(short_runs, vehicle, rates):
    sim = short_runs[vehicle]
    obs = [list(replay_observations(sim, rate)) for rate in rates]
    for name in ("imu", "wheels", "steer", "cam", "currents", "imu_full"):
        rows = [np.concatenate([getattr(o, name) for o in seq]) for seq in obs]
        np.testing.assert_array_equal(rows[0], rows[1], err_msg=name)
