"""Review io22 of terrain.io.writer: a :func:`write_run` that fails half-way (a full disk, an
interrupt) leaves no run that the readers take as complete, and no file of it at all."""

from __future__ import annotations

import errno
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from terrain.io.measured import read_folder_run
from terrain.io.writer import write_run
from terrain.run import IMU_CHANNELS, TIME, WHEEL_CHANNELS, Run

N = 12


def _run() -> Run:
    t = np.arange(N) / 10.0
    imu = pd.DataFrame({TIME: t, **{c: np.linspace(0.0, 0.1, N) for c in IMU_CHANNELS}})
    wheels = pd.DataFrame({TIME: t, **{c: np.linspace(0.1, 0.4, N) for c in WHEEL_CHANNELS}})
    truth = pd.DataFrame({TIME: t, "x": np.linspace(0.0, 1.0, N)})
    return Run("sim/SNOW/00", "sim", "SNOW", {"imu": imu, "wheels": wheels, "truth": truth},
               vehicle="tracked", meta={"seed": 3})


def _fail_at(monkeypatch, calls: int, exc: BaseException) -> None:
    """Make the ``calls``-th file write of write_run (its CSV files, then its meta) raise
    ``exc`` once that file is written (a disk full at its end, an interrupt)."""
    count = {"n": 0}
    to_csv, write_text = pd.DataFrame.to_csv, Path.write_text

    def tick():
        count["n"] += 1
        if count["n"] == calls:
            raise exc

    def failing_to_csv(self, *args, **kwargs):
        to_csv(self, *args, **kwargs)
        tick()

    def failing_write_text(self, *args, **kwargs):
        write_text(self, *args, **kwargs)
        tick()
    monkeypatch.setattr(pd.DataFrame, "to_csv", failing_to_csv)
    monkeypatch.setattr(Path, "write_text", failing_write_text)


def _names(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir()) if folder.exists() else []


@settings(max_examples=12, deadline=None)
@given(calls=st.integers(1, 4),
       exc=st.sampled_from([OSError(errno.ENOSPC, "No space left on device"),
                            KeyboardInterrupt()]))
def test_a_write_failing_half_way_leaves_no_file(tmp_path_factory, calls, exc):
    # imu_00.csv and pro_00.csv were left when truth_00.csv or meta_00.json failed: the
    # readers took them as a complete measured run of the default vehicle (the Husky), the
    # simulated tracked vehicle and its metadata lost without a word; now nothing is left
    out = tmp_path_factory.mktemp("runs")
    with pytest.MonkeyPatch.context() as monkeypatch:
        _fail_at(monkeypatch, calls, exc)
        with pytest.raises(type(exc)):
            write_run(_run(), out, 0)
    assert _names(out / "SNOW") == []
    # the index is free again: the same run written afterwards reads back whole
    paths = write_run(_run(), out, 0)
    assert _names(out / "SNOW") == sorted(p.name for p in paths.values())
    run = read_folder_run(out / "SNOW", "00")
    assert run.vehicle == "tracked" and run.meta["seed"] == 3
    assert set(run.streams) == {"imu", "wheels", "truth"}


def test_a_successful_write_leaves_no_temporary_file(tmp_path):
    paths = write_run(_run(), tmp_path, 4)
    assert sorted(paths) == ["imu", "meta", "pro", "truth"]
    assert _names(tmp_path / "SNOW") == sorted(p.name for p in paths.values())


@pytest.mark.parametrize("at", [1, 2, 3, 4])
def test_a_rename_failing_leaves_no_file(tmp_path, monkeypatch, at):
    # the files renamed into place before a refused (or interrupted) rename are removed too
    import os

    replace, count = os.replace, {"n": 0}

    def failing(src, dst, *args, **kwargs):
        count["n"] += 1
        if count["n"] == at:
            raise KeyboardInterrupt
        return replace(src, dst, *args, **kwargs)
    monkeypatch.setattr(os, "replace", failing)
    with pytest.raises(KeyboardInterrupt):
        write_run(_run(), tmp_path, 0)
    assert _names(tmp_path / "SNOW") == []
