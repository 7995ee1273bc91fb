"""Review sim20: a ContactGeometry (the contact points, motor map and static load shares that
the simulator's force model and can_turn_in_place read) refuses what no vehicle can have,
with a ConfigError naming ``ContactGeometry.<field>``: load shares that do not sum to the
weight, NaN or negative ones, contacts without a motor, motors without a contact, a negative
wheel radius."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from terrain.errors import ConfigError
from terrain.sim.dynamics import integrate
from terrain.terramechanics import get_terrain
from terrain.vehicles import AGRIMARO, HUSKY, TRACKED

GEOMETRY = HUSKY.contact_geometry()

BAD = {
    # the loads summed to twice the weight: every force of the run doubled, no word
    "load_share": [np.full(4, 0.5), np.array([np.nan, 0.25, 0.25, 0.25]),
                   np.array([-0.25, 0.75, 0.25, 0.25]), np.full(3, 1 / 3), np.full(4, True),
                   np.full((4, 1), 0.25), "0.25"],
    "positions_m": [np.zeros((4, 3)), np.full((4, 2), np.nan), np.full((4, 2), np.inf),
                    np.zeros((0, 2)), np.full((4, 2), True), None],
    # motor 2 of two: an IndexError deep in the first step; a float index was truncated
    "motor_of_contact": [np.array([0, 0, 1, 2]), np.array([0, 0, 1, -1]),
                         np.array([0.0, 0.0, 1.0, 1.0]), np.array([0, 0, 1]),
                         np.array([0, 0, 0, 0]), np.array([True, True, False, False])],
    "wheel_radius_m": [-0.1651, 0.0, np.nan, np.inf, True, "0.1651"],
    "steered": ["no", 1, None],
    "motor_names": [("left", "left"), ("left",) * 3, (), "lr", ("left", 2)],
}


@pytest.mark.parametrize("field, bad", [(f, b) for f, values in BAD.items() for b in values],
                         ids=lambda x: x if isinstance(x, str) else None)
def test_an_impossible_contact_geometry_is_refused_naming_its_field(field, bad):
    with pytest.raises(ConfigError, match=rf"ContactGeometry\.{field}"):
        replace(GEOMETRY, **{field: bad})


def test_fields_that_disagree_on_the_number_of_contacts_are_refused():
    # three positions for four motor indices and four shares
    with pytest.raises(ConfigError, match=r"ContactGeometry\.motor_of_contact.*per contact \(3\)"):
        replace(GEOMETRY, positions_m=np.zeros((3, 2)))


def test_the_shipped_geometries_are_valid():
    for vehicle in (HUSKY, AGRIMARO, TRACKED):
        geo = vehicle.contact_geometry()
        assert replace(geo).n_motors == len(geo.motor_names)
    for n in (1, 2, 7):
        assert replace(TRACKED, n_segments=n).contact_geometry().positions_m.shape == (2 * n, 2)


def test_a_geometry_whose_loads_exceed_the_weight_cannot_reach_the_simulator():
    # before: integrate ran it, every contact carrying twice its load
    t = np.arange(11) * 0.01
    with pytest.raises(ConfigError, match=r"ContactGeometry\.load_share"):
        integrate(HUSKY, replace(GEOMETRY, load_share=np.full(4, 0.5)),
                  (get_terrain("ASPHALT"),), np.inf, t, np.zeros((11, 3)), 0.0, 1.0)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(0.01, 1.0), min_size=4, max_size=4),
       st.floats(0.01, 1.0), st.booleans())
def test_any_normalised_nonnegative_shares_and_positive_radius_are_kept(w, radius, steered):
    share = np.asarray(w) / np.sum(w)
    geo = replace(GEOMETRY, load_share=share, wheel_radius_m=radius, steered=steered)
    # kept as a read-only copy (test_geometry_sim23_review): equal, not the same array
    np.testing.assert_array_equal(geo.load_share, share)
    assert geo.wheel_radius_m == radius


@pytest.mark.parametrize("vehicle, fields, name", [
    # a patch in cm (11 for 0.11 m) is wider than the track: left and right wheels overlap
    (HUSKY, dict(contact_width_m=11.0), "contact_width_m"),
    (HUSKY, dict(contact_width_m=0.5708), "contact_width_m"),
    (HUSKY, dict(track_m=0.1), "contact_width_m"),
    # a footprint longer than the wheelbase: front and rear patches overlap
    (HUSKY, dict(contact_length_m=8.0), "contact_length_m"),
    (TRACKED, dict(track_width_m=15.0), "track_width_m"),
    (TRACKED, dict(track_width_m=0.393), "track_width_m"),
])
def test_contacts_wider_than_the_track_or_longer_than_the_wheelbase_are_refused(
        vehicle, fields, name):
    with pytest.raises(ConfigError, match=rf"{type(vehicle).__name__}\.{name}"):
        replace(vehicle, **fields)


@settings(max_examples=40, deadline=None)
@given(st.floats(0.05, 2.0), st.floats(0.01, 0.99), st.floats(0.01, 0.99))
def test_contacts_inside_the_track_and_wheelbase_are_kept(track, width_frac, length_frac):
    h = replace(HUSKY, track_m=track, contact_width_m=width_frac * track,
                contact_length_m=length_frac * HUSKY.wheelbase_m)
    t = replace(TRACKED, track_m=track, track_width_m=width_frac * track)
    assert h.contact_width_m < h.track_m and t.track_width_m < t.track_m
