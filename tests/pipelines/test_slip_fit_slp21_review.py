"""Review slp21: the summary of ``terrain slip-fit`` over hand-made tables."""

from __future__ import annotations

import math

import pandas as pd

from pipelines.slip_fit import _summary


def _odo(plain: float, comp: float) -> pd.DataFrame:
    return pd.DataFrame({"scenario": ["orchard"] * 2, "slid_off": [False, False],
                         "plain_err_pct": [plain, plain], "compensated_err_pct": [comp, comp],
                         "compensated_gyro_err_pct": [comp, comp],
                         "gyro_heading_err_pct": [plain, plain], "reduction_pct": [0.0, 0.0]})


def _errors() -> pd.DataFrame:
    return pd.DataFrame(columns=["split", "model", "terrain", "windows", "median_abs_err"])


def test_summary_reduction_by_hand():
    out = _summary(_errors(), _odo(4.0, 1.0))
    assert out["odometry.orchard.reduction_of_median_pct"] == 75.0
    assert out["odometry.orchard.gyro_reduction_of_median_pct"] == 75.0
    assert out["odometry.orchard.slipping_runs"] == 2.0


def test_summary_exact_plain_odometry_has_no_reduction():
    """Runs whose plain odometry ends exactly on the truth (0 % error) have no reduction
    (NaN, as odometry_errors' reduction_pct), not a bare ZeroDivisionError after the fit."""
    out = _summary(_errors(), _odo(0.0, 0.5))
    assert math.isnan(out["odometry.orchard.reduction_of_median_pct"])
    assert math.isnan(out["odometry.orchard.gyro_reduction_of_median_pct"])
