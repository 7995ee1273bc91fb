"""Review tests of the audit (aud18): settings given as one value where a sequence is
expected, and properties of its pure helpers."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from terrain.audit import AuditSettings
from terrain.audit.effects import EffectSettings
from terrain.errors import ConfigError


@pytest.mark.parametrize("factors", [1.5, "1.5", None])
def test_sweep_factors_given_as_one_value_are_refused_naming_the_field(factors):
    # AuditSettings(sweep_factors=1.5) was a bare "TypeError: 'float' object is not
    # iterable", and the text "1.5" was read letter by letter ("factors[0] ... got str '1'")
    with pytest.raises(ConfigError, match=r"AuditSettings\.sweep_factors.*sequence"):
        AuditSettings(sweep_factors=factors)
    assert AuditSettings(sweep_factors=[0.5, 1.0]).sweep_factors == [0.5, 1.0]
    assert AuditSettings(sweep_factors=()).sweep_factors == ()


@pytest.mark.parametrize("factors", [(1.0, 1.0), (0.5, 2.0, 0.5)])
def test_a_sweep_factor_given_twice_is_refused(factors):
    # (1.0, 1.0) replayed the same friction twice: two identical rows of the what-if table
    with pytest.raises(ConfigError, match=r"AuditSettings\.sweep_factors: factor\(s\) "
                                          r"\[(1\.0|0\.5)\] given twice"):
        AuditSettings(sweep_factors=factors)


def test_the_sweep_refuses_one_factor_given_as_a_number():
    from terrain.audit.core import lateral_friction_sweep

    with pytest.raises(ConfigError, match=r"lateral_friction_sweep: the factors must be a seq"):
        lateral_friction_sweep([], "ASPHALT", 1.5)


@pytest.mark.parametrize("kwargs, field", [
    ({"threshold_quantiles": 0.5}, "threshold_quantiles"),
    ({"threshold_quantiles": "0.5"}, "threshold_quantiles"),
    ({"threshold_quantiles": (0.5, "0.3")}, r"threshold_quantiles\[1\]"),
    ({"threshold_quantiles": (0.5, True)}, r"threshold_quantiles\[1\]"),
    ({"negligible": 0.1}, "negligible"),
])
def test_effect_settings_refuse_a_sequence_setting_given_as_one_value(kwargs, field):
    # threshold_quantiles=0.5 and negligible=0.1 were bare "TypeError: 'float' object is not
    # iterable"; a quantile given as text ("0.3") passed float(q) and failed in the first
    # rate-dependent fit as numpy's "'<=' not supported between 'float' and 'numpy.str_'"
    with pytest.raises(ConfigError, match=rf"EffectSettings\.{field}"):
        EffectSettings(**kwargs)
    assert EffectSettings(threshold_quantiles=[0.25, 0.75]).threshold_quantiles == [0.25, 0.75]


def test_an_immobile_ratio_above_one_is_refused():
    # a turning sample is immobile when the gyro shows less than immobile_ratio of the
    # mobile yaw rate: above 1 every mobile turn would count as dug in
    with pytest.raises(ConfigError, match=r"immobile_ratio must be <= 1"):
        EffectSettings(immobile_ratio=1.5)
    assert EffectSettings(immobile_ratio=1.0).immobile_ratio == 1.0


def test_a_stretch_of_fewer_than_eight_usable_samples_gives_no_lag():
    from terrain.audit.timing import LagSettings, best_lag

    s = LagSettings(max_lag_s=0.5, lag_step_s=0.05)
    t_imu = np.arange(0.0, 20.0, 0.01)
    wz = np.sin(t_imu)
    for n, usable in ((7, False), (8, True)):
        t = 5.0 + np.arange(n) * 0.5
        lag, r2, slope = best_lag(t, np.sin(t), t_imu, wz, s)
        assert np.isfinite(lag) == usable
        if usable:
            assert abs(lag) < 0.03 and slope > 0


def test_two_speed_magnitudes_are_too_few_to_call_a_record_quantised():
    from terrain.audit.replay import speed_resolution

    step = 0.2 / 25.4
    assert speed_resolution(np.array([step, 2 * step, -step])) == 0.0
    assert speed_resolution(np.array([step, 2 * step, 3 * step])) == pytest.approx(step, rel=1e-5)


# ---------------------------------------------------------------------------------------
# properties of pure helpers

@settings(max_examples=40, deadline=None)
@given(lag=st.floats(-1.2, 1.2), chi=st.floats(1.0, 3.0), bias=st.floats(-0.05, 0.05),
       f1=st.floats(0.05, 0.3), df=st.floats(0.03, 0.2), phase=st.floats(0.0, 6.28))
def test_a_planted_lag_is_found_with_its_sign_whatever_chi_and_bias(lag, chi, bias, f1, df,
                                                                    phase):
    # wheel data stamped t show the command at t - lag (positive: wheel data late); the gyro
    # sees x / chi + bias. The lag is free of scale and offset (module docstring)
    from terrain.audit.timing import best_lag

    def x_true(t):
        # two tones of distinct frequencies: the command moves (std >= 0.2 rad/s)
        return 0.3 * np.sin(2 * np.pi * f1 * t) + 0.2 * np.sin(2 * np.pi * (f1 + df) * t + phase)
    t_imu = np.arange(0.0, 60.0, 0.01)
    t_w = np.arange(5.0, 55.0, 1.0 / 6.5)
    found, r2, slope = best_lag(t_w, x_true(t_w - lag), t_imu, x_true(t_imu) / chi + bias)
    assert found == pytest.approx(lag, abs=0.005)     # a quarter of the 0.02 s grid step
    assert r2 > 0.99 and slope == pytest.approx(1.0 / chi, rel=0.02)


@settings(max_examples=30, deadline=None)
@given(data=st.data(), n=st.integers(1, 12), lead=st.floats(0.0, 3.0),
       memory=st.floats(0.5, 20.0))
def test_the_forgetting_sums_are_the_sums_they_define(data, n, lead, memory):
    # sum_j term[j] exp(-(t_k - lead - t_j) / memory) over the samples j of sample k's
    # manoeuvre code with t_j <= t_k - lead within the clock's rounding (0 where none): the
    # O(n^2) definition. (Without the rounding, lead 4.4e-15 s on t = 1, 2 s told the two
    # apart where the function, by design, takes a sample exactly lead earlier)
    from terrain.audit.ceiling import _forgetting_sums
    from terrain.run import clock_slack

    steps = data.draw(st.lists(st.floats(0.05, 2.0), min_size=n, max_size=n))
    t = np.cumsum(steps)
    code = np.array(data.draw(st.lists(st.integers(0, 2), min_size=n, max_size=n)))
    term = np.array(data.draw(st.lists(st.floats(-5.0, 5.0), min_size=n, max_size=n)))
    (got,) = _forgetting_sums(t, code, (term,), lead, memory)
    want = np.zeros(n)
    for k in range(n):
        for j in range(n):
            if code[j] == code[k] and t[j] <= t[k] - lead + clock_slack(t[k]):
                want[k] += term[j] * np.exp(-(t[k] - lead - t[j]) / memory)
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-9)


@settings(max_examples=30, deadline=None)
@given(data=st.data(), n=st.integers(2, 10), scale=st.floats(0.01, 100.0),
       seed=st.integers(0, 2 ** 32 - 1))
def test_the_gain_and_its_interval_do_not_depend_on_the_error_unit(data, n, scale, seed):
    # squared errors in other units (A^2 against mA^2) scale every sum alike: the gain is a
    # fraction of the baseline RMSE, so neither it nor its interval moves; no gain without a
    # change
    from terrain.audit.selection import bootstrap_gain

    pos = st.floats(0.0, 100.0)
    ref = np.array(data.draw(st.lists(pos, min_size=n, max_size=n)))
    new = np.array(data.draw(st.lists(pos, min_size=n, max_size=n)))
    base = ref + 1.0
    g, ci = bootstrap_gain(ref, new, base, np.random.default_rng(seed), 50)
    gs, cis = bootstrap_gain(ref * scale, new * scale, base * scale,
                             np.random.default_rng(seed), 50)
    assert gs == pytest.approx(g, rel=1e-9, abs=1e-12)
    np.testing.assert_allclose(cis, ci, rtol=1e-9, atol=1e-12)
    zero, zero_ci = bootstrap_gain(ref, ref, base, np.random.default_rng(seed), 50)
    assert zero == 0.0 and zero_ci == [0.0, 0.0]


@settings(max_examples=30, deadline=None)
@given(data=st.data(), n=st.integers(1, 40), track=st.floats(0.3, 1.0))
def test_a_mirrored_drive_has_the_same_manoeuvres(data, n, track):
    # swapping the sides negates the commanded yaw rate and keeps the speed: a left turn is
    # classified as the right turn it mirrors
    from terrain.audit.frames import classify_manoeuvres

    speed = st.floats(-1.5, 1.5)
    vl = np.array(data.draw(st.lists(speed, min_size=n, max_size=n)))
    vr = np.array(data.draw(st.lists(speed, min_size=n, max_size=n)))
    v, x = 0.5 * (vl + vr), (vr - vl) / track
    np.testing.assert_array_equal(classify_manoeuvres(x, v, vl, vr, track),
                                  classify_manoeuvres(-x, v, vr, vl, track))


@pytest.mark.slow
@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 10_000), perm_seed=st.integers(0, 10_000))
def test_the_residual_statistics_do_not_depend_on_row_order(seed, perm_seed):
    from terrain.audit.core import residual_statistics

    rng = np.random.default_rng(seed)
    n = 60
    samples = pd.DataFrame({
        "run_id": rng.choice(["a", "b", "c"], n), "terrain": "ASPHALT",
        "manoeuvre": rng.choice(["straight", "curve", "spin"], n),
        "signal": rng.choice(["wz", "cur_l"], n), "measured": rng.normal(size=n),
        "replay": rng.normal(size=n), "extended": rng.normal(size=n)})
    shuffled = samples.sample(frac=1.0, random_state=perm_seed).reset_index(drop=True)
    key = ["signal", "model", "run_id", "manoeuvre"]
    a = residual_statistics(samples, "ASPHALT").sort_values(key).reset_index(drop=True)
    b = residual_statistics(shuffled, "ASPHALT").sort_values(key).reset_index(drop=True)
    pd.testing.assert_frame_equal(a, b, rtol=1e-9)


def test_a_missing_measurement_is_left_out_of_the_statistics_not_counted():
    from terrain.audit.core import residual_statistics

    samples = pd.DataFrame({"run_id": "a", "terrain": "ASPHALT", "manoeuvre": "curve",
                            "signal": "wz", "measured": [1.0, np.nan, 3.0, 5.0],
                            "replay": [0.0, 0.0, 2.0, 4.0]})
    row = residual_statistics(samples, "ASPHALT").iloc[0]
    assert row["n"] == 3 and row["rmse"] == 1.0 and row["bias"] == 1.0


def test_immobilised_on_the_replays_mobile_model_is_not_judged_by_the_replays_chi():
    # chi_mobile < 1 is a wheel radius, track width or gyro scale error only when the mobile
    # model is the kinematic one fitted to the gyro; with the replay as the mobile model the
    # chi is the simulator's own, which the immobilised fit did not choose
    from terrain.audit.effects import YawParams
    from terrain.audit.selection import unphysical

    replayed = YawParams(kinematic=False, inverse_chi=1.25, immobilised=True, fraction=0.3,
                         chi_replay=0.95)
    assert replayed.chi == 0.95 and unphysical("immobilised", replayed) is None
    kinematic = YawParams(kinematic=True, inverse_chi=1.25, immobilised=True, fraction=0.3,
                          chi_replay=1.3)
    assert "mobile chi = 0.8 < 1" in unphysical("immobilised", kinematic)


def test_the_physics_gain_interval_does_not_depend_on_the_order_of_the_runs():
    # the run-bootstrap drew row positions, so the same runs listed in another order
    # (another folder listing, a caller's own list) got another interval: reversed, the
    # interval of 6 asphalt runs moved from [-0.143, 0.342] to [-0.180, 0.319]
    from terrain.audit.physics import PhysicsComparisonSettings, gain_table

    rng = np.random.default_rng(0)
    per_run = pd.DataFrame([
        {"run_id": f"x/{t}/{k:02d}", "terrain": t, "signal": s, "scope": "moving", "n": 100,
         "sse_ref": rng.uniform(1, 10), "sse_new": rng.uniform(1, 10)}
        for t in ("ASPHALT", "GRASS") for k in range(4) for s in ("wz", "cur")])
    settings = PhysicsComparisonSettings(n_bootstrap=200)
    want = gain_table(per_run, settings)
    runs = per_run.run_id.unique()
    for seed in range(3):    # the runs in another order, each run's rows as per_run_errors
        order = np.random.default_rng(seed).permutation(runs)
        shuffled = pd.concat([per_run[per_run.run_id == r] for r in order], ignore_index=True)
        got = gain_table(shuffled, settings)
        key = ["terrain", "signal", "scope"]
        pd.testing.assert_frame_equal(got.sort_values(key).reset_index(drop=True),
                                      want.sort_values(key).reset_index(drop=True))


@pytest.mark.parametrize("which", ["best_lag", "estimate_lag_track"])
@pytest.mark.parametrize("n, m, nx, field", [
    (0, 50, 0, "t_s"), (50, 0, 50, "t_imu_s"), (50, 50, 49, "x"), (50, 50, 50, "wz")])
def test_the_lag_refuses_empty_or_mismatched_series_naming_them(which, n, m, nx, field):
    # an empty wheel or IMU record was numpy's bare "IndexError: index 0 is out of bounds
    # for axis 0 with size 0", x one sample short a boolean-index IndexError
    from terrain.audit import timing
    from terrain.errors import DataFormatError

    t = np.arange(n) * 0.15
    t_imu = np.arange(m) * 0.01
    wz = np.zeros(m - 1 if field == "wz" else m)
    if which == "best_lag" and field == "t_s":
        # a window inside a timestamp gap holds no wheel sample: not usable, no error
        assert np.isnan(timing.best_lag(t, np.zeros(nx), t_imu, wz)).all()
        return
    with pytest.raises(DataFormatError, match=rf"{which}: {field}"):
        getattr(timing, which)(t, np.zeros(nx), t_imu, wz)


def test_a_window_inside_a_long_gap_is_examined_and_not_used():
    from terrain.audit.timing import LagSettings, estimate_lag_track

    s = LagSettings(window_s=10.0, step_s=5.0, max_lag_s=0.5, lag_step_s=0.05)
    t = np.r_[np.arange(0.0, 30.0, 0.15), np.arange(60.0, 90.0, 0.15)]   # 30 s gap
    t_imu = np.arange(0.0, 90.0, 0.01)
    track = estimate_lag_track(t, np.sin(0.7 * t), t_imu, np.sin(0.7 * t_imu), s)
    assert track.n_windows > len(track.lags_s) and np.all(np.abs(track.lags_s) < 0.03)
