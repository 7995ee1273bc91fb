"""ftr18 review of features/: inputs silently taken, and properties of the windowing."""

import numpy as np
import pytest

from features.ekf_signals import window_ekf_channels
from terrain.errors import EstimationError


def test_window_ekf_channels_refuse_a_boolean_mask_for_the_signals():
    # a mask handed over for the windows ran the filter on speeds of 0 and 1 m/s
    X = np.ones((2, 3, 20), dtype=bool)
    with pytest.raises(EstimationError, match="window_ekf_channels: X must hold numbers"):
        window_ekf_channels(X, ("vel_l", "vel_r", "wz"), 50.0)
