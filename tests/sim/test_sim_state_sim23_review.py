"""Review tests (sim23) of state and aliasing in the simulator: what a caller gets back
must not be a view of a finished run's arrays or of what it passed in."""

from __future__ import annotations

import copy
import pickle

import numpy as np
import pytest

from terrain.errors import ConfigError
from terrain.sim import SimConfig
from terrain.sim.closed_loop import OnlineSensors, make_hook, replay_observations
from terrain.sim.forces import COMBINED_SLIP, CombinedSlipParams
from terrain.sim.simulate import DEFAULT_SENSORS, simulate_with_physics
from terrain.terramechanics.catalogue import get_terrain


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


def test_a_tyres_friction_scale_is_checked_once_and_kept():
    """CombinedSlipParams checks each friction factor (finite, > 0) when made but kept the
    caller's dict: a factor set to NaN or -1 there afterwards reached surface_curve
    unchecked."""
    scale = {"ICE": 5.0}
    tyre = CombinedSlipParams(0.6, "test", friction_scale=scale)
    scale["ICE"] = float("nan")
    scale["ASPHALT"] = -1.0
    assert dict(tyre.friction_scale) == {"ICE": 5.0}
    with pytest.raises(TypeError):
        tyre.friction_scale["ICE"] = 2.0


@pytest.mark.parametrize("copier", [copy.deepcopy, lambda t: pickle.loads(pickle.dumps(t))],
                         ids=["deepcopy", "pickle"])
def test_the_catalogued_tyre_copies_and_pickles(copier):
    """The Husky's tyre (a read-only friction_scale) made copy.deepcopy and pickle fail with
    a bare TypeError; the copy scales the same curves."""
    tyre = COMBINED_SLIP["husky"]
    twin = copier(tyre)
    assert twin == tyre
    ice = get_terrain("ICE").curve
    assert twin.surface_curve("ICE", ice) == tyre.surface_curve("ICE", ice)


def test_a_hook_used_for_a_second_run_says_so():
    """A hook counts its controller calls from its first run: handed to a second run it
    called the controller only once the time passed the first run's call count (a run as
    long as the first: not once), silently. It serves one run; a second is refused."""
    config = SimConfig(vehicle="husky", terrains=("ASPHALT",), scenario="straight_accel",
                       duration_s=0.5, seed=1)
    sensors = OnlineSensors("husky", DEFAULT_SENSORS["husky"], 1, 0.5)
    calls = []
    hook = make_hook(sensors, lambda obs: calls.append(obs.t_s), 50.0)
    simulate_with_physics(config, hook)
    assert len(calls) == 26
    with pytest.raises(ConfigError, match="one run"):
        simulate_with_physics(config, hook)
