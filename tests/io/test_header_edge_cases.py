"""Header edge cases of the measured-data CSV reader, for every stream kind it reads.

A trailing comma on every line (header included) adds a column without a name: the file is
still read and the column is reported by position in ``ReadReport.ignored_columns``, the
same for ``imu``, ``pro`` and the extra streams (``truth``, ``steer``...). Two trailing
commas give two such columns, told apart by position. A header-only file is an
:class:`EmptyFileError` that points at a header ending in a comma.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from terrain.errors import (DataFormatError, EmptyFileError, EncodingError, MissingColumnError,
                            NonFiniteError, RaggedRowError)
from terrain.io.measured import read_runs_dir, read_stream_csv
from terrain.io.report import input_report

N_ROWS = 120
#: kind -> (header, one data row at time t); imu and pro are the canonical kinds, truth and
#: steer extra streams (read_run loads any <kind>_XX.csv)
STREAMS = {
    "imu": ("time,wx,wy,wz,ax,ay,az", "{t:.2f},0.01,0.02,0.03,0.1,0.2,9.81"),
    "pro": ("time,curL,curR,velL,velR", "{t:.2f},1.0,1.1,0.5,0.5"),
    "truth": ("time,slip_l,slip_r", "{t:.2f},0.1,0.2"),
    "steer": ("time,angle", "{t:.2f},0.05"),
}
KINDS = list(STREAMS)


def _text(kind, suffix="", rows=N_ROWS):
    """A stream file of ``kind``, each line ending in ``suffix``."""
    header, row = STREAMS[kind]
    lines = [header] + [row.format(t=0.01 * i) for i in range(rows)]
    return "".join(line + suffix + "\n" for line in lines)


def _write(folder, kind, suffix="", rows=N_ROWS, index="00"):
    path = folder / f"{kind}_{index}.csv"
    path.write_text(_text(kind, suffix, rows))
    return path


def _n_columns(kind):
    return len(STREAMS[kind][0].split(","))


@pytest.mark.parametrize("kind", KINDS)
def test_a_trailing_comma_on_every_line_is_read_and_its_column_reported(tmp_path, kind):
    want, _ = read_stream_csv(_write(tmp_path, kind), kind)
    path = _write(tmp_path, kind, ",", index="01")
    got, report = read_stream_csv(path, kind)
    pd.testing.assert_frame_equal(got, want)
    n = _n_columns(kind) + 1
    assert report.ignored_columns == [f"<unnamed column {n}; a trailing comma?>"]
    assert report.warnings == [] and report.repaired == {}


@pytest.mark.parametrize("kind", KINDS)
def test_two_trailing_commas_give_two_unnamed_columns_told_apart(tmp_path, kind):
    want, _ = read_stream_csv(_write(tmp_path, kind), kind)
    got, report = read_stream_csv(_write(tmp_path, kind, ",,", index="01"), kind)
    pd.testing.assert_frame_equal(got, want)
    n = _n_columns(kind) + 1
    assert report.ignored_columns == [f"<unnamed column {n}>",
                                      f"<unnamed column {n + 1}; a trailing comma?>"]
    assert not any("Unnamed" in c for c in report.ignored_columns)


def test_an_unnamed_column_inside_an_extra_stream_is_reported_not_read(tmp_path):
    path = tmp_path / "truth_00.csv"
    path.write_text("time,,slip\n" + "".join(f"{0.1 * i:.1f},,0.{i}\n" for i in range(5)))
    frame, report = read_stream_csv(path, "truth")
    assert list(frame.columns) == ["t_s", "slip"]
    assert report.ignored_columns == ["<unnamed column 2>"]


@pytest.mark.parametrize("kind", KINDS)
def test_duplicated_names_are_still_refused_beside_unnamed_columns(tmp_path, kind):
    header, row = STREAMS[kind]
    name = header.split(",")[1]
    path = tmp_path / f"{kind}_00.csv"
    path.write_text(f"{header},{name},,\n"
                    + "".join(row.format(t=0.01 * i) + ",1,,\n" for i in range(5)))
    with pytest.raises(DataFormatError, match=rf"duplicated column name\(s\) \['{name}'\]") \
            as info:
        read_stream_csv(path, kind)
    assert (info.value.column, info.value.line) == (name, 1)


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("suffix", [",", ",,"])
def test_a_header_only_file_ending_in_a_comma_says_so(tmp_path, kind, suffix):
    path = _write(tmp_path, kind, suffix, rows=0)
    with pytest.raises(EmptyFileError) as info:
        read_stream_csv(path, kind)
    text = str(info.value)
    assert "file has a header but no data rows" in text and "\n" not in text
    assert "trailing comma?" in text and f"{len(suffix)} unnamed column" in text
    assert (info.value.path, info.value.line) == (str(path), 1)


@pytest.mark.parametrize("kind", KINDS)
def test_a_header_only_file_without_a_trailing_comma_gets_no_hint(tmp_path, kind):
    path = _write(tmp_path, kind, rows=0)
    with pytest.raises(EmptyFileError) as info:
        read_stream_csv(path, kind)
    assert str(info.value) == f"file has a header but no data rows (file {path}, line 1)"
    assert info.value.line == 1


@pytest.mark.parametrize("kind", KINDS)
def test_a_header_only_file_names_the_header_line_after_comments(tmp_path, kind):
    path = tmp_path / f"{kind}_00.csv"
    path.write_text("# logged by the rover\n\n" + _text(kind, rows=0) + "\n")
    with pytest.raises(EmptyFileError) as info:
        read_stream_csv(path, kind)
    assert (info.value.path, info.value.line) == (str(path), 3)
    assert str(info.value).endswith(", line 3)")


@pytest.mark.filterwarnings("ignore:.*stuck at one value")   # the synthetic IMU is constant
def test_every_stream_of_a_run_reports_its_unnamed_columns(tmp_path):
    folder = tmp_path / "ICE"
    folder.mkdir()
    for kind in KINDS:
        _write(folder, kind, ",,")
    (run,) = read_runs_dir(tmp_path, "sim")
    assert set(run.streams) == {"imu", "wheels", "truth", "steer"}
    ignored = run.meta["ignored_columns"]
    for kind, stream in (("imu", "imu"), ("pro", "wheels"), ("truth", "truth"),
                         ("steer", "steer")):
        n = _n_columns(kind) + 1
        assert ignored[stream] == [f"<unnamed column {n}>",
                                   f"<unnamed column {n + 1}; a trailing comma?>"]
        assert "" not in run.streams[stream].columns
    np.testing.assert_array_equal(run.streams["truth"]["slip_r"], np.full(N_ROWS, 0.2))
    report = input_report([run])
    assert report.metrics()["input_ignored_columns"] == 8.0
    assert "truth.<unnamed column 5; a trailing comma?>" in report.table.loc[0, "ignored_columns"]
    assert "ignored 8 column(s) not read by the readers (imu.<unnamed column 8>" in report.text()


@pytest.mark.parametrize("kind", KINDS)
def test_a_comma_ending_the_header_only_is_named_in_the_ragged_row_error(tmp_path, kind):
    path = _write(tmp_path, kind)
    lines = path.read_text().split("\n")
    path.write_text("\n".join([lines[0] + ","] + lines[1:]))
    with pytest.raises(RaggedRowError) as info:
        read_stream_csv(path, kind)
    text = str(info.value)
    assert info.value.line == 2 and "\n" not in text
    assert "the header ends in a comma, line 2 does not: a trailing comma?" in text


@pytest.mark.parametrize("prefix", ["#", "# "])
def test_a_header_commented_out_is_named_not_taken_for_data(tmp_path, prefix):
    # numpy.savetxt(header=...) writes '# time,curL,...': the first data row was then read
    # as the header, 'duplicated column name(s) ['0.5'] in the header (line 2)'
    path = tmp_path / "pro_00.csv"
    path.write_text(prefix + _text("pro"))
    with pytest.raises(MissingColumnError) as info:
        read_stream_csv(path, "pro")
    assert info.value.line == 2 and info.value.path == str(path)
    assert "no header line: the first line that is not blank or a comment holds numbers " \
           "('0.00,1.0,1.1,0.5,0.5')" in str(info.value)
    assert f"line 1 ('{prefix}time,curL,curR,velL,velR') looks like the header commented " \
           "out: remove its '#'" in str(info.value)
    # no header at all: the same error, without the hint
    path.write_text(_text("pro").split("\n", 1)[1])
    with pytest.raises(MissingColumnError, match=r"holds numbers \('0.00,1.0,1.1,0.5,0.5'\), "
                                                 r"not column names \(file"):
        read_stream_csv(path, "pro")


def test_a_header_with_some_numeric_names_is_still_a_header(tmp_path):
    """Only a first line of numbers only is taken for a data row: a header naming a
    channel ``2`` (a second steering angle of an extra stream) or with an extra numeric
    column beside the canonical ones is read as the header."""
    path = tmp_path / "steer_00.csv"
    path.write_text("time,1,2\n" + "".join(f"{k / 10:.2f},0.05,0.06\n" for k in range(N_ROWS)))
    frame, _ = read_stream_csv(path, "steer")
    assert list(frame.columns) == ["t_s", "1", "2"] and (frame["2"] == 0.06).all()
    path = tmp_path / "pro_00.csv"
    lines = _text("pro").split("\n")
    path.write_text("\n".join([lines[0] + ",5"] + [ln + ",0" for ln in lines[1:] if ln]) + "\n")
    frame, report = read_stream_csv(path, "pro")
    assert report.ignored_columns == ["5"] and len(frame) == N_ROWS


def test_a_semicolon_file_with_decimal_commas_names_its_separator(tmp_path):
    # the decimal commas split each row into more fields than the one-field header: the
    # ragged-row error said nothing of the separator
    path = tmp_path / "pro_00.csv"
    path.write_text(_text("pro").replace(",", ";").replace(".", ","))
    with pytest.raises(RaggedRowError, match=r"\(the header is separated by semicolons; the "
                                             r"readers take commas only\)"):
        read_stream_csv(path, "pro")


def test_nul_bytes_ending_a_file_and_empty_spreadsheet_rows_are_named(tmp_path):
    path = tmp_path / "pro_00.csv"
    path.write_text(_text("pro") + "\x00" * 4096)   # a log cut by a power loss
    with pytest.raises(RaggedRowError, match="the line holds NUL bytes") as info:
        read_stream_csv(path, "pro")
    assert info.value.line == N_ROWS + 2
    path.write_text(_text("pro") + ",,,,\n" * 3)    # rows emptied in a spreadsheet
    with pytest.raises(NonFiniteError, match="3 of them a line of empty cells only") as info:
        read_stream_csv(path, "pro")
    assert (info.value.column, info.value.line) == ("time", N_ROWS + 2)


def test_a_utf16_file_says_so(tmp_path):
    path = tmp_path / "pro_00.csv"
    path.write_bytes(_text("pro").encode("utf-16"))
    with pytest.raises(EncodingError, match="UTF-16 byte-order mark"):
        read_stream_csv(path, "pro")


def test_a_last_line_cut_mid_row_says_the_file_was_cut_off(tmp_path):
    # a logger stopped while writing: a bare ragged-row error at the last line
    path = tmp_path / "pro_00.csv"
    path.write_text(_text("pro")[:-9])                 # '1.19,1.0,1' of the last row
    with pytest.raises(RaggedRowError, match="it is the last line and has no line break: "
                                             "cut off while the file was written") as info:
        read_stream_csv(path, "pro")
    assert info.value.line == N_ROWS + 1
    path.write_text(_text("pro")[:-9] + "\n")          # its line break written: no such hint
    with pytest.raises(RaggedRowError) as info:
        read_stream_csv(path, "pro")
    assert "cut off" not in str(info.value)
