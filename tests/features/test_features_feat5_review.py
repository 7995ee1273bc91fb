"""Review (feat5) of the feature calculators, transformers and windowing: bad inputs refused,
formulas pinned by known values (tests written for defects and surviving hand mutants)."""

from __future__ import annotations

import numpy as np
import pytest

from features import calculators as calc
from terrain.errors import ConfigError


@pytest.mark.parametrize("q", [1.5, -0.1, np.nan])
def test_quantile_sorted_refuses_a_quantile_outside_zero_to_one(q):
    """q outside [0, 1] read past the array's ends (compiled, no bounds check): q 1.5 of
    [1, 2, 3] gave whatever lay in memory there, not an error."""
    with pytest.raises(ValueError, match=r"q must be a number in \[0, 1\]"):
        calc.quantile_sorted(np.array([1.0, 2.0, 3.0]), q)


def test_quantile_sorted_refuses_an_empty_array():
    """No sample has no quantile (it read the memory before the array)."""
    with pytest.raises(ValueError, match="at least one value"):
        calc.quantile_sorted(np.zeros(0), 0.5)


@pytest.mark.parametrize("n", [0, -4, 2.5, True])
def test_band_weights_refuse_a_window_length_that_is_not_a_count(n):
    """0 samples raised Python's bare ZeroDivisionError, -4 NumPy's 'zero-size array to
    reduction operation minimum', 2.5 NumPy's 'n should be an integer', naming no
    argument; True was taken as 1 sample."""
    with pytest.raises(ConfigError, match="band_weights.n_samples must be an integer >= 1"):
        calc.band_weights(n, 50.0, ((0.0, 5.0),))
