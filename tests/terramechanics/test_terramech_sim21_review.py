"""Review sim21: metamorphic relations of the lateral wheel-soil law of physics v2.

The lateral force of :func:`terrain.terramechanics.lateral.soil_lateral_force_and_slope` is a
resistance: it never pushes a wheel the way it slides (its secant slope is never positive,
as the docstring promises), it is odd in the velocities (a mirrored wheel gets the mirrored
force), the secant slope times the velocity is the force, one wheel at a time gives what all
wheels at once give, and a wheel carrying more load resists at least as much.
"""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from dataclasses import replace

from terrain.terramechanics.lateral import SOILS, soil_contact, soil_lateral_force_and_slope

# the shipped soils and the probes of docs/physics_v2.md (slip sinkage k_s 5, a
# velocity-weakening soil), so that every branch of the law is exercised
VARIANTS = {**SOILS,
            "SANDY_LOAM k_s 5": replace(SOILS["SANDY_LOAM"], slip_sinkage_ratio=5.0),
            "SNOW weakening": replace(SOILS["SNOW"], rate_weakening_speed_m_s=0.1)}
# Husky wheel: width 0.11 m, firm footprint 0.08 m, radius 0.165 m (the tables of a v2 run)
CONTACTS = {name: soil_contact(soil, 0.11, 0.08, 0.165, 600.0)
            for name, soil in VARIANTS.items()}
FLOATS = dict(allow_nan=False, allow_infinity=False)


def _arrays(n, lo, hi):
    return st.lists(st.floats(lo, hi, **FLOATS), min_size=n, max_size=n).map(np.array)


@st.composite
def wheels(draw):
    n = draw(st.integers(1, 5))
    return (draw(_arrays(n, -10.0, 700.0)), draw(_arrays(n, -0.5, 0.5)),
            draw(_arrays(n, -1.0, 1.0)), draw(_arrays(n, -1.0, 1.0)))


@settings(max_examples=60, deadline=None)
@given(name=st.sampled_from(sorted(VARIANTS)), w=wheels(), slip_sunk=st.booleans())
def test_the_lateral_soil_force_resists_is_odd_and_is_its_secant_times_the_velocity(
        name, w, slip_sunk):
    load, v_lat, rim, slip = w
    contact = CONTACTS[name]
    kw = {"slip_ratio": slip} if slip_sunk else {}
    force, slope, _ = soil_lateral_force_and_slope(contact, load, v_lat, rim, **kw)
    assert np.all(slope <= 0.0)
    assert np.all(force * v_lat <= 0.0)
    np.testing.assert_allclose(slope * v_lat, force, rtol=1e-9, atol=1e-9)
    assert np.all(force[load <= 0.0] == 0.0)
    # mirrored left to right: the lateral velocity changes sign, rims and slips do not
    mirrored = soil_lateral_force_and_slope(contact, load, -v_lat, rim, **kw)
    np.testing.assert_allclose(mirrored[0], -force, rtol=0, atol=1e-12)
    np.testing.assert_allclose(mirrored[1], slope, rtol=0, atol=1e-12)
    # driven backwards: rim speed and slip change sign, the lateral resistance does not
    backwards = soil_lateral_force_and_slope(contact, load, v_lat, -rim,
                                             **{k: -a for k, a in kw.items()})
    np.testing.assert_allclose(backwards[0], force, rtol=0, atol=1e-12)
    np.testing.assert_allclose(backwards[1], slope, rtol=0, atol=1e-12)
    one_by_one = [soil_lateral_force_and_slope(contact, load[i:i + 1], v_lat[i:i + 1],
                                               rim[i:i + 1],
                                               **{k: a[i:i + 1] for k, a in kw.items()})[0][0]
                  for i in range(len(load))]
    np.testing.assert_allclose(one_by_one, force, rtol=0, atol=1e-12)


@settings(max_examples=40, deadline=None)
@given(name=st.sampled_from(sorted(VARIANTS)), loads=_arrays(6, 0.0, 700.0),
       v=st.floats(-0.5, 0.5, **FLOATS), rim=st.floats(-1.0, 1.0, **FLOATS))
def test_a_wheel_carrying_more_load_resists_sliding_at_least_as_much(name, loads, v, rim):
    loads = np.sort(loads)
    force = soil_lateral_force_and_slope(CONTACTS[name], loads, np.full(6, v),
                                         np.full(6, rim))[0]
    assert np.all(np.diff(np.abs(force)) >= -1e-9)


# sim21 (fixed 2026-11-30): the shear part subtracted for the longitudinal share was computed
# at the load (c b l + N tan phi, cohesion whole at any load > 0) while the strength was
# interpolated from the table (0 in its unloaded row): below the first loaded row (9.5 N on
# this 600 N table) the strength left was negative and the force pushed the wheel the way it
# slid. The shear part now comes from the table as the strength does (SoilContact.shear_grid_n)
def test_with_the_shared_shear_strength_a_lightly_loaded_wheel_still_resists():
    contact = CONTACTS["SANDY_LOAM"]
    load, v_lat, rim = np.array([0.978]), np.array([-0.0536]), np.array([0.955])
    force, slope, share = soil_lateral_force_and_slope(contact, load, v_lat, rim,
                                                       shear_long=np.array([2.055]))
    assert share is not None
    assert np.all(slope <= 0.0)
    assert np.all(force * v_lat <= 0.0)


@settings(max_examples=40, deadline=None)
@given(name=st.sampled_from(sorted(VARIANTS)), loads=_arrays(6, 0.0, 30.0),
       v=st.floats(-0.5, 0.5, **FLOATS), rim=st.floats(-1.0, 1.0, **FLOATS),
       a_long=st.floats(0.0, 50.0, **FLOATS))
def test_the_shared_strength_left_resists_and_is_the_whole_one_without_longitudinal_shear(
        name, loads, v, rim, a_long):
    # below and around the table's first loaded row: the shared force never pushes, never
    # exceeds the whole-strength force, and is that force when the wheel does not slip along
    contact, n = CONTACTS[name], len(loads)
    v_lat, rims = np.full(n, v), np.full(n, rim)
    whole = soil_lateral_force_and_slope(contact, loads, v_lat, rims)[0]
    shared, slope, _ = soil_lateral_force_and_slope(contact, loads, v_lat, rims,
                                                    shear_long=np.full(n, a_long))
    assert np.all(slope <= 0.0)
    assert np.all(shared * v_lat <= 0.0)
    assert np.all(np.abs(shared) <= np.abs(whole) + 1e-12)
    unshared = soil_lateral_force_and_slope(contact, loads, v_lat, rims,
                                            shear_long=np.zeros(n))[0]
    np.testing.assert_allclose(unshared, whole, rtol=1e-12, atol=1e-12)
