"""Review io22 of terrain.io.shipped.convert_dataset: a conversion that fails while it swaps
its files into place (an interrupt, a rename refused) leaves ``data/`` as the earlier
conversion left it, readable and with its checksums, as the docstring promises."""

from __future__ import annotations

import errno
import os
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from terrain.io.shipped import convert_dataset, read_shipped, verify_manifest
from terrain.io.writer import write_run
from terrain.run import IMU_CHANNELS, TIME, WHEEL_CHANNELS, Run

N = 60


def _tree(root: Path, level: float, imu: bool) -> Path:
    """A CSV tree of one SNOW run (100 Hz), its wheel speeds at ``level``."""
    t = np.arange(N) / 100.0
    streams = {"wheels": pd.DataFrame({TIME: t, **{c: np.full(N, level)
                                                   for c in WHEEL_CHANNELS}})}
    if imu:
        streams["imu"] = pd.DataFrame({TIME: t, **{c: np.full(N, level / 10.0)
                                                   for c in IMU_CHANNELS}})
    write_run(Run("x/SNOW/00", "x", "SNOW", streams, vehicle="husky"), root, 0)
    return root


def _state(data: Path) -> dict[str, bytes]:
    return {str(p.relative_to(data)): p.read_bytes() for p in sorted(data.rglob("*"))
            if p.is_file()}


def _refuse_replace(monkeypatch, at: int, exc: BaseException) -> dict:
    """os.replace raising ``exc`` at its ``at``-th call (the swap of the files into place);
    returns the count of calls."""
    replace, count = os.replace, {"n": 0}

    def failing(src, dst, *args, **kwargs):
        count["n"] += 1
        if count["n"] == at:
            raise exc
        return replace(src, dst, *args, **kwargs)
    monkeypatch.setattr(os, "replace", failing)
    return count


@pytest.mark.parametrize("imu_again", [True, False])
@pytest.mark.parametrize("at", [1, 2, 3, 4, 5, 6])
@pytest.mark.parametrize("exc", [KeyboardInterrupt(), OSError(errno.EIO, "I/O error")])
def test_a_conversion_failing_in_its_swap_leaves_the_earlier_one(tmp_path, monkeypatch,
                                                                 imu_again, at, exc):
    # imu.parquet and wheels.parquet were swapped in one by one, the manifest last: a
    # failure before the manifest's swap left new Parquet files under the earlier manifest,
    # whose checksums then refused every read of the dataset (the earlier conversion
    # destroyed by a failed one); now the earlier files are put back. A rename past the
    # last one the conversion makes fails nothing: the new conversion is then read whole.
    data = tmp_path / "data"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        convert_dataset(_tree(tmp_path / "a", 0.3, True), "borealtc", data)
        before = _state(data)
        src = _tree(tmp_path / "b", 0.5, imu_again)
        with monkeypatch.context() as m:
            count = _refuse_replace(m, at, exc)
            try:
                convert_dataset(src, "borealtc", data)
            except type(exc):
                failed = True
            else:
                failed = False
        assert failed == (count["n"] >= at)
        assert verify_manifest(data) == []
        (run,) = read_shipped("borealtc", data)
    if failed:
        assert _state(data) == before
        assert run.has_imu and run.streams["wheels"]["vel_l"].eq(0.3).all()
    else:
        assert run.has_imu == imu_again and run.streams["wheels"]["vel_l"].eq(0.5).all()
        assert not any(p.name.startswith(".") for p in data.rglob("*"))


def test_a_conversion_without_imu_after_one_with_it_swaps_everything(tmp_path):
    data = tmp_path / "data"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        convert_dataset(_tree(tmp_path / "a", 0.3, True), "borealtc", data)
        convert_dataset(_tree(tmp_path / "b", 0.5, False), "borealtc", data)
        assert verify_manifest(data) == []
        (run,) = read_shipped("borealtc", data)
    assert not run.has_imu and run.streams["wheels"]["vel_l"].eq(0.5).all()
    assert sorted(_state(data)) == ["borealtc/wheels.parquet", "manifest.json"]
