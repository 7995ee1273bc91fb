"""Review sim17: the simulator's inputs and a time-step dependence left open."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import ConfigError
from terrain.sim.scenarios import make_commands


@pytest.mark.parametrize("rng", [None, 3, np.random.RandomState(0)])
def test_the_random_scenario_needs_a_generator(rng):
    # None was an AttributeError ('NoneType' object has no attribute 'uniform')
    with pytest.raises(ConfigError, match="make_commands.rng"):
        make_commands("random", 1.0, 0.01, rng, 1.0)
    # the deterministic scenarios draw nothing: any rng (None included) is fine
    assert make_commands("spin", 1.0, 0.01, rng, 1.0).twist.shape == (101, 3)
