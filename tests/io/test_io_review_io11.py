"""Review tests of terrain.io (pass io11): line numbers of JSON files as an editor shows
them, and behaviours hand mutants showed unpinned."""

import json
import tempfile
import warnings

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from terrain.errors import (ConfigError, DataFormatError, EncodingError, NonFiniteError,
                            NonNumericError, RaggedRowError)
from terrain.io.measured import read_runs_dir, read_stream_csv, text_place
from terrain.io.report import input_report
from terrain.io.shipped import convert_dataset, dataset_entry, read_manifest
from terrain.io.writer import next_index, used_indexes, write_run
from terrain.run import Run

PRO = "time,velL,velR,curL,curR\n" + "".join(
    f"{i * 0.1:.1f},0.5,0.5,2.0,2.1\n" for i in range(30))
#: a metadata file whose third line holds the error (a doubled comma), column 12
BAD_JSON_LINES = ["{", ' "vehicle": "husky",', ' "seed": 3,,', "}"]


def _meta_error(tmp_path, text: str) -> DataFormatError:
    folder = tmp_path / "runs" / "ICE"
    folder.mkdir(parents=True)
    (folder / "pro_00.csv").write_text(PRO)
    (folder / "meta_00.json").write_bytes(text.encode())
    with pytest.raises(DataFormatError, match="invalid JSON") as info:
        read_runs_dir(tmp_path / "runs")
    return info.value


@pytest.mark.parametrize("end", ["\n", "\r\n", "\r"])
def test_invalid_run_metadata_names_the_editor_line_whatever_the_line_ends(tmp_path, end):
    # a lone CR ends a line as the CSV reader and read_text count it (classic Mac OS): the
    # JSON parser counted LF only, and named line 1, column 35 for line 3, column 12
    err = _meta_error(tmp_path, end.join(BAD_JSON_LINES) + end)
    assert err.line == 3
    assert "column 12" in str(err) and "line 3" in str(err)


@pytest.mark.parametrize("end", ["\n", "\r\n", "\r"])
def test_unreadable_manifest_names_the_editor_line_whatever_the_line_ends(tmp_path, end):
    (tmp_path / "manifest.json").write_bytes(end.join(BAD_JSON_LINES).encode())
    with pytest.raises(DataFormatError, match=r"invalid JSON: .*column 12\)") as info:
        read_manifest(tmp_path)
    assert info.value.line == 3


def test_invalid_json_control_character_line_is_its_own(tmp_path):
    # a raw CR LF inside a string: the error points at its CR, on the line it ends
    text = '{\r\n "vehicle": "hus\r\nky"\r\n}\r\n'
    with pytest.raises(json.JSONDecodeError):
        json.loads(text)
    err = _meta_error(tmp_path, text)
    assert err.line == 2


@pytest.mark.parametrize("after", ["\n# end of log", "\n   ", "\n# end of log\n"])
def test_a_short_last_row_followed_by_a_line_is_not_said_cut_off(tmp_path, after):
    # the hint "it is the last line and has no line break" was given whenever the file
    # ended without a line break, though a comment or blank line followed the short row
    rows = PRO.splitlines()
    rows[-1] = rows[-1].rsplit(",", 1)[0]            # line 31: 4 fields of 5
    path = tmp_path / "pro_00.csv"
    path.write_text("\n".join(rows) + after)
    with pytest.raises(RaggedRowError) as info:
        read_stream_csv(path, "pro")
    assert info.value.line == 31 and "no line break" not in str(info.value)


def test_a_short_last_line_without_a_line_break_is_said_cut_off(tmp_path):
    rows = PRO.splitlines()
    rows[-1] = rows[-1].rsplit(",", 1)[0]
    path = tmp_path / "pro_00.csv"
    path.write_text("\n".join(rows))
    with pytest.raises(RaggedRowError, match="it is the last line and has no line break"):
        read_stream_csv(path, "pro")


def test_an_extra_stream_with_a_text_clock_is_refused_as_non_numeric(tmp_path):
    # a text column of an extra stream is a string channel (a per-sample terrain label); the
    # clock never is: read as one, the time checks met text (a bare TypeError)
    path = tmp_path / "truth_00.csv"
    path.write_text("time,x\n" + "".join(f"t{i},{i}\n" for i in range(5)))
    with pytest.raises(NonNumericError) as info:
        read_stream_csv(path, "truth")
    assert (info.value.column, info.value.line) == ("time", 2)


def test_an_extra_stream_keeps_a_text_channel_as_text(tmp_path):
    path = tmp_path / "truth_00.csv"
    path.write_text("time,terrain\n" + "".join(f"{i * 0.1:.1f},SNOW\n" for i in range(5)))
    frame, _ = read_stream_csv(path, "truth")
    assert list(frame["terrain"]) == ["SNOW"] * 5


def test_used_indexes_pass_over_a_name_ending_in_a_superscript_digit(tmp_path):
    # "²".isdigit() is True but int("²") a bare ValueError: a note named scan_².txt in a
    # terrain folder stopped every write_run there
    (tmp_path / "scan_².txt").write_text("12")
    (tmp_path / "imu_03.csv").write_text("")
    (tmp_path / "meta_٠٤.json").write_text("{}")      # Arabic-Indic 04: a decimal index
    assert used_indexes(tmp_path) == {3, 4}
    assert next_index(tmp_path) == 0


def test_a_run_not_windowed_has_windows_minus_one_and_other_window_columns_zero():
    # the docstrings said every window column is -1 without window counts: only ``windows``
    # is; the counts are 0 and the metrics leave such runs out of the window totals
    frame = pd.DataFrame({"t_s": [0.0, 1.0], "vel_l": [0.1, 0.2]})
    used = Run("r/used", "r", "SNOW", {"wheels": frame})
    none = Run("r/none", "r", "SNOW", {"wheels": frame})
    counts = {"per_run": {"r/used": {"windows": 10, "dropped_gap": 2, "dropped_unsteady": 1,
                                     "partition_tail_s": 0.5, "window_tail_s": 0.25}}}
    report = input_report([used, none], counts)
    row = report.table.set_index("run_id").loc["r/none"]
    assert row["windows"] == -1
    assert [row[c] for c in ("dropped_gap", "empty_gap", "dropped_unsteady",
                             "partition_tail_s", "window_tail_s")] == [0, 0, 0, 0.0, 0.0]
    m = report.metrics("")
    assert (m["windows_dropped_gap"], m["windows_dropped_unsteady"]) == (2.0, 1.0)
    assert (m["partition_tail_s"], m["window_tail_s"]) == (0.5, 0.25)


@pytest.mark.parametrize("imu_hz, warned", [(54.0, False), (46.0, False), (56.0, True),
                                            (44.0, True), (75.0, True)])
def test_convert_warns_of_an_imu_rate_more_than_a_tenth_from_the_datasets(
        tmp_path, synth_imu, synth_pro, write_run, imu_hz, warned):
    # Vulpi's windows are aligned at its native 50 Hz: an IMU at 56 Hz is resampled there;
    # a warning at 10 % (not only at the 100 % of a BorealTC run) says so
    write_run(tmp_path / "csv", "CONCRETE", "00", imu=synth_imu(duration_s=20.0,
                                                                rate_hz=imu_hz),
              pro=synth_pro(duration_s=20.0, rate_hz=15.0))
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        convert_dataset(tmp_path / "csv", "vulpi", tmp_path / "data")
    said = [str(w.message) for w in seen if "IMU runs at" in str(w.message)]
    assert bool(said) == warned
    if warned:
        assert f"IMU runs at {imu_hz:g} Hz, dataset 'vulpi' at 50 Hz" in said[0]


def test_a_stream_named_pro_alone_is_refused_not_read_back_as_wheels(tmp_path):
    # pro_XX.csv is read back as the stream 'wheels': a run's stream named 'pro' (without a
    # 'wheels' beside it) was written there and came back under another name
    t = np.arange(40) * 0.1
    frame = pd.DataFrame({"t_s": t, "vel_l": 0.5 + 0.01 * np.sin(t), "vel_r": 0.6 + 0 * t,
                          "cur_l": 5.0 + np.sin(3 * t), "cur_r": 6.0 + np.cos(2 * t)})
    run = Run("x/SNOW/00", "x", "SNOW", {"pro": frame})
    with pytest.raises(ConfigError, match=r"stream names \['pro'\] would be written but "
                                          r"never read back"):
        write_run(run, tmp_path)
    assert not (tmp_path / "SNOW").exists()
    back = write_run(Run("x/SNOW/00", "x", "SNOW", {"wheels": frame}), tmp_path)
    assert back["pro"].name == "pro_00.csv"


_NAME = st.from_regex(r"[a-z][a-z0-9_]{0,8}", fullmatch=True)


@st.composite
def _extra_streams(draw):
    """A run's extra stream (simulator-style: snake_case channels, SI values, maybe a text
    label channel) and its name."""
    name = draw(st.from_regex(r"[a-z][a-z0-9]{0,6}", fullmatch=True).filter(
        lambda s: s not in ("imu", "pro", "wheels", "meta")))
    channels = draw(st.lists(_NAME.filter(lambda s: s not in ("time", "t_s")), min_size=1,
                             max_size=4, unique=True))
    n = draw(st.integers(2, 30))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    t = np.cumsum(rng.uniform(0.01, 0.2, n))
    data = {"t_s": [float(f"{v:.9g}") for v in t]}
    for c in channels:
        scale = 10.0 ** draw(st.integers(-300, 300))
        data[c] = [float(f"{v:.9g}") for v in rng.normal(0.0, 1.0, n) * scale]
    label = draw(st.sampled_from([None, "terrain", "mode"]))
    if label is not None and label not in channels:
        data[label] = [draw(st.sampled_from(["SNOW", "ICE", "SANDY_LOAM", "A,B"]))
                       for _ in range(n)]
    return name, pd.DataFrame(data)


@pytest.mark.slow
@settings(max_examples=30, deadline=None, derandomize=True)
@given(extra=_extra_streams(), seed=st.integers(0, 10))
def test_an_extra_stream_written_reads_back_exactly(extra, seed):
    # the readers' contract for simulator extras (truth_XX.csv ...): ``time`` first, other
    # columns by name, a text column kept as text; values at the writer's 9 digits exact
    name, frame = extra
    t = np.arange(40) * 0.1
    rng = np.random.default_rng(seed)
    wheels = pd.DataFrame({"t_s": t, "vel_l": 0.5 + 0.01 * rng.standard_normal(40),
                           "vel_r": 0.6 + 0.01 * rng.standard_normal(40),
                           "cur_l": 5.0 + rng.standard_normal(40),
                           "cur_r": 6.0 + rng.standard_normal(40)})
    run = Run("x/SNOW/00", "x", "SNOW", {"wheels": wheels, name: frame},
              meta={"seed": np.int64(seed), "scale": np.float32(0.5), "on": np.bool_(True)})
    with tempfile.TemporaryDirectory() as tmp:
        paths = write_run(run, tmp, 0)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            (back,) = read_runs_dir(tmp)
        meta = json.loads(paths["meta"].read_text())
    got = back.streams[name]
    assert list(got.columns) == list(frame.columns)
    for c in frame.columns:
        if frame[c].dtype.kind != "f":      # the text channel
            assert list(got[c]) == list(frame[c])
        else:
            assert got[c].dtype == np.float64
            np.testing.assert_array_equal(got[c].to_numpy(), frame[c].to_numpy())
    assert (meta["seed"], meta["scale"], meta["on"]) == (seed, 0.5, True)
    assert back.meta["seed"] == seed and back.meta["ignored_columns"] == {}


@pytest.mark.parametrize("encoding, mark", [("utf-16-le", b"\xff\xfe"),
                                            ("utf-16-be", b"\xfe\xff")])
def test_a_utf16_file_of_either_byte_order_says_so(tmp_path, encoding, mark):
    path = tmp_path / "pro_00.csv"
    path.write_bytes(mark + PRO.encode(encoding))
    with pytest.raises(EncodingError, match="starts with a UTF-16 byte-order mark") as info:
        read_stream_csv(path, "pro")
    assert (info.value.line, info.value.path) == (1, str(path))


def test_only_rows_of_empty_cells_are_called_a_spreadsheets_emptied_rows(tmp_path):
    # a missing timestamp beside its values is not an emptied row: no such hint then
    path = tmp_path / "pro_00.csv"
    path.write_text(PRO + ",0.5,0.5,2.0,2.1\n" + ",,,,\n")
    with pytest.raises(NonFiniteError, match=r"2 non-finite timestamp\(s\) at lines 32, 33; "
                                             r"1 of them a line of empty cells only") as info:
        read_stream_csv(path, "pro")
    assert (info.value.column, info.value.line) == ("time", 32)
    path.write_text(PRO + ",0.5,0.5,2.0,2.1\n")
    with pytest.raises(NonFiniteError) as info:
        read_stream_csv(path, "pro")
    assert "empty cells" not in str(info.value)


@pytest.mark.parametrize("name, plain", [("meta_00.json.gz", "meta_00.json"),
                                         ("meta_00.json.zst", "meta_00.json"),
                                         ("Meta_00.json", None)])
def test_a_compressed_or_upper_case_metadata_file_is_named_not_left_out(tmp_path, name,
                                                                        plain):
    # left out, the run was read as the Husky's whatever its metadata said
    folder = tmp_path / "runs" / "ICE"
    folder.mkdir(parents=True)
    (folder / "pro_00.csv").write_text(PRO)
    (folder / name).write_bytes(b"{}")
    why = (f"compressed run files are not read: decompress it to {plain}" if plain
           else "run file names are lower case: rename it to meta_00.json")
    with pytest.raises(DataFormatError, match=why) as info:
        read_runs_dir(tmp_path / "runs")
    assert info.value.path == str(folder / name)


def _entry(gaps):
    return {"datasets": {"vulpi": {
        "terrains": ["ICE"], "files": {"vulpi/wheels.parquet": "0" * 64}, "source": "s",
        "runs": [{"run_id": "vulpi/ICE/00", "terrain": "ICE", "repaired": {},
                  "gaps": gaps}]}}}


@pytest.mark.parametrize("pair", [[True, 2.0], [1.0, False], ["1", 2.0], [1.0, 2.0, 3.0]])
def test_a_manifest_gap_that_is_not_a_pair_of_times_is_refused(pair):
    # a JSON boolean is a Python int: [true, 2.0] was taken for the gap 1 s -> 2 s
    with pytest.raises(DataFormatError, match=r"datasets\.vulpi\.runs\[0\]\.gaps' must be an "
                                              r"object of lists of \[t_start_s, t_end_s\]"):
        dataset_entry(_entry({"wheels": [pair]}), "vulpi", "manifest.json")
    entry = dataset_entry(_entry({"wheels": [[1, 2.5]]}), "vulpi", "manifest.json")
    assert entry["runs"][0]["gaps"] == {"wheels": [[1, 2.5]]}


@pytest.mark.parametrize("terrain", ["A\\B", "A/B", "..", "."])
def test_a_terrain_that_is_no_folder_name_is_refused_backslash_included(tmp_path, terrain):
    # 'A\\B' is one folder on Linux but a path on Windows: the readers never look there
    t = np.arange(40) * 0.1
    wheels = pd.DataFrame({"t_s": t, "vel_l": 0.5 + 0 * t, "vel_r": 0.6 + 0 * t,
                           "cur_l": 5.0 + np.sin(t), "cur_r": 6.0 + np.cos(t)})
    with pytest.raises(ConfigError, match="is not a folder name"):
        write_run(Run("x/A/00", "x", terrain, {"wheels": wheels}), tmp_path / "out")
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("text, pos, place", [
    ("ab\ncd", 4, (2, 2)), ("ab\r\ncd", 5, (2, 2)), ("ab\rcd", 4, (2, 2)),
    ("ab\r\ncd", 3, (1, 4)),        # the LF of a CR LF ends line 1, as its CR does
    ("ab\r\ncd", 2, (1, 3)), ("ab", 0, (1, 1)), ("a\n\r\rb", 4, (4, 1))])
def test_text_place_counts_lines_as_an_editor_does(text, pos, place):
    assert text_place(text, pos) == place


def test_the_input_report_adds_up_repaired_cells_and_skipped_lines_of_every_channel():
    # the counts reach the user as sums over the run's channels and files, not as the
    # number of channels or files that had any
    frame = pd.DataFrame({"t_s": [0.0, 1.0], "vel_l": [0.1, 0.2]})
    run = Run("r/SNOW/00", "r", "SNOW", {"wheels": frame},
              meta={"repaired": {"imu.wx": 3, "wheels.vel_l": 2},
                    "skipped_lines": {"imu.blank": 2, "imu.comment": 3, "wheels.blank": 1}})
    report = input_report([run])
    row = report.table.iloc[0]
    assert (row["repaired_cells"], row["skipped_lines"]) == (5, 6)
    assert row["repaired"] == "imu.wx:3, wheels.vel_l:2"
    m = report.metrics()
    assert (m["input_repaired_cells"], m["input_skipped_lines"]) == (5.0, 6.0)
    text = report.text()
    assert "repaired 5 isolated non-finite cell(s)" in text
    assert "skipped 6 blank/comment line(s): r/SNOW/00" in text


@pytest.mark.parametrize("word", ["INF", "-Infinity", "+inf", "NaN"])
def test_a_non_finite_word_of_any_case_is_repaired_not_taken_for_an_overflow(tmp_path, word):
    # '1e400' is a number beyond float64 (refused); 'INF' is a missing sample's word, of
    # any case, repaired and counted as 'inf' is
    rows = PRO.splitlines()
    rows[10] = rows[10].replace(",0.5,", f",{word},", 1)
    path = tmp_path / "pro_00.csv"
    path.write_text("\n".join(rows) + "\n")
    frame, report = read_stream_csv(path, "pro")
    assert report.repaired == {"vel_l": 1} and frame["vel_l"].iloc[9] == 0.5


@pytest.mark.parametrize("name, extra, column", [("truth", "time", "time"),
                                                 ("wheels", "velL", "velL")])
def test_a_channel_named_as_another_column_of_its_file_is_refused_before_writing(
        tmp_path, name, extra, column):
    # a truth channel 'time' beside t_s (written 'time' too), or a wheel column 'velL'
    # beside vel_l, made a file with one name twice that the readers refuse
    t = np.arange(40) * 0.1
    wheels = pd.DataFrame({"t_s": t, "vel_l": 0.5 + 0 * t, "vel_r": 0.6 + 0 * t,
                           "cur_l": 5.0 + np.sin(t), "cur_r": 6.0 + np.cos(t)})
    streams = {"wheels": wheels, "truth": pd.DataFrame({"t_s": t, "x": t})}
    streams[name] = streams[name].assign(**{extra: t + 100.0})
    with pytest.raises(ConfigError, match=rf"stream {name!r} of run x/SNOW/00 has columns "
                                          rf"that its file names alike: \[{column!r}\]"):
        write_run(Run("x/SNOW/00", "x", "SNOW", streams), tmp_path / "out")
    assert not (tmp_path / "out").exists()
