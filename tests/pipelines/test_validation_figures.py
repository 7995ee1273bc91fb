"""The figures of the validation reports (`terrain validate {estimation,sim} --out FILE`)."""

from __future__ import annotations

import argparse
import sys
import types

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from pipelines.validation.figures import binned_nis, slip_tracking


def test_binned_nis_sums_each_bin_and_scales_its_chi_square_interval():
    # 1 s bins: the NIS and the dof of a bin are summed, steps without an accepted row
    # (dof 0, NaN NIS) are left out, an empty bin gives no row
    t = np.array([0.0, 0.5, 0.9, 1.2, 2.5, 3.1])
    nis = np.array([2.0, np.nan, 6.0, 3.0, np.nan, 1.0])
    dof = np.array([4, 0, 4, 2, 0, 2])
    out = binned_nis(t, nis, dof)
    assert out["t_s"].tolist() == [0.5, 1.5, 3.5]
    assert out["nis_per_dof"].tolist() == [1.0, 1.5, 0.5]
    assert out["dof"].tolist() == [8.0, 2.0, 2.0]
    assert out["lower"].iloc[0] == pytest.approx(stats.chi2.ppf(0.025, 8) / 8)
    assert out["upper"].iloc[1] == pytest.approx(stats.chi2.ppf(0.975, 2) / 2)
    assert (out["lower"] < 1.0).all() and (out["upper"] > 1.0).all()


def test_slip_tracking_shows_the_thesis_tuning_blindness_on_grass():
    # docs/estimation_validation.md: the noise tuning's steady slip error is < 0.01, the
    # thesis tuning (eqs. 6.9/6.13/6.14) stays 0.07-0.09 below the true slip on grass
    frame = slip_tracking(("GRASS",), seed=1, duration_s=8.0)
    assert list(frame.columns) == ["terrain", "tuning", "t_s", "slip_true", "slip_est", "nis",
                                   "dof", "seed"]
    steady = frame[frame["t_s"] > 5.0]
    err = (steady["slip_est"] - steady["slip_true"]).groupby(steady["tuning"]).mean()
    assert abs(err["noise"]) < 0.01
    assert -0.1 < err["thesis"] < -0.05
    assert steady["slip_true"].between(0.12, 0.15).all()


@pytest.mark.slow
@pytest.mark.parametrize("report, figure, quick, min_aspect", [
    ("estimation", "slip_tracking", True, 1.0), ("sim", "straight_line", False, 2.0)])
def test_validate_out_draws_the_reports_figure_beside_the_tables(report, figure, quick,
                                                                 min_aspect, tmp_path,
                                                                 monkeypatch, capsys):
    import matplotlib.image

    import pipelines.validate as validate

    tables = types.ModuleType("fake_report_tables")
    tables.sections = lambda quick: [("T", lambda: pd.DataFrame({"x": [1.0]}))]
    monkeypatch.setitem(sys.modules, "fake_report_tables", tables)
    monkeypatch.setattr(validate, "REPORTS", {report: "fake_report_tables"})
    out = tmp_path / "validation.md"
    assert validate.main(argparse.Namespace(report=report, quick=quick, out=out)) == 0
    png = tmp_path / f"validation_{figure}.png"
    assert f"figure: {png}" in capsys.readouterr().out
    image = matplotlib.image.imread(png)
    assert image.ndim == 3 and image.shape[1] > min_aspect * image.shape[0]
    assert image.shape[0] > 250
    assert np.ptp(image[..., :3]) > 0.5       # drawn, not blank


def test_binned_nis_of_no_step_is_an_empty_table():
    """binned_nis on a filter of no step raised a bare IndexError from t_s[0] (trk22's
    left-alone); it now gives no bin, with the table's columns, as a run of steps with no
    accepted row does."""
    empty = binned_nis(np.zeros(0), np.zeros(0), np.zeros(0))
    none_accepted = binned_nis(np.arange(3.0), np.full(3, np.nan), np.zeros(3))
    assert len(empty) == len(none_accepted) == 0
    assert list(empty.columns) == list(none_accepted.columns) == [
        "t_s", "nis_per_dof", "dof", "lower", "upper"]
