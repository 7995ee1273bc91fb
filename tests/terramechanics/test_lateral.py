"""Soil parameters of the lateral wheel-soil model (terrain.terramechanics.lateral)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from terrain.errors import ConfigError
from terrain.terramechanics.lateral import SOILS, soil_contact, soil_lateral_force_and_slope

W = 50.0 * 9.80665 / 4.0          # static Husky wheel load, N


@pytest.mark.parametrize("change", [
    dict(shear_modulus_m=-0.01, lateral_shear_modulus_m=None),   # lateral force along the slide
    dict(lateral_shear_modulus_m=-0.01),
    dict(lateral_shear_modulus_m=0.0),                            # NaN force
    dict(shear_modulus_m=float("nan")),
    dict(n=0.0),                                                  # ZeroDivisionError in sinkage
    dict(n=-0.5),
    dict(friction_angle_deg=0.0),                                 # NaN bearing-capacity factors
    dict(friction_angle_deg=95.0),                                # lateral force along the slide
    dict(friction_angle_deg=float("nan")),
    dict(cohesion_pa=-1000.0),
    dict(unit_weight_n_m3=-1.0),
    dict(k_phi=float("inf")),
])
def test_soil_params_refuse_values_that_give_nan_or_a_force_along_the_slide(change):
    # before: each was accepted; K_y = -0.01 m gave +200 N at v_lat = +0.1 m/s on the Husky
    # wheel (pushing along the slide), phi = 0 or K_y = 0 a NaN force, n = 0 a
    # ZeroDivisionError inside soil_contact
    with pytest.raises(ConfigError):
        replace(SOILS["SANDY_LOAM"], **change)


@pytest.mark.parametrize("name", sorted(SOILS))
def test_shipped_soils_pass_validation_and_resist_the_slide(name):
    soil = replace(SOILS[name])                   # re-runs __post_init__
    contact = soil_contact(soil, 0.11, 0.08, 0.1651, 4.0 * W)
    force, slope, _ = soil_lateral_force_and_slope(contact, np.array([W, W]),
                                                   np.array([0.1, -0.1]), np.array([0.3, 0.3]))
    assert np.all(np.isfinite(force)) and force[0] < 0.0 < force[1]
    assert np.all(slope <= 0.0)


@pytest.mark.parametrize("max_load_n, n_grid, field", [
    (0.0, 64, "max_load_n"),          # before: a table of zero loads, strength 0 at any load
    (-10.0, 64, "max_load_n"),
    (float("nan"), 64, "max_load_n"),
    (4.0 * W, 1, "n_grid"),           # before: one row at load 0, strength 0 at any load
    (4.0 * W, 2.5, "n_grid"),
])
def test_soil_contact_refuses_a_table_with_no_loaded_row(max_load_n, n_grid, field):
    with pytest.raises(ConfigError, match=f"soil_contact: {field}|soil_contact n_grid"):
        soil_contact(SOILS["SNOW"], 0.11, 0.08, 0.1651, max_load_n, n_grid=n_grid)
