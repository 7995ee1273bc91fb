"""window_ekf_channels review (featcalc): channel names and X must agree."""

from __future__ import annotations

import numpy as np
import pytest

from features.ekf_signals import EKF_CHANNELS, window_ekf_channels
from terrain.errors import ShapeError


def test_window_channels_refuse_x_whose_channels_are_not_the_names():
    """Channels are read by position: X with a fourth channel (ax first) for the names
    (vel_l, vel_r, wz) would be read as vel_l = ax, vel_r = vel_l, wz = vel_r without a
    word; it is a ShapeError naming the expected shape."""
    n = 40
    straight = np.stack([np.full(n, 0.5), np.full(n, 0.5), np.zeros(n)])[None]   # (1, 3, n)
    out = window_ekf_channels(straight, ("vel_l", "vel_r", "wz"), 20.0)
    assert out.shape == (1, len(EKF_CHANNELS), n)
    with_ax = np.concatenate([np.full((1, 1, n), 9.81), straight], axis=1)
    with pytest.raises(ShapeError, match=r"\(n_windows, 3, n_samples\)"):
        window_ekf_channels(with_ax, ("vel_l", "vel_r", "wz"), 20.0)
