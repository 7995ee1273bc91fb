"""Review tests (sim23): a :class:`terrain.vehicles.ContactGeometry` is frozen and checked
when made, so it must not share its arrays with the caller who made it."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from terrain.vehicles import get_vehicle
from terrain.vehicles.common import ContactGeometry


def _inputs(y):
    return (np.array([[0.2, y], [0.2, -y], [-0.2, y], [-0.2, -y]]), np.array([0, 1, 0, 1]),
            np.full(4, 0.25))


@settings(max_examples=20, deadline=None)
@given(y=st.floats(0.05, 1.0), scale=st.floats(-3.0, 3.0))
def test_changing_the_arrays_given_leaves_the_geometry_alone(y, scale):
    """The geometry kept the caller's arrays: doubling the load shares it was made from
    after the check (shares summing to 2: every normal load doubled) or moving the
    positions changed a frozen, checked geometry without a word."""
    pos, motors, share = _inputs(y)
    geometry = ContactGeometry(pos, motors, share, False, 0.1, ("left", "right"))
    pos *= scale
    share *= 2.0
    motors[:] = 0
    np.testing.assert_array_equal(geometry.positions_m, _inputs(y)[0])
    np.testing.assert_array_equal(geometry.load_share, np.full(4, 0.25))
    np.testing.assert_array_equal(geometry.motor_of_contact, [0, 1, 0, 1])


@pytest.mark.parametrize("vehicle", ["husky", "tracked", "agrimaro"])
@pytest.mark.parametrize("field", ["positions_m", "motor_of_contact", "load_share"])
def test_a_geometrys_arrays_are_read_only(vehicle, field):
    """A frozen geometry's arrays cannot be written through either (the check of its load
    shares would no longer hold)."""
    geometry = get_vehicle(vehicle).contact_geometry()
    with pytest.raises(ValueError):
        getattr(geometry, field)[0] = 1


def test_lists_are_kept_as_arrays():
    """Lists passed the check and stayed lists (``positions_m[:, 0]`` a TypeError later);
    the geometry holds them as the arrays its docstring names."""
    geometry = ContactGeometry([[0.0, 0.1], [0.0, -0.1]], [0, 1], [0.5, 0.5], False, 0.1,
                               ("left", "right"))
    assert isinstance(geometry.positions_m, np.ndarray)
    assert geometry.positions_m.dtype == float and geometry.load_share.dtype == float
    assert geometry.motor_of_contact.dtype.kind == "i"
