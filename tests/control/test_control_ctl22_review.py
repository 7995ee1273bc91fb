"""Review ctl22: numerical robustness and determinism of the control layer.

Long horizons (an hour of a saturated actuator), derivative kick on a target step, clocks
far from 0 (epoch stamps: intervals from differences), and the same tuning from the same
seeds.
"""

from __future__ import annotations

import numpy as np
import pytest

EPOCH_S = 1.7e9   # a robot's log stamped in Unix time


# --- the AgriMaRo estimator's speed slope on an epoch clock ------------------------------------

def _slope_window(origin: float, window_s: float, calls: int = 60):
    """Window sizes and slopes of ``_speed_slope`` over 50 Hz calls from ``origin`` of a
    speed rising as the square of the time since the first call."""
    from terrain.control.estimators import AgriMaRoVisualOdometryEKF

    est = AgriMaRoVisualOdometryEKF(speed_slope_s=window_s)
    sizes, slopes = [], []
    for k in range(calls):
        t = origin + k * 0.02
        slopes.append(est._speed_slope(t, np.full(3, (k * 0.02) ** 2), np.zeros(3))[0])
        sizes.append(len(est._speeds))
    return sizes, np.array(slopes)


@pytest.mark.parametrize("origin", [EPOCH_S + 636.9616873, EPOCH_S + 269.7867138,
                                    1.6e9 + 0.37])
@pytest.mark.parametrize("window_s", [0.3, 0.5, 0.7])
def test_agrimaro_speed_slope_keeps_the_same_calls_on_an_epoch_clock(origin, window_s):
    """``full-gyro``: the acceleration is the slope of the speeds of the calls in the last
    ``speed_slope_s``. The window dropped a call older than ``t - speed_slope_s - 1 ns``; on
    an epoch clock the difference of two stamps rounds by 2.4e-7 s, so with a window of
    0.3 s the call exactly 0.3 s back was kept or dropped by the clock's origin (15 or 16
    calls at 50 Hz) and the slope of a speed rising as t^2 moved by 0.02 m/s^2 (10 %)."""
    sizes0, slopes0 = _slope_window(0.0, window_s)
    sizes, slopes = _slope_window(origin, window_s)
    assert sizes == sizes0
    np.testing.assert_allclose(slopes, slopes0, atol=1e-4)
