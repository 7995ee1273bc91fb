"""Review srv7b: forward filter inputs, hysteresis in skipped stretches, switching delays."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import DataFormatError
from terrain.serving.smoothing import ForwardFilter, SmoothingConfig


@pytest.mark.parametrize("q", [np.array([0.2, 0.8]), np.array([[0.2, 0.3, 0.5]]),
                               np.array(0.5)])
def test_filter_refuses_probabilities_of_another_shape_than_its_classes(q):
    """A (2,) row for a 3-class filter was a bare broadcasting ValueError of NumPy; a (1, 3)
    row broadcast silently into a (1, 3) ``p`` and a scalar into a 3-vector."""
    filt = ForwardFilter(3, 0.5, SmoothingConfig())
    with pytest.raises(DataFormatError, match=r"\(3,\)"):
        filt.update(q)
    np.testing.assert_allclose(filt.p, np.full(3, 1 / 3))     # nothing folded in
