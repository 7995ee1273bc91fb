"""Review io22 of ``terrain validate --out``: a rerun that fails half-way (a figure that
cannot be drawn, a full disk) keeps the report and figures of the earlier run as they were,
never new tables beside an old figure, and leaves no temporary file."""

from __future__ import annotations

import argparse
import errno
import sys
import types
from pathlib import Path

import pandas as pd
import pytest

import pipelines.validate as validate
import pipelines.validation.figures as figures


def _fake_report(monkeypatch, value: int, draw) -> None:
    report = types.ModuleType("fake_io22_report")
    report.sections = lambda quick: [("T", lambda: pd.DataFrame({"n": [value]}))]
    monkeypatch.setitem(sys.modules, "fake_io22_report", report)
    monkeypatch.setattr(validate, "REPORTS", {"sim": "fake_io22_report"})
    monkeypatch.setattr(figures, "FIGURES", {"sim": {"curve": draw}})


def _drawing(text: str):
    def draw(path: Path, quick: bool) -> Path:
        path.write_text(text)
        return path
    return draw


def _failing(exc: BaseException):
    def draw(path: Path, quick: bool) -> Path:
        path.write_text("half a figure")
        raise exc
    return draw


def _run(out: Path) -> int:
    return validate.main(argparse.Namespace(report="sim", quick=True, out=out))


@pytest.mark.parametrize("exc", [RuntimeError("cannot draw"),
                                 OSError(errno.ENOSPC, "No space left on device"),
                                 KeyboardInterrupt()])
def test_a_rerun_whose_figure_fails_keeps_the_earlier_report_and_figure(tmp_path, monkeypatch,
                                                                        capsys, exc):
    # the new Markdown was written, then the figure failed: report.md held the new tables
    # beside report_curve.png of the earlier run (or the half of a new one), a pair that no
    # run drew; now both stay the earlier run's and no temporary file is left
    out = tmp_path / "report.md"
    _fake_report(monkeypatch, 1, _drawing("figure 1"))
    assert _run(out) == 0
    before = {p.name: p.read_text() for p in tmp_path.iterdir()}
    assert sorted(before) == ["report.md", "report_curve.png"]
    _fake_report(monkeypatch, 2, _failing(exc))
    with pytest.raises(type(exc)):
        _run(out)
    assert {p.name: p.read_text() for p in tmp_path.iterdir()} == before


def test_a_rerun_whose_report_cannot_be_written_keeps_the_earlier_one(tmp_path, monkeypatch):
    # Path.write_text cut short by a full disk left half the new report in place of the
    # earlier one
    out = tmp_path / "report.md"
    _fake_report(monkeypatch, 1, _drawing("figure 1"))
    assert _run(out) == 0
    before = {p.name: p.read_text() for p in tmp_path.iterdir()}
    write_text = Path.write_text

    def full_disk(self, text, *args, **kwargs):
        write_text(self, text[:5], *args, **kwargs)
        raise OSError(errno.ENOSPC, "No space left on device")
    _fake_report(monkeypatch, 2, _drawing("figure 2"))
    monkeypatch.setattr(Path, "write_text", full_disk)
    with pytest.raises(OSError):
        _run(out)
    monkeypatch.undo()
    assert {p.name: p.read_text() for p in tmp_path.iterdir()} == before


def test_a_successful_rerun_replaces_report_and_figure_together(tmp_path, monkeypatch, capsys):
    out = tmp_path / "report.md"
    _fake_report(monkeypatch, 1, _drawing("figure 1"))
    assert _run(out) == 0
    _fake_report(monkeypatch, 2, _drawing("figure 2"))
    assert _run(out) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report.md", "report_curve.png"]
    assert "| 2 |" in out.read_text()
    assert (tmp_path / "report_curve.png").read_text() == "figure 2"
    assert f"figure: {tmp_path / 'report_curve.png'}" in capsys.readouterr().out
