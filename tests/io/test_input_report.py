"""The input report's table, metrics and text from planted run meta and window counts."""

from __future__ import annotations

import pytest

from terrain.io.report import COLUMNS, input_report, merged_gaps, seconds_text
from terrain.run import Run


def _run(run_id: str, **meta) -> Run:
    return Run(run_id, "runs", None, {}, meta=meta)


def _counts():
    return {"per_run": {"r/used": {"windows": 10, "dropped_gap": 2, "dropped_unsteady": 3},
                        "r/stuck": {"windows": 4, "dropped_gap": 0, "dropped_unsteady": 0}},
            "skipped_runs": ["r/skip", "r/skip2"], "too_short_runs": ["r/short"]}


def test_statuses_window_columns_and_totals_of_planted_runs():
    runs = [_run("r/used"), _run("r/stuck", stuck={"ax": 1, "wz": 1}), _run("r/skip"),
            _run("r/short"), _run("r/none"), _run("r/skip2")]
    report = input_report(runs, _counts(), window_s=2.0, flagged={"r/stuck": 3})
    t = report.table.set_index("run_id")
    assert list(report.table.columns) == list(COLUMNS)
    assert list(t["status"]) == ["used", "used", "skipped", "too_short", "used", "skipped"]
    assert t.loc["r/skip", "reason"] == "no imu or wheels stream"
    assert t.loc["r/short", "reason"] == "shorter than one 2 s window"
    assert t.loc["r/none", "windows"] == -1 and t.loc["r/used", "windows"] == 10
    assert t.loc["r/used", "dropped_unsteady"] == 3
    assert t.loc["r/stuck", "stuck"] == "ax,wz"
    m = report.metrics()
    assert (m["input_runs"], m["input_runs_used"], m["input_runs_skipped"],
            m["input_runs_too_short"]) == (6, 3, 2, 1)
    assert m["input_stuck_channels"] == 2            # two channels of one run
    assert m["input_windows_flagged"] == 3           # windows, not runs holding some
    assert (m["input_windows_dropped_gap"], m["input_windows_dropped_unsteady"]) == (2, 3)
    text = report.text()
    assert "dropped windows: 2 spanning a gap, 3 unsteady (--steady-only)" in text
    assert "2 run(s) skipped (no imu or wheels stream): r/skip, r/skip2" in text
    assert "1 run(s) too short (shorter than one 2 s window): r/short" in text
    assert "stuck or dead sensor channel(s): r/stuck (ax,wz); 3 window(s) holding one" in text
    assert "nothing repaired" not in text


def test_a_clean_input_says_so_and_long_lists_are_cut():
    clean = input_report([_run("r/a")]).text()
    assert clean == "input: 1 run(s), 1 used; nothing repaired, dropped or skipped"
    runs = [_run(f"r/{i}", skipped_lines={"imu": 1}) for i in range(6)]
    text = input_report(runs).text(limit=4)
    assert "skipped 6 blank/comment line(s): r/0, r/1, r/2, r/3 and 2 more" in text


def test_touching_gaps_merge_and_huge_negative_durations_print_short():
    assert merged_gaps({"imu": [(1.0, 2.0)], "wheels": [(0.0, 1.0)]}) == [(0.0, 2.0)]
    assert seconds_text(12.34) == "12.3 s"
    assert seconds_text(-2e6) == "-2e+06 s"


@pytest.mark.parametrize("streams, counted", [(("imu", "wheels"), 3.0), (("wheels",), 0.0)])
def test_unused_seconds_count_only_where_both_streams_are_aligned(streams, counted):
    run = _run("r/a", unused_s={"imu": 3.0})
    report = input_report([run], {"per_run": {}, "streams": streams})
    assert report.metrics()["input_unused_imu_s"] == counted


@pytest.mark.parametrize("dropped_gap, dropped_unsteady", [(0, 5), (4, 0)])
def test_windows_dropped_for_one_reason_alone_are_still_reported(dropped_gap, dropped_unsteady):
    # a steady-only command whose runs have no gap drops windows as unsteady only: the line
    # must not hang on the gap count (nor the gap line on the unsteady count)
    counts = {"per_run": {"r/a": {"windows": 6, "dropped_gap": dropped_gap,
                                  "dropped_unsteady": dropped_unsteady}}}
    report = input_report([_run("r/a")], counts)
    assert (f"dropped windows: {dropped_gap} spanning a gap, {dropped_unsteady} unsteady "
            "(--steady-only)") in report.text()
    m = report.metrics()
    assert (m["input_windows_dropped_gap"], m["input_windows_dropped_unsteady"]) == (
        dropped_gap, dropped_unsteady)


def test_gaps_are_merged_across_streams_and_totalled_only_when_several():
    # the gap of a recording shows in both files: counted once, its length as merged
    one = input_report([_run("r/a", gaps={"imu": [(1.0, 3.5)], "wheels": [(1.2, 3.0)]})])
    assert "  1 timestamp gap(s) (2.5 s) in r/a; never interpolated across" in one.text()
    assert (one.metrics()["input_gaps"], one.metrics()["input_gap_s"]) == (1, 2.5)
    two = input_report([_run("r/b", gaps={"imu": [(1.0, 2.0), (5.0, 5.5)]})])
    assert "  2 timestamp gap(s) (1.0 s, 0.5 s; 1.5 s in all) in r/b" in two.text()
