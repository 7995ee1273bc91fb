"""Review tests (est11): the seed 000 adaptive observer over a time gap and with no sample."""

from __future__ import annotations

import numpy as np
import pytest

from terrain.errors import ShapeError
from terrain.estimation.observer import run_adaptive_observer


def test_no_sample_is_a_shape_error():
    # before: numpy's bare "attempt to get argmax of an empty sequence" (ValueError)
    with pytest.raises(ShapeError, match="no sample"):
        run_adaptive_observer(np.zeros(0), np.zeros((0, 3)), np.zeros(0), np.zeros(0))
