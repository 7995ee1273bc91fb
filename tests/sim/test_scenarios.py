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
