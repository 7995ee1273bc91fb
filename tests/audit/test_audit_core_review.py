"""Review tests of the audit's core: ceiling, core, frames, physics and replay."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from terrain.audit import physics
from terrain.audit.ceiling import online_current_samples, online_yaw_rate_samples
from terrain.audit.frames import MANOEUVRES, AuditFrame
from terrain.audit.timing import LagTrack
from terrain.errors import ConfigError

RATE_HZ = 6.5
STOP, STRAIGHT, CURVE, SPIN = (MANOEUVRES.index(m) for m in ("stop", "straight", "curve", "spin"))


def _frame(run_id="a", chi=2.0, n_st=40, n_sp=80, n_stop=0, cycles=3):
    """Cycles of straight driving, spins in place and (``n_stop`` samples of) rest; the gyro
    turns at ``x / chi``, the replay at ``x / 3``, its right motor draws 0.5 A more than its
    left, the measured motors 1.5 A more than the replay's."""
    x = np.concatenate([np.r_[np.zeros(n_st), np.full(n_sp, 0.8), np.zeros(n_stop)]
                        for _ in range(cycles)])
    man = np.concatenate([np.r_[np.full(n_st, STRAIGHT), np.full(n_sp, SPIN),
                                np.full(n_stop, STOP)] for _ in range(cycles)])
    v = np.where(man == STRAIGHT, 0.5, 0.0)
    n = len(x)
    ones = np.ones(n, dtype=bool)
    sim_cur = np.column_stack([2 + 3 * np.abs(x), 2.5 + 3 * np.abs(x)])
    return AuditFrame(
        run_id=run_id, group=run_id, terrain="SNOW", t_s=np.arange(n) / RATE_HZ,
        commanded_yaw_rate=x, commanded_speed=v, manoeuvre=man, quiet=~ones,
        sim_wz=x / 3.0, sim_ax=np.zeros(n), sim_ay=np.zeros(n), sim_vx=v.copy(),
        sim_cur=sim_cur, cur=sim_cur + 1.5, has_imu=True, wz=x / chi, ax=np.zeros(n),
        ay=np.zeros(n), pitch=np.zeros(n), has_pitch=ones.copy(),
        imu_t_s=np.arange(n) / RATE_HZ, imu_wz=x / chi, score_imu=ones,
        score_cur=ones.copy(), lag=LagTrack(np.empty(0), np.empty(0), np.empty(0), 0))


@pytest.mark.parametrize("online", [online_yaw_rate_samples, online_current_samples])
@pytest.mark.parametrize("name", ["lead_s", "prior_s", "memory_s"])
def test_a_nan_online_setting_is_refused_not_read_as_no_evidence(online, name):
    # NaN passed 'lead_s < 0' and 'prior_s < 0': every forecast then quietly fell back to
    # the replay (an online gain of exactly 0) instead of the setting being named
    with pytest.raises(ConfigError, match=rf"{name} must be a finite value"):
        online([_frame()], **{name: float("nan")})


def test_the_online_forecast_leaves_the_replay_with_valid_settings():
    # the counterpart of the NaN test: valid settings learn the run's own chi and offset
    f = _frame()
    wz = online_yaw_rate_samples([f], lead_s=2.0, memory_s=30.0, prior_s=2.0)
    spin = (wz.manoeuvre == "spin").to_numpy()
    assert np.abs(wz.online - wz.reference).to_numpy()[spin].max() > 0.05
    cur = online_current_samples([f], lead_s=2.0, memory_s=15.0, prior_s=0.0)
    assert (cur.online - cur.reference).max() == pytest.approx(1.5)


def test_the_moving_scope_of_the_physics_comparison_leaves_out_stops(monkeypatch):
    # 'moving' pools straight, curve and spin: a run at rest adds nothing to it
    ref = _frame(n_stop=30)
    new = replace(ref, sim_wz=ref.sim_wz + 0.1, sim_cur=ref.sim_cur - 1.0)
    monkeypatch.setattr(physics, "paired_frames", lambda *a, **k: ([(ref, new)], {}))
    tab, _ = physics.per_run_errors([], physics.PhysicsComparisonSettings())
    for sig, per in tab.groupby("signal"):
        per = per.set_index("scope")
        assert per.n["stop"] > 0
        parts = per.loc[["straight", "curve", "spin"]]
        assert per.n["moving"] == parts.n.sum(), sig
        np.testing.assert_allclose(per.loc["moving", ["sse_ref", "sse_new"]].to_numpy(float),
                                   parts[["sse_ref", "sse_new"]].sum().to_numpy(float))
        assert per.n["moving"] + per.n["stop"] == (2 if sig == "cur" else 1) * ref.n


def test_each_versions_errors_are_its_own_on_every_signal(monkeypatch):
    # the reference replay misses the measured currents by 1.5 A, the candidate by 2.5 A
    # on both sides; its yaw rate is 0.1 rad/s off the reference's, its accelerations
    # -0.3 (x) and +0.2 m/s^2 (y) off the measured ones, which the reference matches
    ref = _frame(n_stop=30)
    new = replace(ref, sim_wz=ref.sim_wz + 0.1, sim_cur=ref.sim_cur - 1.0,
                  sim_ax=ref.sim_ax - 0.3, sim_ay=ref.sim_ay + 0.2)
    monkeypatch.setattr(physics, "paired_frames", lambda *a, **k: ([(ref, new)], {}))
    tab, _ = physics.per_run_errors([], physics.PhysicsComparisonSettings())
    cur = tab[tab.signal.isin(["cur_l", "cur_r", "cur"]) & (tab.n > 0)]
    np.testing.assert_allclose(cur.sse_ref / cur.n, 1.5 ** 2)
    np.testing.assert_allclose(cur.sse_new / cur.n, 2.5 ** 2)
    wz = tab[(tab.signal == "wz") & (tab.scope == "moving")].iloc[0]
    m = ref.manoeuvre != STOP
    e = (ref.wz - ref.sim_wz)[m]
    assert wz.sse_ref == pytest.approx(np.sum(e ** 2))
    assert wz.sse_new == pytest.approx(np.sum((e - 0.1) ** 2))
    for sig, off in (("ax", 0.3), ("ay", 0.2)):
        row = tab[(tab.signal == sig) & (tab.scope == "moving")].iloc[0]
        assert row.sse_ref == 0.0 and row.sse_new / row.n == pytest.approx(off ** 2), sig


def test_the_sample_table_reads_each_model_against_its_own_gyro_and_rate():
    # the extended yaw model predicts the gyro: mobile rate + bias. Only the mobile rate
    # turns the body, so ay = v_x wz moves by v_x (mobile - replayed rate), not by the bias
    from types import SimpleNamespace

    from terrain.audit.core import _samples, residual_statistics
    from terrain.audit.effects import YawParams

    # a gyro stamped 0.3 s late: on raw timestamps it is read 0.3 s earlier than aligned
    f = replace(_frame(), sim_vx=np.full(_frame().n, 0.4))
    f = replace(f, imu_t_s=f.t_s + 0.3)
    x = f.commanded_yaw_rate
    params = YawParams(kinematic=True, inverse_chi=0.5, bias_rad_s=0.05)
    groups = {("SNOW", "yaw"): SimpleNamespace(units=[[f]], heldout_params=[params])}
    samples = _samples(groups, "SNOW", [f])
    wz = samples[samples.signal == "wz"]
    np.testing.assert_allclose(wz.extended, 0.5 * x + 0.05)
    np.testing.assert_allclose(wz.measured, f.wz)
    raw = np.interp(f.t_s, f.t_s + 0.3, f.imu_wz)
    assert np.abs(raw - f.wz).max() > 0.1
    np.testing.assert_allclose(wz.measured_raw, raw)
    ay = samples[samples.signal == "ay"]
    np.testing.assert_allclose(ay.extended, f.sim_ay + 0.4 * (0.5 * x - x / 3.0))
    stats = residual_statistics(samples, "SNOW")
    row = stats[(stats.signal == "ay") & (stats.model == "extended") & (stats.run_id == "*")
                & (stats.manoeuvre == "all")].iloc[0]
    e = f.ay - (f.sim_ay + 0.4 * (0.5 * x - x / 3.0))
    assert row.n == f.n and row.bias == pytest.approx(np.mean(e))


def test_a_run_without_imu_is_audited_on_its_currents():
    # a wheel-only run has no IMU sample to score, but its currents are scored: it is an
    # audited frame, not a skipped run
    import pandas as pd

    from terrain.audit import prepare_frames
    from terrain.run import Run

    t = np.arange(0.0, 10.0, 0.15)
    v = np.minimum(t * 0.5, 0.8)
    pro = pd.DataFrame({"t_s": t, "cur_l": 2.0, "cur_r": 2.0, "vel_l": v, "vel_r": 1.1 * v})
    run = Run(run_id="x/ASPHALT/00", dataset="x", terrain="ASPHALT", streams={"wheels": pro},
              vehicle="husky")
    frames, skipped = prepare_frames([run])
    assert skipped == {} and len(frames) == 1
    f = frames[0]
    assert not f.has_imu and not f.score_imu.any()
    # scored: at least edge_s (2 s) from either end of the 9.9 s record
    np.testing.assert_array_equal(f.score_cur, (t >= 2.0) & (t <= t[-1] - 2.0))


@pytest.mark.parametrize("factor", [float("nan"), -0.5, float("inf")])
def test_a_lateral_friction_factor_out_of_range_is_refused(factor):
    # NaN stopped the replay with a bare ValueError ("cannot convert float NaN to integer");
    # a negative factor replayed a negative lateral friction and wrote its chi (0.69 on
    # a simulated SANDY_LOAM run at -1) into the table; AuditSettings took either and failed
    # only after the whole audit had run
    from terrain.audit import AuditSettings
    from terrain.audit.core import lateral_friction_sweep

    with pytest.raises(ConfigError, match=r"factors\[1\] must be a finite value >= 0"):
        AuditSettings(sweep_factors=(1.0, factor))
    with pytest.raises(ConfigError, match=r"factors\[0\] must be a finite value >= 0"):
        lateral_friction_sweep([], "SANDY_LOAM", (factor,))


def test_lateral_friction_factors_in_range_scale_the_catalogue_value():
    from terrain.audit import AuditSettings
    from terrain.audit.core import lateral_friction_sweep
    from terrain.terramechanics.catalogue import get_terrain

    assert AuditSettings(sweep_factors=(0.0, 0.5, 2.0)).sweep_factors == (0.0, 0.5, 2.0)
    tab = lateral_friction_sweep([], "SANDY_LOAM", (0.0, 0.5, 2.0))
    base = get_terrain("SANDY_LOAM").lateral_friction
    np.testing.assert_allclose(tab.lateral_friction, [0.0, 0.5 * base, 2.0 * base])
    assert (tab.n_runs == 0).all() and tab.replay_chi.isna().all()


def test_manoeuvres_follow_the_side_speeds():
    # stop: both sides slower than moving_m_s; straight: |x| < turn_rad_s; spin: the sides
    # turn opposite ways (ICR between the wheels); curve: a turn with both sides one way
    from terrain.audit.frames import FrameSettings, classify_manoeuvres

    rng = np.random.default_rng(1)
    track = 0.555
    v, x = rng.uniform(-1.0, 1.0, 4000), rng.uniform(-2.0, 2.0, 4000)
    v[:1000] *= 0.1                                   # many slow samples, one side at rest
    vel_l, vel_r = v - 0.5 * track * x, v + 0.5 * track * x
    s = FrameSettings()
    got = classify_manoeuvres(x, v, vel_l, vel_r, track, s)
    moving = (np.abs(vel_l) >= s.moving_m_s) | (np.abs(vel_r) >= s.moving_m_s)
    turning = np.abs(x) >= s.turn_rad_s
    want = np.where(~moving, STOP, np.where(~turning, STRAIGHT,
                                            np.where(vel_l * vel_r < 0, SPIN, CURVE)))
    np.testing.assert_array_equal(got, want)
    assert {STOP, STRAIGHT, CURVE, SPIN} <= set(got.tolist())
    # one side at rest and the other just moving is driving, not standing still
    one = classify_manoeuvres(np.array([0.0]), np.array([0.03]), np.array([0.0]),
                              np.array([0.06]), track, s)
    assert one[0] != STOP


def test_quiet_samples_keep_their_margin_from_every_turn():
    from terrain.audit.frames import FrameSettings, _quiet

    t = np.arange(0.0, 20.0, 0.1)
    x = np.where((t >= 10.0) & (t < 11.0), 0.5, 0.0)
    x[20] = 0.07                                       # a slow drift, neither quiet nor a turn
    s = FrameSettings()
    got = _quiet(t, x, s)
    turns = t[np.abs(x) >= s.turn_rad_s]
    gap = np.min(np.abs(t[:, None] - turns[None, :]), axis=1)
    np.testing.assert_array_equal(got, (np.abs(x) < s.quiet_rad_s) & (gap > s.quiet_margin_s))
    assert got[:20].all() and not got[20] and got[-30:].all() and not got[100:125].any()


def test_split_segments_tile_the_frame_and_estimate_their_lag_from_their_own_gyro(
        monkeypatch):
    # a segment left out in cross-validation must not feed the lag of the others: each
    # segment's lag track sees only the gyro samples stamped within its own span
    from terrain.audit import frames as fr

    f = _frame()
    seen = []
    real = fr.estimate_lag_track

    def spy(t, x, t_imu, wz, settings, alternative=None):
        seen.append((t[0], t[-1], t_imu.copy()))
        return real(t, x, t_imu, wz, settings, alternative=alternative)

    monkeypatch.setattr(fr, "estimate_lag_track", spy)
    parts = fr.split_frame(f, 3)
    assert [p.group for p in parts] == ["a#0", "a#1", "a#2"]
    for name in ("t_s", "wz", "manoeuvre", "score_imu"):
        np.testing.assert_array_equal(np.concatenate([getattr(p, name) for p in parts]),
                                      getattr(f, name))
    np.testing.assert_array_equal(np.vstack([p.cur for p in parts]), f.cur)
    assert len(seen) == 3
    for (t0, t1, t_imu), p in zip(seen, parts):
        assert (t0, t1) == (p.t_s[0], p.t_s[-1])
        assert t_imu.min() >= t0 and t_imu.max() <= t1 and len(t_imu) == p.n


def test_the_constant_lag_reading_looks_back_in_the_gyro():
    # positive lag = wheel data late: the gyro is read lag_s earlier than the wheel stamp
    f = _frame()
    f = replace(f, imu_wz=0.1 * f.imu_t_s)               # a ramp: value = 0.1 t
    inner = (f.t_s > 1.0) & (f.t_s < f.t_s[-1] - 1.0)
    np.testing.assert_allclose(f.wz_at_lag(0.3)[inner], 0.1 * (f.t_s[inner] - 0.3))
    np.testing.assert_allclose(f.wz_at_lag(-0.3)[inner], 0.1 * (f.t_s[inner] + 0.3))


def test_an_imu_stream_too_short_to_low_pass_is_set_aside_with_a_warning():
    # fewer than MIN_IMU_SAMPLES (the low-pass's padding) would be compared unfiltered
    # against a filtered replay: the run is audited as one without IMU, and says so
    import warnings

    import pandas as pd

    from terrain.audit import prepare_frames
    from terrain.audit.frames import MIN_IMU_SAMPLES
    from terrain.errors import DataWarning
    from terrain.run import Run

    t = np.arange(0.0, 10.0, 0.15)
    v = np.minimum(t * 0.5, 0.8)
    pro = pd.DataFrame({"t_s": t, "cur_l": 2.0, "cur_r": 2.0, "vel_l": v, "vel_r": 1.1 * v})

    def run(n_imu):
        ti = np.linspace(0.0, 9.9, n_imu)
        imu = pd.DataFrame({"t_s": ti, "wz": 0.0, "ax": 0.0, "ay": 0.0})
        return Run(run_id="x/ASPHALT/00", dataset="x", terrain="ASPHALT",
                   streams={"wheels": pro, "imu": imu}, vehicle="husky")

    with pytest.warns(DataWarning, match=f"fewer than {MIN_IMU_SAMPLES}"):
        (short,), _ = prepare_frames([run(MIN_IMU_SAMPLES - 1)])
    assert not short.has_imu and not short.score_imu.any()
    with warnings.catch_warnings():
        warnings.simplefilter("error", DataWarning)
        (enough,), _ = prepare_frames([run(MIN_IMU_SAMPLES)])
    assert enough.has_imu


def test_sides_two_speed_steps_apart_keep_their_difference():
    # the sub-resolution merge takes one step of difference for rounding; two steps are a
    # real difference (16 mm/s, about 0.03 rad/s commanded) and are replayed as measured
    import pandas as pd

    from terrain.audit.replay import replay_run
    from terrain.run import Run

    step = 0.2 / 25.4
    t = np.arange(0.0, 20.0, 0.15)
    k = np.minimum(np.floor(t / 5.0 * 63.0), 63.0)
    pro = pd.DataFrame({"t_s": t, "cur_l": 2.0, "cur_r": 2.0, "vel_l": k * step,
                        "vel_r": (k + 2 * (t > 5.0)) * step})
    run = Run(run_id="x/ASPHALT/00", dataset="x", terrain="ASPHALT", streams={"wheels": pro},
              vehicle="husky")
    rep = replay_run(run)
    cruise = (t > 8.0) & (t < 18.0)
    commanded = 2 * step / rep.track_m
    assert np.mean(rep.yaw_rate[cruise]) > 0.5 * commanded


def test_replayed_currents_are_magnitudes_even_where_the_filter_rings():
    # the zero-phase low-pass rings ahead of an abrupt start from rest; the dip below 0 is
    # the filter's, and a current magnitude is never negative
    import pandas as pd

    from terrain.audit.replay import replay_run
    from terrain.run import Run

    t = np.arange(0.0, 12.0, 0.15)
    v = np.where(t >= 5.0, 0.8, 0.0)
    pro = pd.DataFrame({"t_s": t, "cur_l": 2.0, "cur_r": 2.0, "vel_l": v, "vel_r": v})
    run = Run(run_id="x/ASPHALT/00", dataset="x", terrain="ASPHALT", streams={"wheels": pro},
              vehicle="husky")
    rep = replay_run(run)
    assert rep.cur.min() >= 0.0 and rep.cur[t > 6.0].min() > 0.5


def test_speed_resolution_is_found_only_in_a_quantised_record():
    from terrain.audit.replay import speed_resolution

    step = 0.2 / 25.4
    rng = np.random.default_rng(3)
    k = rng.integers(-90, 90, 500)
    assert speed_resolution(k * step) == pytest.approx(step, rel=1e-5)   # 7 decimals
    assert speed_resolution(rng.uniform(-1.0, 1.0, 500)) == 0.0
    # a record that is quantised except for a few samples is not quantised
    v = k * step
    v[:5] += 0.3 * step
    assert speed_resolution(v) == 0.0
    assert speed_resolution(np.array([0.0, step, -step])) == 0.0    # too few magnitudes


def test_the_lowpass_cut_off_is_the_one_asked_below_its_ceiling():
    from terrain.audit.replay import MAX_CUTOFF_FRACTION, lowpass_cutoff_hz

    assert lowpass_cutoff_hz(100.0, 2.0) == 2.0
    assert lowpass_cutoff_hz(4.0, 2.0) == pytest.approx(MAX_CUTOFF_FRACTION * 4.0)


@pytest.mark.parametrize("headroom", [0.5, float("nan")])
def test_a_speed_headroom_below_one_is_refused(headroom):
    # below 1 the replay would clip the measured speeds it is meant to impose
    from terrain.audit.replay import ReplaySettings

    with pytest.raises(ConfigError, match="speed_headroom"):
        ReplaySettings(speed_headroom=headroom)
    assert ReplaySettings(speed_headroom=1.0).speed_headroom == 1.0


def test_the_input_lowpass_smooths_each_side_on_its_own():
    import pandas as pd

    from terrain.audit.replay import ReplaySettings, lowpass, replay_run
    from terrain.run import Run

    rng = np.random.default_rng(4)
    t = np.arange(0.0, 12.0, 1 / 15.0)
    vel_l = 0.4 + 0.05 * rng.standard_normal(len(t))
    vel_r = 0.6 + 0.05 * rng.standard_normal(len(t))
    pro = pd.DataFrame({"t_s": t, "cur_l": 2.0, "cur_r": 2.0, "vel_l": vel_l, "vel_r": vel_r})
    run = Run(run_id="x/ASPHALT/00", dataset="x", terrain="ASPHALT", streams={"wheels": pro},
              vehicle="husky")
    rep = replay_run(run, ReplaySettings(input_cutoff_hz=2.0))
    np.testing.assert_allclose(rep.vel_l, lowpass(vel_l, 15.0, 2.0), rtol=1e-9)
    np.testing.assert_allclose(rep.vel_r, lowpass(vel_r, 15.0, 2.0), rtol=1e-9)


def test_the_cruise_acceleration_needs_twenty_cruising_samples():
    import pandas as pd

    from terrain.audit.replay import cruise_wheel_acceleration_rms
    from terrain.run import Run

    def rms(n_cruise):
        v = np.r_[np.zeros(30 - n_cruise), np.tile([0.5, 0.6], n_cruise // 2)]
        t = np.arange(len(v)) * 0.1
        pro = pd.DataFrame({"t_s": t, "cur_l": 2.0, "cur_r": 2.0, "vel_l": v, "vel_r": v})
        return cruise_wheel_acceleration_rms(Run(run_id="x/ASPHALT/00", dataset="x",
                                                 terrain="ASPHALT", streams={"wheels": pro},
                                                 vehicle="husky"))

    assert np.isnan(rms(10))
    assert rms(24) == pytest.approx(1.0)          # +-0.1 m/s every 0.1 s


def test_a_run_without_a_scorable_prediction_has_an_unknown_rmse_not_a_perfect_one():
    import pandas as pd

    from terrain.audit.core import residual_statistics

    samples = pd.DataFrame({"run_id": ["a"] * 5 + ["b"] * 5, "terrain": "SNOW",
                            "manoeuvre": "spin", "signal": "wz",
                            "measured": np.arange(10.0),
                            "replay": np.r_[np.arange(5.0) + 0.5, np.full(5, np.nan)]})
    stats = residual_statistics(samples, "SNOW").set_index("run_id")
    assert stats.loc["a", "n"] == 5 and stats.loc["a", "rmse"] == pytest.approx(0.5)
    assert stats.loc["b", "n"] == 0
    assert np.isnan(stats.loc["b", "rmse"]) and np.isnan(stats.loc["b", "bias"])
