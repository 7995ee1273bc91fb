"""Review io19: readers, writer, shipped converter and windowing.

Each test names the input that went wrong before its fix (see the commit that added it).
"""

from __future__ import annotations

import os
import tempfile
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from terrain.errors import ConfigError, DataWarning, MissingColumnError, NonNumericError
from terrain.io.measured import read_runs_dir, read_stream_csv
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


@pytest.mark.parametrize("stream, column, rows, value", [
    ("wheels", "cur_l", [0], np.nan),           # at the edge: the readers refuse the file
    ("wheels", "vel_r", [5, 6, 7], np.nan),     # a burst: refused too
    ("imu", "wz", [17], np.inf),                # isolated: read back interpolated, not inf
    ("imu", "ax", [399], -np.inf),
])
def test_a_non_finite_channel_value_is_refused_not_written(tmp_path, stream, column, rows,
                                                           value):
    """A NaN or inf sample of a channel was written (an empty cell or ``inf``) without a
    word: the readers then refused the file (at its edge, or in a burst of more than two)
    or gave back another value (an isolated one interpolated). ``write_run`` now refuses
    it as it refuses a non-finite timestamp, naming stream, column and row, and writes
    nothing."""
    run = _husky_run()
    run.streams[stream].loc[rows, column] = value
    with pytest.raises(ConfigError) as info:
        write_run(run, tmp_path)
    text = str(info.value)
    assert f"stream {stream!r}" in text and f"column {column!r}" in text
    assert f"row {rows[0]}" in text and f"{len(rows)} non-finite" in text
    assert not any(tmp_path.iterdir())


def test_finite_channels_still_read_back_to_nine_digits(tmp_path):
    """The refusal leaves finite runs alone: they read back to 9 significant digits."""
    run = _husky_run()
    write_run(run, tmp_path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        (back,) = read_runs_dir(tmp_path)
    for name, frame in run.streams.items():
        np.testing.assert_allclose(back.streams[name][frame.columns].to_numpy(),
                                   frame.to_numpy(), rtol=5e-9, atol=0)


def test_convert_says_which_run_metadata_the_shipped_format_leaves_out(tmp_path):
    """The keys of a run's ``meta_XX.json`` (an operator, a tyre pressure) were dropped by
    ``terrain convert`` without a word, while left-out stream files were warned about; they
    are now warned about too, counted per key. The vehicle (checked against the dataset's)
    and the index and file names the writer records (the run id and files say them) are
    not data the shipped copy lacks."""
    run = _husky_run()
    run.meta.update(operator="jd", tire_pressure_kpa=180)
    write_run(run, tmp_path / "src")
    write_run(_husky_run(), tmp_path / "src")
    with pytest.warns(DataWarning, match=r"metadata key\(s\) left out.*operator \(1 run"
                                         r"\(s\)\), tire_pressure_kpa \(1 run\(s\)\)") as info:
        convert_dataset(tmp_path / "src", "borealtc", tmp_path / "data")
    (text,) = [str(w.message) for w in info if "metadata" in str(w.message)]
    assert text.endswith("): operator (1 run(s)), tire_pressure_kpa (1 run(s))")


def test_convert_of_runs_without_metadata_keys_warns_none(tmp_path):
    """Runs whose metadata holds only what the writer records give no such warning."""
    write_run(_husky_run(), tmp_path / "src")
    with warnings.catch_warnings(record=True) as found:
        warnings.simplefilter("always")
        convert_dataset(tmp_path / "src", "borealtc", tmp_path / "data")
    assert not [w for w in found if "metadata" in str(w.message)]


@pytest.mark.slow
@settings(max_examples=30, deadline=None, derandomize=True)
@given(t0=st.sampled_from([0.0, 1234.5, 86400.0 * 4, 1.0e6, 3.3e6, 1.7e9]),
       wheel_hz=st.sampled_from([6.5, 15.0, 20.0, 66.0]))
def test_a_written_clock_reads_back_within_a_hundredth_of_its_step(t0, wheel_hz):
    """A clock far from 0 (a robot's seconds since boot after 12 days, 1e6 s) was written
    with 9 significant digits whenever they kept it increasing: a 15 Hz wheel clock lost
    its third decimal and read back up to 0.005 s (7.5 % of a step) off, its steps
    alternating 0.06 and 0.07 s. A clock that 9 digits move by more than a hundredth of its
    median step is now written exactly."""
    run = _husky_run()
    run.streams["imu"][TIME] += t0
    wheels = run.streams["wheels"]
    wheels[TIME] = t0 + np.arange(len(wheels)) / wheel_hz
    with tempfile.TemporaryDirectory() as tmp:
        write_run(run, tmp)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            (back,) = read_runs_dir(tmp)
    for name, frame in run.streams.items():
        t, t_back = frame[TIME].to_numpy(), back.streams[name][TIME].to_numpy()
        step = float(np.median(np.diff(t)))
        assert np.max(np.abs(t_back - t)) <= 0.01 * step, name


@pytest.mark.parametrize("kind, log", [
    ("truth", "time,x\n0,1\n0.01,2\n0.02,3\n"),
    ("pro", "time,curL,curR,velL,velR\n0,1,1,0.3,0.3\n0.1,1,1,0.3,0.3\n"),
])
def test_two_logs_with_a_byte_order_mark_joined_are_named_as_joined(tmp_path, kind, log):
    """Two logs that each start with a UTF-8 byte-order mark (as Excel and Windows tools
    save CSV), joined with ``cat``, were refused as holding the non-numeric value
    ``'\\ufefftime'``: the hint that the line repeats the header (two logs joined) was given
    only without the mark. It is now given with it too, and says the mark is there."""
    path = tmp_path / f"{kind}_00.csv"
    path.write_bytes(("\ufeff" + log + "\ufeff" + log).encode())
    second = log.count("\n") + 1
    with pytest.raises(NonNumericError) as info:
        read_stream_csv(path, kind)
    assert f"line {second} repeats the header (two logs joined" in str(info.value)
    assert "byte-order mark" in str(info.value)
    assert (info.value.line, info.value.column) == (second, "time")


def test_a_new_conversion_without_imu_runs_removes_the_old_imu_file(tmp_path):
    """Converting a dataset again from runs without an IMU file left the imu.parquet of the
    earlier conversion in place, unlisted: every read of the dataset then failed ('does not
    list borealtc/imu.parquet, which exists ... regenerate data/ with terrain convert', the
    command just run). The stream files the new conversion does not write are removed."""
    write_run(_husky_run(), tmp_path / "with_imu")
    wheel_only = _husky_run()
    wheel_only = Run("mem/01", "mem", "ICE", {"wheels": wheel_only.streams["wheels"]})
    write_run(wheel_only, tmp_path / "without_imu")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        convert_dataset(tmp_path / "with_imu", "borealtc", tmp_path / "data")
        entry = convert_dataset(tmp_path / "without_imu", "borealtc", tmp_path / "data")
        runs = read_shipped("borealtc", tmp_path / "data")
    assert sorted(p.name for p in (tmp_path / "data" / "borealtc").iterdir()) == [
        "wheels.parquet"]
    assert list(entry["files"]) == ["borealtc/wheels.parquet"]
    assert [sorted(r.streams) for r in runs] == [["wheels"]]
    assert entry["runs_without_imu"] == ["borealtc/ICE/00"]


@pytest.mark.parametrize("before", ["\ufeff\ufeff", "# logged by a tool\n\ufeff"])
def test_a_byte_order_mark_the_reader_keeps_in_the_header_is_named(tmp_path, before):
    """A byte-order mark that is not the file's first character (a second one, or one after
    a comment line) stays in the first header name: the file was refused as missing column
    'time' beside a found '\\ufefftime', without saying what that is. The message now says a
    byte-order mark leads the header."""
    path = tmp_path / "pro_00.csv"
    path.write_bytes((before + "time,curL,curR,velL,velR\n0,1,1,0.3,0.3\n0.1,1,1,0.3,0.3\n"
                      ).encode())
    with pytest.raises(MissingColumnError) as info:
        read_stream_csv(path, "pro")
    assert "byte-order mark" in str(info.value)
    assert (info.value.column, info.value.line) == ("time", before.count("\n") + 1)


@pytest.mark.parametrize("stream, drop, missing", [
    ("truth", TIME, "time"),           # an extra stream without its clock
    ("imu", TIME, "time"),
    ("imu", "az", "az"),               # a canonical channel the readers require
    ("wheels", "cur_r", "curR"),
])
def test_a_stream_lacking_a_column_the_readers_require_is_refused_not_written(
        tmp_path, stream, drop, missing):
    """A stream without ``t_s`` (or an IMU or wheel stream without one of its canonical
    channels) was written without a word, and the readers then refused the file (missing
    column 'time', 'az', 'curR'); ``write_run`` now refuses it naming the stream and the
    file's column, and writes nothing."""
    run = _husky_run()
    streams = dict(run.streams)
    if stream == "truth":
        streams["truth"] = pd.DataFrame({TIME: run.streams["wheels"][TIME], "x": 1.0})
    streams[stream] = streams[stream].drop(columns=[drop])
    run = Run(run.run_id, run.dataset, run.terrain, streams)
    with pytest.raises(ConfigError) as info:
        write_run(run, tmp_path)
    assert f"stream {stream!r}" in str(info.value) and repr(missing) in str(info.value)
    assert not any(tmp_path.iterdir())


_EDIT = st.one_of(
    st.tuples(st.just("value"), st.sampled_from(["imu", "wheels", "truth"]), st.integers(0, 10),
              st.integers(0, 399), st.sampled_from([np.nan, np.inf, -np.inf, 0.25])),
    st.tuples(st.just("drop"), st.sampled_from(["imu", "wheels", "truth"]), st.integers(0, 10)),
    st.tuples(st.just("shift"), st.sampled_from([0.0, 1e5, 1e6, 1.7e9])),
)


def _edited(edits) -> Run:
    run = _husky_run()
    streams = {k: v.copy() for k, v in run.streams.items()}
    streams["truth"] = pd.DataFrame({TIME: np.arange(120) / 20.0,
                                     "x": np.linspace(0.0, 3.0, 120), "label": "ICE"})
    for edit in edits:
        if edit[0] == "value":
            _, name, col, row, value = edit
            frame = streams[name]
            columns = [c for c in frame.columns if c != TIME and frame[c].dtype.kind == "f"]
            frame.loc[frame.index[row % len(frame)], columns[col % len(columns)]] = value
        elif edit[0] == "drop":
            _, name, col = edit
            frame = streams[name]
            streams[name] = frame.drop(columns=[frame.columns[col % len(frame.columns)]])
        else:
            for frame in streams.values():
                if TIME in frame:
                    frame[TIME] += edit[1]
    return Run(run.run_id, run.dataset, run.terrain, streams)


@pytest.mark.slow
@settings(max_examples=40, deadline=None, derandomize=True)
@given(edits=st.lists(_EDIT, max_size=3))
def test_write_run_refuses_or_the_readers_give_the_run_back(edits):
    """For any run edited by non-finite or changed samples, dropped columns and clocks far
    from 0: ``write_run`` raises ConfigError and writes nothing, or the readers read the
    files back without an error, with the same streams and columns, every value to 9
    significant digits and every timestamp to a hundredth of its median step."""
    run = _edited(edits)
    with tempfile.TemporaryDirectory() as tmp:
        try:
            write_run(run, tmp)
        except ConfigError:
            assert not any(Path(tmp).iterdir())
            return
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            (back,) = read_runs_dir(tmp)
    assert set(back.streams) == set(run.streams)
    for name, frame in run.streams.items():
        got = back.streams[name]
        assert set(got.columns) == set(frame.columns)
        t = frame[TIME].to_numpy()
        assert np.max(np.abs(got[TIME].to_numpy() - t)) <= 0.01 * np.median(np.diff(t))
        numbers = [c for c in frame.columns if c != TIME and frame[c].dtype.kind == "f"]
        np.testing.assert_allclose(got[numbers].to_numpy(), frame[numbers].to_numpy(),
                                   rtol=5e-9, atol=0)
        text = [c for c in frame.columns if frame[c].dtype.kind == "O"]
        assert got[text].equals(frame[text])


@pytest.mark.parametrize("times", [[], [np.array([0.0, 1.0]), np.array([])]])
def test_overlap_grid_without_a_sample_in_every_stream_is_a_config_error(times):
    """io19's left-alone: no stream, or an empty one, raised Python's bare ValueError
    (``max() arg is an empty sequence``) or IndexError."""
    from terrain.io.align import overlap_grid, overlap_grid_tail

    with pytest.raises(ConfigError, match="overlap_grid needs at least one stream"):
        overlap_grid(times, 10.0)
    with pytest.raises(ConfigError, match="overlap_grid_tail needs at least one stream"):
        overlap_grid_tail(times, 10.0, 1.0, 3)
