"""The report's text outside the committed page: the terminal summary, the figures folder
written beside the page, the per-run lag table, the timing and stand-still findings and the
flat settings recorded in the report, each on small inputs built by hand."""

from __future__ import annotations

import copy
import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from audit_helpers import synthetic_frame
from terrain.audit import AuditSettings
from terrain.audit.core import lag_table
from terrain.audit.report import figures_folder, summary_lines, to_markdown, write_markdown
from terrain.audit.timing import LagTrack

DOCS = Path(__file__).resolve().parents[2] / "docs"


@pytest.fixture(scope="module")
def shipped_json():
    """The committed JSON report (read only; tests change deep copies)."""
    return json.loads((DOCS / "audit_report.json").read_text())


def _effect(name, terrain, supported, params, gain):
    return {"name": name, "terrain": terrain, "supported": supported, "params": params,
            "heldout_gain": gain}


def test_summary_lines_count_runs_and_list_only_supported_effects():
    report = {"runs": {"audited": ["a", "b", "c"], "skipped": {"d": "no wheel stream"}},
              "terrains": ["ASPHALT", "SNOW"],
              "supported": {"ASPHALT": ["icr_expansion", "gyro_bias"], "SNOW": ["none"]},
              "effects": [_effect("icr_expansion", "ASPHALT", True, {"chi": 1.4812}, 0.456),
                          _effect("gyro_bias", "ASPHALT", True, {"bias_rad_s": None}, 0.1),
                          _effect("wheel_lag", "ASPHALT", False, {"lag_s": 0.3}, 0.01),
                          _effect("immobilised", "SNOW", False, {"fraction": 0.2}, 0.0)]}
    lines = summary_lines(report, {"replay_s": 1.25, "selection_s": 2.5})
    assert lines == [
        "audited 3 runs (ASPHALT, SNOW), skipped 1; 3.8 s",
        "  ASPHALT: icr_expansion (chi=1.48; gain 0.46), gyro_bias (bias_rad_s=n/a; gain 0.10)",
        "  SNOW: none"]


def test_the_figures_folder_is_named_after_the_page_and_linked_relative(tmp_path,
                                                                        shipped_json):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    assert figures_folder(Path("docs/audit_report.md")) == Path("docs/audit_report_figures")
    page = tmp_path / "out" / "audit.md"
    fig = plt.figure(figsize=(2, 2))
    try:
        write_markdown(page, shipped_json, {"yaw": fig}, ["terrain audit"], "T")
    finally:
        plt.close(fig)
    assert (tmp_path / "out" / "audit_figures" / "audit_yaw.png").is_file()
    text = page.read_text()
    assert "](audit_figures/audit_yaw.png)" in text
    assert text == to_markdown(shipped_json, {"yaw": "audit_figures/audit_yaw.png"},
                               ["terrain audit"], "T")


def test_lag_table_has_one_row_per_run_with_imu_and_its_windows_as_text():
    lagged = replace(synthetic_frame("s/ASPHALT/0"), lag=LagTrack(
        np.array([15.0, 30.0, 45.0]), np.array([-0.146, 0.2, 0.1]), np.ones(3), 4))
    flat = synthetic_frame("s/SNOW/1", terrain="SNOW")
    no_imu = replace(synthetic_frame("s/ICE/2", terrain="ICE"), has_imu=False)
    table = lag_table([lagged, flat, no_imu])
    assert list(table.run_id) == ["s/ASPHALT/0", "s/SNOW/1"]
    row = table.iloc[0]
    assert row.terrain == "ASPHALT" and row.windows == "15.0:-0.146;30.0:+0.200;45.0:+0.100"
    assert row.lag_min_s == pytest.approx(-0.146) and row.lag_max_s == pytest.approx(0.2)
    assert row.lag_s == pytest.approx(0.1) and row.n_windows_used == 3 and row.n_windows == 4
    assert bool(row.identifiable) and not bool(table.iloc[1].identifiable)
    assert table.iloc[1].windows == ""


def _lag(run_id, lag_s, lo, hi, drift, identifiable=True):
    return {"run_id": run_id, "terrain": "ASPHALT", "lag_s": lag_s, "lag_start_s": lo,
            "lag_end_s": hi, "lag_min_s": lo, "lag_max_s": hi, "drift_s_per_min": drift,
            "n_windows_used": 3, "n_windows": 3, "identifiable": identifiable, "windows": ""}


def test_the_timing_finding_spans_the_identifiable_runs(shipped_json):
    report = copy.deepcopy(shipped_json)
    report["lags"] = [_lag("a", -0.2, -0.36, -0.1, -0.5), _lag("b", 0.05, 0.01, 0.12, 0.2),
                      _lag("c", 0.05, 0.0, 0.1, None),
                      _lag("d", 3.0, 2.0, 4.0, 9.0, identifiable=False)]
    page = to_markdown(report)
    assert ("in the 3 runs where it is identifiable, the wheel stream is offset from the IMU "
            "by -0.36 to +0.12 s (per-run medians -0.20 to +0.05 s), drifting by up to "
            "0.50 s per minute within a run") in page


def _stop(terrain, signal, bias, model="replay", manoeuvre="stop"):
    return {"signal": signal, "model": model, "terrain": terrain, "manoeuvre": manoeuvre,
            "n": 50, "rmse": abs(bias), "bias": bias, "corr": None}


def test_the_stand_still_finding_takes_the_replays_current_at_rest_per_terrain(shipped_json):
    report = copy.deepcopy(shipped_json)
    ignored = [_stop("all", "cur_l", -9.0), _stop("ICE", "cur_l", -8.0, model="extended"),
               _stop("ICE", "cur_r", -7.0, manoeuvre="straight"), _stop("ICE", "wz", -6.0),
               _stop("ICE", "cur_r", -1.5)]
    report["residuals_by_manoeuvre"] = ignored + [_stop("SNOW", "cur_r", -3.2),
                                                  _stop("ASPHALT", "cur_l", -2.4)]
    page = to_markdown(report)
    assert "(bias down to -3.2 A, on ASPHALT, SNOW)" in page
    report["residuals_by_manoeuvre"] = ignored
    assert "**Stand-still currents**" not in to_markdown(report)


def test_settings_are_recorded_flat_with_tuples_joined():
    params = AuditSettings(pooled=False, sweep_factors=(0.5, 1.0, 2.0)).as_params()
    assert params["pooled"] is False and params["sweep_factors"] == "0.5,1.0,2.0"
    assert params["effects.threshold_quantiles"].startswith("0.15,0.2,")
    assert params["effects.negligible"].startswith("icr_expansion=0.05,")
    assert AuditSettings().as_params()["sweep_factors"] == ""


@pytest.mark.slow
def test_the_json_report_lists_scopes_support_segments_and_skipped_runs():
    """Four ASPHALT runs with a planted gyro bias and current offsets and one SNOW run with
    nothing planted, pooled: every scope (``all`` included) is listed in ``supported``, SNOW
    as ``["none"]``; the single SNOW run is cut into segments; the flat metrics carry the
    gains of the supported effects only."""
    from terrain.audit import POOLED, SelectionSettings, run_audit, to_dict
    from terrain.audit.report import flat_metrics

    frames = [synthetic_frame(f"s/ASPHALT/{i}", seed=i, bias_rad_s=0.02,
                              offsets_a=(-0.3, 0.5)) for i in range(4)]
    frames.append(synthetic_frame("s/SNOW/0", terrain="SNOW", seed=9))
    result = run_audit([], AuditSettings(selection=SelectionSettings(
        n_bootstrap=50, n_param_bootstrap=0)), frames=frames)
    report = to_dict(replace(result, skipped={"s/ICE/0": "no wheel stream"}))
    assert report["runs"] == {"audited": [f.run_id for f in frames],
                              "skipped": {"s/ICE/0": "no wheel stream"}}
    assert list(report["supported"]) == ["ASPHALT", "SNOW", POOLED]
    assert report["supported"]["SNOW"] == ["none"]
    assert {"gyro_bias", "current_offset"} <= set(report["supported"]["ASPHALT"])
    segmented = {(g["terrain"], g["group"]): g["segmented"] for g in report["groups"]}
    assert segmented[("SNOW", "yaw")] and not segmented[("ASPHALT", "yaw")]
    # the yaw group's "ideal" reference is the ideal differential drive (v_R - v_L) / B,
    # the same prediction as the signals table's ideal model on the same samples
    yaw = next(g for g in report["groups"] if g["terrain"] == "ASPHALT" and g["group"] == "yaw")
    wz = next(s for s in report["signals"] if s["signal"] == "wz" and s["terrain"] == "ASPHALT")
    assert yaw["reference_rmse"]["ideal"] == pytest.approx(wz["ideal_rmse"], rel=1e-4)
    metrics = flat_metrics(report)
    supported = [(n, t) for t, names in report["supported"].items() for n in names
                 if n != "none"]
    assert metrics["n_supported"] == len(supported) < len(report["effects"])
    assert {k for k in metrics if k.startswith("gain__")} == {
        f"gain__{n}__{t}" for n, t in supported}
    assert metrics["n_runs"] == 5
