"""What a failed or smaller audit report leaves on disk: the Markdown page and its figures
folder are written whole or not at all, and no figure of an earlier report stays beside a
new page (a failure simulated with monkeypatch, the committed JSON report as input)."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import pytest
from matplotlib.figure import Figure

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
