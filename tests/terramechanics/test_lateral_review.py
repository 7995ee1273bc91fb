"""Soil parameter checks of the lateral wheel-soil model (review tests)."""

from __future__ import annotations

from dataclasses import replace

import pytest

from terrain.errors import ConfigError
from terrain.terramechanics.lateral import SOILS, max_sinkage_m


@pytest.mark.parametrize("layer_m", [0.0, -0.01, float("nan")])
def test_soil_params_refuse_a_layer_that_is_not_a_positive_depth(layer_m):
    # a layer of depth 0 would cap every sinkage at 0 m: no wall to bulldoze, no rut
    with pytest.raises(ConfigError, match="layer_depth_m"):
        replace(SOILS["SNOW"], layer_depth_m=layer_m)


def test_a_thin_positive_layer_is_accepted_and_caps_the_sinkage():
    soil = replace(SOILS["SNOW"], layer_depth_m=1e-3)
    assert max_sinkage_m(0.1651, soil) == 1e-3
