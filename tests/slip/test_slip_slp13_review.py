"""Review slp13: slip baselines and evaluation tables at their documented conventions."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from terrain.estimation.observer import AdaptiveObserverSettings, run_adaptive_observer
from terrain.slip.baselines import observer_slip


def test_observer_slip_is_left_then_right_and_the_faster_side_of_an_overstated_turn_slips():
    # right rims 1.0 m/s, left 0.4 m/s; the gyro turns as if the right side delivered 70 %
    # and the left 90 % of its rim speed (seed 000 eq. 3): a turn the wheels overstate, so
    # the yaw-only observer gives the faster (right) side the larger slip. Its columns are
    # 1 - eta_L, 1 - eta_R of the observer fed the right speeds as v_right (a swap of the
    # columns, or of the speeds in the call, gave the left side the right side's slip)
    d = 0.3
    t = np.arange(0.0, 20.0, 0.01)
    vl, vr = np.full_like(t, 0.4), np.full_like(t, 1.0)
    yaw = (0.7 * vr - 0.9 * vl) / (2 * d) * t
    slip = observer_slip(t, yaw, vl, vr, d)
    res = run_adaptive_observer(t, np.column_stack([np.full_like(t, np.nan),
                                                    np.full_like(t, np.nan), yaw]),
                                v_right_m_s=vr, v_left_m_s=vl,
                                settings=AdaptiveObserverSettings(half_track_m=d,
                                                                  use_position=False))
    np.testing.assert_allclose(slip, np.column_stack([1 - res.eta_left, 1 - res.eta_right]))
    assert slip[-1, 1] > slip[-1, 0] + 0.1
    # the converged slips reproduce the measured yaw rate (eq. 3 with eta = 1 - slip)
    w = (vr[-1] * (1 - slip[-1, 1]) - vl[-1] * (1 - slip[-1, 0])) / (2 * d)
    assert w == pytest.approx((0.7 * 1.0 - 0.9 * 0.4) / (2 * d), rel=1e-3)


def _straight_run(run_id, t, rim_m_s, truth_x):
    from terrain.run import Run
    streams = {"wheels": pd.DataFrame({"t_s": t, "vel_l": rim_m_s, "vel_r": rim_m_s}),
               "truth": pd.DataFrame({"t_s": t, "x": truth_x, "y": 0.0})}
    return Run(run_id, "sim", "ICE", streams)


def test_a_run_slid_off_only_past_three_times_its_wheel_path():
    # wheels 0.1 m/s for 10 s (a 1 m wheel path); the body slid 2.9 m (not yet) or 3.1 m
    # (SLID_OFF_FACTOR = 3: slid off, no wheel odometry follows it)
    from terrain.slip.evaluation import SLID_OFF_FACTOR, odometry_errors
    from terrain.vehicles.skid_steer import HUSKY
    assert SLID_OFF_FACTOR == 3.0
    t = np.linspace(0.0, 10.0, 101)
    meta = pd.DataFrame({"run_id": ["a", "b"], "t_start_s": [0.0, 0.0], "t_end_s": [10.0, 10.0]})
    runs = [_straight_run("a", t, 0.1, 0.29 * t), _straight_run("b", t, 0.1, 0.31 * t)]
    odo = odometry_errors(runs, meta, np.tile([0.0, 0.0, 1.0, 0.0], (2, 1)), HUSKY.track_m,
                          ["a", "b"])
    assert odo["slid_off"].tolist() == [False, True]
    # the plain odometry covers 1 m of the 2.9 m: 1.9 m short, 65.5 % of the path
    assert odo["plain_err_pct"].iloc[0] == pytest.approx(100 * 1.9 / 2.9)


@pytest.mark.parametrize("threshold", [np.nan, -0.1, np.inf, "0.1", True])
def test_turn_thresholds_that_are_not_a_finite_rate_are_refused(threshold):
    # a NaN threshold made every window "not turning": eq. 27 NaN on a turn of 0.5 rad/s
    # and measured_checks' turning windows none, without a word
    from terrain.errors import ConfigError
    from terrain.slip.baselines import endo_turning_slip
    from terrain.slip.evaluation import measured_checks
    with pytest.raises(ConfigError, match="min_turn_rad_s"):
        endo_turning_slip(np.array([0.2]), np.array([0.5]), np.array([0.5]), 0.5,
                          min_turn_rad_s=threshold)
    X = pd.DataFrame({"wz__mean": [0.5], "vel_diff__mean": [0.3], "cur_l__mean": [1.0],
                      "cur_r__mean": [1.0], "phys_slip_l": [0.0], "phys_slip_r": [0.0]})
    with pytest.raises(ConfigError, match="min_turn_rad_s"):
        measured_checks(X, np.array([[0.0, 0.0, 1.5, 0.0]]), np.array(["r"]),
                        np.array(["SNOW"]), 0.5, min_turn_rad_s=threshold)


def test_error_tables_without_a_window_to_score_keep_their_columns():
    # no steady straight window among the held-out runs (short runs): the tables had no
    # column at all, so t["median_abs_err"] was a bare KeyError
    from terrain.slip.evaluation import error_table, std_calibration_table
    meta = pd.DataFrame({"terrain": ["SNOW", "ICE"], "scenario": ["orchard", "random"],
                         "run_id": ["r1", "r2"]})
    none = np.zeros(2, bool)
    err = error_table(np.zeros((2, 2)), np.ones((2, 2)), meta, none)
    assert len(err) == 0
    assert err.columns.tolist() == ["terrain", "median_abs_err", "p90_abs_err", "n_windows",
                                    "n_scored", "n_runs"]
    cal = std_calibration_table(np.zeros((2, 2)), np.ones((2, 2)), np.ones((2, 2)), meta,
                                none, ("scenario",))
    assert len(cal) == 0
    assert cal.columns.tolist() == ["scenario", "n_windows", "n_scored", "coverage_1std",
                                    "coverage_2std", "median_normalised_sq",
                                    "mean_normalised_sq", "median_std", "median_abs_err"]
    # with windows the same columns, in the same order
    some = np.ones(2, bool)
    assert error_table(np.zeros((2, 2)), np.ones((2, 2)), meta, some).columns.tolist() == \
        err.columns.tolist()
    assert std_calibration_table(np.zeros((2, 2)), np.ones((2, 2)), np.ones((2, 2)), meta,
                                 some, ("scenario",)).columns.tolist() == cal.columns.tolist()


@pytest.mark.parametrize("mask", [np.array([1, 0, 1]), np.array([0, 2]),
                                  np.array([True, False]), [True, False, True]])
def test_window_masks_that_are_not_one_boolean_per_window_are_refused(mask):
    # an integer 0/1 mask was read by meta.loc as row labels: error_table scored window B
    # twice and A once instead of A and C; std_calibration_table took [0, 2] as a mask
    # (window B only) and baseline_predictions fancy-indexed its training windows
    from terrain.errors import ShapeError
    from terrain.slip.evaluation import baseline_predictions, error_table, std_calibration_table
    meta = pd.DataFrame({"terrain": ["A", "B", "C"], "run_id": ["r1", "r2", "r3"],
                         "scenario": ["x", "y", "z"], "t_start_s": 0.0, "t_end_s": 2.0})
    pred, truth = np.zeros((3, 2)), np.array([[0.1, 0.1], [0.2, 0.2], [0.3, 0.3]])
    if isinstance(mask, list):      # a list of one boolean per window is one
        assert error_table(pred, truth, meta, mask)["terrain"].tolist() == ["A", "C"]
        return
    with pytest.raises(ShapeError, match="error_table: mask must be a boolean mask"):
        error_table(pred, truth, meta, mask)
    with pytest.raises(ShapeError, match="std_calibration_table: mask must be a boolean"):
        std_calibration_table(pred, np.ones((3, 2)), truth, meta, mask)
    X = pd.DataFrame({"pitch": 0.0, "vel_l__mean": 0.5, "vel_r__mean": 0.5, "wz__mean": 0.0,
                      "phys_slip_l": 0.0, "phys_slip_r": 0.0}, index=range(3))
    with pytest.raises(ShapeError, match="baseline_predictions: train must be a boolean"):
        baseline_predictions(X, truth, meta, mask, [], 0.5)


def test_a_boolean_mask_scores_the_windows_it_selects():
    from terrain.slip.evaluation import error_table, std_calibration_table
    meta = pd.DataFrame({"terrain": ["A", "B", "C"], "run_id": ["r1", "r2", "r3"],
                         "scenario": ["x", "y", "z"]})
    pred, truth = np.zeros((3, 2)), np.array([[0.1, 0.1], [0.2, 0.2], [0.3, 0.3]])
    mask = np.array([True, False, True])
    err = error_table(pred, truth, meta, mask)
    assert err["terrain"].tolist() == ["A", "C"]
    np.testing.assert_allclose(err["median_abs_err"], [0.1, 0.3])
    cal = std_calibration_table(pred, np.full((3, 2), 0.2), truth, meta, mask, ("terrain",))
    assert cal["terrain"].tolist() == ["A", "C"]
    np.testing.assert_allclose(cal["coverage_1std"], [1.0, 0.0])


def test_lag_notes_say_only_a_lag_that_was_not_applied():
    # an applied lag got the "not applied (no lag)" note too when the check read only None
    from terrain.run import Run
    from terrain.slip.alignment import LagEstimate
    from terrain.slip.estimate import lag_notes
    run = Run("sim/ASPHALT/0", "sim", "ASPHALT",
              {"wheels": pd.DataFrame({"t_s": [0.0, 1.0], "vel_l": 0.0, "vel_r": 0.0})})
    assert lag_notes(run, None) == ()
    assert lag_notes(run, LagEstimate(0.37, 0.8, 500)) == ()
    (note,) = lag_notes(run, LagEstimate(-0.665, 0.12, 500, applied=False,
                                         reason="peak correlation 0.120 below 0.3"))
    assert "sim/ASPHALT/0" in note and "not applied" in note and "-0.665 s" in note
    assert "peak correlation 0.120 below 0.3" in note


@pytest.mark.parametrize("track", [0.0, np.nan, -0.5, np.inf, True])
def test_measured_checks_refuse_a_track_that_is_not_a_finite_width(track):
    # the wheel yaw rate divides by the track: 0 gave an infinite yaw RMS, NaN a NaN one and
    # -0.5 turned the wheels' yaw rate the other way (RMS 1.1 and 0.8 instead of 0.1 and
    # 0.2), all without a word
    from terrain.errors import ConfigError
    from terrain.slip.evaluation import measured_checks
    X = pd.DataFrame({"wz__mean": [0.5], "vel_diff__mean": [0.3], "cur_l__mean": [1.0],
                      "cur_r__mean": [1.0], "phys_slip_l": [0.0], "phys_slip_r": [0.0]})
    pred = np.array([[0.0, 0.0, 2.0, 0.0]])
    row = measured_checks(X, pred, np.array(["r"]), np.array(["SNOW"]), 0.5).iloc[0]
    assert row["yaw_rms_plain_rad_s"] == pytest.approx(abs(0.5 - 0.3 / 0.5))
    assert row["yaw_rms_compensated_rad_s"] == pytest.approx(abs(0.5 - 0.3 / (2.0 * 0.5)))
    with pytest.raises(ConfigError, match="measured_checks.track_m"):
        measured_checks(X, pred, np.array(["r"]), np.array(["SNOW"]), track)


@pytest.mark.parametrize("folds", [0, 1, 3])
def test_slip_model_refuses_groups_of_another_length_before_fitting(folds, monkeypatch):
    # with calibration_folds < 2 a groups of 7 entries for 60 windows was taken without a
    # word (the documented ShapeError came only with a calibration, after the four fits)
    from terrain.errors import ShapeError
    from terrain.slip import learned
    rng = np.random.default_rng(0)
    X, y = rng.random((60, 3)), rng.random((60, 4))
    monkeypatch.setattr(learned.SlipRegressor, "_tree",
                        lambda self: pytest.fail("a model was fitted before the check"))
    with pytest.raises(ShapeError, match="groups has 7 entries for 60 windows"):
        learned.SlipRegressor(max_iter=2, calibration_folds=folds).fit(X, y,
                                                                       groups=np.arange(7))


@pytest.mark.parametrize("floor", [0.0, 0.02])
def test_an_infinite_speed_gives_no_slip_as_a_nan_one_does(floor):
    # inf / inf: a corrupt sample has no slip, not a saturated +-1 or a dead-band 0
    from terrain.slip.core import sae_slip, wheel_slip
    s = sae_slip(np.array([np.inf, 1.0, -np.inf, 0.01, np.nan]),
                 np.array([1.0, np.inf, 0.0, np.inf, 0.0]), speed_floor_m_s=floor)
    assert np.isnan(s).all()
    w = wheel_slip(np.array([[np.inf, 1.0]]), np.array([1.0]), np.array([0.0]),
                   np.array([0.0]), np.array([[0.0, 0.3], [0.0, -0.3]]))
    assert np.isnan(w[0, 0]) and w[0, 1] == 0.0


def test_a_lag_that_could_not_be_estimated_says_why():
    """``--lag xcorr`` on a run without a reference stream, or one whose estimate fails,
    used to print "encoder lag not estimated" and nothing else; the reason now reaches the
    summary and a note."""
    from types import SimpleNamespace

    from terrain.slip.estimate import lag_notes, skid_steer_encoder_lag

    t = np.arange(10) / 6.5
    wheels = pd.DataFrame({"t_s": t, "vel_l": np.ones(10), "vel_r": np.ones(10)})
    run = SimpleNamespace(run_id="r/SNOW/00", streams={"wheels": wheels})
    est = skid_steer_encoder_lag(run, 0.555)
    assert not est.estimated and not est.applied
    assert est.reason == "no imu stream (gyro yaw rate against wheel yaw rate)"
    assert lag_notes(run, est) == (
        "note: encoder lag of run r/SNOW/00 not estimated (no lag applied): no imu stream "
        "(gyro yaw rate against wheel yaw rate)",)
    imu = pd.DataFrame({"t_s": t, "wz": np.zeros(10)})
    run = SimpleNamespace(run_id="r/SNOW/00", streams={"wheels": wheels, "imu": imu})
    est = skid_steer_encoder_lag(run, 0.555)
    assert not est.estimated
    assert est.reason == "fewer than 20 finite samples in ref (10 of 10 with a finite t_ref_s)"
