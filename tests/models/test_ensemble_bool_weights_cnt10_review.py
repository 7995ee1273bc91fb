"""Review tests (cnt10): booleans given as the ensemble's member weights are refused."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import ConfigError
from terrain.models.ensemble import normalised_weights


@pytest.mark.parametrize("weights", [[True, False], (True, True), np.array([True, False]),
                                     [True, 0.5], [np.True_, 1.0]])
def test_boolean_weights_are_refused_not_read_as_0_and_1(weights):
    # a member mask passed as the weights was read as 1 / 0: [True, False] -> [1.0, 0.0],
    # the second member silently dropped
    with pytest.raises(ConfigError, match="weights must be numbers, not booleans"):
        normalised_weights(weights, 2)


def test_numeric_weights_still_pass():
    np.testing.assert_allclose(normalised_weights(np.array([1, 3]), 2), [0.25, 0.75])
    np.testing.assert_allclose(normalised_weights([0.0, 1], 2), [0.0, 1.0])
