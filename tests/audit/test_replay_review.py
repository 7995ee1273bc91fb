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


@pytest.mark.slow
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


def test_samples_in_a_timestamp_gap_are_not_scored():
    # a gap of the IMU stream (8-10 s) takes the IMU signals out there; a gap of the wheel
    # stream (12-13 s) takes out both (the currents and the replay's inputs)
    from terrain.audit.frames import prepare_frame
    pro = _pro()
    t = np.arange(0.0, 20.0, 0.01)
    imu = pd.DataFrame({"t_s": t, "wz": 0.1, "ax": 0.0, "ay": 0.0})
    run = Run(run_id="x/ASPHALT/00", dataset="x", terrain="ASPHALT",
              streams={"wheels": pro, "imu": imu}, vehicle="husky",
              meta={"gaps": {"imu": [[8.0, 10.0]], "wheels": [[12.0, 13.0]]}})
    f = prepare_frame(run, replay_run(run))
    assert not f.lag.identifiable                # lag 0: the IMU is read at the wheel times
    ts = f.t_s

    def between(a, b):
        return (ts > a) & (ts < b)
    assert not f.score_imu[between(8.0, 10.0) | between(12.0, 13.0)].any()
    assert not f.score_cur[between(12.0, 13.0)].any()
    assert f.score_cur[between(8.0, 10.0)].all()
    rest = between(2.0, 18.0) & ~between(7.99, 10.01) & ~between(11.99, 13.01)
    assert f.score_imu[rest].all() and f.score_cur[rest].all()


def test_a_nose_up_pitch_reads_positive_and_only_within_the_imu_record():
    # a level accelerometer pitched nose-up by 0.1 rad reads g sin(0.1) on x beyond the
    # vehicle's own acceleration (none while cruising): the pitch estimate is +0.1 rad, and
    # where the IMU record (4-20 s) does not reach there is no estimate
    from terrain.audit.frames import prepare_frame
    pro = _pro()
    t = np.arange(4.0, 20.0, 0.01)
    imu = pd.DataFrame({"t_s": t, "wz": 0.0, "ax": 9.80665 * np.sin(0.1), "ay": 0.0})
    run = Run(run_id="x/ASPHALT/00", dataset="x", terrain="ASPHALT",
              streams={"wheels": pro, "imu": imu}, vehicle="husky")
    f = prepare_frame(run, replay_run(run))
    cruise = (f.t_s > 8.0) & (f.t_s < 18.0)
    np.testing.assert_allclose(f.pitch[cruise], 0.1, atol=0.01)
    assert (f.commanded_yaw_rate[cruise] > 0).all()           # the right side is faster
    assert not f.has_pitch[f.t_s < 4.0].any() and (f.pitch[f.t_s < 4.0] == 0.0).all()
    assert f.has_pitch[f.t_s >= 4.0].all()


@pytest.mark.slow
def test_the_replays_start_from_rest_does_not_lean_on_the_pitch():
    # a record that starts at cruising speed: the replay accelerates from rest at its first
    # steps (7.5 m/s^2), the level IMU reads nothing. Low-passed over the whole record, that
    # transient showed as a pitch of 0.02 rad in the scored span; within the span, none.
    # (Until 2026-11-30 the first step was stored at t = 0, where the zero-phase low-pass's
    # odd extension kept it, rep.ax[0] > 5 m/s^2; the first row is now the rest state and
    # the low-passed transient peaks just after it.)
    from terrain.audit.frames import prepare_frame
    t = np.arange(0.0, 30.0, 0.15)
    pro = pd.DataFrame({"t_s": t, "cur_l": 2.0, "cur_r": 2.0, "vel_l": 0.8, "vel_r": 0.8})
    ti = np.arange(0.0, 30.0, 0.01)
    imu = pd.DataFrame({"t_s": ti, "wz": 0.0, "ax": 0.0, "ay": 0.0})
    run = Run(run_id="x/ASPHALT/00", dataset="x", terrain="ASPHALT",
              streams={"wheels": pro, "imu": imu}, vehicle="husky")
    rep = replay_run(run)
    f = prepare_frame(run, rep)
    assert rep.ax[0] == pytest.approx(0.0, abs=0.5) and rep.ax[:4].max() > 0.5
    assert np.abs(f.pitch[f.score_cur]).max() < 1e-3


@pytest.mark.slow
def test_sides_one_speed_step_apart_are_replayed_at_their_mean():
    # a quantised record (BorealTC: steps of 0.2/25.4 m/s) cruising with the sides rounded
    # to neighbouring steps (63 and 64): the difference carries no information, both sides
    # are replayed at their mean and draw the same current; unmerged, the replayed robot
    # fights a fictitious 8 mm/s difference and its currents split by about 1 A
    step = 0.2 / 25.4
    t = np.arange(0.0, 30.0, 0.15)
    k = np.minimum(np.floor(t / 10.0 * 63.0), 63.0)
    pro = pd.DataFrame({"t_s": t, "cur_l": 2.0, "cur_r": 2.0, "vel_l": k * step,
                        "vel_r": (k + (t > 10.0)) * step})
    rep = replay_run(_run(pro))
    cruise = (t > 12.0) & (t < 28.0)
    assert abs(np.mean(rep.cur[cruise, 0] - rep.cur[cruise, 1])) < 0.05
    assert np.abs(rep.yaw_rate[cruise]).max() < 1e-3
    # the replay reports the record's own speeds (before the merge)
    np.testing.assert_allclose(rep.vel_r - rep.vel_l, np.where(t > 10.0, step, 0.0))
