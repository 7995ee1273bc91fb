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
