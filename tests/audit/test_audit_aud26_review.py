"""Numerical robustness and determinism of the audit (review aud26).

Part A: lag estimation and its drift on an epoch clock, against the same data near 0.
Part B: bootstrap intervals drawn from a seeded generator: the same table gives the same
interval, and one cell's interval does not depend on the other cells of the table.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings, strategies as st

from terrain.audit.physics import PhysicsComparisonSettings, gain_table
from terrain.audit.selection import bootstrap_gain
from terrain.audit.timing import LagSettings, LagTrack, best_lag, estimate_lag_track

EPOCH_S = 1.7e9
KEY = ["terrain", "signal", "scope"]


def _signal(t):
    return np.sin(0.7 * t) + 0.5 * np.sin(1.9 * t + 1.0)


@settings(max_examples=15, deadline=None)
@given(lag=st.floats(-0.5, 0.5), scale=st.floats(0.3, 2.0))
def test_a_lag_found_on_an_epoch_clock_is_the_one_found_near_zero(lag, scale):
    """The same wheel and gyro records stamped 1.7e9 s later give the same lag (the clock's
    last place there is 2.4e-7 s) and the planted one."""
    t = np.arange(0.0, 40.0, 0.1)
    ti = np.arange(-3.0, 43.0, 0.01)
    x = _signal(t)
    wz = scale * _signal(ti + lag)          # wheel sample at t describes the robot at t - lag
    near = best_lag(t, x, ti, wz)
    far = best_lag(t + EPOCH_S, x, ti + EPOCH_S, wz)
    assert near[0] == pytest.approx(lag, abs=2e-3)
    assert far[0] == pytest.approx(near[0], abs=1e-5)
    assert far[2] == pytest.approx(near[2], rel=1e-5)
    s = LagSettings(window_s=20.0, step_s=10.0)
    a = estimate_lag_track(t, x, ti, wz, s)
    b = estimate_lag_track(t + EPOCH_S, x, ti + EPOCH_S, wz, s)
    np.testing.assert_allclose(b.lags_s, a.lags_s, atol=1e-5)
    np.testing.assert_allclose(b.centres_s - EPOCH_S, a.centres_s, atol=1e-5)


def test_the_lag_drift_on_an_epoch_clock_is_the_plain_least_squares_slope():
    """The drift (a straight line through window centres 1.7e9 s from 0) is the centred
    least-squares slope, not a slope lost to the ill-conditioned uncentred fit."""
    c = np.arange(0.0, 600.0, 15.0)
    lags = 0.1 + 0.002 * c / 60.0 + 5e-4 * np.sin(c)
    cc = c - c.mean()
    want = float(np.sum(cc * (lags - lags.mean())) / np.sum(cc * cc) * 60.0)
    for t0 in (0.0, EPOCH_S):
        track = LagTrack(c + t0, lags, np.ones_like(c), len(c))
        assert track.drift_s_per_min() == pytest.approx(want, rel=1e-6)


def _per_run(seed=0):
    rng = np.random.default_rng(seed)
    return pd.DataFrame([
        {"run_id": f"x/{t}/{k:02d}", "terrain": t, "signal": s, "scope": "moving", "n": 100,
         "sse_ref": rng.uniform(1, 10), "sse_new": rng.uniform(1, 10)}
        for t in ("ASPHALT", "GRASS") for k in range(4) for s in ("wz", "cur")])


def test_the_physics_gain_table_is_the_same_in_two_calls_and_moves_with_its_seed():
    per_run = _per_run()
    s = PhysicsComparisonSettings(n_bootstrap=200, seed=5)
    pd.testing.assert_frame_equal(gain_table(per_run, s), gain_table(per_run, s))
    other = gain_table(per_run, PhysicsComparisonSettings(n_bootstrap=200, seed=6))
    assert not np.array_equal(other.gain_lo.to_numpy(), gain_table(per_run, s).gain_lo)
    np.testing.assert_array_equal(other.gain.to_numpy(), gain_table(per_run, s).gain)


def test_a_physics_gain_interval_does_not_depend_on_the_other_cells_of_the_table():
    per_run = _per_run()
    s = PhysicsComparisonSettings(n_bootstrap=200)
    want = gain_table(per_run, s).sort_values(KEY).reset_index(drop=True)
    # the same rows, each run's signals listed in the other order
    got = gain_table(per_run.iloc[::-1], s).sort_values(KEY).reset_index(drop=True)
    pd.testing.assert_frame_equal(got, want)
    alone = gain_table(per_run[per_run.signal == "cur"], s).sort_values(KEY)
    pd.testing.assert_frame_equal(alone.reset_index(drop=True),
                                  want[want.signal == "cur"].reset_index(drop=True))


def test_the_bootstrap_gain_is_the_same_for_generators_of_the_same_seed():
    rng = np.random.default_rng(0)
    ref, new, base = rng.uniform(1, 5, (3, 12))
    strata = np.repeat(["A", "B", "C"], 4)
    a = bootstrap_gain(ref, new, base, np.random.default_rng(7), 300, strata)
    b = bootstrap_gain(ref, new, base, np.random.default_rng(7), 300, strata)
    assert a == b
    c = bootstrap_gain(ref, new, base, np.random.default_rng(8), 300, strata)
    assert c[0] == a[0] and c[1] != a[1]


def _wheel_run(t0_s, duration_s=60.0, rate_hz=16.0):
    """A Husky run turning and speeding up and down, wheel stamps ``t0_s + k / 16`` s
    (exact in binary near 0 and at an epoch: the same relative clock at both)."""
    from terrain.run import Run

    t = np.arange(int(duration_s * rate_hz)) / rate_hz
    v = 0.8 + 0.4 * np.sin(0.31 * t)
    x = 0.9 * np.sin(0.53 * t) + 0.3 * np.sin(1.7 * t)
    half = 0.5 * 0.555 * x
    wheels = pd.DataFrame({"t_s": t0_s + t, "vel_l": v - half, "vel_r": v + half,
                           "cur_l": 5.0 + np.abs(x), "cur_r": 5.0 + np.abs(x)})
    return Run(run_id="x/ASPHALT/00", dataset="x", terrain="ASPHALT", streams={"wheels": wheels})


@pytest.mark.slow
def test_a_replay_on_an_epoch_clock_is_the_replay_near_zero():
    """The replay integrated on ``t0 + k dt`` rounded at the clock's magnitude: at 1.7e9 s
    the physics step (read from the grid's first two times) was 0.005 s +- 1.1e-7, so the
    simulated time ran 2.3e-5 off the wheel clock (82 ms per hour of run at 200 Hz), and
    the replay of the same record moved with the clock's origin (yaw rate 8e-5 rad/s,
    current 5e-4 A apart after 2 min). Stamps exact at both origins: the same replay."""
    from terrain.audit.replay import ReplaySettings, replay_run

    s = ReplaySettings(physics_rate_hz=200.0)
    near = replay_run(_wheel_run(0.0, duration_s=30.0), s)
    far = replay_run(_wheel_run(EPOCH_S, duration_s=30.0), s)
    np.testing.assert_allclose(far.yaw_rate, near.yaw_rate, rtol=0, atol=1e-9)
    np.testing.assert_allclose(far.cur, near.cur, rtol=0, atol=1e-9)
    np.testing.assert_allclose(far.ax, near.ax, rtol=0, atol=1e-9)
    np.testing.assert_allclose(far.v_x, near.v_x, rtol=0, atol=1e-9)


def test_a_parameter_interval_does_not_depend_on_the_number_of_gain_resamples():
    from audit_helpers import synthetic_frame
    from terrain.audit.selection import SelectionSettings, select_group

    units = [[synthetic_frame(f"s/ASPHALT/{i}", seed=i, bias_rad_s=0.01, chi=1.5,
                              noise=0.01)] for i in range(4)]

    def intervals(n_bootstrap):
        g = select_group(units, "yaw", "ASPHALT",
                         SelectionSettings(n_bootstrap=n_bootstrap, n_param_bootstrap=20))
        return {e.name: e.ci95 for e in g.effects}

    assert intervals(100) == intervals(200)


@pytest.mark.parametrize("signal", ["wz", "cur"])
def test_an_online_forecast_does_not_depend_on_the_clock_origin(signal):
    from dataclasses import replace

    from audit_helpers import synthetic_frame
    from terrain.audit.ceiling import online_current_samples, online_yaw_rate_samples

    frames = [synthetic_frame(f"s/ASPHALT/{i}", seed=i, chi=1.5, offsets_a=(1.0, 0.5))
              for i in range(2)]
    late = [replace(f, t_s=f.t_s + EPOCH_S, imu_t_s=f.imu_t_s + EPOCH_S) for f in frames]
    online = online_yaw_rate_samples if signal == "wz" else online_current_samples
    np.testing.assert_allclose(online(late, lead_s=0.7).online.to_numpy(),
                               online(frames, lead_s=0.7).online.to_numpy(), atol=1e-6)
