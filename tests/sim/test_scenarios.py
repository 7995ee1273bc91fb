"""Scenario commands: every scenario starts from rest and respects its rate limits."""

import numpy as np
import pytest

from terrain.sim import SCENARIO_NAMES, make_commands

#: Rate limits of terrain/sim/scenarios.py per scenario: (v_x m/s^2, v_y m/s^2, yaw rad/s^2);
#: straight_accel is its own 1 m/s^2 ramp.
LIMITS = {"straight_accel": (1.0, 0.0, 0.0), "orchard": (0.5, 0.0, 2.0),
          "slope_turn": (0.5, 0.0, 1.0), "spin": (0.0, 0.0, 1.5), "random": (0.8, 0.8, 1.5)}


@pytest.mark.parametrize("name", SCENARIO_NAMES)
def test_commands_start_at_rest_and_respect_the_rate_limits(name):
    dt = 0.01
    cmd = make_commands(name, 30.0, dt, np.random.default_rng(3), 1.0, omnidirectional=True)
    # the vehicle starts standing: the command at t = 0 is one limited step from 0 (it was
    # the first segment's value before, e.g. orchard 0.475 m/s, spin 0.6 rad/s: a step that
    # no limit allowed)
    rate = np.abs(np.diff(np.vstack([np.zeros(3), cmd.twist]), axis=0)) / dt
    assert np.all(rate <= np.asarray(LIMITS[name]) + 1e-9), rate.max(axis=0)
    assert np.abs(cmd.twist).max() > 0.1        # and the scenario still moves


def test_rate_limited_command_reaches_its_target():
    # orchard cruises at 0.5 m/s after a 1 s ramp at 0.5 m/s^2 (0.005 m/s a step)
    cmd = make_commands("orchard", 5.0, 0.01, np.random.default_rng(0), 1.0)
    v = cmd.twist[:, 0]
    np.testing.assert_allclose(v[:100], 0.005 * np.arange(1, 101))
    np.testing.assert_allclose(v[100:], 0.5)


def test_orchard_u_turn_of_the_tracked_vehicle_is_a_half_turn_of_radius_1_5_m():
    """The orchard's U-turn at 0.95 of the speed limit asked the tracked vehicle's outer
    track for 0.475 (1 + 0.393 / 3) = 0.54 m/s, over its 0.5 m/s limit: the clipped wheel
    commands turned by 2.18 rad (not pi) on a 2.06 m radius (not 1.5 m). The speed now
    leaves the outer track within the limit."""
    from terrain.sim import SimConfig, simulate_with_physics
    from terrain.vehicles import get_vehicle
    tracked = get_vehicle("tracked")
    sim = simulate_with_physics(SimConfig(vehicle="tracked", terrains=("ASPHALT",),
                                          scenario="orchard", duration_s=60.0, seed=0))
    rim = sim.physics.omega_cmd * tracked.wheel_radius_m
    limit = tracked.motor.max_wheel_speed_rad_s * tracked.wheel_radius_m
    assert np.abs(rim).max() < limit                       # no wheel command clipped
    yaw_rate = (rim[:, 1] - rim[:, 0]) / tracked.track_m
    speed = rim.mean(axis=1)
    turning = np.abs(yaw_rate) > 0.05
    assert turning.any() and not turning[-1]               # one whole U-turn in the run
    np.testing.assert_allclose(np.median(speed[turning] / np.abs(yaw_rate[turning])), 1.5,
                               rtol=1e-6)
    np.testing.assert_allclose(yaw_rate.sum() * 0.01, np.pi, atol=2e-3)
