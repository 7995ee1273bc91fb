"""Review fixslip of the measured checks: windows whose gyro yaw rate lies between the
straight threshold (0.05 rad/s) and the turning one (``min_turn_rad_s``) are in neither
group; they are counted and said, as the windows without a yaw rate are, the figures
unchanged."""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pytest

from terrain.errors import DataWarning
from terrain.slip.evaluation import measured_checks

TRACK_M = 0.5


def _inputs(wz):
    wz = np.asarray(wz, dtype=float)
    n = wz.size
    rise = np.arange(n, dtype=float)
    X = pd.DataFrame({"wz__mean": wz, "vel_diff__mean": 0.8 * wz * TRACK_M,
                      "cur_l__mean": rise, "cur_r__mean": rise,
                      "phys_slip_l": 0.01 * rise, "phys_slip_r": 0.0})
    pred = np.column_stack([0.02 * rise, 0.01 * rise, np.full(n, 1.25), np.zeros(n)])
    return X, pred, np.array([f"r{i % 3}" for i in range(n)]), np.array(["SNOW"] * n)


WZ = [0.0, 0.01, -0.02, 0.03, 0.07, -0.08, 0.2, -0.3, 0.05, np.nextafter(0.1, 0.0), 0.1]


def test_windows_between_the_straight_and_the_turning_threshold_are_counted_and_said():
    X, pred, runs, terr = _inputs(WZ)
    with pytest.warns(DataWarning,
                      match=r"measured_checks: 4 of 11 windows have a gyro yaw rate between the "
                            r"straight \(\|wz__mean\| < 0.05 rad/s\) and the turning \(>= 0.1 "
                            r"rad/s\) thresholds and are left out of the turning and the "
                            r"straight windows \(windows 4, 5, 8 and 1 more\)"):
        out = measured_checks(X, pred, runs, terr, TRACK_M)
    row = out.iloc[0]
    assert row["n_turning_windows"] == 3            # 0.2, -0.3, 0.1
    # the figures: over the turning windows and the four straight ones only
    turn = np.array([0.2, -0.3, 0.1])
    assert row["yaw_rms_plain_rad_s"] == pytest.approx(np.sqrt(np.mean((0.2 * turn) ** 2)))
    rise = np.arange(11.0)
    straight = np.array([0, 1, 2, 3])
    learned = (0.015 * rise)[straight]
    assert row["median_learned_minus_physics"] == pytest.approx(
        np.median(np.abs(learned - 0.005 * rise[straight])))


def test_the_count_is_apart_from_the_windows_without_a_yaw_rate():
    X, pred, runs, terr = _inputs([0.0, np.nan, 0.07, 0.3])
    with pytest.warns(DataWarning) as record:
        measured_checks(X, pred, runs, terr, TRACK_M)
    said = [str(w.message) for w in record]
    assert any("1 of 4 windows have no gyro yaw rate" in m for m in said)
    assert any("1 of 4 windows have a gyro yaw rate between" in m and "(window 2)" in m
               for m in said)


@pytest.mark.parametrize("min_turn", [0.05, 0.02])
def test_no_window_is_between_when_the_thresholds_meet(min_turn):
    X, pred, runs, terr = _inputs([0.0, 0.04, 0.07, 0.3])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        measured_checks(X, pred, runs, terr, TRACK_M, min_turn_rad_s=min_turn)


def test_the_figures_are_those_of_the_windows_in_a_group():
    """Leaving the in-between windows out (the table computed without them) gives the same
    table: they never counted."""
    X, pred, runs, terr = _inputs(WZ)
    between = (np.abs(X["wz__mean"]) >= 0.05) & (np.abs(X["wz__mean"]) < 0.1)
    with pytest.warns(DataWarning):
        full = measured_checks(X, pred, runs, terr, TRACK_M)
    keep = ~between.to_numpy()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        kept = measured_checks(X[keep].reset_index(drop=True), pred[keep], runs[keep],
                               terr[keep], TRACK_M)
    pd.testing.assert_frame_equal(full, kept, check_exact=True)
