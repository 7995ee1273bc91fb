"""Resistance inputs (errx review): the bulldozing wall of a negative or non-numeric
sinkage, consistent with the compaction of a rut, and the Bekker plate checks naming the
function called (``bekker_compaction_coefficient``'s errors were named
``bekker_sinkage_m``)."""

import numpy as np
import pytest

from terrain.errors import ConfigError, DataFormatError
from terrain.terramechanics.lateral import SOILS, bulldozing_force_n
from terrain.terramechanics.resistance import (bekker_compaction_coefficient, bekker_sinkage_m,
                                               compaction_resistance_n)

SOIL = next(iter(SOILS.values()))


@pytest.mark.parametrize("z", [-0.01, -1.0, np.array([-0.05, -1e-9])])
def test_a_negative_sinkage_is_no_wall_as_no_rut(z):
    force = bulldozing_force_n(z, 0.2, SOIL)       # was negative: pulled the wheel
    np.testing.assert_array_equal(force, np.zeros(np.shape(z)))
    np.testing.assert_array_equal(compaction_resistance_n(z, 0.2, 1e3, 1e5, 1.0)[0],
                                  np.zeros(np.shape(z)))


def test_a_nan_sinkage_passes_as_nan_in_both():
    assert np.isnan(bulldozing_force_n(np.nan, 0.2, SOIL))
    assert np.isnan(compaction_resistance_n(np.nan, 0.2, 1e3, 1e5, 1.0)[0])


def test_a_positive_sinkage_gives_the_force_it_gave():
    z = np.array([0.0, 0.01, 0.05])
    phi = np.radians(SOIL.friction_angle_deg)
    from terrain.terramechanics.lateral import bearing_capacity_factors
    n_c, _, n_g = bearing_capacity_factors(SOIL.friction_angle_deg)
    cos2 = np.cos(phi) ** 2
    k_pc, k_pg = (n_c - np.tan(phi)) * cos2, (2.0 * n_g / np.tan(phi) + 1.0) * cos2
    expected = 0.2 * (0.67 * SOIL.cohesion_pa * z * k_pc + 0.5 * z * z * SOIL.unit_weight_n_m3
                      * k_pg)
    np.testing.assert_array_equal(bulldozing_force_n(z, 0.2, SOIL), expected)
    assert bulldozing_force_n(0.05, 0.2, SOIL) == expected[2]


@pytest.mark.parametrize("z", [True, [0.05, True], None, "0.05", np.array(["a"])])
def test_a_sinkage_that_is_not_a_number_is_refused_naming_it(z):
    with pytest.raises(DataFormatError, match="bulldozing_force_n: sinkage_m must"):
        bulldozing_force_n(z, 0.2, SOIL)     # True was a 1 m wall, None a NaN force


def test_bekker_errors_name_the_function_called():
    args = (100.0, 0.1, 0.2, 1e3, 1e5)
    with pytest.raises(ConfigError, match=r"^bekker_compaction_coefficient\.n must be"):
        bekker_compaction_coefficient(*args, -1.0)     # was "bekker_sinkage_m.n"
    with pytest.raises(ConfigError, match=r"^bekker_compaction_coefficient\.load_n must be"):
        bekker_compaction_coefficient(np.nan, *args[1:], 1.0)
    with pytest.raises(ConfigError, match=r"^bekker_compaction_coefficient: k_c / width_m"):
        bekker_compaction_coefficient(100.0, 0.1, 0.2, -1e5, 1e3, 1.0)
    with pytest.raises(ConfigError, match=r"^bekker_sinkage_m\.n must be"):
        bekker_sinkage_m(*args, -1.0)
