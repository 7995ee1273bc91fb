"""Review ctl21: the slip evaluation's thresholds, exactly at each and one ulp either side."""

import numpy as np
import pandas as pd
import pytest

from terrain.errors import DataWarning
from terrain.slip.evaluation import (CHI_RANGE, STEADY_AFTER_S, measured_checks,
                                     steady_straight)


def _up(x):
    return float(np.nextafter(x, np.inf))


def _down(x):
    return float(np.nextafter(x, -np.inf))


def test_steady_straight_window_starts_at_the_ramp_end_and_turns_below_0_05():
    """Steady straight windows: ``t_start_s >= STEADY_AFTER_S`` (a window starting exactly
    at 3 s is steady, one ulp before it is not) and true ``|yaw rate| < 0.05`` rad/s (0.05
    itself is a turn, on either sign)."""
    starts = [STEADY_AFTER_S, _down(STEADY_AFTER_S), 5.0, 5.0, 5.0, 5.0]
    yaw = [0.0, 0.0, 0.05, -0.05, _down(0.05), -_down(0.05)]
    meta = pd.DataFrame({"scenario": "straight_accel", "t_start_s": starts})
    expected = [True, False, False, False, True, True]
    assert steady_straight(meta, np.array(yaw)).tolist() == expected


def _measured(wz, chi, straight_windows=0):
    """measured_checks' inputs: one terrain, windows of gyro yaw rate ``wz`` (a wheel yaw
    rate of 2 wz) with predicted ``chi``, and ``straight_windows`` more windows driving
    straight with the learned slip rising with the current."""
    wz = list(wz) + [0.0] * straight_windows
    n = len(wz)
    rise = np.arange(n, dtype=float)
    X = pd.DataFrame({"wz__mean": wz, "vel_diff__mean": 2.0 * np.array(wz) * 0.5,
                      "cur_l__mean": rise, "cur_r__mean": rise,
                      "phys_slip_l": 0.0, "phys_slip_r": 0.0})
    pred = np.column_stack([0.01 * rise, 0.01 * rise, list(chi) + [1.0] * straight_windows,
                            np.zeros(n)])
    return X, pred, np.array([f"r{i}" for i in range(n)]), np.array(["SNOW"] * n)


def test_measured_checks_turning_threshold_is_inclusive_and_chi_range_ends_unclipped():
    """Turning windows: gyro ``|yaw rate| >= min_turn_rad_s`` (a window exactly at it is
    turning, one ulp below is not); a predicted chi exactly at an end of CHI_RANGE is
    used as it is and not counted as clipped (one ulp outside is, with a warning)."""
    lo, hi = CHI_RANGE
    X, pred, runs, terr = _measured([0.1, _down(0.1), -0.1], [lo, 2.0, hi])
    # (the window one ulp below the threshold is neither turning nor straight: said)
    with pytest.warns(DataWarning, match="1 of 3 windows have a gyro yaw rate between") as said:
        out = measured_checks(X, pred, runs, terr, track_m=0.5, min_turn_rad_s=0.1)
    assert not [w for w in said if "clipped" in str(w.message)]  # neither end is clipped
    assert out.loc[0, "n_turning_windows"] == 2
    X, pred, runs, terr = _measured([0.1, 0.1], [_down(lo), _up(hi)])
    with pytest.warns(DataWarning, match="chi of 2 of 2 turning windows"):
        measured_checks(X, pred, runs, terr, track_m=0.5, min_turn_rad_s=0.1)


@pytest.mark.parametrize("n_straight, defined", [(3, False), (4, True)])
def test_measured_checks_spearman_needs_four_straight_windows(n_straight, defined):
    """The Spearman correlation of the learned slip with the current is given over at least
    four straight windows (documented); with three it is NaN, the median difference to the
    physics slip still given."""
    X, pred, runs, terr = _measured([], [], straight_windows=n_straight)
    out = measured_checks(X, pred, runs, terr, track_m=0.5)
    rho = out.loc[0, "spearman_slip_current"]
    assert (rho == pytest.approx(1.0)) if defined else np.isnan(rho)
    assert out.loc[0, "median_learned_minus_physics"] >= 0.0
