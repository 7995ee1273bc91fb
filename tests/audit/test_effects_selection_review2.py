"""Review tests (second pass) of the audit's effect models, selection and clock alignment:
boundaries and scopes the earlier tests left open."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from audit_helpers import synthetic_frame
from terrain.audit.effects import YawParams, predict_yaw
from terrain.audit.frames import CURVE, SPIN, STRAIGHT, FrameSettings, _quiet


def test_the_dug_in_expectation_scales_turning_samples_only():
    # the immobile fraction is fitted on turning samples (effects._fit_immobile); a straight
    # sample keeps the mobile model's yaw rate however much the robot digs in while turning
    f = synthetic_frame("s/ASPHALT/0", drift_rad_s=0.05, noise=0.0)
    p = YawParams(immobilised=True, fractions=(0.4, 0.4), bias_rad_s=0.01)
    pred = predict_yaw(f, p)
    straight = f.manoeuvre == STRAIGHT
    turn = np.isin(f.manoeuvre, (CURVE, SPIN))
    assert straight.any() and turn.any()
    assert pred[straight] == pytest.approx(f.sim_wz[straight] + 0.01)
    assert pred[turn] == pytest.approx(0.6 * f.sim_wz[turn] + 0.01)


def test_a_sample_exactly_the_quiet_margin_from_a_turn_is_not_quiet():
    # "no turning sample lies within quiet_margin_s": a turn exactly 1.5 s away lies within
    # it (exact times: 0.5 s steps, margin 1.5 s)
    t = np.arange(0.0, 10.0, 0.5)
    x = np.zeros(t.size)
    x[t == 5.0] = 0.5
    q = _quiet(t, x, FrameSettings(quiet_margin_s=1.5))
    assert not q[t == 3.5][0] and not q[t == 6.5][0]
    assert q[t == 3.0][0] and q[t == 7.0][0]


def test_the_physics_comparison_scores_imu_and_current_samples_on_their_own_masks():
    # the gyro is scored where the IMU is (score_imu), the currents where the wheel stream is
    # (score_cur): here the IMU covers the first half of the scored span only
    from terrain.audit.physics import _errors
    f = synthetic_frame("s/ASPHALT/0", noise=0.0)
    f = replace(f, score_imu=f.score_imu & (np.arange(f.n) < f.n // 2))
    other = replace(f, sim_wz=f.wz - 1.0, sim_ax=f.ax, sim_ay=f.ay, sim_cur=f.cur - 2.0)
    e = _errors(f, other)
    assert e["wz"][0].size == f.score_imu.sum() < f.score_cur.sum()
    assert e["wz"][0] == pytest.approx(1.0)
    assert e["cur_l"][0].size == e["cur_r"][0].size == f.score_cur.sum()
    assert e["cur"][0].size == 2 * f.score_cur.sum() and e["cur"][0] == pytest.approx(4.0)


def test_the_moving_scope_of_the_physics_comparison_leaves_out_stops():
    # "moving" pools straight, curve and spin: a stopped sample is its own scope
    from terrain.audit.physics import _sums
    man = np.array([0, 1, 2, 3, 0, 1])                   # stop, straight, curve, spin, ...
    e = np.array([100.0, 1.0, 2.0, 3.0, 100.0, 4.0])
    errors = {"wz": (e, man)}
    assert _sums(errors, "moving") == {"wz": (10.0, 4)}
    assert _sums(errors, "stop") == {"wz": (200.0, 2)}
    assert _sums(errors, "straight") == {"wz": (5.0, 2)}


def test_the_lag_is_scored_on_the_gyros_samples():
    # wheel_lag is a yaw-rate effect: scored where the gyro is scored (score_imu), not where
    # the currents are; here the IMU covers the first half of the scored span only
    from terrain.audit.effects import LagParams, lag_sse
    f = synthetic_frame("s/ASPHALT/0", noise=0.0)
    f = replace(f, score_imu=f.score_imu & (np.arange(f.n) < f.n // 2),
                sim_wz=f.sim_wz - 0.5)
    sse, n = lag_sse(f, LagParams(0.0), "all")
    assert n == f.score_imu.sum() < f.score_cur.sum()
    assert sse == pytest.approx(0.25 * n)


def _dug_in(run_id, seed, bias_rad_s):
    """A synthetic run (chi 1.5, gyro bias) whose robot digs in during the curves of
    cycles 0 and 2: the gyro reads its bias there (turning samples: 1/4 dug in)."""
    f = synthetic_frame(run_id, seed=seed, chi=1.5, bias_rad_s=bias_rad_s)
    wz = f.wz.copy()
    rng = np.random.default_rng(seed + 100)
    for c in (0, 2):
        sl = slice(300 * c + 100, 300 * c + 150)
        wz[sl] = bias_rad_s + 0.005 * rng.standard_normal(50)
    return replace(f, wz=wz, imu_wz=wz)


def test_a_dug_in_sample_is_told_by_the_gyro_net_of_its_bias():
    # a gyro biased by 0.3 rad/s reads 0.3 where the robot digs in: against the mobile
    # model's 0.33-0.53 rad/s that is immobile once the bias is taken off, not before
    from terrain.audit.effects import fit_yaw
    frames = [_dug_in(f"s/ASPHALT/{i}", i, 0.3) for i in range(3)]
    p = fit_yaw(frames, ["icr_expansion", "gyro_bias", "immobilised"], form="uniform")
    assert p.bias_rad_s == pytest.approx(0.3, abs=0.01)
    assert p.chi == pytest.approx(1.5, rel=0.02)
    assert p.fraction == pytest.approx(0.25, abs=0.03)


@pytest.mark.parametrize("gyro", ["inverted", "dead"])
def test_a_gyro_that_turns_the_other_way_or_not_at_all_names_no_icr_expansion(gyro):
    # an upside-down gyro fitted chi = -1.2 and a dead one (reads 0) chi = NaN; both were
    # supported as an ICR expansion (gain 0.995 and 1.0): neither is a wider track
    from terrain.audit import selection
    from terrain.audit.selection import SelectionSettings, select_group

    def broken(f):
        wz = -f.wz if gyro == "inverted" else np.zeros(f.n)
        return replace(f, wz=wz, imu_wz=wz)
    units = [[broken(synthetic_frame(f"s/ASPHALT/{i}", seed=i))] for i in range(4)]
    g = select_group(units, "yaw", "ASPHALT",
                     SelectionSettings(n_bootstrap=50, n_param_bootstrap=0))
    icr = next(e for e in g.effects if e.name == "icr_expansion")
    assert "icr_expansion" not in g.selected and not icr.supported
    assert "chi" in icr.details["unphysical"]
    assert selection.unphysical("icr_expansion",
                                YawParams(kinematic=True, inverse_chi=1 / 1.4)) is None


def test_the_lag_of_a_unit_is_the_median_of_its_windows():
    # each unit's own lag is the median of its window lags (not its first window), and the
    # fitted lag the median over units
    from terrain.audit.effects import fit_lag
    from terrain.audit.timing import LagTrack

    def unit(i, lags):
        k = len(lags)
        return replace(synthetic_frame(f"s/ASPHALT/{i}", seed=i),
                       lag=LagTrack(np.arange(k) * 15.0 + 15.0, np.asarray(lags),
                                    np.full(k, 0.9), k))
    frames = [unit(0, [0.1, 0.5, 0.2]), unit(1, [0.6, 0.3, 0.4]), unit(2, [0.0, 0.35, 0.7])]
    p = fit_lag(frames, ["wheel_lag"])
    assert dict(p.per_run) == pytest.approx({"s/ASPHALT/0": 0.2, "s/ASPHALT/1": 0.4,
                                             "s/ASPHALT/2": 0.35})
    assert p.lag_s == pytest.approx(0.35)


def test_a_pooled_parameter_interval_resamples_units_within_each_terrain():
    # two terrains whose units are alike within each (gyro bias 0.01 on A, 0.05 on B): every
    # resample that keeps two units of each terrain fits the same pooled bias, so the
    # interval is the point; resampling across terrains would spread it over the mix
    from terrain.audit import selection
    from terrain.audit.effects import EffectSettings
    units = [[synthetic_frame(f"s/{t}/{i}", terrain=t, seed=i, bias_rad_s=b, noise=0.0)]
             for t, b in (("A", 0.01), ("B", 0.05)) for i in range(2)]
    ci = selection._param_ci(units, "yaw", ["gyro_bias"], "gyro_bias", None,
                             EffectSettings(), np.random.default_rng(0), 20)
    lo, hi = ci["bias_rad_s"]
    assert lo == pytest.approx(0.03, abs=1e-9) and hi == pytest.approx(0.03, abs=1e-9)


def test_segments_of_one_run_are_counted_as_one_run():
    # four segments of a single run are four cross-validation units but one run: the report
    # says a result from them transfers to no other run (report._timing_finding, n_runs < 2)
    from terrain.audit.frames import split_frame
    from terrain.audit.selection import SelectionSettings, select_group
    units = [[p] for p in split_frame(synthetic_frame("s/ASPHALT/0", bias_rad_s=0.02), 4)]
    g = select_group(units, "yaw", "ASPHALT",
                     SelectionSettings(n_bootstrap=50, n_param_bootstrap=0), segmented=True)
    assert {e.n_units for e in g.effects} == {4}
    assert {e.n_runs for e in g.effects} == {1}


def test_a_unit_drawn_several_times_by_the_bootstrap_weighs_as_often_in_the_lag():
    # a resample that draws unit 0 three times and unit 1 once: the median of
    # [0.1, 0.1, 0.1, 0.2] is 0.1; keyed by run name the repeats collapsed to [0.1, 0.2]
    # and gave 0.15, so the parameter interval of wheel_lag was not a bootstrap interval
    from terrain.audit.effects import fit_lag
    from terrain.audit.timing import LagTrack

    def unit(i, lag):
        return replace(synthetic_frame(f"s/ASPHALT/{i}", seed=i),
                       lag=LagTrack(np.array([15.0]), np.array([lag]), np.array([0.9]), 1))
    u0, u1 = unit(0, 0.1), unit(1, 0.2)
    p = fit_lag([u0, u0, u0, u1], ["wheel_lag"])
    assert p.lag_s == pytest.approx(0.1)
    assert dict(p.per_run) == pytest.approx({"s/ASPHALT/0": 0.1, "s/ASPHALT/1": 0.2})
    assert fit_lag([u0, u1], ["wheel_lag"]).lag_s == pytest.approx(0.15)   # distinct units
