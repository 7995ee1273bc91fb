"""Boundary review of the simulator (sim22): limits reached exactly, counts at their edges."""

from dataclasses import replace
from types import MappingProxyType

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import terrain.sim.dynamics as dynamics
from terrain.sim.dynamics import integrate
from terrain.sim.forces import LOAD_TRANSFER, MIN_LOAD_FRACTION, transferred_normal_loads
from terrain.terramechanics.catalogue import get_terrain
from terrain.vehicles import get_vehicle

HUSKY = get_vehicle("husky")


def test_a_load_only_rescaled_below_the_floor_is_not_counted_as_floored(monkeypatch):
    """load_floor_steps counts the steps on which a contact's transferred load was floored
    (the transfer asked for less than MIN_LOAD_FRACTION of its static load). It counted the
    loads found at or below the floor *after* the rescaling to the static total: a Husky with
    its CoG at 0.6 m accelerating into a turn asked at step 6 for 0.0507 of the static load
    on its front right wheel (above the floor: not floored), the front left's floor raised the
    total and the rescaling put the front right at 0.0494, and the step was counted. The
    flags now come from the transfer itself. Since the implicit-Euler step iterates
    (2026-11-30) that run no longer has such a step; CoG 0.65 m and a 1.2 rad/s turn have one
    (contact 2, step 7), so the counts are checked against what each step asked."""
    from terrain.sim.forces import _unfloored_loads

    monkeypatch.setattr(dynamics, "LOAD_TRANSFER", MappingProxyType(
        {"husky": replace(LOAD_TRANSFER["husky"], cog_height_m=0.65)}))
    asked, rescaled = [], []

    def recording(static, *args):
        out = transferred_normal_loads(static, *args)
        asked.append(_unfloored_loads(static, *args) < MIN_LOAD_FRACTION * static)
        rescaled.append(out < MIN_LOAD_FRACTION * static)
        return out

    monkeypatch.setattr(dynamics, "transferred_normal_loads", recording)
    t = np.arange(0.0, 4.0, 0.01)
    cmd = np.zeros((len(t), 3))
    cmd[t < 2.0, 0] = 1.0
    cmd[:, 2] = np.where(t < 3.0, 1.2, -1.2)
    p = integrate(HUSKY, HUSKY.contact_geometry(), (get_terrain("ASPHALT"),), 1e9, t, cmd,
                  0.0, 1.0, physics="v2")
    asked, rescaled = np.array(asked), np.array(rescaled)
    assert len(asked) == len(t) - 1                       # one transfer per step
    only_rescaled = rescaled & ~asked
    assert only_rescaled[:, 2].any()                      # the case this test is about
    np.testing.assert_array_equal(p.load_floor_steps, asked.sum(axis=0))
    assert p.load_floor_steps[2] < rescaled[:, 2].sum()


def test_load_transfer_flags_exactly_the_loads_the_floor_raised():
    """A transfer that asks for exactly MIN_LOAD_FRACTION of a contact's static load leaves it
    there (not floored: the floor raised nothing); one ulp more transfer floors it; a load
    that only the rescaling takes below the floor is not flagged."""
    from terrain.sim.forces import floored_contacts, transferred_normal_loads
    static = np.full(4, 100.0)
    x = np.array([0.25, -0.25, 0.25, -0.25])
    y = np.array([0.25, 0.25, -0.25, -0.25])
    front = x > 0
    # dN_front = -(m h a_x / sum x^2) x = -95 N: the front loads at 5 N = 0.05 x 100 N exactly
    args = (static, x, y, 95.0, 1.0)
    np.testing.assert_array_equal(transferred_normal_loads(*args, 1.0, 0.0),
                                  [5.0, 195.0, 5.0, 195.0])
    assert not floored_contacts(*args, 1.0, 0.0).any()
    np.testing.assert_array_equal(floored_contacts(*args, np.nextafter(1.0, 2.0), 0.0), front)
    # front left floored (-75.5 N asked), front right (5.5 N asked) rescaled to 4.58 N by
    # the front left's floor: not floored
    mixed = (135.0 / 95.0, 40.5 / 95.0)
    assert transferred_normal_loads(*args, *mixed)[2] < MIN_LOAD_FRACTION * static[2]
    np.testing.assert_array_equal(floored_contacts(*args, *mixed), [True, False, False, False])


def test_online_encoder_reports_the_batch_count_rate_from_the_first_step():
    """With a speed quantum of 0 (the AgriMaRo) both sensor models report the encoder's
    count rate per physics step through the driver's filter (SensorSettings: "in the batch
    model and the closed loop's online sensors alike"). At the first step no count has
    changed: the batch model reports 0 there, the online one the true wheel speed, and the
    filter carries the difference on (0.0086 rad/s, then 0.0079 ...)."""
    from terrain.sim import SimConfig
    from terrain.sim.closed_loop import OnlineSensors
    from terrain.sim.dynamics import PlantSnapshot
    from terrain.sim.sensors import encoder_count_rate, first_order_filter
    from terrain.sim.simulate import DEFAULT_SENSORS, simulate_with_physics

    sensors = replace(DEFAULT_SENSORS["agrimaro"], wheel_rate_hz=100.0)
    p = simulate_with_physics(SimConfig(vehicle="agrimaro", terrains=("GRASS",),
                                        scenario="random", duration_s=0.5, seed=3,
                                        sensors=sensors)).physics
    motor = get_vehicle("agrimaro").motor
    batch = first_order_filter(encoder_count_rate(p.omega, 0.01, motor.encoder_counts_per_rev),
                               0.01, motor.encoder_filter_s)
    online = OnlineSensors("agrimaro", sensors, 3, 0.5)
    for k in range(len(p.t_s)):
        online.record(PlantSnapshot(k, float(p.t_s[k]), p.pose[k], p.twist[k],
                                    p.accel_body[k], p.omega[k], p.delta[k], p.omega_cmd[k],
                                    p.torque[k]))
    wheels = online.take(0.5, np.zeros(3)).wheels
    np.testing.assert_allclose(wheels[:, 1:], batch, atol=1e-12)


def test_physics_steps_rounds_to_the_nearest_step_and_half_way_to_even():
    """Pins the rounding of a duration to physics steps (documented in physics_steps)."""
    from terrain.sim.scenarios import physics_steps
    assert physics_steps(1.004, 0.01) == 100 and physics_steps(1.006, 0.01) == 101
    dt = 1.0 / 64.0                             # exact in binary: exact half-way cases
    assert physics_steps(10.5 * dt, dt) == 10
    assert physics_steps(11.5 * dt, dt) == 12
    assert physics_steps(np.nextafter(10.5 * dt, 1.0), dt) == 11


@pytest.mark.parametrize("duration, end, rows", [(1.004, 1.0, 101), (1.006, 1.01, 102)])
def test_a_duration_between_steps_ends_at_the_rounded_step_and_keeps_its_last_sample(
        duration, end, rows):
    """The run ends at the nearest physics step (not before the duration asked for when that
    step lies after it), its metadata says so, and the 100 Hz streams hold that last step."""
    from terrain.sim import SimConfig
    from terrain.sim.simulate import simulate_with_physics
    sim = simulate_with_physics(SimConfig(duration_s=duration, scenario="straight_accel"))
    assert sim.physics.t_s[-1] == pytest.approx(end, abs=1e-12)
    assert sim.run.meta["duration_s"] == pytest.approx(end, abs=1e-12)
    for name in ("imu", "truth"):
        t = sim.run.streams[name]["t_s"].to_numpy()
        assert len(t) == rows and t[-1] == pytest.approx(end, abs=1e-12)


def test_the_first_command_is_one_rate_limited_step_from_rest():
    """The scenarios' module docstring: at t = 0 each rate-limited command is one step of its
    limit from 0 (not 0), straight_accel's ramp 0."""
    from terrain.sim.scenarios import make_commands
    rng = np.random.default_rng(0)
    first = {name: make_commands(name, 10.0, 0.01, rng, 2.0, track_m=0.555).twist[0]
             for name in ("straight_accel", "orchard", "spin")}
    np.testing.assert_array_equal(first["straight_accel"], [0.0, 0.0, 0.0])
    np.testing.assert_allclose(first["orchard"], [0.005, 0.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(first["spin"], [0.0, 0.0, 0.015], atol=1e-15)


def test_the_truth_at_t_0_is_the_vehicle_at_rest():
    """Every scenario starts with the vehicle standing (scenarios module docstring), so the
    truth at t = 0 is the rest state. Until 2026-11-30 the first row held the state after
    the first step: orchard at 100 Hz, x = 5.0e-6 m, v_bx = 5.0e-4 m/s, omega 0.0030 rad/s
    at t = 0 (the pose at t_s[k] was integrated over [t_s[k], t_s[k] + dt])."""
    from terrain.sim import SimConfig
    from terrain.sim.simulate import simulate_with_physics
    sim = simulate_with_physics(SimConfig(scenario="orchard", duration_s=1.0))
    first = sim.run.streams["truth"].iloc[0]
    assert first["t_s"] == 0.0
    for column in ("x", "y", "yaw", "v_bx", "v_by", "yaw_rate", "omega_1", "omega_2"):
        assert first[column] == 0.0, column


@settings(max_examples=200, deadline=None)
@given(ax=st.floats(-60.0, 60.0), ay=st.floats(-60.0, 60.0), h=st.floats(0.0, 2.0))
def test_floored_contacts_are_those_at_the_common_floor_ratio(ax, ay, h):
    """Whatever the specific force: the loads keep the static total, every floored contact
    ends at the same fraction of its static load (the floor times the rescaling), and every
    contact left unfloored ends at or above that fraction (the floor is the least load)."""
    from terrain.sim.forces import floored_contacts, transferred_normal_loads
    geo = HUSKY.contact_geometry()
    static = geo.load_share * HUSKY.mass_kg * 9.80665
    x, y = geo.positions_m[:, 0].copy(), geo.positions_m[:, 1].copy()
    loads = transferred_normal_loads(static, x, y, HUSKY.mass_kg, h, ax, ay)
    floored = floored_contacts(static, x, y, HUSKY.mass_kg, h, ax, ay)
    assert loads.sum() == pytest.approx(static.sum(), rel=1e-12)
    ratio = loads / static
    if floored.any():
        np.testing.assert_allclose(ratio[floored], ratio[floored][0], rtol=1e-12)
        assert ratio[floored][0] <= MIN_LOAD_FRACTION * (1 + 1e-12)
        assert np.all(ratio[~floored] >= ratio[floored][0] * (1 - 1e-12))
    else:
        assert np.all(ratio >= MIN_LOAD_FRACTION * (1 - 1e-12))
