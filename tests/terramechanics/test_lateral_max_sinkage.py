"""The deepest sinkage of a wheel: one rule for the static and the slip sinkage."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from terrain.terramechanics.lateral import SOILS, max_sinkage_m, wheel_sinkage_m


@pytest.mark.parametrize("layer_m, expected_m", [(None, 0.165), (0.05, 0.05), (0.3, 0.165)])
def test_max_sinkage_is_the_radius_or_the_shallower_firm_base(layer_m, expected_m):
    soil = replace(SOILS["SANDY_LOAM"], layer_depth_m=layer_m)
    assert max_sinkage_m(0.165, soil) == expected_m


def test_static_sinkage_stops_at_a_shallow_firm_base():
    soil = SOILS["SANDY_LOAM"]
    free, _ = wheel_sinkage_m(2000.0, 0.1, 0.08, 0.165, soil)
    capped, _ = wheel_sinkage_m(2000.0, 0.1, 0.08, 0.165,
                                replace(soil, layer_depth_m=0.5 * free))
    assert capped == pytest.approx(0.5 * free)
    assert np.isfinite(free) and free > capped
