"""ftr18 review of features/: inputs silently taken, and properties of the windowing."""

import numpy as np
import pandas as pd
import pytest

from features.ekf_signals import window_ekf_channels
from terrain.errors import ConfigError, EstimationError


def test_window_ekf_channels_refuse_a_boolean_mask_for_the_signals():
    # a mask handed over for the windows ran the filter on speeds of 0 and 1 m/s
    X = np.ones((2, 3, 20), dtype=bool)
    with pytest.raises(EstimationError, match="window_ekf_channels: X must hold numbers"):
        window_ekf_channels(X, ("vel_l", "vel_r", "wz"), 50.0)


@pytest.mark.parametrize("track", [0.0, -0.5708, float("nan"), float("inf"), True, "0.57"])
def test_derived_wheel_channels_refuse_a_track_that_is_not_a_positive_length(track):
    # 0 gave yaw_rate_wheels NaN (inf for a turn), a negative track the opposite yaw rate
    from features.windows import add_derived_channels, derived_wheel_arrays

    one = np.ones(3)
    with pytest.raises(ConfigError, match="derived_wheel_arrays.track_m"):
        derived_wheel_arrays(one, 2 * one, one, one, track)
    frame = pd.DataFrame({"t_s": [0.0, 0.02, 0.04], "vel_l": one, "vel_r": 2 * one,
                          "cur_l": one, "cur_r": one})
    with pytest.raises(ConfigError, match="derived_wheel_arrays.track_m"):
        add_derived_channels(frame, track)


def test_derived_wheel_channels_of_a_valid_track_are_unchanged():
    from features.windows import derived_wheel_arrays

    out = derived_wheel_arrays(np.array([0.2]), np.array([0.4]), np.array([1.0]),
                               np.array([3.0]), 0.5)
    assert out["yaw_rate_wheels"][0] == pytest.approx(0.4)
    assert out["vel_mean"][0] == pytest.approx(0.3)
    assert out["cur_diff"][0] == pytest.approx(2.0)
