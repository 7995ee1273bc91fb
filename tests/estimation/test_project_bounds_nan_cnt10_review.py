"""Review tests (cnt10): a NaN bound of project_to_bounds is refused, not taken as no bound."""

from __future__ import annotations

import re

import numpy as np
import pytest

from terrain.errors import NonFiniteInputError
from terrain.estimation.ekf import project_to_bounds


@pytest.mark.parametrize("name, lower, upper, states", [
    ("lower", [np.nan, -1.0], [1.0, 1.0], "[0]"),
    ("upper", [-1.0, -1.0], [1.0, np.nan], "[1]"),
    ("lower", np.nan, 1.0, "[0, 1]")])
def test_a_nan_bound_is_refused_naming_the_argument(name, lower, upper, states):
    # before: x = [5, 0] with lower[0] NaN and upper[0] 1 ... NaN comparisons are False, so
    # a NaN bound was no bound: [5, 0] came back unprojected without a word
    message = rf"{name} holds NaN at state\(s\) {re.escape(states)}"
    with pytest.raises(NonFiniteInputError, match=message):
        project_to_bounds(np.array([5.0, 0.0]), np.eye(2), lower, upper)


def test_infinite_bounds_still_mean_no_bound():
    xc, active = project_to_bounds(np.array([5.0, -3.0]), np.eye(2), [-np.inf, -1.0],
                                   [np.inf, 1.0])
    np.testing.assert_array_equal(xc, [5.0, -1.0])
    np.testing.assert_array_equal(active, [False, True])
