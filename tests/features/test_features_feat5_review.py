"""Review (feat5) of the feature calculators, transformers and windowing: bad inputs refused,
formulas pinned by known values (tests written for defects and surviving hand mutants)."""

from __future__ import annotations

import numpy as np
import pytest

from features import calculators as calc


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
