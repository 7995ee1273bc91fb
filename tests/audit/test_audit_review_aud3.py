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


@pytest.mark.slow
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


@pytest.mark.slow
def test_the_gyro_is_read_at_t_minus_the_lag_of_a_late_wheel_stream():
    # timing convention (terrain.audit.timing): lag > 0 = wheel stream late, a wheel sample
    # stamped t describes the robot at IMU time t - lag; the frame must read the gyro there
    from terrain.vehicles import get_vehicle
    lag, b = 0.5, get_vehicle("husky").track_m
    t = np.arange(0.0, 60.0, 0.15)

    def x_true(tau):
        return 0.4 * np.sin(2.0 * np.pi * tau / 8.0)
    x_w = x_true(t - lag)                                  # the late wheel stream
    pro = pd.DataFrame({"t_s": t, "cur_l": 2.0, "cur_r": 2.0, "vel_l": 0.5 - 0.5 * b * x_w,
                        "vel_r": 0.5 + 0.5 * b * x_w})
    ti = np.arange(0.0, 60.0, 0.01)
    imu = pd.DataFrame({"t_s": ti, "wz": x_true(ti), "ax": 0.0, "ay": 0.0})
    run = _run(pro, imu)
    frame = prepare_frame(run, replay_run(run))
    assert frame.lag.identifiable
    assert frame.lag.median_s == pytest.approx(lag, abs=0.03)
    m = frame.score_imu
    assert m.sum() > 200
    # aligned: the gyro equals the commanded yaw rate (ideal drive) up to the filters
    assert np.sqrt(np.mean((frame.wz[m] - frame.commanded_yaw_rate[m]) ** 2)) < 0.01
    # the raw clock is off by the lag: 0.4 * 2 pi / 8 * 0.5 s ~ 0.16 rad/s amplitude
    assert np.sqrt(np.mean((frame.wz_at_lag(0.0)[m] - frame.commanded_yaw_rate[m]) ** 2)) > 0.05


def test_manoeuvre_thresholds_are_inclusive_as_documented():
    # frames module table: turning from |x| >= turn_rad_s, curve when |v| >= |x| B / 2,
    # moving when a side reaches moving_m_s (values exact in binary: 0.125, 0.5, 0.0625)
    from terrain.audit.frames import CURVE, SPIN, STOP, STRAIGHT, FrameSettings
    from terrain.audit.frames import classify_manoeuvres
    s = FrameSettings(turn_rad_s=0.125, moving_m_s=0.0625)
    track = 0.5
    x = np.array([0.125, 0.0625, 0.5, 0.5, 0.0])
    v = np.array([1.0, 1.0, 0.125, 0.124, 0.0])
    vel_l, vel_r = v - 0.5 * track * x, v + 0.5 * track * x
    vel_l[4], vel_r[4] = 0.0625, -0.0625             # both sides exactly at moving_m_s
    out = classify_manoeuvres(x, v, vel_l, vel_r, track, s)
    assert list(out) == [CURVE, STRAIGHT, CURVE, SPIN, STRAIGHT]
    vel_l[4] = vel_r[4] = 0.06
    assert classify_manoeuvres(x, v, vel_l, vel_r, track, s)[4] == STOP


@pytest.mark.parametrize("kw", [{"input_cutoff_hz": float("inf")}, {"input_cutoff_hz": True},
                                {"output_cutoff_hz": True}, {"speed_headroom": float("inf")},
                                {"speed_headroom": True}])
def test_replay_settings_refuse_infinite_or_boolean_values(kw):
    # input_cutoff_hz=inf reads as "no low-pass" but was accepted and then clipped by
    # lowpass() to 0.45 of the wheel rate (2.9 Hz on BorealTC): the inputs were filtered;
    # True passed as a 1 Hz cut-off or a headroom of 1
    from terrain.audit.replay import ReplaySettings
    from terrain.errors import ConfigError
    with pytest.raises(ConfigError, match=next(iter(kw))):
        ReplaySettings(**kw)
    ReplaySettings(input_cutoff_hz=2.0, output_cutoff_hz=1.0, speed_headroom=1.0)


def _turning_run(run_id: str) -> Run:
    t = np.arange(0.0, 20.0, 0.15)
    pro = pd.DataFrame({"t_s": t, "cur_l": 2.0, "cur_r": 2.0, "vel_l": -0.3, "vel_r": 0.3})
    ti = np.arange(0.0, 20.0, 0.01)
    imu = pd.DataFrame({"t_s": ti, "wz": 0.5, "ax": 0.0, "ay": 0.0})
    return Run(run_id=run_id, dataset="x", terrain="ASPHALT",
               streams={"wheels": pro, "imu": imu}, vehicle="husky")


@pytest.mark.slow
@pytest.mark.parametrize("spoil", ["nan", "missing", "order"])
def test_the_friction_sweep_leaves_out_a_run_the_audit_skips(spoil):
    # run_audit lists a run it cannot replay as skipped; the what-if sweep then replayed the
    # same run again and stopped the whole audit (NonFiniteError, TimestampError, or a bare
    # KeyError 'vel_l' for a missing column)
    from dataclasses import replace

    from terrain.audit import AuditSettings, run_audit
    good, bad = _turning_run("x/ASPHALT/00"), _turning_run("x/ASPHALT/01")
    wheels = bad.streams["wheels"].copy()
    if spoil == "nan":
        wheels.loc[40, "vel_r"] = np.nan
    elif spoil == "missing":
        wheels = wheels.drop(columns=["vel_l"])
    else:
        t = wheels.t_s.to_numpy().copy()
        t[40], t[41] = t[41], t[40]
        wheels["t_s"] = t
    bad = replace(bad, streams={**bad.streams, "wheels": wheels})
    from terrain.audit.core import lateral_friction_sweep
    tab = lateral_friction_sweep([good, bad], "ASPHALT", (1.0,))
    assert list(tab.n_runs) == [1] and np.isfinite(tab.replay_chi).all()
    assert list(tab.attrs["skipped"]) == ["x/ASPHALT/01"]
    res = run_audit([good, bad], AuditSettings(sweep_factors=(1.0,)))
    assert "x/ASPHALT/01" in res.skipped and list(res.sweep.n_runs) == [1]


@pytest.mark.slow
def test_the_replay_is_sampled_on_the_wheel_clock_without_a_delay():
    # the replay's outputs are sampled at the wheel timestamps: the replayed yaw rate must
    # follow the commanded one without a shift beyond the body's own response time
    from terrain.audit.timing import LagSettings, best_lag
    from terrain.vehicles import get_vehicle
    b = get_vehicle("husky").track_m
    t = np.arange(0.0, 60.0, 0.15)
    x = 0.4 * np.sin(2.0 * np.pi * t / 8.0)
    pro = pd.DataFrame({"t_s": t, "cur_l": 2.0, "cur_r": 2.0, "vel_l": 0.5 - 0.5 * b * x,
                        "vel_r": 0.5 + 0.5 * b * x})
    rep = replay_run(_run(pro))
    lag, r2, slope = best_lag(t, x, rep.t_s, rep.yaw_rate,
                              LagSettings(max_lag_s=1.0, lag_step_s=0.01))
    assert r2 > 0.95 and slope > 0
    assert abs(lag) < 0.08


@pytest.mark.slow
def test_imu_samples_are_scored_edge_s_inside_the_overlap_on_the_wheel_clock_too():
    # FrameSettings.edge_s: samples closer than edge_s to either end of the overlap of both
    # streams are not scored. With an early wheel stream (lag < 0) the gyro is read at
    # t + |lag|, which lies edge_s inside the IMU record before t itself does
    from terrain.audit.frames import FrameSettings
    from terrain.vehicles import get_vehicle
    lag, b, edge = -0.5, get_vehicle("husky").track_m, FrameSettings().edge_s
    t = np.arange(0.0, 60.0, 0.15)

    def x_true(tau):
        return 0.4 * np.sin(2.0 * np.pi * tau / 8.0)
    x_w = x_true(t - lag)
    pro = pd.DataFrame({"t_s": t, "cur_l": 2.0, "cur_r": 2.0, "vel_l": 0.5 - 0.5 * b * x_w,
                        "vel_r": 0.5 + 0.5 * b * x_w})
    ti = np.arange(10.0, 60.0, 0.01)                    # the IMU starts 10 s later
    imu = pd.DataFrame({"t_s": ti, "wz": x_true(ti), "ax": 0.0, "ay": 0.0})
    run = _run(pro, imu)
    frame = prepare_frame(run, replay_run(run))
    assert frame.lag.median_s == pytest.approx(lag, abs=0.03)
    scored = frame.t_s[frame.score_imu]
    assert scored.min() >= ti[0] + edge
    assert scored.min() < ti[0] + edge + 0.2            # and no later than the next samples
    assert scored.max() <= min(t[-1], ti[-1]) - edge
