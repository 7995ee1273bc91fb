"""Property tests of the CSV reader's file lines and counts under interleaved skipped lines.

For any file of a stream with blank and ``#`` comment lines inserted anywhere (above the
header too), and lines ended by LF, CR LF or a lone CR, the reader counts every skipped line
by kind, repairs each isolated non-finite cell by linear interpolation in time (counted per
channel), and an error names the file line where the offending cell lies, as an editor
numbers it (counted here from the bytes written, independently of the reader).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from terrain.errors import ImplausibleValueError, NonNumericError, TimestampError
from terrain.io.measured import read_stream_csv

SETTINGS = settings(max_examples=40, deadline=None, derandomize=True,
                    suppress_health_check=[HealthCheck.function_scoped_fixture])
HEADER = ["time", "curL", "curR", "velL", "velR"]
ENDINGS = {"lf": "\n", "crlf": "\r\n", "cr": "\r"}


def _rows(n: int, seed: int) -> list[list[str]]:
    """``n`` data rows of a plausible wheel file at 10 Hz."""
    rng = np.random.default_rng(seed)
    return [[f"{0.1 * i:.1f}", f"{rng.uniform(1, 5):.4f}", f"{rng.uniform(1, 5):.4f}",
             f"{rng.uniform(0.1, 0.5):.4f}", f"{rng.uniform(0.1, 0.5):.4f}"]
            for i in range(n)]


@st.composite
def files(draw):
    """A wheel file: its data rows, and the skipped lines to insert before each line."""
    n = draw(st.integers(8, 40))
    seed = draw(st.integers(0, 2**16))
    # before each of the n + 1 lines (header first), and after the last: skipped lines
    skipped = draw(st.lists(st.lists(st.sampled_from(["", "  ", "# note", " # x,y,z"]),
                                     max_size=3), min_size=n + 2, max_size=n + 2))
    ending = draw(st.sampled_from(sorted(ENDINGS)))
    return _rows(n, seed), skipped, ending


def _write(path, rows, skipped, ending) -> list[int]:
    """Write the file; returns the 1-based file line of each data row."""
    out, where = [], []
    for k, fields in enumerate([HEADER, *rows]):
        out += skipped[k]
        out.append(",".join(fields))
        if k:
            where.append(len(out))
    out += skipped[-1]
    text = ENDINGS[ending].join(out) + ENDINGS[ending]
    path.write_bytes(text.encode())
    # the lines an editor shows: counted on the bytes, every ending a line break
    assert text.replace("\r\n", "\n").replace("\r", "\n").count("\n") == len(out)
    return where


def _read(path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return read_stream_csv(path, "pro")


@SETTINGS
@given(spec=files(), data=st.data())
def test_skipped_lines_and_isolated_repairs_are_counted_exactly(tmp_path, spec, data):
    rows, skipped, ending = spec
    # isolated non-finite cells of velL, away from the edges and from each other
    picks = sorted(set(data.draw(st.lists(st.integers(1, len(rows) - 2), max_size=4))))
    picks = [p for k, p in enumerate(picks) if k == 0 or p - picks[k - 1] > 1]
    clean = [list(r) for r in rows]
    for p in picks:
        rows[p][3] = data.draw(st.sampled_from(["nan", "", "-inf", "NaN"]))
    path = tmp_path / "pro_00.csv"
    _write(path, rows, skipped, ending)
    frame, report = _read(path)
    flat = [line for block in skipped for line in block]
    blank = sum(1 for line in flat if not line.strip())
    assert report.skipped_lines == {"blank": blank, "comment": len(flat) - blank}
    assert report.repaired == ({"vel_l": len(picks)} if picks else {})
    v = np.array([float(r[3]) for r in clean])
    t = np.array([float(r[0]) for r in clean])
    for p in picks:   # equal steps: the mean of the two neighbours
        expected = np.interp(t[p], [t[p - 1], t[p + 1]], [v[p - 1], v[p + 1]])
        assert frame["vel_l"].iloc[p] == pytest.approx(expected, rel=1e-12)
    assert len(frame) == len(rows)


@SETTINGS
@given(spec=files(), pick=st.integers(0, 10_000),
       what=st.sampled_from(["text", "duplicated_time", "beyond_range", "negative_beyond"]))
def test_an_error_names_the_file_line_of_the_cell_among_skipped_lines(tmp_path, spec, pick,
                                                                      what):
    rows, skipped, ending = spec
    row = 1 + pick % (len(rows) - 1)
    column = {"text": HEADER[1 + pick % 4], "duplicated_time": "time",
              "beyond_range": "velR", "negative_beyond": "curL"}[what]
    j = HEADER.index(column)
    rows[row][j] = {"text": "1,5".replace(",", ";"), "duplicated_time": rows[row - 1][0],
                    "beyond_range": "5.01", "negative_beyond": "-1000.5"}[what]
    path = tmp_path / "pro_00.csv"
    where = _write(path, rows, skipped, ending)
    error = {"text": NonNumericError, "duplicated_time": TimestampError,
             "beyond_range": ImplausibleValueError,
             "negative_beyond": ImplausibleValueError}[what]
    with pytest.raises(error) as info:
        _read(path)
    err = info.value
    assert (err.path, err.column, err.line) == (str(path), column, where[row])
    assert f"line {where[row]}" in str(err) and "\n" not in str(err)


_number = st.floats(min_value=-4.0, max_value=4.0, allow_nan=False, allow_infinity=False)
_spelling = st.sampled_from(["{!r}", "{:.17g}", "{:e}", " {!r} ", "+{!r}", "{:.3f}"])


@SETTINGS
@given(values=st.lists(st.tuples(_number, _spelling), min_size=12, max_size=12),
       nan_row=st.integers(1, 4))
def test_a_file_with_an_ignored_column_reads_the_same_values(tmp_path, values, nan_row):
    """The reader parses a file whose columns are exactly the canonical ones in one call
    (NumPy) and any other file column by column (pandas): a column it does not read must
    not change one bit of the values it reads, nor what it repairs."""
    def cell(pair):
        x, spelling = pair
        text = spelling.format(x)
        return text.replace("+-", "-") if spelling.startswith("+") else text

    rows = [[f"{0.1 * i:.1f}", *(cell(values[(4 * i + j) % len(values)])
                                 for j in range(4))] for i in range(6)]
    rows[nan_row][2] = "nan"
    plain, extra = tmp_path / "plain.csv", tmp_path / "extra.csv"
    _write(plain, rows, [[]] * (len(rows) + 2), "lf")
    extra.write_text("\n".join([",".join(HEADER + ["note"])]
                               + [",".join(r + [f"n{k}"]) for k, r in enumerate(rows)]) + "\n")
    a, report_a = _read(plain)
    b, report_b = _read(extra)
    assert a.equals(b) and report_a.repaired == report_b.repaired == {"cur_r": 1}
    assert report_b.ignored_columns == ["note"] and report_a.ignored_columns == []


def test_a_number_led_by_a_plus_sign_reads_its_exact_value_beside_an_ignored_column(
        tmp_path):
    # pandas' parser, which reads a file column by column when it has a column the reader
    # does not take, rounded "+1.4718714553235301" to 1.47187145532353 (one unit in the
    # last place off, about 1 number in 8 led by "+"); the file without the column read it
    # exactly
    cell = "+1.4718714553235301"
    rows = [[f"{0.1 * i:.1f}", cell, "2.0", "0.25", "0.25"] for i in range(4)]
    extra = tmp_path / "extra.csv"
    extra.write_text("\n".join([",".join(HEADER + ["note"])]
                               + [",".join(r + ["n"]) for r in rows]) + "\n")
    frame, report = _read(extra)
    assert report.ignored_columns == ["note"]
    assert (frame["cur_l"] == float(cell)).all()
