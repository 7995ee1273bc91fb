"""Residual statistics of the audit: RMSE, bias and a correlation that means something."""

import numpy as np
import pandas as pd
import pytest

from terrain.audit.core import CONSTANT_SPREAD_TOL, residual_statistics


def _table(measured, replay):
    n = len(measured)
    return pd.DataFrame({"run_id": ["r1"] * n, "terrain": ["SNOW"] * n,
                         "manoeuvre": ["spin"] * n, "signal": ["ax"] * n,
                         "measured": measured, "replay": replay})


def test_a_replay_constant_up_to_float_noise_has_no_correlation():
    # a spin in place: the replayed body acceleration is zero up to 1e-19 of integrator noise;
    # two noise draws of that size must not give two different correlations
    rng = np.random.default_rng(0)
    measured = rng.normal(0.0, 0.4, 300)
    out = []
    for seed in (1, 2):
        noise = np.random.default_rng(seed).normal(0.0, 1e-19, 300)
        stats = residual_statistics(_table(measured, noise), "SNOW")
        out.append(stats)
        assert stats["corr"].isna().all()
    # RMSE and bias are unaffected by the noise
    assert out[0]["rmse"].iloc[0] == pytest.approx(np.sqrt(np.mean(measured ** 2)))
    assert out[0]["bias"].iloc[0] == pytest.approx(np.mean(measured))


def test_a_replay_that_varies_keeps_its_pearson_correlation():
    rng = np.random.default_rng(3)
    replay = rng.normal(0.0, 0.3, 200)
    measured = 0.8 * replay + rng.normal(0.0, 0.1, 200)
    stats = residual_statistics(_table(measured, replay), "SNOW")
    expected = np.corrcoef(measured, replay)[0, 1]
    assert len(stats) == 3  # pooled, per run, per manoeuvre
    assert np.allclose(stats["corr"], expected)
    assert expected > 0.9


def test_the_tolerance_lies_far_below_sensor_resolution():
    # a replay varying by a micro-unit (1e-6 m/s^2, far below an IMU's 1e-3) still counts
    rng = np.random.default_rng(4)
    replay = 1e-6 * rng.normal(size=100)
    measured = replay * 1e5 + rng.normal(0.0, 0.01, 100)
    stats = residual_statistics(_table(measured, replay), "SNOW")
    assert CONSTANT_SPREAD_TOL < 1e-6
    assert stats["corr"].notna().all()


def test_the_raw_timestamp_replay_is_scored_against_the_gyro_on_raw_timestamps():
    rng = np.random.default_rng(5)
    replay = rng.normal(0.0, 0.3, 50)
    table = _table(replay + 0.1, replay).assign(signal="wz", replay_raw=replay,
                                                measured_raw=replay - 0.2)
    stats = residual_statistics(table, "SNOW").set_index(["model", "run_id", "manoeuvre"])
    assert stats.loc[("replay", "*", "all"), "bias"] == pytest.approx(0.1)
    assert stats.loc[("replay_raw", "*", "all"), "bias"] == pytest.approx(-0.2)
    assert stats.loc[("replay_raw", "*", "all"), "rmse"] == pytest.approx(0.2)


def test_measured_facts_of_synthetic_runs():
    from audit_helpers import synthetic_frame
    from terrain.audit.core import measured_facts

    from dataclasses import replace

    from terrain.vehicles.icr import icr_expansion_factor

    frames = [synthetic_frame(f"s/ASPHALT/{i}", seed=i, chi=1.5, offsets_a=(-0.3, 0.5),
                              noise=0.0) for i in range(2)]
    # spins scrub more than curves (chi 2.0): the pooled chi takes both kinds of turn
    frames = [replace(f, wz=np.where(f.manoeuvre == 3, f.commanded_yaw_rate / 2.0, f.wz))
              for f in frames]
    facts = measured_facts(frames)
    turn = [f.score_imu & np.isin(f.manoeuvre, (2, 3)) for f in frames]
    chi = icr_expansion_factor(np.concatenate([f.wz[k] for f, k in zip(frames, turn)]),
                               np.concatenate([f.commanded_yaw_rate[k]
                                               for f, k in zip(frames, turn)]))
    assert 1.5 < chi < 2.0 and facts["chi_pooled"] == pytest.approx(chi)
    m = np.concatenate([f.manoeuvre[f.score_cur] for f in frames])
    assert facts["n_straight"] == np.sum(m == 1) and facts["n_spin"] == np.sum(m == 3)
    # replay currents 2 + |x|, offsets -0.3 / +0.5 while moving: mean of sides +0.1
    assert facts["current_straight_a"] == pytest.approx(2.1)
    assert facts["current_spin_a"] == pytest.approx(2.9)
    assert facts["current_curve_a"] == pytest.approx(2.6)
    assert facts["spin_to_straight_current_ratio"] == pytest.approx(2.9 / 2.1)
    assert facts["straight_right_minus_left_a"] == pytest.approx(0.8)
    assert facts["runs"] == 2 and facts["runs_with_imu"] == 2
    assert facts["runs_with_identifiable_lag"] == 0 and facts["lag_min_s"] is None


@pytest.mark.slow
def test_runs_are_pooled_only_across_several_terrains():
    from dataclasses import replace

    from audit_helpers import synthetic_frame
    from terrain.audit import POOLED, AuditSettings, SelectionSettings, run_audit

    settings = AuditSettings(selection=SelectionSettings(n_bootstrap=50,
                                                         n_param_bootstrap=0))
    frames = [synthetic_frame(f"s/ASPHALT/{i}", seed=i) for i in range(4)]
    one = run_audit([], settings, frames=frames)
    assert {t for t, _ in one.groups} == {"ASPHALT"} and set(one.facts) == {"ASPHALT"}
    two = run_audit([], settings, frames=frames[:2] + [
        replace(f, terrain="SNOW", run_id=f"s/SNOW/{i}", group=f"s/SNOW/{i}")
        for i, f in enumerate(frames[2:])])
    assert {t for t, _ in two.groups} == {"ASPHALT", "SNOW", POOLED}
    assert two.facts[POOLED]["runs"] == 4


def test_the_turning_forms_are_compared_on_turning_samples():
    """The current group's ``turning_resistance`` details carry the held-out RMSE of each
    forced form on the turning samples (the effect's scope), not on every sample."""
    from audit_helpers import synthetic_frame
    from terrain.audit import AuditSettings, SelectionSettings, run_audit
    from terrain.audit.selection import loro, unit_errors

    frames = [synthetic_frame(f"s/ASPHALT/{i}", seed=i) for i in range(4)]
    result = run_audit([], AuditSettings(selection=SelectionSettings(
        n_bootstrap=50, n_param_bootstrap=0), pooled=False), frames=frames)
    details = result.effect("turning_resistance", "ASPHALT").details
    units = [[f] for f in frames]
    for form in ("coulomb", "proportional"):
        held = loro(units, "current", ["turning_resistance"], [], result.settings.effects,
                    form=form)
        s, n = unit_errors(units, "current", held, "turning")
        s_all, n_all = unit_errors(units, "current", held, "all")
        assert details[f"heldout_rmse_turning_{form}"] == pytest.approx(
            np.sqrt(s.sum() / n.sum()), rel=1e-12)
        assert np.sqrt(s_all.sum() / n_all.sum()) != pytest.approx(
            np.sqrt(s.sum() / n.sum()), rel=1e-3)


def test_two_samples_have_no_correlation():
    # any two distinct pairs lie on a line: their Pearson correlation is +-1 and says nothing
    two = residual_statistics(_table([0.1, 0.5], [0.2, 0.3]), "SNOW")
    assert two["corr"].isna().all() and (two["n"] == 2).all()
    three = residual_statistics(_table([0.1, 0.5, 0.2], [0.2, 0.3, 0.1]), "SNOW")
    assert np.isfinite(three["corr"]).all()


def test_the_pooled_chi_needs_more_than_ten_turning_samples():
    from dataclasses import replace

    from audit_helpers import synthetic_frame
    from terrain.audit.core import measured_facts

    frame = synthetic_frame("s/ASPHALT/0", chi=1.5, noise=0.0)
    turning = np.flatnonzero(frame.score_imu & np.isin(frame.manoeuvre, (2, 3)))
    straight = frame.score_imu & ~np.isin(frame.manoeuvre, (2, 3))
    for n, chi in ((10, None), (11, pytest.approx(1.5))):
        score = straight.copy()
        score[turning[:n]] = True
        assert measured_facts([replace(frame, score_imu=score)])["chi_pooled"] == chi


def test_the_lag_range_of_the_facts_spans_the_runs_with_an_identifiable_lag():
    from dataclasses import replace

    from audit_helpers import synthetic_frame
    from terrain.audit.core import measured_facts
    from terrain.audit.timing import LagTrack

    def lagged(i, lags):
        return replace(synthetic_frame(f"s/ASPHALT/{i}", seed=i), lag=LagTrack(
            np.arange(len(lags)) * 15.0 + 15.0, np.array(lags), np.ones(len(lags)), 3))
    frames = [lagged(0, [-0.2, 0.1]), lagged(1, [0.3, 0.05, 0.2]),
              synthetic_frame("s/ASPHALT/2", seed=2),                   # no identifiable lag
              replace(lagged(3, [5.0]), has_imu=False)]                 # no IMU: no lag
    facts = measured_facts(frames)
    assert facts["lag_min_s"] == pytest.approx(-0.2) and facts["lag_max_s"] == pytest.approx(0.3)
    assert facts["runs_with_identifiable_lag"] == 2 and facts["runs_with_imu"] == 3
    assert facts["runs"] == 4


def test_turning_forms_without_a_scored_turn_are_unknown_not_perfect():
    from dataclasses import replace

    from audit_helpers import synthetic_frame
    from terrain.audit import AuditSettings, SelectionSettings, run_audit

    frames = [synthetic_frame(f"s/ASPHALT/{i}", seed=i) for i in range(4)]
    frames = [replace(f, score_cur=f.score_cur & ~np.isin(f.manoeuvre, (2, 3)))
              for f in frames]
    result = run_audit([], AuditSettings(selection=SelectionSettings(
        n_bootstrap=50, n_param_bootstrap=0), pooled=False), frames=frames)
    details = result.effect("turning_resistance", "ASPHALT").details
    assert np.isnan(details["heldout_rmse_turning_coulomb"])
    assert np.isnan(details["heldout_rmse_turning_proportional"])


def test_a_spin_current_of_zero_gives_a_ratio_of_zero_not_none():
    """'spin / straight if spin and straight' read a mean spin current of exactly 0 A as
    missing (None); only a missing or zero straight current leaves the ratio undefined."""
    from dataclasses import replace

    from audit_helpers import synthetic_frame
    from terrain.audit.core import measured_facts

    frame = synthetic_frame("s/ASPHALT/0", chi=1.5, noise=0.0)
    spin = (frame.manoeuvre == 3)[:, None]
    facts = measured_facts([replace(frame, cur=np.where(spin, 0.0, frame.cur))])
    assert facts["current_spin_a"] == 0.0 and facts["current_straight_a"] > 0
    assert facts["spin_to_straight_current_ratio"] == 0.0
    straight = (frame.manoeuvre == 1)[:, None]
    facts = measured_facts([replace(frame, cur=np.where(straight, 0.0, frame.cur))])
    assert facts["spin_to_straight_current_ratio"] is None
