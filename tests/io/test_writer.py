"""The writer of the measured-run layout (:mod:`terrain.io.writer`): what it writes the readers
read back."""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pytest

from terrain.errors import ConfigError
from terrain.io.measured import read_runs_dir
from terrain.io.writer import FLOAT_FORMAT, write_run
from terrain.run import IMU_CHANNELS, TIME, WHEEL_CHANNELS, Run


def _run(t0_s: float, n_imu: int = 300, n_wheels: int = 40, seed: int = 0) -> Run:
    """A small Husky run whose clocks start at ``t0_s``."""
    rng = np.random.default_rng(seed)
    imu = pd.DataFrame({TIME: t0_s + np.arange(n_imu) / 100.0,
                        **{c: rng.normal(0.0, 0.1, n_imu) for c in IMU_CHANNELS}})
    imu["az"] += 9.81
    wheels = pd.DataFrame({TIME: t0_s + np.arange(n_wheels) / 6.5,
                           **{c: rng.uniform(0.0, 0.5, n_wheels) for c in WHEEL_CHANNELS}})
    return Run(run_id="x/ASPHALT/00", dataset="x", terrain="ASPHALT",
               streams={"imu": imu, "wheels": wheels}, vehicle="husky", source="", meta={})


@pytest.mark.parametrize("t0_s", [0.0, 1234.5, 1.7e9])
def test_a_written_run_reads_back_with_its_timestamps(tmp_path, t0_s):
    """An epoch clock (1.7e9 s) written with 9 significant digits became whole seconds: the
    written IMU file held 300 rows at 1700000000 and its reading raised TimestampError
    'duplicated timestamp 1700000000.0 after 1700000000.0 (299 such row(s) ...)'. A clock
    that the number format cannot keep in order is written exactly."""
    run = _run(t0_s)
    write_run(run, tmp_path, 0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        back = read_runs_dir(tmp_path)[0]
    for name, frame in run.streams.items():
        t = back.streams[name][TIME].to_numpy()
        assert np.all(np.diff(t) > 0)
        as_written = np.array([float(FLOAT_FORMAT % x) for x in frame[TIME]])
        if np.all(np.diff(as_written) > 0):   # the usual clock: written as before
            np.testing.assert_array_equal(t, as_written)
        else:
            np.testing.assert_array_equal(t, frame[TIME].to_numpy())
        np.testing.assert_allclose(back.streams[name][frame.columns].to_numpy(),
                                   frame.to_numpy(), rtol=1e-8, atol=0)


def test_the_run_vehicle_is_written_not_a_stale_one_of_its_meta(tmp_path):
    # meta.setdefault kept a 'vehicle' of run.meta: a husky run read back as 'tracked'
    run = _run(0.0)
    run = Run(run.run_id, run.dataset, run.terrain, run.streams, vehicle="husky",
              meta={"vehicle": "tracked"})
    write_run(run, tmp_path, 0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        back = read_runs_dir(tmp_path)[0]
    assert back.vehicle == "husky" and back.meta["vehicle"] == "husky"


@pytest.mark.parametrize("terrain, stream, words", [
    ("A/B", None, "is not a folder name"), ("..", None, "is not a folder name"),
    ("ASPHALT", "meta", "not 'meta'"),
    # a lower-case label: the readers upper-case the folder name, so 'snow' came back SNOW
    ("snow", None, "would be read back as 'SNOW'"),
    ("Sandy_Loam", None, "would be read back as 'SANDY_LOAM'")])
def test_what_would_not_read_back_is_refused_before_anything_is_written(
        tmp_path, terrain, stream, words):
    # a stream 'meta' became meta_00.csv, shadowed by meta_00.json when read back: the
    # stream was lost without a word; terrain 'A/B' wrote A/B/, where no reader looks
    run = _run(0.0)
    streams = dict(run.streams)
    if stream:
        streams[stream] = run.streams["wheels"][[TIME, "vel_l"]]
    run = Run(run.run_id, run.dataset, terrain, streams)
    with pytest.raises(ConfigError, match=words):
        write_run(run, tmp_path / "out", 0)
    assert not (tmp_path / "out").exists()


def test_a_meta_csv_file_is_named_not_shadowed_by_the_metadata(tmp_path):
    from terrain.errors import DataFormatError

    write_run(_run(0.0), tmp_path, 0)
    (tmp_path / "ASPHALT" / "meta_00.csv").write_text("time,x\n0,1\n1,2\n")
    with pytest.raises(DataFormatError, match="a stream cannot be named meta"):
        read_runs_dir(tmp_path)


def test_the_default_index_is_the_smallest_free_one_up_to_99(tmp_path):
    """Index 99 is the last one the two-digit layout has: a folder using 00-98 (and a gap
    at 05) gets 05, then 99, then no more."""
    from terrain.errors import ConfigError

    folder = tmp_path / "ASPHALT"
    folder.mkdir()
    for i in range(99):
        if i != 5:
            (folder / f"note_{i:02d}.txt").write_text("")
    assert write_run(_run(0.0), tmp_path)["pro"].name == "pro_05.csv"
    assert write_run(_run(0.0), tmp_path)["meta"].name == "meta_99.json"
    with pytest.raises(ConfigError, match="already holds runs 00-99"):
        write_run(_run(0.0), tmp_path)


def test_two_streams_that_go_to_one_file_are_refused_before_anything_is_written(tmp_path):
    # 'wheels' is written as pro_XX.csv, and so was a stream named 'pro': the second
    # silently overwrote the first, and the run read back had lost its wheel stream
    from dataclasses import replace

    from terrain.errors import ConfigError

    run = _run(0.0)
    pro = run.streams["wheels"].copy()
    pro["vel_l"] += 1.0
    both = replace(run, streams={**run.streams, "pro": pro})
    with pytest.raises(ConfigError, match=r"streams 'wheels' and 'pro' would both be written "
                                          r"to pro_XX\.csv"):
        write_run(both, tmp_path, 0)
    assert not (tmp_path / "ASPHALT").exists()


@pytest.mark.parametrize("index", [True, 2.7, "3", None])
def test_an_index_that_is_not_an_integer_of_the_layout_is_refused_before_writing(
        tmp_path, index):
    # True was written as run 01 and 2.7 as run 02 without a word, and "x" raised int()'s
    # bare ValueError
    from terrain.errors import ConfigError

    if index is None:       # the default: the next free index
        assert write_run(_run(0.0), tmp_path / "out")["meta"].name == "meta_00.json"
        assert write_run(_run(0.0), tmp_path / "out", np.int64(7))["pro"].name == "pro_07.csv"
        return
    with pytest.raises(ConfigError, match=r"write_run.index must be an integer in \[0, 99\], "
                                          rf"got {index!r}"):
        write_run(_run(0.0), tmp_path / "out", index)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("stream, row, value, word", [
    ("imu", 120, 1.0, "decreasing"), ("wheels", 7, None, "duplicated"),
    ("wheels", 0, np.nan, "non-finite"), ("imu", 299, np.inf, "non-finite")])
def test_timestamps_the_readers_refuse_are_refused_before_anything_is_written(
        tmp_path, stream, row, value, word):
    """A stream whose timestamps do not increase strictly, or hold NaN or inf, was written
    without a word and its file refused at reading (TimestampError, NonFiniteError): the
    run could not be read back. It is refused at writing, naming the stream, the run and
    the row, and nothing is written."""
    run = _run(0.0)
    t = run.streams[stream][TIME].to_numpy().copy()
    t[row] = t[row - 1] if value is None else value
    run.streams[stream] = run.streams[stream].assign(**{TIME: t})
    with pytest.raises(ConfigError) as err:
        write_run(run, tmp_path, 0)
    msg = str(err.value)
    assert f"stream {stream!r} of run x/ASPHALT/00" in msg and f"row {row}" in msg, msg
    assert word in msg, msg
    assert not any(tmp_path.iterdir())


def test_a_file_where_the_terrain_folder_goes_is_refused_before_anything_is_simulated(
        tmp_path, capsys):
    # terrain simulate simulated the run, then failed on mkdir with a bare "File exists"
    from terrain.cli import main
    from terrain.io.writer import free_index
    (tmp_path / "GRASS").write_text("not a folder")
    with pytest.raises(ConfigError, match="GRASS is a file, not a terrain folder"):
        free_index(tmp_path / "GRASS")
    assert main(["simulate", "--vehicle", "husky", "--terrain", "GRASS", "--scenario",
                 "spin", "--duration-s", "0.5", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "is a file, not a terrain folder" in err and "Traceback" not in err
    assert (tmp_path / "GRASS").read_text() == "not a folder"
