"""The Markdown report: rendered from the template, numbers from the JSON report and its
settings."""

from __future__ import annotations

import copy
import json
import re
from pathlib import Path

import pytest

from terrain.audit.report import to_markdown
from terrain.audit.selection import EffectResult

DOCS = Path(__file__).resolve().parents[2] / "docs"


@pytest.fixture(scope="module")
def shipped_report():
    """The committed report pair: JSON and the Markdown written from it."""
    return (json.loads((DOCS / "audit_report.json").read_text()),
            (DOCS / "audit_report.md").read_text())


def _page_inputs(md: str):
    lines = md.splitlines()
    title = lines[0][2:]
    start = lines.index("Reproduce:") + 3
    commands = lines[start:lines.index("```", start)]
    figures = {m.group(2): m.group(1) for m in
               re.finditer(r"\]\(((?:[^)]*/)?audit_(\w+)\.png)\)", md)}
    return title, commands, figures


def test_committed_markdown_is_the_rendering_of_the_committed_json(shipped_report):
    report, md = shipped_report
    title, commands, figures = _page_inputs(md)
    assert to_markdown(report, figures, commands, title) == md


def test_settings_reach_the_prose(shipped_report):
    report, md = shipped_report
    title, commands, figures = _page_inputs(md)
    changed = copy.deepcopy(report)
    changed["settings"]["lag.window_s"] = 20.0
    changed["settings"]["selection.min_gain"] = 0.05
    page = to_markdown(changed, figures, commands, title)
    assert "estimated in 20 s windows" in page and "estimated in 30 s windows" in md
    assert "the gain is at least 0.05," in page


def test_grade_details_name_the_samples_left_out_without_a_pitch(shipped_report):
    report, md = shipped_report
    title, commands, figures = _page_inputs(md)
    changed = copy.deepcopy(report)
    grade = next(e for e in changed["effects"]
                 if e["name"] == "grade_resistance" and e["terrain"] == "SNOW")
    grade["details"]["n_moving_outside_imu"] = 37
    page = to_markdown(changed, figures, commands, title)
    assert "37 moving samples outside their run's IMU record (no pitch) left out" in page
    assert "outside their run's IMU record" not in md


def test_effect_results_are_built_by_keyword_and_frozen():
    with pytest.raises(TypeError):
        EffectResult("icr_expansion", "ASPHALT", "yaw")          # positional: refused
    e = EffectResult(name="icr_expansion", terrain="ASPHALT", group="yaw",
                     params={"chi": 1.5}, ci95={"chi": (1.4, 1.6)}, heldout_gain=0.5,
                     heldout_gain_ci95=(0.4, 0.6), supported=True, step=1)
    assert e.as_dict()["ci95"] == {"chi": [1.4, 1.6]}
    with pytest.raises(AttributeError):
        e.supported = False


def test_a_supported_effect_fitted_the_other_way_round_gets_its_own_cause(shipped_report):
    # vulpi PLOUGHED: turning_resistance supported at k_a = -3.18 A; the causes listed only
    # the vocabulary's "the current rises in every turn by more than the model gives"
    from terrain.audit.effects import CurrentParams, effect_cause
    report, md = shipped_report
    title, commands, figures = _page_inputs(md)
    changed = copy.deepcopy(report)
    e = next(e for e in changed["effects"] if e["name"] == "turning_resistance")
    e["supported"], e["params"] = True, {"k_a": -3.18}
    e["cause"] = effect_cause("turning_resistance", CurrentParams(k_a=-3.18))
    page = to_markdown(changed, figures, commands, title)
    assert f"- `turning_resistance on {e['terrain']}`: {e['cause']}" in page
    assert "- `turning_resistance`: While turning" in page         # the vocabulary's, once


def test_a_lag_fitted_on_segments_of_one_run_is_not_said_to_transfer_between_runs(
        shipped_report):
    # a terrain with one run is cut into segments: its wheel_lag can only hold from segment
    # to segment of that run, and its intervals resample those segments. Before, the page
    # said "a constant lag transfers between runs on ASPHALT" and "... s late on every run"
    # and printed the interval as if runs had been resampled
    report, md = shipped_report
    title, commands, figures = _page_inputs(md)
    changed = copy.deepcopy(report)
    lag = next(e for e in changed["effects"]
               if e["name"] == "wheel_lag" and e["terrain"] == "ASPHALT")
    lag.update(supported=True, step=1, params={"lag_s": 0.5}, heldout_gain=0.965,
               heldout_gain_ci95=[0.951, 0.975])
    for e in changed["effects"]:
        if e["terrain"] == "ASPHALT":
            e["n_runs"], e["n_units"] = 1, 4
    changed["supported"]["ASPHALT"] = ["wheel_lag"]
    page = to_markdown(changed, figures, commands, title)
    assert "transfers between runs" not in page
    assert ("on ASPHALT (one run, cut into segments) a constant lag holds from segment to "
            "segment of that run, which says nothing about other runs") in page
    assert "0.50 s late throughout its one run (held-out gain 96 %)" in page
    assert "| 0.965 [0.951, 0.975] within one run |" in page
    # the same effect over two runs transfers between them
    for e in changed["effects"]:
        if e["terrain"] == "ASPHALT":
            e["n_runs"] = 2
    page = to_markdown(changed, figures, commands, title)
    assert "a constant lag transfers between runs on ASPHALT" in page
    assert "0.50 s late on every run" in page and "within one run" not in page


def test_signal_records_keep_replay_as_the_bare_physics_and_extended_as_held_out():
    """The ``signals`` records, by hand on synthetic frames with a planted gyro bias and
    current offsets: ``replay_*`` is the replay with no fitted effect, ``extended_*`` the
    held-out (leave-one-run-out) predictions of the selected effects, each on the scored
    samples of the signal pooled over runs and manoeuvres; bias = measured - predicted."""
    import numpy as np

    from audit_helpers import synthetic_frame
    from terrain.audit import AuditSettings, SelectionSettings, run_audit, to_dict
    from terrain.audit.effects import predict_current, predict_yaw
    from terrain.audit.report import flat_metrics, signal_table
    from terrain.audit.selection import loro

    from dataclasses import replace

    # the gyro on its own (raw) clock reads 0.05 rad/s above the aligned one
    frames = [synthetic_frame(f"s/ASPHALT/{i}", seed=i, bias_rad_s=0.02,
                              offsets_a=(-0.3, 0.5)) for i in range(4)]
    frames = [replace(f, imu_wz=f.wz + 0.05) for f in frames]
    result = run_audit([], AuditSettings(selection=SelectionSettings(
        n_bootstrap=200, n_param_bootstrap=20), pooled=False), frames=frames)
    assert result.supported("ASPHALT") == ["gyro_bias", "current_offset"]
    table = signal_table(result).set_index("signal")
    units = [[f] for f in frames]
    yaw = loro(units, "yaw", ["gyro_bias"], [], result.settings.effects)
    cur = loro(units, "current", ["current_offset"], [], result.settings.effects)

    def pooled(pairs):
        r = np.concatenate([m - p for m, p in pairs])
        return r.size, np.sqrt(np.mean(r * r)), np.mean(r)

    m = [f.score_imu for f in frames]
    n, rmse, bias = pooled((f.wz[k], f.sim_wz[k]) for f, k in zip(frames, m))
    assert table.loc["wz", "n"] == n
    assert table.loc["wz", "replay_rmse"] == pytest.approx(rmse, rel=1e-9)
    assert table.loc["wz", "replay_bias"] == pytest.approx(bias, rel=1e-9)
    assert bias == pytest.approx(0.02, abs=1e-3)
    _, ext, _ = pooled((f.wz[k], predict_yaw(f, p)[k]) for f, k, p in zip(frames, m, yaw))
    assert table.loc["wz", "extended_rmse"] == pytest.approx(ext, rel=1e-9)
    assert table.loc["wz", "ideal_rmse"] == pytest.approx(
        pooled((f.wz[k], f.commanded_yaw_rate[k]) for f, k in zip(frames, m))[1], rel=1e-9)
    assert table.loc["wz", "extended_gain"] == pytest.approx(1.0 - ext / rmse, rel=1e-9)
    assert table.loc["wz", "replay_raw_rmse"] == pytest.approx(
        pooled((f.wz[k] + 0.05, f.sim_wz[k]) for f, k in zip(frames, m))[1], rel=1e-9)
    # a gyro bias is a sensor offset: it does not move the body, so the extended lateral
    # acceleration is the replay's
    assert table.loc["ay", "extended_rmse"] == table.loc["ay", "replay_rmse"]
    for j, side, offset in ((0, "cur_l", -0.3), (1, "cur_r", 0.5)):
        k = [f.score_cur for f in frames]
        n, rmse, bias = pooled((f.cur[q, j], f.sim_cur[q, j]) for f, q in zip(frames, k))
        assert table.loc[side, "replay_rmse"] == pytest.approx(rmse, rel=1e-9)
        assert table.loc[side, "replay_bias"] == pytest.approx(bias, rel=1e-9)
        _, ext, _ = pooled((f.cur[q, j], predict_current(f, p)[q, j])
                           for f, q, p in zip(frames, k, cur))
        assert table.loc[side, "extended_rmse"] == pytest.approx(ext, rel=1e-9)
        assert ext < 0.2 * rmse
        # the moving samples carry the planted offset, the stops do not
        assert np.sign(bias) == np.sign(offset)
    # the JSON records and the flat metrics carry the same numbers under the same names
    report = to_dict(result)
    rec = {r["signal"]: r for r in report["signals"]}
    metrics = flat_metrics(report)
    for s in ("wz", "cur_l", "cur_r"):
        assert rec[s]["terrain"] == "ASPHALT" and rec[s]["n"] == table.loc[s, "n"]
        for model in ("replay", "extended"):
            assert rec[s][f"{model}_rmse"] == pytest.approx(table.loc[s, f"{model}_rmse"],
                                                            abs=1e-5)
            assert metrics[f"rmse_{model}__{s}__ASPHALT"] == rec[s][f"{model}_rmse"]
