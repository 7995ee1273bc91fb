"""Second review of the slip evaluation and baselines: per-terrain checks, groups without
training data, half-open windows, window order, the eq. 22 pitch-span rule."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from terrain.run import Run
from terrain.slip.baselines import fit_pitch_slip, observer_slip, slip_ratio_as_sae
from terrain.slip.evaluation import (leave_one_out, measured_checks, observer_window_slip,
                                     odometry_errors)
from terrain.slip.odometry import dead_reckon
from terrain.vehicles import HUSKY


class _Mean:
    """Predicts the mean target of the rows it was fitted on."""

    def fit(self, X, Y):
        self.mean = np.asarray(Y).mean(axis=0)
        return self

    def predict(self, X):
        return np.tile(self.mean, (len(X), 1))


def test_measured_checks_compare_learned_and_physics_slip_within_each_terrain():
    # learned - physics is 0.01 on every SNOW window and 0.3 on every ICE one: each terrain's
    # median is its own, not the median over both terrains' straight windows
    phys = np.array([0.1, 0.2, 0.3, 0.4, 0.1, 0.2, 0.3, 0.4])
    learned = phys + np.array([0.01] * 4 + [0.3] * 4)
    cur = np.array([1.0, 2.0, 3.0, 4.0, 4.0, 3.0, 2.0, 1.0])
    X = pd.DataFrame({"wz__mean": np.zeros(8), "vel_diff__mean": np.zeros(8),
                      "cur_l__mean": cur, "cur_r__mean": cur,
                      "phys_slip_l": phys, "phys_slip_r": phys})
    pred = np.column_stack([learned, learned, np.ones(8), np.zeros(8)])
    out = measured_checks(X, pred, np.array(["a"] * 4 + ["b"] * 4),
                          np.array(["SNOW"] * 4 + ["ICE"] * 4), HUSKY.track_m)
    out = out.set_index("terrain")
    assert out.loc["SNOW", "median_learned_minus_physics"] == pytest.approx(0.01)
    assert out.loc["ICE", "median_learned_minus_physics"] == pytest.approx(0.3)
    assert out.loc["SNOW", "spearman_slip_current"] == pytest.approx(1.0)
    assert out.loc["ICE", "spearman_slip_current"] == pytest.approx(-1.0)


def test_leave_one_out_leaves_a_group_without_training_data_elsewhere_unpredicted():
    # group "b" has no training window; group "a"'s training windows are all in "a": when "a"
    # is held out nothing is left to fit on, so its test windows stay NaN (documented), and
    # "b" is predicted from "a"'s training windows
    X = pd.DataFrame({"i": np.arange(6, dtype=float)})
    Y = np.arange(12, dtype=float).reshape(6, 2)
    groups = np.array(["a", "a", "a", "b", "b", "b"])
    train = np.array([1, 1, 0, 0, 0, 0], bool)
    out = leave_one_out(_Mean, X, Y, groups, train, ~train)
    assert np.isnan(out[:3]).all()
    np.testing.assert_allclose(out[3:], np.tile(Y[:2].mean(axis=0), (3, 1)))


def test_observer_window_mean_is_over_the_half_open_window():
    # windows are [t_start, t_end): t_end is the last sample's time plus one period
    # (features.windows), so the sample at t_end belongs to the next window
    t = np.arange(0.0, 4.0, 0.1)
    wz = np.where(t < 1.0, 0.0, 0.6)
    vl, vr = np.full_like(t, 0.4), np.full_like(t, 0.7)
    run = Run("sim/X/orchard/0", "sim", "ASPHALT",
              {"imu": pd.DataFrame({"t_s": t, "wz": wz}),
               "wheels": pd.DataFrame({"t_s": t, "vel_l": vl, "vel_r": vr})})
    meta = pd.DataFrame({"run_id": [run.run_id] * 4, "t_start_s": t[[5, 10, 15, 20]],
                         "t_end_s": t[[10, 15, 20, 25]]})
    out = observer_window_slip([run], meta, HUSKY.track_m)
    yaw = np.concatenate([[0.0], np.cumsum(np.diff(t) * wz[:-1])])
    s = slip_ratio_as_sae(np.column_stack([vl, vr]),
                          observer_slip(t, yaw, vl, vr, 0.5 * HUSKY.track_m))
    expected = np.array([s[5 * k + 5:5 * k + 10].mean(axis=0) for k in range(4)])
    assert np.ptp(s[5:25], axis=0).max() > 1e-3      # the slip changes: the test can tell
    np.testing.assert_allclose(out, expected, rtol=1e-12, atol=1e-12)


def test_odometry_errors_do_not_depend_on_the_order_of_the_windows():
    t = np.arange(0.0, 12.0, 0.05)
    vl, vr = np.full_like(t, 0.5), np.full_like(t, 1.0)
    starts = np.arange(0.0, 10.0, 2.0)
    s_left = np.array([0.3, 0.05, 0.4, 0.35, 0.1])
    s_right = np.array([0.05, 0.25, 0.0, 0.1, 0.2])
    truth = dead_reckon(t, vl, vr, HUSKY.track_m, np.interp(t, starts + 1.0, s_left),
                        np.interp(t, starts + 1.0, s_right))
    run = Run("sim/SNOW/turn/0", "sim", "SNOW",
              {"wheels": pd.DataFrame({"t_s": t, "vel_l": vl, "vel_r": vr}),
               "truth": pd.DataFrame({"t_s": t, "x": truth[:, 0], "y": truth[:, 1]})})
    meta = pd.DataFrame({"run_id": run.run_id, "t_start_s": starts, "t_end_s": starts + 2.0})
    pred = np.column_stack([s_left, s_right, np.ones(5), np.zeros(5)])
    order = np.array([3, 0, 4, 1, 2])
    row = odometry_errors([run], meta.iloc[order].reset_index(drop=True), pred[order],
                          HUSKY.track_m, [run.run_id]).iloc[0]
    assert row["compensated_err_pct"] < 1e-9
    assert row["plain_err_pct"] > 1.0


def test_pitch_line_is_fitted_from_a_span_of_exactly_one_hundredth():
    # "less than 0.01 rad of pitch" gets b = 0; a span of exactly 0.01 is fitted
    coef = fit_pitch_slip(np.array([0.0, 0.005, 0.01]), np.array([0.1, 0.105, 0.11]),
                          ["SNOW"] * 3)
    a, b = coef["SNOW"]
    assert a == pytest.approx(0.1) and b == pytest.approx(1.0)
