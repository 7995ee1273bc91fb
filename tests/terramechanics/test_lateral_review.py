"""Soil parameter checks of the lateral wheel-soil model (review tests)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from terrain.errors import ConfigError
from terrain.terramechanics.lateral import SOILS, max_sinkage_m, soil_contact


@pytest.mark.parametrize("layer_m", [0.0, -0.01, float("nan")])
def test_soil_params_refuse_a_layer_that_is_not_a_positive_depth(layer_m):
    # a layer of depth 0 would cap every sinkage at 0 m: no wall to bulldoze, no rut
    with pytest.raises(ConfigError, match="layer_depth_m"):
        replace(SOILS["SNOW"], layer_depth_m=layer_m)


def test_a_thin_positive_layer_is_accepted_and_caps_the_sinkage():
    soil = replace(SOILS["SNOW"], layer_depth_m=1e-3)
    assert max_sinkage_m(0.1651, soil) == 1e-3


@pytest.mark.parametrize("field, args", [
    ("wheel_radius_m", (0.11, 0.08, -0.1651)),   # before: sinkage -0.1651 m, strength 109 N
    ("wheel_radius_m", (0.11, 0.08, 0.0)),       # before: sinkage 0 at every load
    ("wheel_radius_m", (0.11, 0.08, float("nan"))),
    ("width_m", (0.0, 0.08, 0.1651)),
    ("footprint_length_m", (0.11, -0.08, 0.1651)),
])
def test_soil_contact_refuses_a_wheel_that_is_not_finite_and_positive(field, args):
    with pytest.raises(ConfigError, match=f"soil_contact.{field}"):
        soil_contact(SOILS["SNOW"], *args, 4.0 * 50.0 * 9.80665 / 4.0)


def test_soil_contact_sinkage_stays_within_the_rim():
    c = soil_contact(SOILS["SNOW"], 0.11, 0.08, 0.1651, 4.0 * 50.0 * 9.80665 / 4.0)
    assert np.all(c.sinkage_grid_m >= 0.0) and np.all(c.sinkage_grid_m <= 0.1651)
    assert np.all(np.diff(c.sinkage_grid_m) >= 0.0)      # deeper under more load
