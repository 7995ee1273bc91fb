"""`terrain validate`'s Markdown tables and its validation tables (pipelines.validation)."""

from __future__ import annotations

import numpy as np
import pandas as pd

from pipelines.validate import to_markdown


def test_markdown_tells_an_infinite_figure_from_a_missing_one():
    # every non-finite float was printed "nan": a ratio that ran to infinity (a zero
    # denominator) read as a figure that is missing
    table = pd.DataFrame({"case": ["a", "b", "c"], "ratio": [np.inf, -np.inf, np.nan],
                          "x": [1.234567, 0.5, 2.0]})
    assert to_markdown(table).splitlines() == [
        "| case | ratio | x |", "|---|---|---|", "| a | inf | 1.235 |", "| b | -inf | 0.5 |",
        "| c | nan | 2 |"]


def test_measured_runs_without_an_imu_are_skipped_with_a_count():
    # runs without an IMU were skipped without a word: 3 of the 55 shipped BorealTC runs
    # are missing from the measured table of docs/estimation_validation.md (52 runs)
    import pytest

    from pipelines.validation.harness import measured_skid_steer_summary
    from terrain.errors import DataWarning
    from terrain.run import TIME, Run

    wheels = pd.DataFrame({TIME: np.arange(0.0, 1.0, 0.05), "vel_l": 0.5, "vel_r": 0.5})
    runs = [Run(f"r{i}", "borealtc", "SNOW", {"wheels": wheels}) for i in range(2)]
    with pytest.warns(DataWarning, match=r"measured_skid_steer_summary: 2 of 2 runs have no "
                                         r"imu stream and are skipped: r0, r1"):
        summary = measured_skid_steer_summary(runs)
    assert summary.empty
    assert list(summary.columns) == ["run_id", "terrain", "chi_ekf", "chi_observer", "eta_R",
                                     "eta_L", "gyro_bias", "turning_fraction", "duration_s"]


def test_validate_out_writes_every_printed_table(tmp_path, monkeypatch, capsys):
    # --out "also writes the Markdown": the file holds each section as printed, in order
    import argparse
    import sys
    import types

    import pipelines.validate as validate

    report = types.ModuleType("fake_validation_report")
    report.sections = lambda quick: [
        ("First", lambda: pd.DataFrame({"case": ["a"], "x": [0.5]})),
        ("Second" if quick else "Long", lambda: pd.DataFrame({"n": [3]}))]
    monkeypatch.setitem(sys.modules, "fake_validation_report", report)
    monkeypatch.setattr(validate, "REPORTS", {"fake": "fake_validation_report"})
    out = tmp_path / "sub" / "report.md"
    assert validate.main(argparse.Namespace(report="fake", quick=True, out=out)) == 0
    printed = capsys.readouterr().out
    text = out.read_text()
    assert text.startswith("### First\n\n| case | x |\n|---|---|\n| a | 0.5 |\n\n")
    assert "### Second\n\n| n |\n|---|\n| 3 |\n" in text and "Long" not in text
    assert text.index("### First") < text.index("### Second")
    assert all(line in printed for line in text.splitlines())


def test_validate_refuses_a_figure_path_it_cannot_write_before_any_table(tmp_path, monkeypatch):
    # --out's figure (<stem>_straight_line.png) was written after every table had been
    # computed (35 s for sim, minutes for estimation): a folder of that name stopped the
    # command only then, with the Markdown written and no figure
    import argparse
    import sys
    import types

    import pytest

    import pipelines.validate as validate
    from terrain.errors import ConfigError

    computed = []
    report = types.ModuleType("fake_sim_report")
    report.sections = lambda quick: [("T", lambda: computed.append(1) or pd.DataFrame({"n": [3]}))]
    monkeypatch.setitem(sys.modules, "fake_sim_report", report)
    monkeypatch.setattr(validate, "REPORTS", {"sim": "fake_sim_report"})
    (tmp_path / "report_straight_line.png").mkdir()
    out = tmp_path / "report.md"
    with pytest.raises(ConfigError, match=r"--out: cannot write .*report_straight_line\.png"):
        validate.main(argparse.Namespace(report="sim", quick=True, out=out))
    assert not computed and not out.exists()
