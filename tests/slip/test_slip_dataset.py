"""Slip run grid and its cache keys."""

from __future__ import annotations

import pytest

from terrain.errors import ConfigError
from terrain.sim.simulate import SimConfig
from terrain.slip.dataset import SlipDataSpec, cache_key


def test_cache_key_tells_apart_settings_that_are_not_in_the_cell_name():
    # the physics rate is not in the readable name: only the settings hash separates the
    # two runs (the same key would read one run's file back for the other)
    a = SimConfig(terrains=("SNOW",), scenario="straight_accel", duration_s=2.0, seed=5)
    b = SimConfig(terrains=("SNOW",), scenario="straight_accel", duration_s=2.0, seed=5,
                  physics_rate_hz=2 * a.physics_rate_hz)
    assert cache_key(a) != cache_key(b)
    assert cache_key(a) == cache_key(SimConfig(terrains=("SNOW",), scenario="straight_accel",
                                               duration_s=2.0, seed=5))


def test_slip_data_spec_refuses_a_zero_duration():
    with pytest.raises(ConfigError, match="duration_s must be > 0"):
        SlipDataSpec(terrains=("SNOW",), duration_s=0.0)


@pytest.mark.parametrize("axis, values", [("terrains", ("SNOW", "ICE", "SNOW")),
                                          ("scenarios", ("orchard", "orchard")),
                                          ("seeds", (0, 1, 1))])
def test_slip_data_spec_refuses_a_value_repeated_on_an_axis(axis, values):
    # a repeated value gives the same run twice (one run id): its windows would weigh twice
    # in the fit and the error tables
    with pytest.raises(ConfigError, match=f"{axis}: .* given more than once"):
        SlipDataSpec(**{axis: values})
