"""Review tests (aud3) of the audit's replay, frames, residual statistics and ceiling."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from terrain.audit import prepare_frames
from terrain.audit.frames import prepare_frame
from terrain.audit.replay import replay_run
from terrain.errors import TimestampError
from terrain.run import Run


def _pro() -> pd.DataFrame:
    t = np.arange(0.0, 20.0, 0.15)
    v = np.minimum(t * 0.5, 0.8)
    return pd.DataFrame({"t_s": t, "cur_l": 2.0, "cur_r": 2.0, "vel_l": v, "vel_r": 1.1 * v})


def _imu() -> pd.DataFrame:
    t = np.arange(0.0, 20.0, 0.01)
    return pd.DataFrame({"t_s": t, "wz": 0.1, "ax": 0.0, "ay": 0.0})


def _run(pro: pd.DataFrame, imu: pd.DataFrame | None = None) -> Run:
    streams = {"wheels": pro} if imu is None else {"wheels": pro, "imu": imu}
    return Run(run_id="x/ASPHALT/00", dataset="x", terrain="ASPHALT", streams=streams,
               vehicle="husky")


@pytest.mark.parametrize("repeat", [False, True])
def test_wheel_times_out_of_order_are_refused_naming_the_row(repeat):
    # np.interp does not check that its abscissae increase: two swapped wheel rows (or a
    # repeated time) were replayed without a word, the integrator fed speeds interpolated on
    # a clock that goes back
    pro = _pro()
    t = pro.t_s.to_numpy().copy()
    if repeat:
        t[30] = t[29]
    else:
        t[30], t[31] = t[31], t[30]
    pro["t_s"] = t
    with pytest.raises(TimestampError, match=r"x/ASPHALT/00.*wheels.*row 3[01]") as info:
        replay_run(_run(pro))
    assert info.value.column == "t_s" and info.value.row in (30, 31)
    frames, skipped = prepare_frames([_run(pro)])
    assert not frames and "wheels" in skipped["x/ASPHALT/00"]


def test_imu_times_out_of_order_are_refused_naming_the_row():
    # the IMU is low-passed and read by np.interp at the lagged wheel times: a record whose
    # clock goes back gave gyro values from the wrong time, scored as if measured
    imu = _imu()
    t = imu.t_s.to_numpy().copy()
    t[500], t[501] = t[501], t[500]
    imu["t_s"] = t
    run = _run(_pro(), imu)
    with pytest.raises(TimestampError, match=r"x/ASPHALT/00.*imu.*row 501") as info:
        prepare_frame(run, replay_run(run))
    assert info.value.column == "t_s" and info.value.row == 501
    frames, skipped = prepare_frames([run])
    assert not frames and "imu" in skipped["x/ASPHALT/00"]
    # the ordered record is audited
    ok = _run(_pro(), _imu())
    assert prepare_frame(ok, replay_run(ok)).has_imu
