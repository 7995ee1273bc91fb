"""Boundaries of the audit report (terrain.audit.report), review aud23: a measured chi met
exactly by an end of the lateral-friction sweep."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from terrain.audit.report import matching_lateral_friction


def _sweep(mu, chi, measured):
    return pd.DataFrame({"lateral_friction": mu, "replay_chi": chi,
                         "measured_chi": [measured] * len(mu)})


@pytest.mark.parametrize("mu, chi, expected", [
    ([0.5], [1.8], "~0.50"),                          # one friction, met exactly (was above)
    ([0.5, 1.0], [1.8, np.inf], "~0.50"),             # met before digging in (was between)
    ([0.25, 0.5, 1.0], [1.2, 1.8, np.inf], "~0.50"),  # the same inside the sweep
    ([0.5, 1.0], [1.2, 1.8], "~1.00"),                # the last friction, met exactly
    ([0.5, 1.0], [1.8, 2.4], "~0.50"),                # the first friction, met exactly
])
def test_a_sweep_point_whose_replayed_chi_is_the_measured_one_is_the_match(mu, chi, expected):
    """The sweep brackets the measured chi with closed ends: a friction whose replay gives
    exactly the measured chi is the matching friction, whether it is the sweep's only point,
    its first, its last or the last before the replay digs in (chi inf). A single factor
    was reported 'above 0.5', and a point just before one digging in 'between 0.5 and 1'."""
    assert matching_lateral_friction(_sweep(mu, chi, 1.8)) == expected


@pytest.mark.parametrize("delta, expected", [(-1, "below 0.5"), (1, "above 0.5")])
def test_one_ulp_either_side_of_a_single_point_is_below_or_above(delta, expected):
    """One ulp off the only sweep point is not bracketed: below or above it, as before."""
    measured = float(np.nextafter(1.8, 1.8 + delta))
    assert matching_lateral_friction(_sweep([0.5], [1.8], measured)) == expected
