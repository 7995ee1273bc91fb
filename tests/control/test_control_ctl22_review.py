"""Review ctl22: numerical robustness and determinism of the control layer.

Long horizons (an hour of a saturated actuator), derivative kick on a target step, clocks
far from 0 (epoch stamps: intervals from differences), and the same tuning from the same
seeds.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
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


# --- a measured run's replay: the calls do not depend on the clock's origin ---------------------

def _logged_run(t0: float, seconds: float):
    """A run logged with millisecond stamps: IMU at 100 Hz, wheels at 50 Hz from ``t0``."""
    from terrain.run import Run

    def stamps(rate):
        return np.array([float(f"{t0 + k / rate:.3f}")
                         for k in range(int(round(seconds * rate)) + 1)])

    imu = pd.DataFrame({"t_s": stamps(100), "wx": 0.0, "wy": 0.0, "wz": 0.0, "ax": 0.0,
                        "ay": 0.0, "az": 9.81})
    wheels = pd.DataFrame({"t_s": stamps(50), "vel_l": 1.0, "vel_r": 1.0, "cur_l": 2.0,
                           "cur_r": 2.0})
    return Run("logged", "test", "ASPHALT", {"imu": imu, "wheels": wheels})


@pytest.mark.parametrize("t0", [0.0, 123.457, EPOCH_S + 0.013, EPOCH_S + 52_345.678,
                                1.6e9 + 0.37])
@pytest.mark.parametrize("seconds", [1.7, 2.3, 2.9])
def test_replay_makes_every_call_of_the_span_on_any_clock(t0, seconds):
    """measured_observations: "calls are at t0, t0 + 1/rate, ... from the later of the two
    streams' first samples to the earlier of their last". The number of calls compared
    ``(t1 - t0) / period`` with a slack of 1e-9 periods; on an epoch clock ``t1 - t0``
    rounds by 2.4e-7 s, so the call at t1 itself (the last sample of the span) was dropped
    on some origins: 85 calls over 1.7 s of a log stamped from 1.7e9 s, 86 from 0 s, and the
    last wheel and IMU samples were not replayed."""
    from terrain.control.replay import measured_observations

    calls = list(measured_observations(_logged_run(t0, seconds), 0.165, 50.0))
    assert len(calls) == int(round(seconds * 50)) + 1
    assert calls[-1].t_s == pytest.approx(t0 + seconds, abs=1e-5)
    for c in calls:   # still: no call receives a sample stamped after it
        assert np.all(c.wheels[:, 0] <= c.t_s) and np.all(c.imu[:, 0] <= c.t_s)


def test_replay_keeps_the_call_count_of_the_shipped_runs():
    """The slack of the call count changes nothing on the shipped BorealTC runs (stamped
    from 0 s: 1 ns there, as the 1e-9 periods before, to well within a period): the same
    last call on every run, so no figure measured on them moves."""
    from terrain.control.replay import measured_observations
    from terrain.io.shipped import read_shipped

    runs = [r for r in read_shipped("borealtc") if "imu" in r.streams][:12]
    assert runs
    for run in runs:
        t_imu, t_wh = (run.streams[s]["t_s"].to_numpy(float) for s in ("imu", "wheels"))
        t0, t1 = max(t_imu[0], t_wh[0]), min(t_imu[-1], t_wh[-1])
        old = int(np.floor((t1 - t0) / 0.02 + 1e-9))
        replay = measured_observations(run, 0.165, 50.0)
        assert sum(1 for _ in replay) == old + 1, run.run_id
