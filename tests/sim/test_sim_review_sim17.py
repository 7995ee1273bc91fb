"""Review sim17: the simulator's inputs and a time-step dependence left open."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import ConfigError
from terrain.sim import SimConfig
from terrain.sim.closed_loop import OnlineSensors, simulate_closed_loop
from terrain.sim.digest import simulator_digest
from terrain.sim.effects import parse_effects
from terrain.sim.scenarios import make_commands
from terrain.sim.simulate import DEFAULT_SENSORS


@pytest.mark.parametrize("rng", [None, 3, np.random.RandomState(0)])
def test_the_random_scenario_needs_a_generator(rng):
    # None was an AttributeError ('NoneType' object has no attribute 'uniform')
    with pytest.raises(ConfigError, match="make_commands.rng"):
        make_commands("random", 1.0, 0.01, rng, 1.0)
    # the deterministic scenarios draw nothing: any rng (None included) is fine
    assert make_commands("spin", 1.0, 0.01, rng, 1.0).twist.shape == (101, 3)


@pytest.mark.parametrize("terrains", [5, b"ASPHALT", 2.5])
def test_a_terrain_list_that_is_not_a_sequence_of_names_is_refused(terrains):
    # 5 was a bare "'int' object is not iterable"; b"ASPHALT" "unknown terrain 65" (a byte)
    with pytest.raises(ConfigError, match="SimConfig.terrains"):
        SimConfig(terrains=terrains)
    with pytest.raises(ConfigError, match="OnlineSensors.terrains"):
        OnlineSensors("husky", DEFAULT_SENSORS["husky"], 0, 1.0, terrains=terrains)


@pytest.mark.parametrize("terrains", ["ASPHALT", 5])
def test_the_simulator_digest_needs_a_sequence_of_terrain_names(terrains):
    # "ASPHALT" was read letter by letter ("unknown terrain 'A'"), 5 a bare TypeError
    with pytest.raises(ConfigError, match="simulator_digest"):
        simulator_digest("husky", terrains)


@pytest.mark.parametrize("items", [5, 2.5, b"gyro_bias=0.1"])
def test_effect_items_that_are_not_a_sequence_are_refused(items):
    # 5 was a bare "'int' object is not iterable"
    with pytest.raises(ConfigError, match="parse_effects"):
        parse_effects(items)


def test_a_controller_that_is_not_callable_is_refused_before_the_run():
    # None was a bare TypeError ('NoneType' object is not callable) at the first call,
    # after the integrator had started
    with pytest.raises(ConfigError, match="controller"):
        simulate_closed_loop(SimConfig(duration_s=1.0), None)
