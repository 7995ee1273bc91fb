"""EKF channels review (ftr23): boundaries (the fewest samples a window or frame may hold)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from features.ekf_signals import EKF_CHANNELS, add_ekf_channels, window_ekf_channels
from terrain.errors import ShapeError
from terrain.run import TIME

_NAMES = ["vel_l", "vel_r", "wz"]


def _windows(n):
    X = np.zeros((2, 3, n))
    X[:, :2] = 0.5
    return X


def test_a_window_of_one_sample_is_refused_naming_its_shape():
    """The filter needs a step: windows of 1 sample are a ShapeError (documented), 2 are
    the fewest that give channels."""
    with pytest.raises(ShapeError, match=r"n_samples >= 2"):
        window_ekf_channels(_windows(1), _NAMES, 50.0)
    out = window_ekf_channels(_windows(2), _NAMES, 50.0)
    assert out.shape == (2, len(EKF_CHANNELS), 2) and np.isfinite(out).all()


@pytest.mark.parametrize("n, finite", [(0, False), (1, False), (2, True), (3, True)])
def test_a_frame_of_two_rows_is_the_shortest_the_filter_runs_on(n, finite):
    """A frame shorter than 2 rows gets the EKF channels as NaN; one of exactly 2 rows is
    filtered (finite channels on every row)."""
    frame = pd.DataFrame({TIME: np.arange(n) / 50.0, "vel_l": 0.5, "vel_r": 0.5, "wz": 0.0})
    out = add_ekf_channels(frame)
    assert list(out.columns[-len(EKF_CHANNELS):]) == list(EKF_CHANNELS) and len(out) == n
    values = out[list(EKF_CHANNELS)].to_numpy(float)
    assert np.isfinite(values).all() if finite else np.isnan(values).all()
