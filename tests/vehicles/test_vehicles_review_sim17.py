"""Review sim17: the ICR fits and the skid-steer kinematics on bad samples and inputs."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.vehicles.icr import chi_from_truth, icr_expansion_factor, inverse_icr_factor

INF = np.inf


@pytest.mark.parametrize("yaw, commanded", [
    ([INF, 0.5], [1.0, 1.0]),       # an infinite yaw rate gave chi = 0 (sum(x^2) / inf)
    ([-INF, 0.5], [1.0, 1.0]),      # and -inf chi = inf: a vehicle "dug in"
    ([0.5, 0.5], [INF, 1.0]),
])
def test_an_infinite_sample_gives_an_unknown_icr_fit(yaw, commanded):
    # a broken sample is an unknown chi (NaN), as a NaN one is, not a chi of 0 or inf
    assert np.isnan(icr_expansion_factor(yaw, commanded))
    assert np.isnan(inverse_icr_factor(yaw, commanded))
    # along the last axis: only the window that holds it
    a = inverse_icr_factor(np.array([yaw, [0.5, 0.5]]), np.array([commanded, [1.0, 1.0]]))
    assert np.isnan(a[0]) and a[1] == pytest.approx(0.5)


@pytest.mark.parametrize("left, right, yaw", [
    ([INF, 0.0], [1.0, 1.0], [1.0, 1.0]),        # gave chi = -inf
    ([0.0, 0.0], [INF, 1.0], [1.0, 1.0]),        # gave chi = inf
    ([0.0, 0.0], [1.0, 1.0], [-INF, 1.0]),
])
def test_chi_from_truth_of_an_infinite_turning_sample_is_unknown(left, right, yaw):
    assert np.isnan(chi_from_truth(left, right, yaw, 0.5))


def test_chi_from_truth_leaves_out_an_infinite_speed_of_a_sample_that_does_not_turn():
    # (the samples turning slower than the threshold are not used, as documented)
    assert chi_from_truth([INF, 0.0], [1.0, 1.0], [0.0, 1.0], 0.5) == pytest.approx(2.0)
