"""Review tests (sim23) of state and aliasing in the simulator: what a caller gets back
must not be a view of a finished run's arrays or of what it passed in."""

from __future__ import annotations

import numpy as np

from terrain.sim import SimConfig
from terrain.sim.closed_loop import replay_observations
from terrain.sim.simulate import simulate_with_physics


def _short_run():
    return simulate_with_physics(SimConfig(vehicle="husky", terrains=("ASPHALT",),
                                           scenario="straight_accel", duration_s=1.0, seed=3))


def test_a_replayed_command_is_not_a_view_of_the_run():
    """The replayed Observation's ``omega_low_level`` was a row of the run's
    ``physics.omega_cmd``: a controller adding its correction to it in place rewrote the
    stored commands of the run (the closed loop's hook hands a copy)."""
    sim = _short_run()
    before = sim.physics.omega_cmd.copy()
    for obs in replay_observations(sim, control_rate_hz=50.0):
        obs.omega_low_level[:] += 1.0
    np.testing.assert_array_equal(sim.physics.omega_cmd, before)


def test_replaying_twice_gives_the_same_observations():
    """Each replay builds its own sensors from the run's seed: no generator state is shared
    between two replays of one run, nor changed by one of them."""
    sim = _short_run()
    first = list(replay_observations(sim, control_rate_hz=25.0))
    second = list(replay_observations(sim, control_rate_hz=25.0))
    assert len(first) == len(second)
    for a, b in zip(first, second):
        for x, y in zip(a, b):
            np.testing.assert_array_equal(x, y)
