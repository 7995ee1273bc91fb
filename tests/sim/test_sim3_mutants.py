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
