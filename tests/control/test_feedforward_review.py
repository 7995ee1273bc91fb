"""Review tests of the feed-forward slip limit (terrain.control.feedforward)."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.control.feedforward import feedforward_step, traction_acceleration_limit
from terrain.terramechanics import get_terrain


def test_a_nan_speed_estimate_counts_as_zero_and_the_reference_stays_usable():
    """v_est NaN (an estimator without a sample yet) counts as 0: the reference grows by
    a_max dt from its previous value, and the next step accepts it. A NaN reaching the
    reference would be refused at the next step (ImplausibleValueError) and stop the loop."""
    args = (np.array([2.0, 2.0]), 1.0, 0.2, 0.1, 0.02)   # omega_ll, a_max, s_t, r, dt
    ff = feedforward_step(np.array([0.05, 0.05]), np.array([np.nan, 0.0]), *args)
    np.testing.assert_allclose(ff.v_ref_m_s, [0.07, 0.07])          # 0.05 + 1.0 * 0.02
    np.testing.assert_allclose(ff.omega_limit_rad_s, [0.07 / (0.1 * 0.8)] * 2)
    assert ff.engaged.all()
    again = feedforward_step(ff.v_ref_m_s, np.array([np.nan, np.nan]), *args, ff.engaged)
    np.testing.assert_allclose(again.v_ref_m_s, [0.09, 0.09])


@pytest.mark.parametrize("bad", [np.inf, -np.inf])
def test_an_infinite_speed_estimate_counts_as_zero_too(bad):
    """The docstring's rule is for any non-finite estimate: +inf became 1.8e308 through
    nan_to_num, lifting the reference to it, and the wheel's limit was released."""
    args = (np.array([2.0, 2.0]), 1.0, 0.2, 0.1, 0.02)
    ff = feedforward_step(np.array([0.05, 0.05]), np.array([bad, 0.0]), *args)
    np.testing.assert_allclose(ff.v_ref_m_s, [0.07, 0.07])
    assert ff.engaged.all()


@pytest.mark.parametrize("name", ["ICE", "GRASS", "SNOW"])
def test_the_acceleration_limit_depends_on_the_slip_magnitude_only(name):
    """slip is a magnitude: a braking-signed slip gives the limit of its magnitude (on the
    deformable soils the soil resistance exceeds the traction at 0.1: a negative limit)."""
    terrain = get_terrain(name)
    for s in (0.05, 0.1, 0.3):
        assert traction_acceleration_limit(terrain, -s) == traction_acceleration_limit(terrain, s)
    assert traction_acceleration_limit(terrain, 0.3) != traction_acceleration_limit(terrain, 0.05)
