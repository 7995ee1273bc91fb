"""Review sim17: the ICR fits and the skid-steer kinematics on bad samples and inputs."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import EstimationError
from terrain.vehicles.icr import chi_from_truth, icr_expansion_factor, inverse_icr_factor
from terrain.vehicles.skid_steer import (endo_slip_ratio_ratio, skid_steer_forward,
                                         skid_steer_inverse, skid_steer_pose_rates)

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


KINEMATICS = [
    (skid_steer_forward, lambda bad: (bad, [1.0], 0.5), "v_left_m_s"),
    (skid_steer_forward, lambda bad: ([1.0], [1.0], 0.5, 1.0, bad), "eta_right"),
    (skid_steer_inverse, lambda bad: ([1.0], bad, 0.5), "yaw_rate_rad_s"),
    (skid_steer_pose_rates, lambda bad: (bad, [1.0], [0.0]), "yaw_rad"),
    (endo_slip_ratio_ratio, lambda bad: ([1.0], bad), "v_right_m_s"),
    (inverse_icr_factor, lambda bad: (bad, [1.0]), "yaw_rate_rad_s"),
    (icr_expansion_factor, lambda bad: ([1.0], bad), "commanded_yaw_rate_rad_s"),
    (chi_from_truth, lambda bad: ([0.0], [1.0], bad, 0.5), "yaw_rate_rad_s"),
]


@pytest.mark.parametrize("func, args, name", KINEMATICS)
@pytest.mark.parametrize("bad", [[True], np.array([False]), True])
def test_kinematics_refuse_booleans_naming_the_argument(func, args, name, bad):
    # skid_steer_forward([True], [False], 0.5) was a yaw rate of -2 rad/s
    with pytest.raises(EstimationError, match=name):
        func(*args(bad))


@pytest.mark.parametrize("func, args, name", KINEMATICS)
@pytest.mark.parametrize("bad", [["fast"], "fast", [[1.0], [1.0, 2.0]]])
def test_kinematics_name_the_argument_that_is_not_numbers(func, args, name, bad):
    # NumPy's "could not convert string to float: 'fast'" (or its "inhomogeneous shape" of a
    # ragged list) named no argument
    with pytest.raises(EstimationError, match=name):
        func(*args(bad))
