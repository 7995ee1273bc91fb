"""Review of terrain.io.align: the ends of the span and the order of timestamps."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from terrain.errors import DataFormatError, TimestampError
from terrain.io.align import align_streams, overlap_grid
from terrain.run import TIME


def _wheels(t, vel_l=None):
    n = len(t)
    vel_l = np.arange(n, dtype=float) if vel_l is None else vel_l
    return pd.DataFrame({TIME: t, "vel_l": vel_l, "vel_r": np.full(n, 0.6),
                         "cur_l": np.full(n, 5.0), "cur_r": np.full(n, 6.0)})


def _imu(t):
    n = len(t)
    return pd.DataFrame({TIME: t, "wx": np.zeros(n), "wy": np.zeros(n), "wz": np.zeros(n),
                         "ax": np.zeros(n), "ay": np.zeros(n), "az": np.full(n, 9.81)})


def test_spans_that_only_touch_do_not_overlap(make_run):
    # the IMU ends at 1 s where the wheels begin: no stretch of time both cover, as the
    # readers' clock_overlap rule (overlap <= 0) says; a one-point grid would make a 1-row
    # frame of one instant out of two streams that never ran together
    t_imu = np.arange(0, 101) / 100.0
    t_wh = 1.0 + np.arange(0, 11) / 10.0
    assert overlap_grid([t_imu, t_wh], 50.0).size == 0
    run = make_run({"imu": _imu(t_imu), "wheels": _wheels(t_wh)})
    with pytest.raises(DataFormatError, match="do not overlap"):
        align_streams(run, rate_hz=50.0)
    # one common sample period later they do overlap: two grid points
    assert overlap_grid([t_imu, t_wh - 0.02], 50.0).size == 2


@pytest.mark.parametrize("where", ["swapped", "repeated", "nan"])
def test_timestamps_that_do_not_increase_strictly_are_refused(make_run, where):
    # a hand-built Run (the contract: t_s strictly increasing) with two samples swapped was
    # interpolated without a word: at t = 1.0 s a ramp vel_l = 10 t read 9.5, not 10; a NaN
    # time made the grid's length a bare ValueError
    t = np.arange(0, 51) / 10.0
    v = 10.0 * t
    if where == "swapped":
        t[[10, 11]] = t[[11, 10]]
    elif where == "repeated":
        t[20] = t[19]
    else:
        t[30] = np.nan
    run = make_run({"wheels": _wheels(t, vel_l=v)})
    with pytest.raises(TimestampError, match=r"wheels.*increase strictly") as err:
        align_streams(run, ("wheels",), rate_hz=50.0)
    assert err.value.column == TIME
    assert err.value.row == {"swapped": 11, "repeated": 20, "nan": 30}[where]


def test_align_streams_names_a_stream_without_samples():
    # an empty stream raised a bare IndexError reading its first sample
    from terrain.run import Run
    t = np.arange(0, 2, 0.01)
    imu = pd.DataFrame({"t_s": t, **{c: np.zeros(t.size) for c in
                                     ("wx", "wy", "wz", "ax", "ay", "az")}})
    wheels = pd.DataFrame({c: np.zeros(0) for c in ("t_s", "vel_l", "vel_r", "cur_l",
                                                    "cur_r")})
    run = Run("t/ICE/00", "t", "ICE", {"imu": imu, "wheels": wheels})
    with pytest.raises(DataFormatError, match="stream 'wheels' has no samples"):
        align_streams(run, ("imu", "wheels"), 50.0)
