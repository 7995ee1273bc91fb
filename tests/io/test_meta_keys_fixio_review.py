"""Review fixio of :func:`terrain.io.measured.read_run`: a key of a run's ``meta_XX.json``
that the reader sets itself (``repaired``, ``gaps``, ``files``...) no longer loses the user's
value without a word; runs written by :func:`terrain.io.writer.write_run` read as before."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pandas as pd
import pytest

from terrain.errors import DataWarning
from terrain.io.measured import read_folder_run
from terrain.io.writer import write_run
from terrain.run import IMU_CHANNELS, TIME, WHEEL_CHANNELS, Run


def _run(meta: dict | None = None, vehicle: str = "husky") -> Run:
    rng = np.random.default_rng(0)
    imu = pd.DataFrame({TIME: np.arange(300) / 100.0,
                        **{c: rng.normal(0.0, 0.1, 300) for c in IMU_CHANNELS}})
    imu["az"] += 9.81
    wheels = pd.DataFrame({TIME: np.arange(20) / 6.5,
                           **{c: rng.uniform(0.0, 0.5, 20) for c in WHEEL_CHANNELS}})
    return Run(run_id="x/ASPHALT/00", dataset="x", terrain="ASPHALT",
               streams={"imu": imu, "wheels": wheels}, vehicle=vehicle, source="",
               meta=dict(meta or {}))


def _with_meta(tmp_path, meta: dict):
    """A run written by write_run, its meta_00.json then replaced by ``meta``."""
    paths = write_run(_run(), tmp_path, 0)
    paths["meta"].write_text(json.dumps(meta))
    return paths["meta"]


def _read(folder):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        run = read_folder_run(folder)
    return run, [str(w.message) for w in caught if issubclass(w.category, DataWarning)]


@pytest.mark.parametrize("key, value", [("repaired", "by hand, 2024-03-02"),
                                        ("gaps", [[1.0, 2.5]]),
                                        ("files", {"video": "run3.mp4"}),
                                        ("warnings", ["wet lens"])])
def test_a_users_value_of_a_key_the_reader_sets_is_warned_not_dropped_silently(
        tmp_path, key, value):
    # {"repaired": "by hand, 2024-03-02"} came back as {} (the reader's count) without a
    # word: the user's note was lost; now the reader's value is kept (every later step
    # reads it) and a DataWarning names the file, the key and the value it replaces
    meta_path = _with_meta(tmp_path, {"note": "second lap", key: value})
    run, said = _read(tmp_path / "ASPHALT")
    assert run.meta["note"] == "second lap"
    assert run.meta[key] != value       # the reader's own value
    told = [m for m in said if "meta_00.json" in m and repr(key) in m]
    assert len(told) == 1, said
    assert str(meta_path) in told[0] and repr(value) in told[0]
    assert told[0] in run.meta["file_warnings"]     # kept with the run, as file findings


def test_a_value_equal_to_the_readers_own_is_not_warned(tmp_path):
    # what the reader would set anyway loses nothing
    _with_meta(tmp_path, {"repaired": {}, "gaps": {}, "skipped_lines": {}})
    run, said = _read(tmp_path / "ASPHALT")
    assert run.meta["repaired"] == {} and run.meta["gaps"] == {}
    assert not [m for m in said if "meta_00.json" in m], said


@pytest.mark.parametrize("vehicle", ["husky", "Husky"])
def test_a_user_vehicle_is_kept_as_given_and_read_as_the_runs_vehicle(tmp_path, vehicle):
    # the reader reads 'vehicle' (any case) but sets no key of that name: nothing replaced
    _with_meta(tmp_path, {"vehicle": vehicle})
    run, said = _read(tmp_path / "ASPHALT")
    assert run.vehicle == "husky" and run.meta["vehicle"] == vehicle
    assert not [m for m in said if "meta_00.json" in m], said


def test_a_run_written_by_write_run_reads_without_a_metadata_warning(tmp_path):
    # write_run puts 'vehicle', 'index' and 'files' (the file names) in meta_XX.json beside
    # the run's own metadata (a simulated run's): none of that is a clash
    paths = write_run(_run({"scenario": "straight", "seed": 3}), tmp_path, 0)
    written = json.loads(paths["meta"].read_text())
    assert written["files"] == {"imu": "imu_00.csv", "pro": "pro_00.csv"}
    run, said = _read(tmp_path / "ASPHALT")
    assert not [m for m in said if "meta_00.json" in m], said
    assert run.meta["files"]["pro"] == str(paths["pro"])
    assert run.meta["scenario"] == "straight" and run.meta["index"] == "00"
    assert not [m for m in run.meta["file_warnings"] if "meta_00.json" in m]
