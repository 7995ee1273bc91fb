"""Scenario commands: every scenario starts from rest and respects its rate limits."""

import numpy as np
import pytest

from terrain.errors import ConfigError
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


@pytest.mark.slow
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


def _at(cmd, t_s: float) -> np.ndarray:
    """Commanded twist at time ``t_s`` (nearest physics step)."""
    return cmd.twist[int(round(t_s / (cmd.t_s[1] - cmd.t_s[0])))]


def test_physics_steps_round_the_duration_and_the_grid_ends_on_it():
    from terrain.sim.scenarios import physics_steps
    assert physics_steps(0.3, 0.1) == 3 and physics_steps(0.7, 0.1) == 7
    cmd = make_commands("spin", 0.3, 0.1, np.random.default_rng(0), 1.0)
    np.testing.assert_allclose(cmd.t_s, [0.0, 0.1, 0.2, 0.3])


def test_orchard_u_turns_are_half_turns_alternating_left_and_right():
    # 0.5 m/s on 20 m rows, U-turns of radius 1.5 m (3 pi s each): left first, then right
    dt = 0.01
    cmd = make_commands("orchard", 100.0, dt, np.random.default_rng(0), 1.0)
    t_turn = np.pi * 1.5 / 0.5
    assert cmd.slope_rad == 0.0
    yaw = cmd.twist[:, 2]
    first = cmd.t_s < 40.0 + t_turn + 1.0
    np.testing.assert_allclose(yaw[first].sum() * dt, np.pi, atol=0.01)
    np.testing.assert_allclose(yaw[~first].sum() * dt, -np.pi, atol=0.01)
    np.testing.assert_allclose(_at(cmd, 45.0), [0.5, 0.0, 0.5 / 1.5])
    np.testing.assert_allclose(_at(cmd, 60.0), [0.5, 0.0, 0.0])
    np.testing.assert_allclose(_at(cmd, 95.0), [0.5, 0.0, -0.5 / 1.5])


def test_orchard_slows_a_skid_steer_so_its_outer_side_stays_within_the_limit():
    track, vmax = 0.6, 0.5
    cmd = make_commands("orchard", 30.0, 0.01, np.random.default_rng(0), vmax, track_m=track)
    v = cmd.twist[-1, 0]
    assert v * (1.0 + track / (2.0 * 1.5)) == pytest.approx(0.95 * vmax, rel=1e-12)


def test_slope_turn_and_spin_timing():
    dt = 0.01
    cmd = make_commands("slope_turn", 40.0, dt, np.random.default_rng(0), 1.0)
    assert cmd.slope_rad == pytest.approx(np.radians(15.0))
    # 0.2 m/s for 10 s, then 0.05 m/s for 10 s; turning left at 20 deg/s for 20 s, then right
    for t, v, r in ((5.0, 0.2, 20.0), (15.0, 0.05, 20.0), (25.0, 0.2, -20.0),
                    (35.0, 0.05, -20.0)):
        np.testing.assert_allclose(_at(cmd, t), [v, 0.0, np.radians(r)], atol=1e-12)
    # spin: +0.6 rad/s for 8 s, then -0.6 rad/s for 8 s (reached through the 1.5 rad/s^2 limit)
    cmd = make_commands("spin", 16.0, dt, np.random.default_rng(0), 1.0)
    assert cmd.slope_rad == 0.0
    np.testing.assert_allclose(_at(cmd, 4.0), [0.0, 0.0, 0.6], atol=1e-12)
    np.testing.assert_allclose(_at(cmd, 12.0), [0.0, 0.0, -0.6], atol=1e-12)
    np.testing.assert_allclose(_at(cmd, 8.0 + 0.6 / 1.5), [0.0, 0.0, 0.0], atol=0.02)


def test_straight_accel_ramps_at_1_m_s2_to_its_speed():
    cmd = make_commands("straight_accel", 3.0, 0.01, np.random.default_rng(0), 0.8)
    np.testing.assert_allclose(_at(cmd, 0.5), [0.5, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(cmd.twist[-1], [0.95 * 0.8, 0.0, 0.0], atol=1e-12)


def test_random_scenario_stays_within_the_speed_limit_and_follows_its_seed():
    a = make_commands("random", 120.0, 0.01, np.random.default_rng(5), 0.6)
    b = make_commands("random", 120.0, 0.01, np.random.default_rng(5), 0.6)
    c = make_commands("random", 120.0, 0.01, np.random.default_rng(6), 0.6)
    np.testing.assert_array_equal(a.twist, b.twist)
    assert not np.array_equal(a.twist, c.twist)
    assert np.all(a.twist[:, 1] == 0.0)        # not omnidirectional: no lateral command
    assert np.abs(a.twist[:, 0]).max() <= 0.95 * 0.6 + 1e-12
    assert np.abs(a.twist[:, 0]).max() > 0.5 * 0.6
    omni = make_commands("random", 120.0, 0.01, np.random.default_rng(5), 0.6,
                         omnidirectional=True)
    assert np.abs(omni.twist[:, 1]).max() > 0.05
    assert np.abs(omni.twist[:, 1]).max() <= 0.5 * 0.95 * 0.6 + 1e-12


def test_random_scenario_holds_each_command_for_two_to_six_seconds():
    # a new segment starts where the command starts to move again after holding still; the
    # ramps (at most 1.6 s at these limits) end inside a segment of 2-6 s
    dt = 0.01
    cmd = make_commands("random", 300.0, dt, np.random.default_rng(8), 1.0,
                        omnidirectional=True)
    moving = np.any(np.diff(cmd.twist, axis=0) != 0.0, axis=1)
    onsets = cmd.t_s[1:][moving & ~np.concatenate([[True], moving[:-1]])]
    gaps = np.diff(onsets)
    assert len(gaps) > 300.0 / 6.0 - 2
    assert gaps.min() >= 2.0 - 1e-9 and gaps.max() <= 6.0 + 1e-9


@pytest.mark.parametrize("duration_s, dt_s, match", [
    (1.0, 0.0, "make_commands.dt_s must be"), (1.0, float("nan"), "make_commands.dt_s must be"),
    (1.0, -0.01, "make_commands.dt_s must be"), (1.0, float("inf"), "make_commands.dt_s must be"),
    (float("inf"), 0.01, "make_commands.duration_s must be"),
    (float("nan"), 0.01, "make_commands.duration_s must be")])
def test_make_commands_refuses_a_step_or_duration_that_is_not_a_finite_time(
        duration_s, dt_s, match):
    # a step of 0 was a ZeroDivisionError, NaN a ValueError, -0.01 s and inf were called
    # longer than the duration; an infinite duration was an OverflowError
    with pytest.raises(ConfigError, match=match):
        make_commands("spin", duration_s, dt_s, np.random.default_rng(0), 1.0)
