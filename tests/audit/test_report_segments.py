"""The audit page's wording where the units of a terrain are segments of two or more runs:
a held-out segment is then fitted on its own run's other segments too, so a supported effect
does not show that it carries over from run to run."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import pytest

from terrain.audit.report import to_markdown

DOCS = Path(__file__).resolve().parents[2] / "docs"


@pytest.fixture(scope="module")
def borealtc_report():
    return json.loads((DOCS / "audit_report.json").read_text())


def _with_ice_lag(report, n_runs, segmented):
    report = copy.deepcopy(report)
    lag = next(e for e in report["effects"]
               if e["terrain"] == "ICE" and e["name"] == "wheel_lag")
    lag.update(supported=True, step=1, heldout_gain=0.1)
    for e in report["effects"]:
        if e["terrain"] == "ICE":
            e["n_runs"] = n_runs
    for g in report["groups"]:
        if g["terrain"] == "ICE":
            g["segmented"] = segmented
    return report


def test_a_lag_supported_between_whole_runs_transfers_between_runs(borealtc_report):
    page = to_markdown(_with_ice_lag(borealtc_report, 8, False))
    assert "a constant lag transfers between runs on ICE" in page
    assert "the segments come from two or more runs" not in page


def test_a_lag_supported_between_segments_of_several_runs_is_not_said_to_transfer(
        borealtc_report):
    # before: "a constant lag transfers between runs on ICE", though each held-out
    # segment was fitted on the other segments of its own run
    page = to_markdown(_with_ice_lag(borealtc_report, 2, True))
    assert "transfers between runs on ICE" not in page
    assert ("on ICE (runs cut into segments) a constant lag holds from segment to segment, "
            "each held-out segment fitted on its own run's others too") in page
    assert ("In ICE (current), ICE (timing), ICE (yaw) the segments come from two or more "
            "runs: a held-out segment is fitted on the other segments, its own run's among "
            "them") in page


def test_segments_of_a_single_run_keep_their_own_wording(borealtc_report):
    page = to_markdown(_with_ice_lag(borealtc_report, 1, True))
    assert "on ICE (one run, cut into segments) a constant lag holds" in page
    assert "the segments come from two or more runs" not in page
