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
