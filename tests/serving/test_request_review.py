"""Review of :func:`terrain.serving.request.parse_request` on synthetic requests (no model).

A long-format request interleaves the rows of its streams, so an error must name the
request's own row (a position in the table), not the sample's place within its stream.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from terrain.errors import MissingColumnError, NonFiniteError, NonNumericError
from terrain.run import IMU_CHANNELS, WHEEL_CHANNELS
from terrain.serving.request import numeric_column, parse_request, planned_decisions, time_span_s

BOTH = {"wheels": WHEEL_CHANNELS, "imu": IMU_CHANNELS}


def _long_frame(span_s: float = 4.0, seed: int = 0) -> pd.DataFrame:
    """Wheels at 20 Hz and IMU at 100 Hz, plausible noisy values, rows in time order."""
    rng = np.random.default_rng(seed)
    tw, ti = np.arange(0, span_s, 0.05), np.arange(0, span_s, 0.01)
    wheels = pd.DataFrame({"stream": "wheels", "t_s": tw,
                           **{c: (0.5 if c.startswith("vel") else 5.0)
                              + 0.05 * rng.standard_normal(tw.size) for c in WHEEL_CHANNELS}})
    imu = pd.DataFrame({"stream": "imu", "t_s": ti,
                        **{c: (9.81 if c == "az" else 0.0) + 0.1 * rng.standard_normal(ti.size)
                           for c in IMU_CHANNELS}})
    return pd.concat([wheels, imu]).sort_values("t_s", kind="stable").reset_index(drop=True)


def test_the_synthetic_request_is_taken():
    run = parse_request(_long_frame(), BOTH, 2.0, 10_000)
    assert set(run.streams) == {"wheels", "imu"} and len(run.streams["imu"]) == 400


@pytest.mark.parametrize("where", ["burst", "last"])
def test_a_non_finite_run_of_an_interleaved_stream_names_the_requests_row(where):
    frame = _long_frame()
    imu_rows = np.flatnonzero(frame["stream"] == "imu")
    bad = imu_rows[50:53] if where == "burst" else imu_rows[-1:]
    frame.loc[bad, "wx"] = np.nan
    with pytest.raises(NonFiniteError) as err:
        parse_request(frame, BOTH, 2.0, 10_000)
    assert err.value.row == bad[0] and err.value.column == "wx"
    assert f"data row {bad[0]} (0-based)" in str(err.value)
    # the sample's place within its stream is another number: 50 or 399
    assert bad[0] != (50 if where == "burst" else 399)


def test_a_non_finite_timestamp_of_an_interleaved_stream_names_the_requests_row():
    frame = _long_frame()
    row = int(np.flatnonzero(frame["stream"] == "imu")[120])
    frame.loc[row, "t_s"] = np.inf
    with pytest.raises(NonFiniteError, match="non-finite timestamp in stream 'imu'") as err:
        parse_request(frame, BOTH, 2.0, 10_000)
    assert err.value.row == row != 120


def test_rows_of_a_stream_the_model_does_not_need_are_counted_down_to_one():
    frame = _long_frame()
    one_imu_row = pd.concat([frame[frame["stream"] == "wheels"],
                             frame[frame["stream"] == "imu"].iloc[[7]]])
    run = parse_request(one_imu_row.reset_index(drop=True), {"wheels": WHEEL_CHANNELS}, 2.0,
                        10_000)
    assert run.meta["unused"] == {"imu": 1}
    run = parse_request(frame, {"wheels": WHEEL_CHANNELS}, 2.0, 10_000)
    assert run.meta["unused"] == {"imu": 400} and run.meta["ignored_columns"] == []


def test_an_empty_cell_among_numbers_written_as_text_is_a_missing_value_not_text():
    # JSON ["0.5", null, 2] gives an object column: null is an empty cell (NaN, repaired
    # when isolated), never "non-numeric value None"
    frame = pd.DataFrame({"v": pd.Series(["0.5", None, 2, np.nan], dtype=object)})
    values = numeric_column(frame, "v", np.arange(4), "request")
    np.testing.assert_array_equal(values, [0.5, np.nan, 2.0, np.nan])
    frame.loc[3, "v"] = "fast"
    with pytest.raises(NonNumericError, match=r"non-numeric value 'fast' \(1 such") as err:
        numeric_column(frame, "v", np.array([3, 1, 0]), "request")
    assert err.value.row == 3


def test_the_time_span_runs_from_the_earliest_first_sample_of_any_stream():
    # IMU 0-3.99 s, wheels 1-3.95 s: 3.99 s, so at most 4 decisions of a 2 s window every
    # 0.5 s (from the wheels' first sample only 2)
    frame = _long_frame()
    frame = frame[(frame["stream"] == "imu") | (frame["t_s"] >= 1.0)].reset_index(drop=True)
    run = parse_request(frame, BOTH, 2.0, 10_000)
    assert time_span_s(run) == pytest.approx(3.99)
    assert planned_decisions(run, 2.0, 0.5) == 4


@pytest.mark.parametrize("rename", [lambda c: " " + c, lambda c: c.upper(), lambda c: c + " "],
                         ids=["leading space", "capitals", "trailing space"])
def test_a_needed_column_written_with_spaces_or_in_capitals_is_named_as_sent(rename):
    # a CSV written "stream, t_s, vel_l" (a space after each comma) has the column ' t_s';
    # "missing ['t_s', ...]" alone reads as if the request had no time column at all
    frame = _long_frame().rename(columns={"t_s": rename("t_s"), "cur_l": rename("cur_l")})
    with pytest.raises(MissingColumnError) as err:
        parse_request(frame, BOTH, 2.0, 10_000)
    assert err.value.column == "t_s"
    assert f"the request has {[rename('t_s'), rename('cur_l')]}" in str(err.value)
    assert "spaces or case differ" in str(err.value)


def test_a_stream_column_written_with_a_space_is_named_as_sent():
    frame = _long_frame().rename(columns={"stream": " stream"})
    with pytest.raises(MissingColumnError, match=r"the request has \[' stream'\]"):
        parse_request(frame, BOTH, 2.0, 10_000)


def test_a_missing_column_with_no_near_name_gets_no_such_hint():
    with pytest.raises(MissingColumnError) as err:
        parse_request(_long_frame().drop(columns="cur_l"), BOTH, 2.0, 10_000)
    assert "missing ['cur_l']" in str(err.value) and "the request has" not in str(err.value)


@pytest.mark.parametrize("values", [
    pd.Series(pd.to_datetime([0, 1, 2], unit="s", utc=True)),          # tz-aware dtype
    pd.Series([pd.Timestamp(0), pd.Timestamp(1), pd.Timestamp(2)], dtype=object),
    pd.Series([pd.Timedelta(1, "s")] * 3, dtype=object),
    pd.Series(pd.period_range("2020", periods=3, freq="Y")),
    pd.Series([np.datetime64(1, "s")] * 3, dtype=object),
], ids=["tz-aware", "timestamps", "timedeltas", "periods", "datetime64-objects"])
def test_dates_and_durations_of_any_dtype_are_not_numbers(values):
    """A tz-aware timestamp column (as Parquet gives one), or dates and durations held as
    objects, were read as nanoseconds, microseconds or years since an epoch: a served
    request then failed on the 'ns clock' rule ("divide the time column by 1e9") or ran
    on; the naive datetime64 dtype was already refused."""
    frame = pd.DataFrame({"t_s": values})
    with pytest.raises(NonNumericError, match=r"where a number is expected") as err:
        numeric_column(frame, "t_s", np.arange(3), "request")
    assert err.value.column == "t_s" and err.value.row == 0


def _wide(frame: pd.DataFrame) -> pd.DataFrame:
    """The long request as a wide one (``<stream>_t_s`` beside each stream's channels)."""
    parts = [frame[frame["stream"] == s].drop(columns="stream")[["t_s", *ch]]
             .rename(columns={"t_s": f"{s}_t_s"}).reset_index(drop=True)
             for s, ch in BOTH.items()]
    return pd.concat(parts, axis=1)


@pytest.mark.parametrize("spoil, error, words", [
    (lambda f: f.assign(imu_t_s=f["imu_t_s"].where(f.index != 10, 99.0)), "TimestampError",
     "decreasing timestamp"),
    (lambda f: f.iloc[:50], "DataFormatError", "too short"),
    (lambda f: f.assign(imu_t_s=f["imu_t_s"] * 1000), "UnitError", "milliseconds"),
], ids=["decreasing", "too short", "ms"])
def test_a_wide_request_s_time_errors_name_its_own_time_column(spoil, error, words):
    """A wide request has no 't_s' column: its time errors named one (HTTP probe: a wide
    request with an IMU stamp out of order was told "column 't_s'"), now
    '<stream>_t_s'."""
    frame = spoil(_wide(_long_frame()))
    with pytest.raises(Exception) as info:
        parse_request(frame, BOTH, 2.0, 10_000)
    assert type(info.value).__name__ == error and words in str(info.value)
    assert f"column '{info.value.column}'" in str(info.value)
    assert info.value.column in frame.columns and info.value.column.endswith("_t_s")
