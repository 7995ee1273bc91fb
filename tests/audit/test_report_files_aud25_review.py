"""What a failed or smaller audit report leaves on disk: the Markdown page and its figures
folder are written whole or not at all, and no figure of an earlier report stays beside a
new page (a failure simulated with monkeypatch, the committed JSON report as input)."""

from __future__ import annotations

import argparse
import copy
import json
from pathlib import Path
from types import SimpleNamespace

import pandas as pd
import pytest
from matplotlib.figure import Figure

import pipelines.audit as audit_cli
from terrain.audit.report import figures_folder, to_markdown, write_markdown

DOCS = Path(__file__).resolve().parents[2] / "docs"


@pytest.fixture(scope="module")
def report():
    """The committed JSON report (tests change deep copies)."""
    return json.loads((DOCS / "audit_report.json").read_text())


def _figures(*keys, color="white"):
    return {k: Figure(figsize=(1, 1), facecolor=color) for k in keys}


def _listing(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def test_a_smaller_report_leaves_no_figure_of_the_earlier_one(tmp_path, report):
    page = tmp_path / "audit.md"
    write_markdown(page, report, _figures("yaw", "lags"))
    write_markdown(page, report, _figures("yaw"))
    assert sorted(p.name for p in figures_folder(page).iterdir()) == ["audit_yaw.png"]
    assert "audit_lags" not in page.read_text()


def test_a_figure_that_fails_to_save_leaves_the_earlier_report_whole(
        tmp_path, report, monkeypatch):
    page = tmp_path / "audit.md"
    write_markdown(page, report, _figures("yaw", "rmse"), ["first"])
    before = _listing(tmp_path)
    figures = _figures("yaw", "rmse", color="red")

    def full(*args, **kwargs):
        raise OSError(28, "No space left on device")
    monkeypatch.setattr(figures["rmse"], "savefig", full)
    with pytest.raises(OSError):
        write_markdown(page, report, figures, ["second"])
    assert _listing(tmp_path) == before           # no new yaw figure beside the old page
    assert sorted(p.name for p in tmp_path.iterdir()) == ["audit.md", "audit_figures"]


def test_a_page_that_cannot_be_rendered_writes_no_figure(tmp_path, report):
    page = tmp_path / "audit.md"
    broken = copy.deepcopy(report)
    del broken["settings"]
    with pytest.raises(KeyError):
        write_markdown(page, broken, _figures("yaw"))
    assert list(tmp_path.iterdir()) == []


def test_the_page_holds_the_appendix(tmp_path, report):
    page = tmp_path / "audit.md"
    write_markdown(page, report, {}, ["c"], "T", appendix="\nmore\n")
    assert page.read_text() == to_markdown(report, {}, ["c"], "T") + "\nmore\n"


def _args(tmp_path: Path, **extra) -> argparse.Namespace:
    values = dict(runs_dir=None, dataset="borealtc", json=tmp_path / "audit.json",
                  md=tmp_path / "audit.md", bootstrap=200, param_bootstrap=0,
                  min_gain=0.02, seed=0, physics="v1", compare_physics=False,
                  replay_input_lowpass_hz=None, no_pooled=False,
                  sweep_lateral_friction=False, no_mlflow=True, no_progress=True)
    values.update(extra)
    return argparse.Namespace(**values)


def _fake_audit(monkeypatch, report):
    """The pipeline's steps around the writing replaced by the committed report."""
    result = SimpleNamespace(skipped={}, frames=[], timings_s={"replay_s": 0.0},
                             residuals=pd.DataFrame(), lags=pd.DataFrame(),
                             sweep=pd.DataFrame())
    monkeypatch.setattr(audit_cli, "_run_with_progress", lambda *a: result)
    monkeypatch.setattr(audit_cli, "input_report", lambda *a: SimpleNamespace(
        text=lambda: "", metrics=lambda: {}, table=pd.DataFrame()))
    monkeypatch.setattr(audit_cli, "to_dict", lambda *a: copy.deepcopy(report))
    monkeypatch.setattr("terrain.audit.make_figures", lambda result: _figures("yaw"))
    settings = SimpleNamespace(replay=SimpleNamespace(physics="v1", input_cutoff_hz=None))
    return settings


def test_a_markdown_report_that_fails_keeps_the_earlier_json(tmp_path, report, monkeypatch):
    settings = _fake_audit(monkeypatch, report)
    (tmp_path / "audit.json").write_text('{"earlier": true}\n')

    def fails(*args, **kwargs):
        raise OSError(28, "No space left on device")
    monkeypatch.setattr(audit_cli, "write_markdown", fails)
    with pytest.raises(OSError):
        audit_cli._audit(_args(tmp_path), [], settings, {"dataset": "borealtc"}, "b", None)
    assert (tmp_path / "audit.json").read_text() == '{"earlier": true}\n'


def test_a_comparison_that_fails_to_render_writes_no_report(tmp_path, report, monkeypatch):
    settings = _fake_audit(monkeypatch, report)
    settings.frames = settings.lag = None
    monkeypatch.setattr(audit_cli, "per_run_errors", lambda *a: ({}, {}))
    monkeypatch.setattr(audit_cli, "gain_table", lambda *a: pd.DataFrame())

    def fails(*args):
        raise ValueError("cannot render")
    monkeypatch.setattr(audit_cli, "comparison_markdown", fails)
    with pytest.raises(ValueError):
        audit_cli._audit(_args(tmp_path, compare_physics=True), [], settings,
                         {"dataset": "borealtc"}, "b", None)
    assert list(tmp_path.iterdir()) == []
