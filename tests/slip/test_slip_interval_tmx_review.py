"""Review tmx: the physics slip interval of a traction interval with an infinite end."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.slip.physics import _slip_interval
from terrain.terramechanics.catalogue import TERRAIN_NAMES, get_terrain
from terrain.terramechanics.inverse import slip_from_traction, stable_side

BIG = 1e300     # a finite end beyond every curve's maximum, as far out as a float goes


@pytest.mark.parametrize("name", TERRAIN_NAMES)
def test_an_infinite_end_gives_the_limit_of_ever_larger_finite_ends(name):
    # an infinite end was read as a NaN slip (slip_from_traction masked it), so the interval
    # was NaN at that end although +-inf is beyond the maximum: it is open to full slip
    curve = get_terrain(name).curve
    mu_max = stable_side(curve)[1][-1]
    low = np.array([[-np.inf, 0.3 * mu_max, -np.inf, 1.5 * mu_max, np.inf, -np.inf]])
    high = np.array([[np.inf, np.inf, -0.3 * mu_max, np.inf, np.inf, -np.inf]])
    got = _slip_interval(curve, low, high)
    want = _slip_interval(curve, np.clip(low, -BIG, BIG), np.clip(high, -BIG, BIG))
    for g, w in zip(got, want):
        assert not np.isnan(g).any()
        np.testing.assert_array_equal(g, w)
    lower, upper = got
    assert lower[0, 0] == -1.0 and upper[0, 0] == 1.0         # (-inf, inf): any slip
    assert upper[0, 1] == 1.0 and lower[0, 2] == -1.0          # open to full slip
    # the finite end keeps its exact stable-side slip
    assert lower[0, 1] == slip_from_traction(curve, 0.3 * mu_max).slip
    assert upper[0, 2] == slip_from_traction(curve, -0.3 * mu_max).slip


@pytest.mark.parametrize("name", ["ASPHALT", "SNOW"])
def test_a_nan_end_stays_nan(name):
    curve = get_terrain(name).curve
    lower, upper = _slip_interval(curve, np.array([[np.nan, -np.inf]]),
                                  np.array([[np.inf, np.nan]]))
    assert np.isnan(lower[0, 0]) and upper[0, 0] == 1.0
    assert lower[0, 1] == -1.0 and np.isnan(upper[0, 1])
