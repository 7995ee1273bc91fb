"""Windowing review: the book-keeping states what was aligned."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from features.windows import WindowConfig, make_windows
from terrain.io.report import input_report
from terrain.run import IMU_CHANNELS, TIME, Run


def _run() -> Run:
    """IMU at 100 Hz over 0-20 s, wheels at 10 Hz over 3-20 s at a steady 0.5 m/s."""
    ti = np.arange(2001) / 100.0
    rng = np.random.default_rng(0)
    imu = pd.DataFrame({TIME: ti, **{c: 0.05 * rng.standard_normal(ti.size)
                                     for c in IMU_CHANNELS}})
    tw = 3.0 + np.arange(171) / 10.0
    wheels = pd.DataFrame({TIME: tw, "vel_l": 0.5, "vel_r": 0.5, "cur_l": 5.0, "cur_r": 5.0})
    return Run(run_id="t/ICE/00", dataset="t", terrain="ICE",
               streams={"imu": imu, "wheels": wheels}, source="in-memory test run",
               meta={"unused_s": {"imu": 3.0}})


def test_steady_only_records_the_wheel_stream_it_aligns_for_imu_signals():
    # steady_only aligns the wheels beside the IMU whatever the signals, so the IMU is cut
    # to the wheels' span (3-20 s): the 3 s before it are unused and the report says so
    run = _run()
    ws = make_windows([run], "imu", WindowConfig(window_s=2.0, steady_only=True))
    assert ws.t_start_s.min() == pytest.approx(3.0)
    assert ws.counts["streams"] == ["imu", "wheels"]
    row = input_report([run], ws.counts, 2.0).table.iloc[0]
    assert row["unused_imu_s"] == pytest.approx(3.0)
    # without steady_only only the IMU is aligned: all of it is windowed, nothing unused
    plain = make_windows([run], "imu", WindowConfig(window_s=2.0))
    assert plain.t_start_s.min() == pytest.approx(0.0) and plain.counts["streams"] == ["imu"]
    assert input_report([run], plain.counts, 2.0).table.iloc[0]["unused_imu_s"] == 0.0
