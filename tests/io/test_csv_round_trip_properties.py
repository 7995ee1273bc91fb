"""Property tests of the CSV readers on generated run folders.

A random valid run (random row counts and values, SI units) written by
:func:`terrain.io.writer.write_run` reads back exactly through :func:`read_runs_dir`, and so
do the same files in every dialect the reader documents: no line break after the last line,
CR LF line endings, a UTF-8 byte-order mark, quoted numbers, extra columns (reported in
``ignored_columns``), columns in another order. One corrupted cell (text, empty, NaN, inf, a
duplicated or decreasing timestamp), a missing column, a header-only file or a file of only a
BOM raises the documented :class:`~terrain.errors.DataFormatError` subclass naming the file,
the column and the 1-based file line (header = line 1).
"""

from __future__ import annotations

import tempfile
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from terrain.errors import (EmptyFileError, MissingColumnError, NonFiniteError,
                            NonNumericError, TimestampError)
from terrain.io.measured import COLUMN_MAPS, read_runs_dir
from terrain.io.writer import write_run
from terrain.run import IMU_CHANNELS, TIME, WHEEL_CHANNELS, Run

SETTINGS = settings(max_examples=40, deadline=None, derandomize=True)
KINDS = {"imu": "imu", "pro": "wheels"}


def _nine(x: np.ndarray) -> np.ndarray:
    """Values exact at the writer's 9 significant digits."""
    return np.array([float(f"{v:.9g}") for v in x])


@st.composite
def runs(draw) -> Run:
    seed = draw(st.integers(0, 2**32 - 1))
    n_imu, n_pro = draw(st.integers(20, 120)), draw(st.integers(4, 15))
    rng = np.random.default_rng(seed)
    t_imu = _nine(np.cumsum(rng.uniform(0.008, 0.012, n_imu)))
    t_pro = _nine(np.cumsum(rng.uniform(0.08, 0.12, n_pro)))
    imu = pd.DataFrame({TIME: t_imu, **{c: _nine(rng.normal(0.0, 0.2, n_imu))
                                        for c in IMU_CHANNELS}})
    imu["az"] = _nine(9.81 + rng.normal(0.0, 0.5, n_imu))
    wheels = pd.DataFrame({TIME: t_pro, **{c: _nine(rng.uniform(0.0, 0.8 if "vel" in c else 20,
                                                                n_pro))
                                           for c in WHEEL_CHANNELS}})
    return Run(run_id="gen/SNOW/00", dataset="gen", terrain="SNOW",
               streams={"imu": imu, "wheels": wheels}, vehicle="husky", source="", meta={})


def _read(root):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")   # plausibility warnings on random values
        (run,) = read_runs_dir(root)
    return run


def _assert_equal(run: Run, back: Run) -> None:
    for name, frame in run.streams.items():
        got = back.streams[name]
        assert list(got.columns) == list(frame.columns)
        np.testing.assert_array_equal(got.to_numpy(), frame.to_numpy())


def _rewrite(path: Path, lines_fn=None, *, crlf=False, bom=False, final_newline=True):
    lines = path.read_text().splitlines()
    if lines_fn is not None:
        lines = lines_fn(lines)
    end = "\r\n" if crlf else "\n"
    text = end.join(lines) + (end if final_newline else "")
    path.write_bytes((b"\xef\xbb\xbf" if bom else b"") + text.encode())


def _table(lines):
    return [line.split(",") for line in lines]


@pytest.mark.slow
@SETTINGS
@given(run=runs(), crlf=st.booleans(), bom=st.booleans(), final_newline=st.booleans(),
       quote=st.booleans(), extra=st.booleans(), order_seed=st.integers(0, 1000))
def test_written_runs_read_back_exactly_in_every_dialect(run, crlf, bom, final_newline,
                                                         quote, extra, order_seed):
    with tempfile.TemporaryDirectory() as tmp:
        paths = write_run(run, tmp, 0)
        _assert_equal(run, _read(tmp))
        order = np.random.default_rng(order_seed)

        def dialect(lines):
            rows = _table(lines)
            perm = order.permutation(len(rows[0]))
            rows = [[r[j] for j in perm] for r in rows]
            if extra:
                rows = [r + (["note"] if i == 0 else [f"x{i}"]) for i, r in enumerate(rows)]
            if quote:
                rows = [rows[0]] + [[f'"{c}"' for c in r] for r in rows[1:]]
            return [",".join(r) for r in rows]

        for kind in KINDS:
            _rewrite(paths[kind], dialect, crlf=crlf, bom=bom, final_newline=final_newline)
        back = _read(tmp)
        _assert_equal(run, back)
        expected = {"imu": ["note"], "wheels": ["note"]} if extra else {}
        assert back.meta["ignored_columns"] == expected


CORRUPTIONS = {
    # what -> (cell text or edit, error type, which column it names)
    "text": NonNumericError, "empty_time": NonFiniteError, "nan_time": NonFiniteError,
    "inf_edge": NonFiniteError, "duplicated_time": TimestampError,
    "decreasing_time": TimestampError,
}


@pytest.mark.slow
@SETTINGS
@given(run=runs(), kind=st.sampled_from(sorted(KINDS)), what=st.sampled_from(
    sorted(CORRUPTIONS)), pick=st.integers(0, 10_000), crlf=st.booleans(), bom=st.booleans())
def test_one_corrupted_cell_names_file_column_and_line(run, kind, what, pick, crlf, bom):
    columns = list(COLUMN_MAPS[kind])
    with tempfile.TemporaryDirectory() as tmp:
        paths = write_run(run, tmp, 0)
        path = paths[kind]
        n = len(run.streams[KINDS[kind]])
        row = 1 + pick % (n - 1)              # a data row with one before it
        column = "time" if "time" in what else columns[1 + pick % (len(columns) - 1)]
        if what == "text":
            column = columns[pick % len(columns)]
        if what == "inf_edge":
            row = 0 if pick % 2 else n - 1

        def corrupt(lines):
            rows = _table(lines)
            j = rows[0].index(column)
            previous = float(rows[row][j]) if what == "decreasing_time" else None
            rows[1 + row][j] = {"text": "abc", "empty_time": "", "nan_time": "nan",
                                "inf_edge": "-inf", "duplicated_time": rows[row][j],
                                "decreasing_time": repr((previous or 0.0) - 1e-3)}[what]
            return [",".join(r) for r in rows]

        _rewrite(path, corrupt, crlf=crlf, bom=bom)
        with pytest.raises(CORRUPTIONS[what]) as info:
            _read(tmp)
    err = info.value
    assert (err.path, err.column, err.line) == (str(path), column, row + 2)
    assert str(path) in str(err) and f"column {column!r}" in str(err)
    assert f"line {row + 2}" in str(err) and "\n" not in str(err)


@pytest.mark.slow
@SETTINGS
@given(run=runs(), kind=st.sampled_from(sorted(KINDS)), pick=st.integers(0, 100),
       bom=st.booleans())
def test_a_missing_column_is_named_on_the_header_line(run, kind, pick, bom):
    columns = list(COLUMN_MAPS[kind])
    drop = columns[pick % len(columns)]
    with tempfile.TemporaryDirectory() as tmp:
        path = write_run(run, tmp, 0)[kind]

        def without(lines):
            rows = _table(lines)
            j = rows[0].index(drop)
            return [",".join(c for k, c in enumerate(r) if k != j) for r in rows]

        _rewrite(path, without, bom=bom)
        with pytest.raises(MissingColumnError) as info:
            _read(tmp)
    assert (info.value.path, info.value.column, info.value.line) == (str(path), drop, 1)


@pytest.mark.parametrize("content", [b"\xef\xbb\xbf", b"", b"\xef\xbb\xbf\r\n",
                                     b"time,wx,wy,wz,ax,ay,az\n",
                                     b"\xef\xbb\xbftime,wx,wy,wz,ax,ay,az\r\n"])
def test_a_file_of_only_a_bom_or_a_header_is_empty(tmp_path, content):
    folder = tmp_path / "SNOW"
    folder.mkdir()
    (folder / "pro_00.csv").write_text("time,curL,curR,velL,velR\n0,1,1,0.1,0.1\n"
                                       "0.1,1,1,0.1,0.1\n")
    (folder / "imu_00.csv").write_bytes(content)
    with pytest.raises(EmptyFileError) as info:
        _read(tmp_path)
    assert info.value.path == str(folder / "imu_00.csv")
