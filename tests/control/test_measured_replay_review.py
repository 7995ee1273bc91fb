"""Review tests of the measured-run replay (terrain.control.replay)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from terrain.control.replay import measured_observations
from terrain.errors import ClockError
from terrain.run import Run


def _run(imu_t, wheel_t):
    imu = pd.DataFrame({"t_s": imu_t, "wx": 0.0, "wy": 0.0, "wz": 0.0, "ax": 0.0, "ay": 0.0,
                        "az": 9.81})
    wheels = pd.DataFrame({"t_s": wheel_t, "vel_l": 0.2, "vel_r": 0.2, "cur_l": 1.0,
                           "cur_r": 1.0})
    return Run("test/ICE/00", "test", "ICE", {"imu": imu, "wheels": wheels}, source="mem")


@pytest.mark.parametrize("gap_s", [0.01, 0.5])
def test_streams_that_do_not_overlap_in_time_are_a_clock_error(gap_s):
    """IMU 0-1 s, wheels from 1 s + gap: no call could receive both streams. Even a gap
    shorter than a control period (0.01 s at 20 Hz) is refused, naming both spans."""
    imu_t = np.linspace(0.0, 1.0, 101)
    wheel_t = 1.0 + gap_s + np.arange(10) / 6.5
    with pytest.raises(ClockError, match="do not overlap"):
        list(measured_observations(_run(imu_t, wheel_t), 0.2, control_rate_hz=20.0))
    obs = list(measured_observations(_run(imu_t, wheel_t - gap_s - 0.5), 0.2, 20.0))
    assert obs[0].t_s == pytest.approx(0.5) and obs[-1].t_s == pytest.approx(1.0)
