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
    speed = np.hypot(p.twist[:-1, 0], p.twist[:-1, 1])
    travelled = np.concatenate([[0.0], np.cumsum(0.01 * speed)])
    assert abs(p.pose[-1, 0]) < 0.05 and abs(p.pose[-1, 1]) > 1.0
    np.testing.assert_array_equal(p.terrain_index, (travelled // 0.4).astype(int) % 2)
    assert set(p.terrain_index.tolist()) == {0, 1}
