"""Review tmx: the soil relations refuse a contact geometry or soil that is not physical."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import ConfigError
from terrain.terramechanics.lateral import (SOILS, SoilContact, bulldozing_force_n,
                                            contact_chord_m, lateral_strength_n,
                                            max_sinkage_m, shear_strength_n, soil_contact)
from terrain.terramechanics.resistance import (bekker_compaction_coefficient,
                                               compaction_resistance_n)

LOAM = SOILS["SANDY_LOAM"]
BAD_LENGTHS = [-0.11, 0.0, np.nan, np.inf, True, "0.11", None]


@pytest.mark.parametrize("width", BAD_LENGTHS, ids=repr)
def test_compaction_resistance_refuses_a_width_that_is_not_a_finite_length(width):
    # a negative width gave a resistance pushing the wheel (-0.11 m: R_c < 0), 0 divided by
    # zero, True was a 1 m wide contact
    with pytest.raises(ConfigError, match=r"compaction_resistance_n\.width_m"):
        compaction_resistance_n(0.01, width, LOAM.k_c, LOAM.k_phi, LOAM.n)


@pytest.mark.parametrize("kwargs, name", [
    ({"n": -0.7}, r"\.n must be a finite value > 0"),
    ({"n": np.nan}, r"\.n must be a finite value > 0"),
    ({"k_c": "5270"}, r"\.k_c must be a real number"),
    ({"k_phi": None}, r"\.k_phi must be a real number"),
    ({"k_c": -1e6, "k_phi": 0.0}, r": k_c / width_m \+ k_phi must be a finite modulus"),
])
def test_compaction_resistance_refuses_a_soil_without_a_pressure_sinkage_modulus(kwargs, name):
    soil = {"k_c": LOAM.k_c, "k_phi": LOAM.k_phi, "n": LOAM.n} | kwargs
    with pytest.raises(ConfigError, match="compaction_resistance_n" + name):
        compaction_resistance_n(0.01, 0.11, **soil)


def test_compaction_resistance_of_a_valid_contact_is_unchanged():
    # the checks add no arithmetic: Wong eq. 2.54 by hand, and Python ints still accepted
    z = np.array([0.0, 0.004, 0.02])
    r, dr = compaction_resistance_n(z, 0.11, LOAM.k_c, LOAM.k_phi, LOAM.n)
    modulus = 0.11 * (LOAM.k_c / 0.11 + LOAM.k_phi)
    np.testing.assert_array_equal(r, modulus * z ** (LOAM.n + 1.0) / (LOAM.n + 1.0))
    np.testing.assert_array_equal(dr, modulus * z ** LOAM.n)
    assert compaction_resistance_n(0.01, 1, 5270, 1515040, 1)[0] == 1.0 * (5270 + 1515040) \
        * 0.01 ** 2 / 2.0
    assert bekker_compaction_coefficient(123.0, 0.11, 0.08, LOAM.k_c, LOAM.k_phi,
                                         LOAM.n) > 0.0


@pytest.mark.parametrize("radius", [-0.165, 0.0, np.nan, np.inf, True], ids=repr)
def test_a_wheel_radius_that_is_not_a_finite_length_is_refused(radius):
    # max_sinkage_m returned a negative radius as the deepest sinkage; contact_chord_m gave
    # the firm footprint at any sinkage
    with pytest.raises(ConfigError, match=r"max_sinkage_m\.wheel_radius_m"):
        max_sinkage_m(radius, LOAM)
    with pytest.raises(ConfigError, match=r"contact_chord_m\.wheel_radius_m"):
        contact_chord_m(0.01, radius, 0.08)


@pytest.mark.parametrize("width", [-0.11, 0.0, np.nan, np.inf, True], ids=repr)
def test_strengths_refuse_a_width_that_is_not_a_finite_length(width):
    # a negative width took the cohesion c b l off the strength (36.5 N instead of 66.8 N)
    load, length = np.array([100.0]), np.array([0.1])
    with pytest.raises(ConfigError, match=r"shear_strength_n\.width_m"):
        shear_strength_n(LOAM, width, load, length)
    with pytest.raises(ConfigError, match=r"lateral_strength_n\.width_m"):
        lateral_strength_n(LOAM, width, load, np.array([0.01]), length)


@pytest.mark.parametrize("bad", [-0.1, np.nan, np.array([0.1, -0.1]),
                                 np.array([0.1, np.inf]), np.array([True])], ids=repr)
def test_length_arrays_refuse_negative_or_non_finite_entries(bad):
    # a negative wall gave a bulldozing force pulling the wheel into its slide; a negative
    # footprint was read as none
    with pytest.raises(ConfigError, match=r"bulldozing_force_n.*wall_width_m"):
        bulldozing_force_n(0.01, bad, LOAM)
    with pytest.raises(ConfigError, match=r"contact_chord_m.*footprint_length_m"):
        contact_chord_m(np.array([0.01, 0.02]), 0.165, bad)


def test_the_flat_index_of_the_first_bad_length_is_named():
    with pytest.raises(ConfigError, match=r"1 that are not, the first -0\.2 at flat index 2"):
        bulldozing_force_n(0.01, np.array([0.1, 0.0, -0.2]), LOAM)


def test_zero_lengths_stay_valid_where_they_mean_something():
    # a rim without a footprint (the chord alone) and a wall of no width (no force)
    assert float(contact_chord_m(0.2, 0.2, 0.0)) == pytest.approx(0.4)
    assert bulldozing_force_n(0.01, 0.0, LOAM) == 0.0
    np.testing.assert_array_equal(bulldozing_force_n(np.array([0.01, 0.02]),
                                                     np.array([0.0, 1]), LOAM)[0], 0.0)


def test_soil_contact_built_directly_refuses_a_negative_width_or_radius():
    c = soil_contact(LOAM, 0.11, 0.08, 0.165, 600.0, n_grid=4)
    grids = (c.load_grid_n, c.strength_grid_n, c.length_grid_m, c.sinkage_grid_m,
             c.shear_grid_n)
    with pytest.raises(ConfigError, match=r"SoilContact\.width_m"):
        SoilContact(LOAM, -0.11, 0.165, *grids)
    with pytest.raises(ConfigError, match=r"SoilContact\.wheel_radius_m"):
        SoilContact(LOAM, 0.11, -0.165, *grids)
