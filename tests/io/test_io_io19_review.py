"""Review io19: readers, writer, shipped converter and windowing.

Each test names the input that went wrong before its fix (see the commit that added it).
"""

from __future__ import annotations

import os
import warnings

import numpy as np
import pandas as pd
import pytest

from terrain.io.shipped import convert_dataset, read_shipped
from terrain.io.writer import write_run
from terrain.run import IMU_CHANNELS, TIME, WHEEL_CHANNELS, Run


def _husky_run(terrain: str = "ICE", n_imu: int = 400, n_wheels: int = 60) -> Run:
    """A plausible Husky run: IMU at 100 Hz, wheels at 15 Hz."""
    rng = np.random.default_rng(3)
    t_i, t_w = np.arange(n_imu) / 100.0, np.arange(n_wheels) / 15.0
    imu = pd.DataFrame({TIME: t_i, **{c: rng.normal(0.0, 0.05, n_imu) for c in IMU_CHANNELS}})
    imu["az"] += 9.81
    wheels = pd.DataFrame({TIME: t_w, **{c: rng.normal(0.3, 0.01, n_wheels)
                                         for c in WHEEL_CHANNELS}})
    return Run(run_id="mem/00", dataset="mem", terrain=terrain,
               streams={"imu": imu, "wheels": wheels})


def test_convert_takes_a_terrain_folder_whose_name_is_not_utf8(tmp_path):
    """A terrain folder named with a byte that is not UTF-8 (``ic\\xff``) made ``terrain
    convert`` fail with a bare UnicodeEncodeError when it wrote the Parquet file; it now
    names the run as the CSV readers do (the byte as a ``\\xff`` escape), and the shipped
    copy reads back under that id and label."""
    src = tmp_path / "src"
    write_run(_husky_run(), src)
    try:
        os.rename(src / "ICE", os.fsencode(src) + b"/ic\xff")
    except OSError:     # a file system that takes UTF-8 names only
        pytest.skip("the file system refuses a name that is not UTF-8")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        entry = convert_dataset(src, "borealtc", tmp_path / "data")
        runs = read_shipped("borealtc", tmp_path / "data")
    assert [r["run_id"] for r in entry["runs"]] == ["borealtc/ic\\xff/00"]
    assert entry["terrains"] == ["IC\\XFF"]
    assert [(r.run_id, r.terrain) for r in runs] == [("borealtc/ic\\xff/00", "IC\\XFF")]
