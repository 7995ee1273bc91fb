"""Tests that kill hand mutants of the integrator that survived the sim tests (tm15)."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.sim.dynamics import integrate, soil_contacts
from terrain.terramechanics.catalogue import get_terrain
from terrain.vehicles import AGRIMARO, HUSKY, TRACKED


@pytest.mark.parametrize("vehicle, per_contact_m", [(HUSKY, 0.08), (TRACKED, 0.6 / 5)])
def test_a_soil_contacts_firm_footprint_is_its_share_of_the_wheel_or_track(
        vehicle, per_contact_m):
    # the tracked vehicle's 0.6 m track is five contact points of 0.12 m each; the Husky's
    # two wheels per motor are two contacts of its own 0.08 m footprint (taking the whole
    # track length per point survived every test: only Husky runs are pinned)
    geo = vehicle.contact_geometry()
    contact = soil_contacts(vehicle, geo, (get_terrain("SANDY_LOAM"),))["SANDY_LOAM"]
    assert contact.length_grid_m[0] == pytest.approx(per_contact_m, rel=1e-12)
    assert contact.width_m == pytest.approx(float(vehicle.contact_width_m))


def test_the_terrain_changes_after_the_distance_travelled_sideways_too():
    # a swerve drive crabbing sideways at 0.5 m/s crosses a 0.4 m segment in about 0.8 s:
    # the travelled distance is |(v_x, v_y)|, not v_x alone (which never left terrain 0)
    geo = AGRIMARO.contact_geometry()
    t = np.arange(0.0, 3.0, 0.01)
    cmd = np.column_stack([np.zeros_like(t), np.full_like(t, 0.5), np.zeros_like(t)])
    p = integrate(AGRIMARO, geo, (get_terrain("ASPHALT"), get_terrain("GRASS")), 0.4, t, cmd,
                  0.0, 1.0)
    # row k is the vehicle at t_s[k] (row 0 at rest): the distance travelled by then is the
    # sum of the speeds at the ends of the k steps before it
    speed = np.hypot(p.twist[1:, 0], p.twist[1:, 1])
    travelled = np.concatenate([[0.0], np.cumsum(0.01 * speed)])
    assert abs(p.pose[-1, 0]) < 0.05 and abs(p.pose[-1, 1]) > 1.0
    np.testing.assert_array_equal(p.terrain_index, (travelled // 0.4).astype(int) % 2)
    assert set(p.terrain_index.tolist()) == {0, 1}


def test_combined_shear_scales_the_traction_slope_by_its_share_too():
    # the slope the Jacobian and the reach chord use is the shared curve's, share * mu'(s)
    # (with the share held fixed), as the traction itself is share * mu(s): the slope of the
    # one-direction curve survived every test
    from dataclasses import replace

    from terrain.sim.dynamics import v2_terrain
    from terrain.sim.forces import contact_forces, contact_layout, velocity_maps
    from terrain.terramechanics.lateral import SOILS, soil_contact

    w = HUSKY.mass_kg * 9.80665 / 4.0
    layout = contact_layout(HUSKY.contact_geometry(), HUSKY.mass_kg, 0.0, 1.0)
    maps = velocity_maps(layout, np.zeros_like(layout.x_m))
    soil = replace(SOILS["SANDY_LOAM"], combined_shear=True)
    contact = soil_contact(soil, 0.11, 0.08, 0.1651, 4 * w)
    ter = v2_terrain(get_terrain("SANDY_LOAM"), contact, w)
    omega = np.full(2, 0.5 / HUSKY.wheel_radius_m)
    c = contact_forces(layout, maps, ter, np.array([0.4, 0.2, 0.0]), omega, soil=contact)
    assert np.all(c.shear_share < 0.9)
    alone = ter.curve.coefficients(np.abs(c.slip), 0.0)
    np.testing.assert_allclose(c.mu, alone.mu * c.shear_share, rtol=1e-12)
    np.testing.assert_allclose(c.dmu_ds_tangent, alone.dmu_ds * c.shear_share, rtol=1e-12)
