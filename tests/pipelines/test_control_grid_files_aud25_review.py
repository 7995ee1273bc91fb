"""What ``terrain control-grid`` leaves in ``--out`` when it fails half-way, and beside a
smaller rerun: the earlier run's files whole, never a new ``summary.json`` beside the
earlier plots, nor an earlier run's tuning table or plot beside a new report (a tiny grid,
MLflow stood in for, a failure simulated with monkeypatch)."""

from __future__ import annotations

from pathlib import Path

import pytest

from cli_helpers import RecordingRun

import pipelines.control_grid as control_grid
from terrain.cli import main


def _grid(terrain: str) -> int:
    return main(["control-grid", "--vehicles", "husky", "--terrains", terrain, "--scenarios",
                 "straight_accel", "--no-tune", "--seeds", "3", "--duration-s", "0.5",
                 "--out", "g"])


def _listing(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


@pytest.mark.slow
def test_a_failed_rerun_leaves_the_earlier_outputs_whole(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(control_grid, "tracked_run", RecordingRun())
    assert _grid("SNOW") == 0
    before = _listing(tmp_path / "g")
    assert "summary.json" in before and "slip_husky_SNOW_straight_accel.png" in before

    def full(*args, **kwargs):
        raise OSError(28, "No space left on device")
    monkeypatch.setattr(control_grid, "_plots", full)
    assert _grid("ICE") != 0
    assert _listing(tmp_path / "g") == before


@pytest.mark.slow
def test_a_rerun_keeps_no_plot_or_tuning_table_of_the_earlier_one(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(control_grid, "tracked_run", RecordingRun())
    (tmp_path / "g").mkdir()
    (tmp_path / "g" / "tuning_agrimaro.csv").write_text("of an earlier tuned run\n")
    (tmp_path / "g" / "notes.txt").write_text("the user's\n")
    assert _grid("SNOW") == 0
    assert _grid("ICE") == 0
    names = sorted(_listing(tmp_path / "g"))
    assert "slip_husky_SNOW_straight_accel.png" not in names
    assert "tuning_agrimaro.csv" not in names
    assert "notes.txt" in names and "slip_husky_ICE_straight_accel.png" in names
