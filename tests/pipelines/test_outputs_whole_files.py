"""Outputs written whole or not at all: `terrain estimate`'s per-run tables and the
live-sim classifier's cache record (pipelines/estimate.py, pipelines/control_classifier.py).

A write that fails half-way (a full disk, Ctrl-C) must neither leave half a file that a
later step reads as whole nor destroy the file of an earlier run."""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd
import pytest

from pipelines.control_classifier import sim_classifier
from terrain.cli import main

#: one 4 s straight run per terrain, one seed (tests/control/test_sim_classifier_training.py)
FAST = dict(seeds=(2000,), scenarios=("straight_accel",), duration_s=4.0)


def _full_disk_half_way(written: str) -> OSError:
    """What a full disk raises once half of ``written`` is on it."""
    return OSError(28, f"No space left on device (after {len(written) // 2} characters)")


@pytest.mark.slow
def test_estimate_keeps_the_earlier_table_when_the_rewrite_fails(tmp_path, monkeypatch,
                                                                 capsys):
    run_dir = tmp_path / "sim"
    assert main(["simulate", "--vehicle", "husky", "--terrain", "ICE", "--duration-s", "3",
                 "--out", str(run_dir)]) == 0
    out = tmp_path / "est" / "state.csv"
    assert main(["estimate", "--out", str(out), str(run_dir)]) == 0
    before = out.read_text()
    assert len(pd.read_csv(out)) > 10
    real = pd.DataFrame.to_csv

    def half(self, target=None, *args, **kwargs):
        text = real(self, None, *args, **kwargs)
        Path(target).write_text(text[:len(text) // 2])
        raise _full_disk_half_way(text)

    monkeypatch.setattr(pd.DataFrame, "to_csv", half)
    assert main(["estimate", "--out", str(out), str(run_dir)]) != 0
    capsys.readouterr()
    assert out.read_text() == before
    assert sorted(p.name for p in out.parent.iterdir()) == ["state.csv"]


@pytest.mark.slow
def test_the_classifier_cache_holds_no_cut_short_record(tmp_path, monkeypatch):
    # info.json cut short by a full disk stood beside the model, and the next call read
    # the cache as complete and failed in json.loads; now the record is whole or absent,
    # and the next call trains again
    real = Path.write_text
    failed = []

    def half(self, data, *args, **kwargs):
        if "info.json" not in self.name:
            return real(self, data, *args, **kwargs)
        real(self, data[:len(data) // 2])
        failed.append(self.name)
        raise _full_disk_half_way(data)

    monkeypatch.setattr(Path, "write_text", half)
    with pytest.raises(OSError, match="No space left"):
        sim_classifier("husky", ("SNOW", "ICE"), cache_dir=tmp_path, **FAST)
    monkeypatch.undo()
    assert failed
    assert list(tmp_path.glob("*/info.json")) == []
    path, info = sim_classifier("husky", ("SNOW", "ICE"), cache_dir=tmp_path, **FAST)
    assert not info["cached"]
    assert json.loads((path.parent / "info.json").read_text())["key"] == info["key"]
    assert sorted(p.name for p in path.parent.iterdir()) == ["info.json", "model"]
