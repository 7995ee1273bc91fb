"""Replay, manoeuvres, effect fits and the bootstrap, on data with known answers."""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pytest

from audit_helpers import simulated_streams
from terrain.audit.effects import (EffectSettings, NotIdentifiable, _current_data,
                                   effect_details, fit_current, fit_yaw, predict_current)
from terrain.audit.frames import MANOEUVRES, classify_manoeuvres, prepare_frame
from terrain.audit.replay import (JITTER_ACCEL_M_S2, ReplaySettings,
                                  cruise_wheel_acceleration_rms, replay_run)
from terrain.audit import selection
from terrain.audit.selection import SelectionSettings, bootstrap_gain, make_units
from terrain.errors import ConfigError, DataFormatError, DataWarning
from terrain.io.shipped import load_dataset
from terrain.run import Run
from terrain.io.writer import to_file_frames
from terrain.sim import SimConfig, simulate
from terrain.vehicles import HUSKY

B = HUSKY.track_m


def _run(imu, pro, terrain="ASPHALT", run_id="t/ASPHALT/00", vehicle="husky"):
    streams = {"wheels": pro.rename(columns={"time": "t_s", "velL": "vel_l", "velR": "vel_r",
                                             "curL": "cur_l", "curR": "cur_r"})}
    if imu is not None:
        streams["imu"] = imu.rename(columns={"time": "t_s"})
    return Run(run_id=run_id, dataset="t", terrain=terrain, streams=streams, vehicle=vehicle)


@pytest.fixture(scope="module")
def sim_run():
    res = to_file_frames(simulate(SimConfig(vehicle="husky", terrains=("ASPHALT",),
                                            scenario="random", duration_s=60.0, seed=21)))
    return res, _run(res["imu"], res["pro"])


@pytest.mark.slow
def test_replay_reproduces_the_simulator(sim_run):
    """Replaying a simulated run's own wheel speeds gives back its yaw rate and currents."""
    res, run = sim_run
    rep = replay_run(run)
    truth = res["truth"]
    keep = (rep.t_s > 2.0) & (rep.t_s < rep.t_s[-1] - 2.0)
    yaw = np.interp(rep.t_s, truth.time, truth.yaw_rate)
    assert np.sqrt(np.mean((rep.yaw_rate - yaw)[keep] ** 2)) < 0.02
    pro = res["pro"]
    cur = pro[["curL", "curR"]].to_numpy()
    diff = rep.cur[keep] - cur[keep]
    assert np.all(np.abs(diff.mean(axis=0)) < 0.1)   # no bias (sensor noise 0.08 A)
    assert np.abs(diff).mean() < 0.5                 # transients are low-passed
    assert rep.cur.shape == (len(pro), 2) and np.all(rep.cur >= 0)


def test_replay_imposes_measured_speeds_without_clipping():
    t = np.arange(0.0, 20.0, 0.15)
    v = np.minimum(t * 0.5, 1.3)                     # above the Husky's 1.0 m/s limit
    pro = pd.DataFrame({"time": t, "curL": 2.0, "curR": 2.0, "velL": v, "velR": v})
    rep = replay_run(_run(None, pro))
    assert rep.v_x[-20:].mean() == pytest.approx(1.3, abs=0.02)
    assert np.abs(rep.yaw_rate).max() < 1e-6


def test_replay_errors():
    t = np.arange(0.0, 5.0, 0.15)
    pro = pd.DataFrame({"time": t, "curL": 1.0, "curR": 1.0, "velL": 0.2, "velR": 0.2})
    with pytest.raises(ConfigError, match="ASPHALT"):
        replay_run(_run(None, pro, terrain="LAVA"))
    with pytest.raises(ConfigError, match="skid-steer"):
        replay_run(_run(None, pro, vehicle="agrimaro"))
    with pytest.raises(DataFormatError, match="wheel"):
        replay_run(Run("t/ASPHALT/01", "t", "ASPHALT", {}))


def test_a_stream_without_its_columns_is_skipped_with_a_typed_error():
    """A wheel stream without currents (or an IMU without ``wz``) reached the frame as a bare
    KeyError ("None of [Index(['cur_l', 'cur_r'])] are in the [columns]"), a traceback
    instead of a skipped run; it is refused with MissingColumnError naming the columns."""
    from terrain.audit import prepare_frames
    from terrain.errors import MissingColumnError
    t = np.arange(0.0, 15.0, 0.15)
    pro = pd.DataFrame({"time": t, "curL": 1.0, "curR": 1.0, "velL": 0.2, "velR": 0.3})
    with pytest.raises(MissingColumnError, match="cur_l"):
        replay_run(_run(None, pro.drop(columns=["curL"])))
    imu = pd.DataFrame({"time": t, "wx": 0.0, "wy": 0.0, "ax": 0.0, "ay": 0.0, "az": 9.8})
    frames, skipped = prepare_frames([_run(imu, pro)])
    assert not frames and "wz" in skipped["t/ASPHALT/00"]


@pytest.mark.slow
def test_input_lowpass_removes_the_noise_a_replay_rectifies_into_current():
    # a 0.57 m/s cruise recorded at 15 Hz whose every 4th sample reads about half (the
    # pattern of the Vulpi wheel-speed record, e.g. vulpi/CONCRETE/1: 0.57 0.57 0.57 0.29
    # ...): as recorded, the replayed motors brake and accelerate with it and the reported
    # current magnitude rises far above the steady cruise current (4.4 A against 1.9 A; 10.3 A
    # while the integrator charged the motors for traction the body never received); with
    # the input low-pass it is back within 0.3 A of a clean cruise at the record's mean speed
    t = np.arange(0.0, 30.0, 1.0 / 15.0)
    ramp = np.minimum(t * 0.5, 1.0)
    dropout = np.where(np.arange(t.size) % 4 == 3, 0.5, 1.0)
    record = 0.57 * ramp * dropout
    cruise = 0.57 * ramp * dropout.mean()

    def cur(v, **kw):
        pro = pd.DataFrame({"time": t, "curL": 2.0, "curR": 2.0, "velL": v, "velR": v})
        rep = replay_run(_run(None, pro), ReplaySettings(**kw))
        return rep.cur[(t > 5.0) & (t < 25.0)].mean(), rep

    steady = cur(cruise)[0]
    assert cur(record)[0] > steady + 2.0
    smoothed, rep = cur(record, input_cutoff_hz=2.0)
    assert smoothed == pytest.approx(steady, abs=0.3)
    # the smoothed speeds are the replay's inputs (hence the frame's commanded yaw rate)
    assert np.std(np.diff(rep.vel_l[t > 5.0])) < 0.1 * np.std(np.diff(record[t > 5.0]))
    with pytest.raises(ConfigError, match="input_cutoff_hz"):
        ReplaySettings(input_cutoff_hz=0.0)


@pytest.mark.slow
def test_a_short_imu_stream_is_used_when_filterable_and_warned_about_otherwise(sim_run):
    """An IMU stream of 30 samples or fewer was dropped without a word (``len(imu) > 30``):
    the run was audited as one without IMU. The code after needs more samples than the
    low-pass pads each end with (15); the lag estimation copes with any length (no
    identifiable lag). 20 samples are now used; 10 are ignored with a DataWarning naming
    the run and the count."""
    res, _ = sim_run
    imu, pro = res["imu"], res["pro"]
    start = len(imu) // 2
    used = _run(imu.iloc[start:start + 20], pro)
    assert prepare_frame(used, replay_run(used)).has_imu
    short = _run(imu.iloc[start:start + 10], pro)
    with pytest.warns(DataWarning, match=r"t/ASPHALT/00.*10 samples"):
        frame = prepare_frame(short, replay_run(short))
    assert not frame.has_imu
    none = _run(None, pro)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert not prepare_frame(none, replay_run(none)).has_imu


def test_manoeuvre_classes():
    vl = np.array([0.0, 0.5, 0.3, -0.2, 0.5, 0.01])
    vr = np.array([0.0, 0.5, 0.6, 0.2, 0.52, -0.01])
    x, v = (vr - vl) / B, (vl + vr) / 2
    got = [MANOEUVRES[k] for k in classify_manoeuvres(x, v, vl, vr, B)]
    assert got == ["stop", "straight", "curve", "spin", "straight", "stop"]


def _frame_with(run_streams, wz_of, cur_extra=None):
    """A frame whose gyro is ``wz_of(x)`` and whose currents are the replay's plus extras."""
    imu, pro = run_streams
    base = _run(imu, pro)
    rep = replay_run(base)
    x = (rep.vel_r - rep.vel_l) / B
    ti = imu.time.to_numpy()
    imu = imu.assign(wz=wz_of(np.interp(ti, rep.t_s, x)))
    cur = rep.cur.copy()
    if cur_extra is not None:
        cur += cur_extra(rep, x)
    pro = pro.assign(curL=cur[:, 0], curR=cur[:, 1])
    run = _run(imu, pro)
    return prepare_frame(run, replay_run(run))


@pytest.mark.slow
def test_fit_yaw_recovers_chi_and_bias():
    streams = simulated_streams(seeds=(41,))[0]
    frame = _frame_with(streams, lambda x: x / 1.6 + 0.01)
    p = fit_yaw([frame], ["icr_expansion", "gyro_bias"])
    assert p.chi == pytest.approx(1.6, rel=0.02)
    assert p.bias_rad_s == pytest.approx(0.01, abs=1e-3)
    assert p.fraction < 0.02
    with pytest.raises(NotIdentifiable):
        fit_yaw([frame], ["gyro_bias"], EffectSettings(min_quiet_samples=10 ** 6))


@pytest.mark.slow
def test_fit_current_recovers_offsets_and_turning_term():
    streams = simulated_streams(seeds=(42,))[0]
    settings = EffectSettings()

    def extra(rep, x):
        turn = np.abs(x) >= 0.1
        moving = np.maximum(np.abs(rep.vel_l), np.abs(rep.vel_r)) >= 0.05
        g = np.where(turn, np.tanh(np.abs(x) / 0.1) / np.tanh(5.0), 0.0)
        return np.column_stack([0.8 * g - 0.4 * moving, 0.8 * g + 0.9 * moving])
    frame = _frame_with(streams, lambda x: x, extra)
    p = fit_current([frame], ["current_offset", "turning_resistance"], settings)
    assert p.form == "coulomb"
    assert p.k_a == pytest.approx(0.8, abs=0.05)
    assert p.offset_a == pytest.approx(1.3, abs=0.05)
    assert p.common_a == pytest.approx(0.25, abs=0.05)
    pred = predict_current(frame, p)
    m = frame.score_cur
    assert np.abs(pred[m] - frame.cur[m]).mean() < 0.05
    with pytest.raises(NotIdentifiable, match="level ground"):
        fit_current([frame], ["grade_resistance"], settings)


def _hills_frame(streams, level_a=0.0, offsets_a=(0.0, 0.0), k_a_per_rad=10.0):
    """A simulated frame driven over rolling hills (pitch 0.15 sin(2 pi t / 20)): the
    accelerometer reads ``g sin(pitch)`` on x, both currents ``k |pitch|`` more, plus a
    level on moving samples and per-side offsets."""
    imu, pro = streams

    def pitch(t):
        return 0.15 * np.sin(2 * np.pi * np.asarray(t) / 20.0 + 0.7)
    imu = imu.assign(ax=imu.ax + 9.80665 * np.sin(pitch(imu.time)))

    def extra(rep, x):
        moving = np.maximum(np.abs(rep.vel_l), np.abs(rep.vel_r)) >= 0.05
        common = k_a_per_rad * np.abs(pitch(rep.t_s)) + level_a * moving
        return np.column_stack([common + offsets_a[0] * moving, common + offsets_a[1] * moving])
    return _frame_with((imu, pro), lambda x: x, extra)


@pytest.mark.slow
def test_fit_current_grade_is_not_a_level():
    """|pitch| is never negative: a grade fitted through the origin reports any level of the
    moving currents as a grade (1.5 A over mean |pitch| ~ 0.1 rad: +15 A/rad)."""
    streams = simulated_streams(seeds=(43,))[0]
    frame = _hills_frame(streams, level_a=1.5)
    p = fit_current([frame], ["grade_resistance"])
    assert p.k_a_per_rad == pytest.approx(10.0, abs=1.5)
    flat = fit_current([_hills_frame(streams, level_a=1.5, k_a_per_rad=0.0)],
                       ["grade_resistance"])
    assert abs(flat.k_a_per_rad) < 1.5


@pytest.mark.slow
def test_fit_current_alternation_converges_with_offsets_and_grade():
    """Offsets (median over straight samples) and the grade (least squares over moving
    samples) share the straight samples; the fit must be their common fixed point (three
    alternations stopped halfway: 6.2 against 9.9 A/rad on the planted real runs)."""
    streams = simulated_streams(seeds=(43,))[0]
    frame = _hills_frame(streams, offsets_a=(-0.7, 0.9))
    p = fit_current([frame], ["current_offset", "grade_resistance"])
    # below 10 by the pitch estimate's own error and the straight samples' median: 8.2
    assert p.k_a_per_rad == pytest.approx(10.0, abs=2.0)
    assert p.offset_a == pytest.approx(1.6, abs=0.1)
    d = _current_data([frame])
    grade = p.k_a_per_rad * d.pitch
    off = np.median(d.res[d.straight] - grade[d.straight, None], axis=0)
    assert off == pytest.approx([p.offset_left_a, p.offset_right_a], abs=1e-6)
    target = (d.res - off[None, :]).mean(axis=1)[d.moving]
    k = float(np.linalg.lstsq(d.pitch[d.moving, None], target, rcond=None)[0][0])
    assert k == pytest.approx(p.k_a_per_rad, abs=1e-6)
    short = fit_current([frame], ["current_offset", "grade_resistance"],
                        EffectSettings(max_alternations=1))
    assert abs(short.k_a_per_rad - p.k_a_per_rad) > 1.0


@pytest.mark.slow
def test_fit_current_grade_takes_only_runs_with_a_pitch():
    """A run without an IMU has no pitch estimate (its pitch is 0 as a placeholder): its
    rows in the grade's least squares said "level ground" while its currents climbed the
    same hills, which pulled the grade down (3.5 A/rad for 10 planted, 2 of 4 runs without
    an IMU)."""
    from dataclasses import replace

    frames = [_hills_frame(s) for s in simulated_streams(seeds=(43, 44))]
    both = fit_current(frames, ["grade_resistance"]).k_a_per_rad
    blind = replace(frames[1], has_imu=False, pitch=np.zeros(frames[1].n))
    k = fit_current([frames[0], blind], ["grade_resistance"]).k_a_per_rad
    alone = fit_current([frames[0]], ["grade_resistance"]).k_a_per_rad
    assert both == pytest.approx(10.0, abs=1.5)
    assert k == pytest.approx(alone, abs=1e-9)


@pytest.mark.slow
def test_fit_current_offsets_beside_a_grade_take_only_runs_with_a_pitch():
    """With ``current_offset`` beside the grade, the offsets (medians of straight driving)
    took the straight rows of a run without an IMU, whose pitch 0 is a placeholder: its
    climbing current went into the offsets as if on level ground and halved the grade
    (4.0 A/rad for 10 planted, 8.2 on the run with an IMU alone). Those rows are left out
    of a fit with a grade, and counted."""
    from dataclasses import replace

    frames = [_hills_frame(s, offsets_a=(-0.7, 0.9)) for s in simulated_streams(seeds=(43, 44))]
    blind = replace(frames[1], has_imu=False, pitch=np.zeros(frames[1].n))
    for spec in (["current_offset", "grade_resistance"],
                 ["turning_resistance", "current_offset", "grade_resistance"]):
        alone = fit_current([frames[0]], spec)
        p = fit_current([frames[0], blind], spec)
        assert p.k_a_per_rad == pytest.approx(alone.k_a_per_rad, abs=1e-9)
        assert p.offset_a == pytest.approx(alone.offset_a, abs=1e-9)
        assert p.n_straight == alone.n_straight
        assert p.n_without_pitch == int(((blind.manoeuvre != 0) & blind.score_cur).sum()) > 0
        assert alone.n_without_pitch == 0
        assert effect_details("grade_resistance", p) == {
            "n_moving_without_imu": p.n_without_pitch, "n_moving_outside_imu": 0}
    # a fit without a grade needs no pitch: every run's rows
    both = fit_current([frames[0], blind], ["current_offset"])
    assert both.n_without_pitch == 0
    assert both.n_straight > fit_current([frames[0]], ["current_offset"]).n_straight


@pytest.mark.slow
def test_fit_current_grade_leaves_out_samples_outside_the_imu_record():
    """Past the IMU's last stamp (and before its first) the pitch was read from the filtered
    accelerometer held at its end value, and those samples entered the grade fit as if
    measured: an IMU record of 12-40 s under 60 s of wheels gave 9.1 A/rad for 10 planted
    (10.7 with the samples read within the record only). They are left out, and counted."""
    from dataclasses import replace

    imu, pro = simulated_streams(seeds=(43,))[0]
    frame = _hills_frame((imu[(imu.time >= 12.0) & (imu.time <= 40.0)], pro))
    t_imu = frame.t_s - frame.lag.at(frame.t_s)
    outside = (t_imu < frame.imu_t_s[0]) | (t_imu > frame.imu_t_s[-1])
    moving_out = int((frame.score_cur & (frame.manoeuvre != 0) & outside).sum())
    assert moving_out > 100
    inside = replace(frame, score_cur=frame.score_cur & ~outside)
    for spec in (["grade_resistance"], ["current_offset", "grade_resistance"]):
        p = fit_current([frame], spec)
        ref = fit_current([inside], spec)
        assert p.k_a_per_rad == pytest.approx(ref.k_a_per_rad, abs=1e-9)
        assert p.offset_a == pytest.approx(ref.offset_a, abs=1e-9)
        assert p.n_outside_imu == moving_out and p.n_without_pitch == 0
        assert effect_details("grade_resistance", p) == {
            "n_moving_without_imu": 0, "n_moving_outside_imu": moving_out}
    assert fit_current([frame], ["grade_resistance"]).k_a_per_rad == pytest.approx(
        10.0, abs=1.0)
    # the grade term predicts nothing where there is no pitch
    assert not frame.has_pitch[outside].any() and frame.has_pitch[~outside].all()
    assert np.all(frame.pitch[outside] == 0.0)
    # a fit without a grade needs no pitch: every sample
    assert fit_current([frame], ["current_offset"]).n_outside_imu == 0


@pytest.mark.slow
def test_pitch_estimate_ignores_the_replay_start_transient(shipped_borealtc):
    """The replay starts from rest, so its first step accelerates at the friction limit
    (+-7.5 m/s^2 on ASPHALT); low-passed with the rest, it read as up to 0.29 rad of pitch on
    these level runs for several seconds past the scoring edge. (Until 2026-11-30 the
    integrator stored that step at t = 0, where the zero-phase low-pass's odd extension
    kept it, > 5 m/s^2 at the frame's first sample; the first row is now the rest state.)"""
    for rid in ("borealtc/ASPHALT/00", "borealtc/ASPHALT/02", "borealtc/ASPHALT/04"):
        run = shipped_borealtc[rid]
        frame = prepare_frame(run, replay_run(run))
        m = frame.score_cur
        assert np.max(np.abs(frame.pitch[m])) < 0.1, rid     # 0.24, 0.29, ... before


def test_bootstrap_gain():
    rng = np.random.default_rng(0)
    ref = rng.uniform(1.0, 2.0, 10)
    gain, ci = bootstrap_gain(ref, 0.25 * ref, ref, rng, 200)
    assert gain == pytest.approx(0.5)                 # RMSE halves
    assert ci[0] == pytest.approx(0.5) and ci[1] == pytest.approx(0.5)
    gain, ci = bootstrap_gain(ref, ref, ref, rng, 200)
    assert gain == 0.0 and ci == [0.0, 0.0]
    # the cases above have the same gain on every unit, so a 'bootstrap' that never
    # resamples (every draw = all units, or every draw = unit 0) passes them too. Here half
    # the units gain 0.5 and half nothing: the point is 1 - sqrt(6.25 / 10) = 0.209 and the
    # unit resamples spread it ([0.078, 0.368] with seed 0); the never-resampling variants
    # give [0.209, 0.209] or [0.5, 0.5]
    ones = np.ones(10)
    new = np.r_[np.full(5, 0.25), np.ones(5)]
    gain, ci = bootstrap_gain(ones, new, ones, np.random.default_rng(0), 200)
    assert gain == pytest.approx(1.0 - np.sqrt(6.25 / 10.0))
    assert ci[0] < gain < ci[1] and ci[1] - ci[0] > 0.15
    assert 0.0 < ci[0] and ci[1] < 0.5


def test_bootstrap_gain_of_pooled_terrains_resamples_within_each():
    """Units of several terrains (the audit's pooled ``all`` scope) were resampled across
    terrains, so the interval measured the resampled terrain mix: three units of a terrain
    where the candidate halves the error and three where it does nothing gave [0.00, 0.39]
    around 0.21 although every resample keeping three of each gives 0.21. With ``strata``
    each terrain keeps its count; one stratum draws exactly the unstratified resamples."""
    ref = np.full(6, 4.0)
    new = np.array([1.0] * 3 + [4.0] * 3)
    strata = np.array(["X"] * 3 + ["Y"] * 3)
    gain, ci = bootstrap_gain(ref, new, ref, np.random.default_rng(0), 200, strata)
    assert ci == pytest.approx([gain, gain])
    idx = selection.stratified_resamples(strata, np.random.default_rng(1), 50)
    assert idx.shape == (50, 6)
    assert (idx[:, :3] < 3).all() and (idx[:, 3:] >= 3).all()
    one = selection.stratified_resamples(np.zeros(6), np.random.default_rng(1), 50)
    assert (one == np.random.default_rng(1).integers(0, 6, (50, 6))).all()
    uneven = np.array([1.0, 2.0, 0.5, 4.0, 3.0, 3.9])
    assert (bootstrap_gain(ref, uneven, ref, np.random.default_rng(2), 100)
            == bootstrap_gain(ref, uneven, ref, np.random.default_rng(2), 100, np.zeros(6)))


def test_bootstrap_gain_of_one_unit_per_terrain_has_no_interval():
    """Resampled within each terrain, one unit per terrain (the pooled scope where each
    terrain has one run in the effect's scope) always draws the same units: the interval was
    the point itself, [0.217, 0.217], so any gain above ``min_gain`` passed the
    "interval above 0" rule that should be able to reject it. No spread: no interval, and
    the candidate is not supported."""
    ref = np.array([4.0, 4.0])
    new = np.array([1.0, 3.9])
    gain, ci = bootstrap_gain(ref, new, ref, np.random.default_rng(0), 200,
                              np.array(["X", "Y"]))
    assert gain == pytest.approx(0.2174, abs=1e-4)
    assert np.isnan(ci[0]) and np.isnan(ci[1])
    trial = selection.Trial(name="gyro_bias", scope="all", heldout_params=(), gain=gain,
                            gain_ci95=(ci[0], ci[1]), rmse_baseline=1.0, rmse_before=1.0,
                            rmse_with=0.8, unphysical=None, negligible=None)
    assert not selection.is_supported(trial, SelectionSettings())
    # one stratum with two or more units keeps its spread
    gain, ci = bootstrap_gain(np.full(3, 4.0), np.array([1.0, 3.9, 2.0]), np.full(3, 4.0),
                              np.random.default_rng(0), 200, np.array(["X", "Y", "Y"]))
    assert ci[0] < ci[1]


def test_forward_selection_takes_the_best_supported_candidate(monkeypatch):
    # the round's largest gain is noisy (interval reaches below 0: not supported); a smaller
    # gain whose interval lies above 0 meets the stated rule and must join. Before, the
    # round looked only at the largest admissible gain, found it unsupported and stopped:
    # selected () with turning_resistance (0.08 [0.05, 0.11]) reported as unsupported
    trials = {"current_offset": (0.10, (-0.05, 0.30)),
              "turning_resistance": (0.08, (0.05, 0.11)),
              "grade_resistance": (0.0, (-0.01, 0.01))}

    def fake(units, group, spec, name, before, es, rng, n_bootstrap):
        gain, ci = trials[name]
        return selection.Trial(name=name, scope="all", heldout_params=tuple(before),
                               gain=gain, gain_ci95=ci, rmse_baseline=1.0, rmse_before=1.0,
                               rmse_with=1.0 - gain, unphysical=None, negligible=None)

    monkeypatch.setattr(selection, "score_candidate", fake)
    settings = SelectionSettings()
    path = selection.forward_selection([[None]] * 5, "current", settings, EffectSettings(),
                                       np.random.default_rng(0))
    assert path.selected == ("turning_resistance",)
    assert set(path.final_round) == {"current_offset", "grade_resistance"}
    assert not any(selection.is_supported(t, settings) for t in path.final_round.values())


@pytest.mark.slow
def test_gain_vs_ideal_is_scored_on_the_effects_own_samples(sim_null):
    # icr_expansion is scored on turning samples and the report prints its gain vs ideal
    # drive beside 'scored on turning samples'; that gain was computed on every scored
    # sample (null ASPHALT audit: 0.1876 reported before, 0.1900 on the turning samples)
    from terrain.audit.effects import predict_yaw, scope_mask
    from terrain.audit.selection import loro

    result, _ = sim_null
    g = result.groups[("ASPHALT", "yaw")]
    e = next(x for x in g.effects if x.name == "icr_expansion")
    assert e.details["scope"] == "turning" and not e.supported and g.selected == ()
    held = loro(list(g.units), "yaw", ["icr_expansion"], [], EffectSettings())

    def vs_ideal(scope):
        s_with = s_ideal = 0.0
        for u, p in zip(g.units, held):
            for f in u:
                m = f.score_imu & scope_mask(f, scope)
                s_with += np.sum((f.wz[m] - predict_yaw(f, p)[m]) ** 2)
                s_ideal += np.sum((f.wz[m] - f.commanded_yaw_rate[m]) ** 2)
        return 1.0 - np.sqrt(s_with / s_ideal)

    assert e.details["heldout_gain_vs_ideal"] == pytest.approx(vs_ideal("turning"), rel=1e-9)
    assert abs(vs_ideal("all") - vs_ideal("turning")) > 2e-3          # the test can tell
    # the group's reference RMSE stays over all scored samples
    n = sum(int(f.score_imu.sum()) for u in g.units for f in u)
    s = sum(float(np.sum((f.wz - f.commanded_yaw_rate)[f.score_imu] ** 2))
            for u in g.units for f in u)
    assert g.reference_rmse["ideal"] == pytest.approx(np.sqrt(s / n), rel=1e-12)


@pytest.mark.slow
def test_make_units_cuts_few_runs_into_segments(sim_run):
    _, run = sim_run
    frame = prepare_frame(run, replay_run(run))
    units, segmented = make_units([frame], 4, lambda f: True)
    assert segmented and len(units) == 4
    assert sum(u[0].n for u in units) == frame.n
    assert {u[0].group for u in units} == {f"{frame.run_id}#{k}" for k in range(4)}
    units, segmented = make_units([frame] * 5, 4, lambda f: True)
    assert not segmented and len(units) == 5


@pytest.mark.slow
def test_segments_carry_their_own_lag_and_the_held_out_one_stays_out(sim_run):
    # one run cut in two halves; the gyro of the second half is read 0.8 s late. The fold
    # that leaves that half out must fit the same lag whatever its gyro does. Before, every
    # segment carried the whole run's track (windows centred 15, 30, 45 s), so the training
    # half's lag was the whole-run median: 0.0013 s, and -0.33 s with the second half
    # delayed; now 0.0017 s in both (the first half's own 30 s window), and the delayed half
    # carries its own -0.80 s
    from dataclasses import replace

    from terrain.audit.effects import fit_lag
    from terrain.audit.timing import estimate_lag_track

    _, run = sim_run
    frame = prepare_frame(run, replay_run(run))
    late = frame.imu_t_s > frame.t_s[frame.n // 2]
    wz = frame.imu_wz.copy()
    wz[late] = np.interp(frame.imu_t_s[late] - 0.8, frame.imu_t_s, frame.imu_wz)
    # segments are aligned from the measured record (split_frame low-passes each segment's
    # own samples), so the measured gyro is delayed too
    raw = frame.imu_raw.copy()
    raw[late, 0] = np.interp(frame.imu_t_s[late] - 0.8, frame.imu_t_s, frame.imu_raw[:, 0])
    delayed = replace(frame, imu_wz=wz, imu_raw=raw, lag=estimate_lag_track(
        frame.t_s, frame.commanded_yaw_rate, frame.imu_t_s, wz, alternative=frame.sim_wz))
    assert delayed.lag.median_s == pytest.approx(-0.33, abs=0.05)   # the run's own track
    fits = []
    for f in (frame, delayed):
        units, segmented = make_units([f], 2, lambda f: True)
        assert segmented and [u[0].group for u in units] == [f"{f.run_id}#0", f"{f.run_id}#1"]
        for u in units:                        # each segment's windows lie in its own span
            assert u[0].lag.identifiable
            assert np.all((u[0].lag.centres_s >= u[0].t_s[0])
                          & (u[0].lag.centres_s <= u[0].t_s[-1]))
        fit = fit_lag(units[0], ["wheel_lag"])            # the fold leaving out #1
        assert set(fit.per_run) == {f"{f.run_id}#0"}
        fits.append(fit.lag_s)
        assert units[1][0].lag.median_s == pytest.approx(0.0 if f is frame else -0.8,
                                                         abs=0.05)
    assert fits[0] == fits[1] == pytest.approx(0.0, abs=0.01)


@pytest.mark.slow
def test_jittery_wheel_records_are_told_apart_from_clean_ones(shipped_borealtc):
    # every shipped Vulpi record carries the every-4th-sample dropout, no BorealTC one does
    boreal = [cruise_wheel_acceleration_rms(r) for r in shipped_borealtc.values()]
    vulpi = [cruise_wheel_acceleration_rms(r) for r in load_dataset("vulpi")]
    boreal = [a for a in boreal if np.isfinite(a)]
    assert len(boreal) >= 15 and max(boreal) < JITTER_ACCEL_M_S2
    assert len(vulpi) == 15 and min(vulpi) > JITTER_ACCEL_M_S2
    # a clean cruise is far below the threshold; too little cruising gives NaN
    t = np.arange(0.0, 20.0, 1.0 / 15.0)
    v = np.minimum(t * 0.5, 0.57)
    pro = pd.DataFrame({"time": t, "curL": 2.0, "curR": 2.0, "velL": v, "velR": v})
    assert cruise_wheel_acceleration_rms(_run(None, pro)) < 0.1
    slow = pro.assign(velL=0.1, velR=0.1)
    assert np.isnan(cruise_wheel_acceleration_rms(_run(None, slow)))


@pytest.mark.parametrize("field, value, match", [
    ("edge_s", float("nan"), r"FrameSettings\.edge_s must be a finite value >= 0"),
    ("turn_rad_s", -0.1, r"FrameSettings\.turn_rad_s must be a finite value > 0"),
    ("quiet_rad_s", float("nan"), r"FrameSettings\.quiet_rad_s"),
    ("moving_m_s", float("inf"), r"FrameSettings\.moving_m_s"),
    ("imu_cutoff_hz", 0.0, r"FrameSettings\.imu_cutoff_hz")])
def test_frame_settings_refuse_a_nan_or_out_of_range_threshold(field, value, match):
    # Was: NaN passed every check (only the cut-offs and edge_s < 0 were tested), and a
    # NaN turn threshold made no sample a turn without a word.
    from terrain.audit.frames import FrameSettings
    with pytest.raises(ConfigError, match=match):
        FrameSettings(**{field: value})


@pytest.mark.parametrize("kwargs, match", [
    (dict(immobile_ratio=float("nan")), r"immobile_ratio must be a finite value > 0"),
    (dict(immobile_ratio=1.5), r"immobile_ratio must be <= 1"),
    (dict(turn_ref_rad_s=0.0), r"turn_ref_rad_s"),
    (dict(max_alternations=0), r"max_alternations must be an integer >= 1"),
    (dict(min_turn_samples=2.5), r"min_turn_samples must be an integer"),
    (dict(threshold_quantiles=(0.5, 1.0)), r"threshold_quantiles must be quantiles"),
    (dict(negligible=(("gyro_bias", float("nan")),)), r"negligible\['gyro_bias'\]")])
def test_effect_settings_refuse_a_nan_or_out_of_range_constant(kwargs, match):
    # Was: no check at all (a NaN ratio classified every turning sample as mobile).
    with pytest.raises(ConfigError, match=match):
        EffectSettings(**kwargs)
    EffectSettings()                               # the defaults stay valid


def _trial(gain=0.1, ci=(0.05, 0.15), unphysical=None, negligible=None):
    return selection.Trial(name="gyro_bias", scope="all", heldout_params=(), gain=gain,
                           gain_ci95=ci, rmse_baseline=1.0, rmse_before=1.0,
                           rmse_with=1.0 - gain, unphysical=unphysical, negligible=negligible)


def test_support_needs_an_interval_above_zero_the_minimum_gain_and_an_admissible_fit():
    settings = SelectionSettings(min_gain=0.02)
    assert selection.is_supported(_trial(), settings)
    # the rule is "above 0": an interval that reaches 0 exactly does not support
    assert not selection.is_supported(_trial(ci=(0.0, 0.2)), settings)
    # "at least min_gain": the bound itself passes, just below does not
    assert selection.is_supported(_trial(gain=0.02, ci=(0.01, 0.03)), settings)
    assert not selection.is_supported(_trial(gain=0.0199, ci=(0.01, 0.03)), settings)
    # a supported-looking gain is refused when the fit is negligible or unphysical
    assert not selection.is_supported(_trial(negligible="tiny"), settings)
    assert not selection.is_supported(_trial(unphysical="wrong way"), settings)


def test_bootstrap_gain_is_a_fraction_of_the_baseline_with_percentile_bounds():
    # the gain divides by the *baseline* RMSE, not by the RMSE of the model before: here the
    # model before already removed half the baseline's squared error
    ref = np.ones(8)
    new = np.r_[np.full(4, 0.25), np.ones(4)]
    base = 4.0 * ref
    gain, ci = bootstrap_gain(ref, new, base, np.random.default_rng(7), 300)
    assert gain == pytest.approx((np.sqrt(8.0) - np.sqrt(5.0)) / np.sqrt(32.0))
    # the interval is the 2.5 / 97.5 % percentiles of the gains of unit resamples
    idx = np.random.default_rng(7).integers(0, 8, (300, 8))
    g = ((np.sqrt(ref[idx].sum(1)) - np.sqrt(new[idx].sum(1)))
         / np.sqrt(base[idx].sum(1)))
    assert ci == pytest.approx([np.percentile(g, 2.5), np.percentile(g, 97.5)])


def test_negligible_and_unphysical_floors():
    from terrain.audit.effects import CurrentParams, YawParams

    es = EffectSettings()                             # gyro_bias floor 0.002, chi 5 %
    assert selection.negligible("gyro_bias", YawParams(bias_rad_s=-0.002), es) is None
    assert "below" in selection.negligible("gyro_bias", YawParams(bias_rad_s=0.0019), es)
    # chi is compared with the replay's own chi, relatively: 1.55 against 1.5 is 3.3 %
    near = YawParams(kinematic=True, inverse_chi=1.0 / 1.55, chi_replay=1.5)
    assert "within 5 %" in selection.negligible("icr_expansion", near, es)
    far = YawParams(kinematic=True, inverse_chi=1.0 / 1.3, chi_replay=1.2)   # 8.3 %
    assert selection.negligible("icr_expansion", far, es) is None
    # a grade resistance must cost current: zero or negative is unphysical
    assert selection.unphysical("grade_resistance", CurrentParams(k_a_per_rad=2.0)) is None
    for k in (0.0, -2.0):
        assert "<= 0" in selection.unphysical("grade_resistance",
                                              CurrentParams(k_a_per_rad=k))
    assert selection.unphysical("gyro_bias", YawParams(bias_rad_s=-1.0)) is None


def _synthetic_units(**kw):
    from audit_helpers import synthetic_frame
    return [[synthetic_frame(f"s/ASPHALT/{i}", seed=i, **kw)] for i in range(4)]


FAST_SELECTION = SelectionSettings(n_bootstrap=200, n_param_bootstrap=20)


def test_selection_on_synthetic_units_names_nothing_when_nothing_is_planted():
    for group in ("yaw", "current"):
        g = selection.select_group(_synthetic_units(), group, "ASPHALT", FAST_SELECTION)
        assert g.selected == () and not any(e.supported for e in g.effects)
        assert g.final_rmse == g.baseline_rmse


def test_loro_fits_each_fold_without_its_own_unit():
    from dataclasses import replace

    biases = (0.01, 0.02, 0.03, 0.07)
    units = [[replace(u[0], wz=u[0].sim_wz + b)]
             for u, b in zip(_synthetic_units(noise=0.0), biases)]
    held = selection.loro(units, "yaw", ["gyro_bias"], [], EffectSettings())
    others = [np.mean([b for j, b in enumerate(biases) if j != k]) for k in range(4)]
    assert [p.bias_rad_s for p in held] == pytest.approx(others, abs=1e-12)


def test_forward_selection_takes_the_larger_gain_first_and_scores_the_next_against_it():
    """chi 1.5 against the replay's 1.2 and a 0.02 rad/s gyro bias planted: both join, the
    one with the larger first-round gain first; the second is scored against the model
    holding the first (its RMSE before is not the baseline's), and the group's final RMSE is
    the held-out RMSE of the final model."""
    from terrain.audit.effects import YawParams, predict_yaw

    units = _synthetic_units(bias_rad_s=0.02, chi=1.5)
    g = selection.select_group(units, "yaw", "ASPHALT", FAST_SELECTION)
    assert set(g.selected) == {"icr_expansion", "gyro_bias"}
    first = next(e for e in g.effects if e.step == 1)
    second = next(e for e in g.effects if e.step == 2)
    other = selection.score_candidate(units, "yaw", [], second.name,
                                      [YawParams()] * len(units), EffectSettings(),
                                      np.random.default_rng(0), 200)
    assert first.heldout_gain > other.gain > 0
    assert second.details["heldout_rmse_before"] < 0.5 * second.details["heldout_rmse_baseline"]
    bias = next(e for e in g.effects if e.name == "gyro_bias")
    assert bias.params["bias_rad_s"] == pytest.approx(0.02, abs=1e-3)
    assert next(e for e in g.effects if e.name == "icr_expansion").params["chi"] == \
        pytest.approx(1.5, rel=1e-3)
    # final RMSE: the held-out predictions of the final model, pooled over scored samples
    s = n = 0
    for u, p in zip(g.units, g.heldout_params):
        for f in u:
            r = (f.wz - predict_yaw(f, p))[f.score_imu]
            s, n = s + np.sum(r * r), n + r.size
    assert g.final_rmse == pytest.approx(np.sqrt(s / n), rel=1e-12)
    assert g.final_rmse < 0.1 * g.baseline_rmse


def test_a_candidates_gain_is_scored_on_its_own_scope_against_the_replay():
    """icr_expansion acts on turning samples: its gain is (RMSE_before - RMSE_with) /
    RMSE_baseline with all three on the turning samples (held-out), by hand."""
    from terrain.audit.effects import YawParams, predict_yaw, scope_mask

    units = _synthetic_units(chi=1.5)
    trial = selection.score_candidate(units, "yaw", [], "icr_expansion",
                                      [YawParams()] * len(units), EffectSettings(),
                                      np.random.default_rng(0), 200)
    held = selection.loro(units, "yaw", ["icr_expansion"], [], EffectSettings())

    def rmse(params, scope):
        s = n = 0
        for u, p in zip(units, params):
            m = u[0].score_imu & scope_mask(u[0], scope)
            r = (u[0].wz - predict_yaw(u[0], p))[m]
            s, n = s + np.sum(r * r), n + r.size
        return np.sqrt(s / n)
    base = rmse([YawParams()] * 4, "turning")
    assert trial.rmse_baseline == pytest.approx(base, rel=1e-12)
    assert trial.rmse_with == pytest.approx(rmse(held, "turning"), rel=1e-12)
    assert trial.gain == pytest.approx(1.0 - rmse(held, "turning") / base, rel=1e-12)
    assert abs(rmse([YawParams()] * 4, "all") - base) > 0.01       # the scope matters


def test_manoeuvre_thresholds_are_inclusive_and_a_pivot_turn_is_a_curve():
    # passed as x, v and side speeds directly, so the thresholds are met exactly
    from terrain.audit.frames import FrameSettings
    s = FrameSettings()                          # moving 0.05 m/s, turn 0.1 rad/s
    vl = np.array([0.05, 0.0, 0.3, 0.3, 0.0])
    vr = np.array([0.0, 0.05, 0.3, 0.3, 0.5])
    x = np.array([0.0, 0.0, 0.1, 0.0999, 0.5 / B])
    v = np.array([0.025, 0.025, 0.3, 0.3, 0.25])
    got = [MANOEUVRES[k] for k in classify_manoeuvres(x, v, vl, vr, B, s)]
    # one side at the threshold moves; |x| at the threshold turns; a pivot on one
    # standing side (ICR on that wheel, |v| = |x| B / 2) is a curve, not a spin
    assert got == ["straight", "straight", "curve", "straight", "curve"]
    x2 = np.array([0.4, 0.4])
    got = [MANOEUVRES[k] for k in classify_manoeuvres(
        x2, np.array([0.5 * 0.4 * B * 0.99, 0.5 * 0.4 * B * 1.01]), np.full(2, 0.3),
        np.full(2, 0.3), B, s)]
    assert got == ["spin", "curve"]


def test_quiet_samples_are_slow_and_far_from_every_turn():
    from terrain.audit.frames import FrameSettings, _quiet
    t = np.arange(0.0, 30.0, 0.1)
    x = np.zeros(t.size)
    x[(t >= 10.0) & (t <= 12.0)] = 0.5               # one turn
    x[(t >= 20.0) & (t <= 25.0)] = 0.07              # slow, below the turn threshold
    q = _quiet(t, x, FrameSettings())                # quiet below 0.05, margin 1.5 s

    def at(s):
        return bool(q[np.argmin(np.abs(t - s))])
    assert at(2.0) and at(8.4) and at(13.6) and at(18.0)   # before the first turn too
    assert not at(8.6) and not at(11.0) and not at(13.4)
    assert not at(22.0)                                     # 0.07 rad/s is not quiet
    assert _quiet(t, np.zeros(t.size), FrameSettings()).all()


def test_turning_shape_is_one_at_the_reference_turn():
    from terrain.audit.effects import CurrentParams
    p = CurrentParams(turn_ref_rad_s=0.5, coulomb_scale_rad_s=0.1)
    x = np.array([-0.5, 0.25, 0.5, 1.0])
    assert p.turning_shape(x, "proportional") == pytest.approx([1.0, 0.5, 1.0, 2.0])
    assert p.turning_shape(x, "coulomb") == pytest.approx(
        np.tanh(np.abs(x) / 0.1) / np.tanh(5.0))
    assert p.turning_shape(np.array([0.5]), "coulomb")[0] == pytest.approx(1.0)


def test_current_errors_count_both_sides_and_the_straight_difference_once():
    from dataclasses import replace

    from audit_helpers import synthetic_frame
    from terrain.audit.effects import CurrentParams, current_sse
    f = synthetic_frame("s/ASPHALT/0", offsets_a=(-0.3, 0.5), noise=0.0)
    straight = f.score_cur & (f.manoeuvre == 1)
    s, n = current_sse(f, CurrentParams(), "all")
    assert n == 2 * f.score_cur.sum()
    moving = f.score_cur & (f.manoeuvre != 0)
    assert s == pytest.approx(moving.sum() * (0.3 ** 2 + 0.5 ** 2))
    # right - left: measured 0.8 more than the replay; a model with the offsets the right
    # way round explains it, the wrong way round doubles it
    s, n = current_sse(f, CurrentParams(), "straight_diff")
    assert n == straight.sum() and s == pytest.approx(n * 0.8 ** 2)
    s, _ = current_sse(f, CurrentParams(offset_left_a=-0.3, offset_right_a=0.5),
                       "straight_diff")
    assert s == pytest.approx(0.0, abs=1e-18)
    s, _ = current_sse(f, CurrentParams(offset_left_a=0.5, offset_right_a=-0.3),
                       "straight_diff")
    assert s == pytest.approx(n * 1.6 ** 2)
    assert current_sse(replace(f, score_cur=np.zeros(f.n, dtype=bool)),
                       CurrentParams()) == (0.0, 0)


def test_make_units_keeps_runs_at_the_minimum_and_cuts_fewer_into_enough_segments():
    from audit_helpers import synthetic_frame
    frames = [synthetic_frame(f"s/ASPHALT/{i}", seed=i) for i in range(4)]
    units, segmented = make_units(frames, 4, lambda f: True)
    assert not segmented and [u[0].group for u in units] == [f.run_id for f in frames]
    # 3 runs for 4 units: each cut in ceil(4 / 3) = 2, so at least 4 units
    units, segmented = make_units(frames[:3], 4, lambda f: True)
    assert segmented and len(units) == 6
    assert [u[0].group for u in units[:2]] == ["s/ASPHALT/0#0", "s/ASPHALT/0#1"]
    assert make_units(frames, 4, lambda f: False) == ([], False)


def test_scopes_select_the_samples_each_effect_acts_on():
    from audit_helpers import synthetic_frame
    from terrain.audit.effects import scope_mask
    f = synthetic_frame("s/ASPHALT/0")
    assert scope_mask(f, "all").all()
    assert (scope_mask(f, "active") == ~f.quiet).all() and f.quiet.any()
    assert (scope_mask(f, "turning") == np.isin(f.manoeuvre, (2, 3))).all()
    assert (scope_mask(f, "moving") == (f.manoeuvre != 0)).all()
    assert (scope_mask(f, "straight") == (f.manoeuvre == 1)).all()
    assert {int(k) for k in np.unique(f.manoeuvre)} == {1, 2, 3}


def test_a_fold_that_cannot_identify_the_candidate_keeps_the_model_before():
    """Only one unit turns: the fold that holds it out cannot fit turning_resistance and
    predicts with the model before (the offsets), not with the bare replay."""
    from dataclasses import replace

    from terrain.audit.effects import CurrentParams

    units = _synthetic_units(offsets_a=(-0.3, 0.5))
    for u in units[1:]:
        f = u[0]
        u[0] = replace(f, manoeuvre=np.where(np.isin(f.manoeuvre, (2, 3)), 0, f.manoeuvre)
                       .astype(f.manoeuvre.dtype))
    before = selection.loro(units, "current", ["current_offset"], [], EffectSettings())
    trial = selection.score_candidate(units, "current", ["current_offset"],
                                      "turning_resistance", before, EffectSettings(),
                                      np.random.default_rng(0), 50)
    held = trial.heldout_params[0]
    assert held.k_a == 0.0 and held.offset_a == pytest.approx(0.8, abs=0.01)
    assert trial.heldout_params[1].k_a != 0.0
    assert isinstance(held, CurrentParams)


def test_units_without_samples_in_scope_are_left_out_of_the_gain_interval():
    """icr_expansion on units of which four hold no scored turning sample: the interval is
    resampled over the six units that do (an empty unit drawn would only dilute it)."""
    from dataclasses import replace

    from terrain.audit.effects import YawParams

    from audit_helpers import synthetic_frame

    # runs that scrub differently, so that the per-unit gains differ; the last four
    # score no turning sample. (With few units the percentiles sit on the extreme
    # resamples, "every draw the same unit", which empty units do not change.)
    chis = (1.3, 1.4, 1.5, 1.6, 1.8, 2.0, 1.5, 1.5, 1.5, 1.5)
    units = [[synthetic_frame(f"s/ASPHALT/{i}", seed=i, chi=chi, n_cycles=2)]
             for i, chi in enumerate(chis)]
    for k in range(6, 10):
        units[k] = [replace(units[k][0], score_imu=units[k][0].score_imu
                            & (units[k][0].manoeuvre == 1))]
    es = EffectSettings()
    trial = selection.score_candidate(units, "yaw", [], "icr_expansion",
                                      [YawParams()] * 10, es, np.random.default_rng(3), 200)
    held = selection.loro(units, "yaw", ["icr_expansion"], [], es)
    base, n = selection.unit_errors(units, "yaw", [YawParams()] * 10, "turning")
    new, _ = selection.unit_errors(units, "yaw", held, "turning")
    keep = n > 0
    assert keep.tolist() == [True] * 6 + [False] * 4
    gain, ci = bootstrap_gain(base[keep], new[keep], base[keep], np.random.default_rng(3),
                              200)
    assert trial.gain == pytest.approx(gain)
    assert trial.gain_ci95 == pytest.approx(tuple(ci), rel=1e-12)
    assert ci[1] - ci[0] > 0.01


def test_gyro_bias_is_fitted_on_quiet_samples_against_the_mobile_model():
    """Straight stretches command a slow 0.03 rad/s drift (quiet: below 0.05 rad/s): the
    bias is the gyro minus the mobile model there, ``x / chi`` with icr_expansion, the
    replay without; turning samples, where chi 1.5 departs from the replay's 1.2, stay out."""
    from audit_helpers import synthetic_frame
    frames = [synthetic_frame(f"s/ASPHALT/{i}", seed=i, bias_rad_s=0.02, chi=1.5,
                              drift_rad_s=0.03, noise=0.001) for i in range(2)]
    p = fit_yaw(frames, ["icr_expansion", "gyro_bias"])
    assert p.chi == pytest.approx(1.5, rel=1e-3)
    assert p.bias_rad_s == pytest.approx(0.02, abs=2e-4)
    # against the replay (x / 1.2) on quiet samples: 0.02 + 0.03 / 1.5 - 0.03 / 1.2
    p = fit_yaw(frames, ["gyro_bias"])
    assert p.bias_rad_s == pytest.approx(0.02 + 0.03 / 1.5 - 0.03 / 1.2, abs=2e-4)


def test_immobile_scale_takes_the_fraction_of_its_side_of_the_threshold():
    from terrain.audit.effects import immobile_scale
    x = np.array([0.2, -0.6, 0.5, 0.6, 0.0])
    turn = np.array([True, True, True, False, False])
    assert immobile_scale(x, turn, (0.1, 0.5), 0.5) == pytest.approx(
        [0.9, 0.5, 0.5, 1.0, 1.0])
    assert immobile_scale(x, turn, (0.25, 0.9), np.inf) == pytest.approx(
        [0.75, 0.75, 0.75, 1.0, 1.0])


def test_grade_current_grows_with_the_slope_in_either_direction():
    from dataclasses import replace

    from audit_helpers import synthetic_frame
    from terrain.audit.effects import CurrentParams
    f = synthetic_frame("s/ASPHALT/0", noise=0.0)
    pitch = np.where(np.arange(f.n) % 2, 0.1, -0.1)
    f = replace(f, pitch=pitch)
    extra = predict_current(f, CurrentParams(k_a_per_rad=10.0)) - f.sim_cur
    moving = f.manoeuvre != 0
    assert extra[moving] == pytest.approx(1.0)
    assert np.all(extra[~moving] == 0.0)


def test_wheel_lag_is_the_median_unit_lag_and_reads_the_gyro_earlier_for_late_wheels():
    from dataclasses import replace

    from audit_helpers import synthetic_frame
    from terrain.audit.effects import LagParams, fit_lag, lag_sse
    from terrain.audit.timing import LagTrack

    frames = [replace(synthetic_frame(f"s/ASPHALT/{i}", seed=i),
                      lag=LagTrack(np.array([10.0, 40.0]), np.array([lag, lag]),
                                   np.array([0.9, 0.9]), 2))
              for i, lag in enumerate((0.1, 0.2, 0.9))]
    p = fit_lag(frames, ["wheel_lag"])
    assert p.lag_s == pytest.approx(0.2)
    assert p.per_run == pytest.approx({f.group: f.lag.median_s for f in frames})
    assert fit_lag(frames, []).lag_s == 0.0
    # wheel data 0.5 s late: the gyro at real time tau shows the wheels stamped tau + 0.5
    f = frames[0]
    late = replace(f, imu_wz=np.interp(f.t_s + 0.5, f.t_s, f.sim_wz))
    m = late.score_imu & ~late.quiet & (late.t_s < late.t_s[-1] - 1.0)
    late = replace(late, score_imu=m)
    assert lag_sse(late, LagParams(0.5), "all")[0] == pytest.approx(0.0, abs=1e-20)
    assert lag_sse(late, LagParams(-0.5), "all")[0] > 1.0


def test_immobilised_keeps_the_mobile_model_that_fits_better():
    """chi 1.5 against the replay's 1.2, and the robot dug in (gyro 0) for the first 30 % of
    every turn: ``immobilised`` alone tries the replay and ``x / chi_m`` as the mobile yaw
    rate and must keep the kinematic one, with its chi and the planted fraction."""
    from dataclasses import replace

    from audit_helpers import synthetic_frame
    frames = []
    for i in range(2):
        f = synthetic_frame(f"s/ASPHALT/{i}", seed=i, chi=1.5, noise=0.002)
        turn = np.isin(f.manoeuvre, (2, 3))
        start = np.flatnonzero(turn & ~np.r_[False, turn[:-1]])
        dug = np.zeros(f.n, dtype=bool)
        for s in start:
            dug[s:s + 15] = True                         # 15 of each 50-sample turn
        frames.append(replace(f, wz=np.where(dug, 0.0, f.wz)))
    p = fit_yaw(frames, ["immobilised"])
    assert p.kinematic and p.chi == pytest.approx(1.5, rel=0.01)
    assert p.fraction == pytest.approx(0.3, abs=0.03) and p.form == "uniform"


def test_a_turning_resistance_fitted_below_zero_gets_its_own_cause():
    from terrain.audit.effects import EFFECT_VOCABULARY, CurrentParams, effect_cause
    vocab = EFFECT_VOCABULARY["turning_resistance"].cause
    assert effect_cause("turning_resistance", CurrentParams(k_a=1.2)) == vocab
    below = effect_cause("turning_resistance", CurrentParams(k_a=-1.2))
    assert below != vocab and "less current" in below
    assert effect_cause("gyro_bias", CurrentParams(k_a=-1.2)) == \
        EFFECT_VOCABULARY["gyro_bias"].cause


@pytest.mark.slow
def test_the_gyro_is_read_on_the_runs_own_clock_and_the_edges_are_not_scored(sim_run):
    """IMU stamps 0.5 s early against the wheels (wheel data late): the frame reads the gyro
    at ``t - lag`` and matches the replay there far better than on raw timestamps; the first
    and last ``edge_s`` of the run are not scored."""
    _, run = sim_run
    imu = run.streams["imu"]
    late = _run(imu.assign(t_s=imu.t_s - 0.5).rename(columns={"t_s": "time"}),
                run.streams["wheels"].rename(columns={"t_s": "time", "vel_l": "velL",
                                                      "vel_r": "velR", "cur_l": "curL",
                                                      "cur_r": "curR"}))
    frame = prepare_frame(late, replay_run(late))
    assert frame.lag.median_s == pytest.approx(0.5, abs=0.05)
    m = frame.score_imu

    def rmse(wz):
        return np.sqrt(np.mean((wz - frame.sim_wz)[m] ** 2))
    assert rmse(frame.wz) < 0.5 * rmse(frame.wz_at_lag(0.0))
    assert rmse(frame.wz) == pytest.approx(rmse(frame.wz_at_lag(0.5)), rel=0.05)
    t = frame.t_s
    for mask in (frame.score_cur, frame.score_imu):
        assert t[mask].min() >= t[0] + 2.0 and t[mask].max() <= t[-1] - 2.0
    assert frame.score_cur[(t > t[0] + 2.2) & (t < t[-1] - 2.2)].all()


def test_the_rate_dependent_form_needs_fast_turns_to_dig_in_more():
    """Dug in for 60 % of every fast turn (spins, |x| = 0.8) and never in slow ones (curves,
    0.5): the rate-dependent form splits them. Dug in on the slow turns only contradicts
    "faster scrub digs in more": the uniform form is kept."""
    from dataclasses import replace

    from audit_helpers import synthetic_frame

    def dug_in(code):
        frames = []
        for i in range(2):
            f = synthetic_frame(f"s/ASPHALT/{i}", seed=i, chi=1.5, noise=0.002)
            turn = f.manoeuvre == code
            start = np.flatnonzero(turn & ~np.r_[False, turn[:-1]])
            dug = np.zeros(f.n, dtype=bool)
            for s in start:
                dug[s:s + 30] = True                     # 30 of each 50-sample turn
            frames.append(replace(f, wz=np.where(dug, 0.0, f.wz)))
        return fit_yaw(frames, ["icr_expansion", "immobilised"])
    fast = dug_in(3)
    assert fast.form == "rate_dependent" and 0.5 < fast.threshold_rad_s <= 0.8
    # 0.6 of each spin, but the last spin of a run ends in the unscored 2 s edge, where
    # only its dug-in 30 samples are scored: (3 * 30 + 30) / (3 * 50 + 30) = 2/3
    assert fast.fractions == pytest.approx((0.0, 2.0 / 3.0), abs=0.02)
    slow = dug_in(2)
    assert slow.form == "uniform" and slow.fraction == pytest.approx(0.3, abs=0.03)


def test_current_offsets_are_added_while_moving_only():
    """``current_offset``: constant offsets of the left and right readings *while moving*
    (a robot at rest draws the replay's stand-still current): left to ``cur_l``, right to
    ``cur_r``, nothing on stopped samples."""
    from dataclasses import replace

    from audit_helpers import synthetic_frame
    from terrain.audit.effects import CurrentParams
    from terrain.audit.frames import STOP
    f = synthetic_frame("s/ASPHALT/0", noise=0.0)
    manoeuvre = f.manoeuvre.copy()
    manoeuvre[:30] = STOP                                # the run starts at rest for 3 s
    f = replace(f, manoeuvre=manoeuvre)
    extra = predict_current(f, CurrentParams(offset_left_a=-0.3, offset_right_a=0.5)) - f.sim_cur
    moving = manoeuvre != STOP
    assert moving.any() and (~moving).sum() == 30
    np.testing.assert_allclose(extra[moving], [[-0.3, 0.5]] * int(moving.sum()), atol=1e-12)
    assert np.all(extra[~moving] == 0.0)


def test_the_vocabulary_fits_and_scores_each_effect_where_the_table_says():
    """The vocabulary (module table): each effect's group, JSON parameter and unit, and the
    samples its held-out gain is scored on; every effect the simulator plants is audited
    under the same name and unit, and the Coulomb turning shape is the simulator's."""
    from terrain.audit.effects import EFFECT_VOCABULARY, EffectSettings
    from terrain.sim import PLANTED_EFFECTS
    from terrain.sim.effects import TURN_RATE_SCALE_RAD_S
    table = {
        "icr_expansion": ("yaw", "chi", "1", "turning"),
        "gyro_bias": ("yaw", "bias_rad_s", "rad/s", "all"),
        "wheel_lag": ("timing", "lag_s", "s", "active"),
        "turning_resistance": ("current", "k_a", "A", "turning"),
        "current_offset": ("current", "offset_a", "A", "straight_diff"),
        "grade_resistance": ("current", "k_a_per_rad", "A/rad", "moving"),
        "immobilised": ("yaw", "fraction", "1", "turning"),
    }
    assert {name: (s.group, s.param, s.unit, s.scope)
            for name, s in EFFECT_VOCABULARY.items()} == table
    for name, planted in PLANTED_EFFECTS.items():
        assert EFFECT_VOCABULARY[name].unit == planted.unit, name
    assert EffectSettings().coulomb_scale_rad_s == TURN_RATE_SCALE_RAD_S


def test_fitted_chi_is_the_kinematic_one_or_the_replays_own():
    """``YawParams.chi``: ``1 / inverse_chi`` when the mobile model is kinematic, the
    replay's own chi when the mobile yaw rate is the replay's (the report's ``chi_mobile``)."""
    from terrain.audit.effects import YawParams
    assert YawParams(kinematic=True, inverse_chi=0.8, chi_replay=1.3).chi == pytest.approx(1.25)
    assert YawParams(kinematic=False, inverse_chi=0.8, chi_replay=1.3).chi == 1.3
    assert np.isnan(YawParams().chi)


def test_a_run_without_imu_is_audited_on_its_currents_and_an_unknown_terrain_skipped():
    """A wheel stream alone still gives current samples to score: the run is prepared (not
    skipped for lacking gyro samples); a run on a terrain outside the catalogue is skipped
    with the replay's reason."""
    from terrain.audit import prepare_frames

    t = np.arange(0.0, 20.0, 0.1)
    pro = pd.DataFrame({"time": t, "curL": 2.0, "curR": 2.0, "velL": 0.4, "velR": 0.4})
    frames, skipped = prepare_frames([_run(None, pro),
                                      _run(None, pro, terrain="LAVA", run_id="t/LAVA/00")])
    assert [f.run_id for f in frames] == ["t/ASPHALT/00"]
    assert not frames[0].has_imu and frames[0].score_cur.any()
    assert list(skipped) == ["t/LAVA/00"] and "LAVA" in skipped["t/LAVA/00"]
