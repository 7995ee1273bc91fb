"""Review io20 of terrain.io.writer: what :func:`write_run` writes reads back as the run held
it, or nothing is written (its promise for every file the readers would refuse or change)."""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from terrain.errors import ConfigError
from terrain.io.measured import read_folder_run
from terrain.io.writer import write_run
from terrain.run import TIME, WHEEL_CHANNELS, Run

N = 14


def _run(**extra) -> Run:
    wheels = pd.DataFrame({TIME: np.arange(N) / 6.5,
                           **{c: np.linspace(0.1, 0.4, N) for c in WHEEL_CHANNELS}})
    truth = pd.DataFrame({TIME: np.arange(N) / 6.5, **extra})
    return Run("x/SNOW/00", "x", "SNOW", {"wheels": wheels, "truth": truth})


def _missing_cells(kind: str, rows: list[int]) -> pd.Series:
    """A column of N numbers with missing cells at ``rows``, of pandas dtype ``kind``."""
    if kind == "Int64":
        values = pd.array(list(range(N)), dtype="Int64")
        values[rows] = pd.NA
        return pd.Series(values)
    values = [float(k) for k in range(N)]
    for k in rows:
        values[k] = None
    return pd.Series(values, dtype=kind)


@settings(max_examples=30, deadline=None)
@given(kind=st.sampled_from(["Int64", "Float64", "object"]),
       rows=st.lists(st.integers(0, N - 1), min_size=1, max_size=N, unique=True))
def test_a_missing_number_of_a_nullable_or_object_column_is_refused(tmp_path_factory, kind,
                                                                    rows):
    # pandas' nullable columns (Int64, Float64: pd.NA) made write_run a bare TypeError
    # (float() of NAType); an object column of numbers with None was written as an empty
    # cell, which the readers interpolated (the run read back other than written) or refused
    # (a burst: a file written that the readers refuse); both now refused as NaN is, naming
    # the column and the first row, and nothing written
    out = tmp_path_factory.mktemp("runs")
    with pytest.raises(ConfigError, match=rf"column 'x' holds {len(rows)} non-finite "
                                          rf"value\(s\), the first .* at row {min(rows)}"):
        write_run(_run(x=_missing_cells(kind, rows)), out, 0)
    assert not any(out.iterdir())


@pytest.mark.parametrize("kind", ["Int64", "Float64", "object"])
def test_a_nullable_or_object_column_without_missing_numbers_reads_back(tmp_path, kind):
    column = _missing_cells(kind, []) if kind != "object" else pd.Series(
        [float(k) for k in range(N)], dtype=object)
    write_run(_run(x=column), tmp_path, 0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        back = read_folder_run(tmp_path / "SNOW")
    np.testing.assert_array_equal(back.streams["truth"]["x"].to_numpy(), np.arange(N))
    assert back.meta["repaired"] == {}


def test_a_missing_timestamp_of_a_nullable_clock_is_refused(tmp_path):
    run = _run(x=np.arange(N, dtype=float))
    t = pd.array(list(run.streams["truth"][TIME]), dtype="Float64")
    t[3] = pd.NA
    run.streams["truth"][TIME] = t
    with pytest.raises(ConfigError, match=r"stream 'truth' .* 1 non-finite timestamp\(s\), "
                                          r"the first .* at row 3"):
        write_run(run, tmp_path, 0)
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize("cell", [pd.NaT, float("inf"), np.float32("-inf"), np.nan])
def test_a_missing_or_infinite_cell_among_object_numbers_is_refused(tmp_path, cell):
    # NaT was written as an empty cell (interpolated back), inf as 'inf' (repaired back)
    column = pd.Series([float(k) for k in range(N)], dtype=object)
    column[4] = cell
    with pytest.raises(ConfigError, match=r"column 'x' holds 1 non-finite value\(s\), the "
                                          r"first .* at row 4"):
        write_run(_run(x=column), tmp_path, 0)
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize("streams", [("truth",), ()])
def test_a_run_without_a_wheel_stream_is_refused_before_writing(tmp_path, streams):
    # written as imu_XX.csv (or truth_XX.csv, or meta_XX.json alone) without pro_XX.csv: a
    # run every reader refuses (OrphanFileError), and with it every run of the folder
    full = _run(x=np.arange(N, dtype=float))
    run = Run(full.run_id, full.dataset, full.terrain,
              {k: full.streams[k] for k in streams})
    with pytest.raises(ConfigError, match=r"run x/SNOW/00 has no 'wheels' stream: the readers "
                                          r"read a run from its pro_XX.csv"):
        write_run(run, tmp_path, 0)
    assert not any(tmp_path.iterdir())
