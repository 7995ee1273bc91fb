"""Review tests of the replay's and the frames' input checks (terrain.audit.replay, .frames)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from terrain.audit import prepare_frames
from terrain.audit.replay import replay_run
from terrain.errors import NonFiniteError
from terrain.run import Run


def _run(pro: pd.DataFrame) -> Run:
    return Run(run_id="x/ASPHALT/00", dataset="x", terrain="ASPHALT",
               streams={"wheels": pro}, vehicle="husky")


def _pro() -> pd.DataFrame:
    t = np.arange(0.0, 20.0, 0.15)
    v = np.minimum(t * 0.5, 0.8)
    return pd.DataFrame({"t_s": t, "cur_l": 2.0, "cur_r": 2.0, "vel_l": v, "vel_r": 1.1 * v})


@pytest.mark.parametrize("column", ["vel_l", "vel_r", "cur_r", "t_s"])
def test_a_non_finite_wheel_sample_is_refused_naming_the_run_and_column(column):
    # a NaN wheel speed reached the integrator, which raised a bare ValueError ("cannot
    # convert float NaN to integer") that prepare_frames does not catch: one such run
    # stopped the whole audit; a NaN current was scored as NaN without a word
    pro = _pro()
    pro.loc[40, column] = np.nan
    with pytest.raises(NonFiniteError, match=rf"x/ASPHALT/00.*{column}.*row 40") as info:
        replay_run(_run(pro))
    assert info.value.column == column and info.value.row == 40
    frames, skipped = prepare_frames([_run(pro)])
    assert not frames and column in skipped["x/ASPHALT/00"]
    # the finite record replays
    assert np.isfinite(replay_run(_run(_pro())).cur).all()


@pytest.mark.parametrize("column", ["wz", "ax", "t_s"])
def test_a_non_finite_imu_sample_is_refused_naming_the_run_and_column(column):
    # one NaN gyro sample went through the zero-phase low-pass, which spreads it over the
    # whole record: every scored gyro sample NaN, the run's yaw-rate error NaN (or its
    # samples silently left out where a caller filters NaN)
    from terrain.audit.frames import prepare_frame
    pro = _pro()
    t = np.arange(0.0, 20.0, 0.01)
    imu = pd.DataFrame({"t_s": t, "wz": 0.1, "ax": 0.0, "ay": 0.0})
    imu.loc[500, column] = np.nan
    run = Run(run_id="x/ASPHALT/00", dataset="x", terrain="ASPHALT",
              streams={"wheels": pro, "imu": imu}, vehicle="husky")
    with pytest.raises(NonFiniteError, match=rf"x/ASPHALT/00.*{column}.*row 500") as info:
        prepare_frame(run, replay_run(run))
    assert info.value.column == column and info.value.row == 500
    frames, skipped = prepare_frames([run])
    assert not frames and column in skipped["x/ASPHALT/00"]
