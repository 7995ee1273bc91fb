"""Review tests of the served model's request parsing and answer (hand mutants of
terrain/serving/request.py, served.py and body.py that the other tests left alive)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from terrain.errors import DataFormatError, NonFiniteError
from terrain.run import WHEEL_CHANNELS
from terrain.serving.body import body_refusal
from terrain.serving.request import parse_request, planned_decisions, time_span_s


def _wide(n: int = 20) -> pd.DataFrame:
    """``n`` wheel samples at 8 Hz in the wide format (``wheels_t_s``)."""
    rng = np.random.default_rng(0)
    return pd.DataFrame({"wheels_t_s": 10.0 + np.arange(n) * 0.125, "vel_l": 0.2,
                         "vel_r": 0.2, "cur_l": rng.uniform(5, 20, n),
                         "cur_r": rng.uniform(5, 20, n)})


def test_a_wide_empty_row_just_before_the_last_stamp_is_refused():
    """The whole row before the stream's last stamped row is empty: it is inside the
    stream, not a trailing cell, so refused (not skipped) like any earlier empty row."""
    wide = _wide()
    wide.loc[18] = np.nan
    with pytest.raises(NonFiniteError) as info:
        parse_request(wide, {"wheels": WHEEL_CHANNELS}, 2.0, 100)
    assert "wheels_t_s is empty in a row that comes before a stamped row (1 such row(s)" \
        in str(info.value)
    assert str(info.value).endswith("(file request, column 'wheels_t_s', data row 18 "
                                    "(0-based))")


def _long(n: int = 20) -> pd.DataFrame:
    """``n`` wheel samples at 8 Hz in the long format (``stream`` column)."""
    return (_wide(n).rename(columns={"wheels_t_s": "t_s"})
            .assign(stream="wheels").astype({"stream": object}))


def test_six_unknown_streams_are_five_named_and_one_counted():
    """One past the five named: the sixth unknown value is counted, never dropped unsaid."""
    frame = _long()
    frame.loc[3:8, "stream"] = list("abcdef")
    with pytest.raises(DataFormatError) as info:
        parse_request(frame, {"wheels": WHEEL_CHANNELS}, 2.0, 100)
    assert str(info.value).startswith("unknown stream 'a', 'b', 'c', 'd', 'e' and 1 more in 6 "
                                      "row(s), data rows 3")


def test_a_column_name_that_is_not_text_is_refused():
    """``mlflow models serve`` without the guard hands such a frame on (a JSON
    ``dataframe_split`` of ``"columns": [..., 0]``): refused, not read as an ignored column."""
    frame = _long().assign(**{"x": 1.0}).rename(columns={"x": 0})
    with pytest.raises(DataFormatError, match=r"column names must be text, got 0 "
                                              r"\(file request\)"):
        parse_request(frame, {"wheels": WHEEL_CHANNELS}, 2.0, 100)


def test_the_planned_decisions_span_from_the_first_sample_to_the_last_of_any_stream():
    """IMU 10-13 s and wheels 10-15 s: the span is 5 s (the wheels' end), so 7 decisions of
    a 2 s window at the 0.5 s hop, not those of the stream that ends first."""
    rng = np.random.default_rng(1)
    imu = pd.DataFrame({"stream": "imu", "t_s": 10.0 + np.arange(301) * 0.01,
                        **{c: rng.normal(0.0, 0.1, 301) for c in ("ax", "ay", "wx", "wy",
                                                                  "wz")},
                        "az": rng.normal(9.81, 0.1, 301)})
    frame = pd.concat([imu, _long(41)], ignore_index=True)
    streams = {"wheels": WHEEL_CHANNELS, "imu": ["ax", "ay", "az", "wx", "wy", "wz"]}
    run = parse_request(frame, streams, 2.0, 10_000)
    assert time_span_s(run) == pytest.approx(5.0)
    assert planned_decisions(run, 2.0, 0.5) == 7


def test_an_unexpected_failure_is_a_one_line_500_that_shows_nothing_of_it(caplog):
    """The server answers an unexpected error 500 (not the client's fault: not 400), with
    the exception's class only; its text and traceback go to the server log."""
    from mlflow.protos.databricks_pb2 import INTERNAL_ERROR, ErrorCode

    from terrain.serving.served import ServedInputError, ServedStreamModel

    model = ServedStreamModel()

    def decide(frame):
        raise RuntimeError("secret detail of the failure")

    model.decide = decide
    with pytest.raises(ServedInputError) as raised:
        model.predict(None, _long())
    assert raised.value.error_code == ErrorCode.Name(INTERNAL_ERROR)
    assert raised.value.get_http_status_code() == 500
    assert raised.value.message == "internal error (RuntimeError); see the server log"
    assert "secret detail" in caplog.text   # the log keeps it


def test_the_served_error_message_cannot_be_rewritten():
    """MLflow's server assigns the request dump + error to ``message``: ignored."""
    from terrain.serving.served import ServedInputError

    error = ServedInputError("TimestampError: stream 'wheels': decreasing timestamp")
    error.message = "Failed to predict data '   stream  t_s ...'"
    assert error.message == "TimestampError: stream 'wheels': decreasing timestamp"
    assert error.get_http_status_code() == 400


@pytest.mark.parametrize("key, value, words", [
    ("min_confidence", 1.5, "min_confidence must be in [0, 1], got 1.5"),
    ("min_confidence", -0.1, "min_confidence must be in [0, 1], got -0.1"),
    ("max_rows", 0, "max_rows must be an integer >= 1, got 0"),
    ("max_decisions", 0, "max_decisions must be an integer >= 1, got 0"),
])
def test_served_settings_out_of_range_are_refused(key, value, words):
    from terrain.errors import ConfigError
    from terrain.serving.served import check_settings

    settings = {"hop_s": 0.5, "rate_hz": 20.0, "dwell_s": 10.0, "min_confidence": 0.5,
                "max_rows": 100, "max_decisions": 10}
    check_settings(settings)
    with pytest.raises(ConfigError) as info:
        check_settings({**settings, key: value})
    assert words in str(info.value)


_CSV = b"stream,t_s,vel_l,vel_r,cur_l,cur_r\nwheels,10.0,0.1,0.1,15.0,18.0\n"


def test_a_nul_byte_at_the_very_start_of_the_body_is_named():
    """Byte 0 is a byte like any other: a body that starts with padding is refused."""
    status, answer = body_refusal("text/csv", b"\x00" + _CSV, None, 10**6)
    assert status == 400
    assert answer["message"].startswith("EncodingError: the request body holds a NUL byte "
                                        "(0x00) at byte 0 ")
    assert answer["message"].endswith("(file request, line 1)")


@pytest.mark.parametrize("encoding", ["utf-16-le", "utf-16-be"])
def test_utf16_without_a_byte_order_mark_is_told_in_either_byte_order(encoding):
    """ASCII in UTF-16 has its NUL bytes in the odd positions (little-endian) or the even
    ones (big-endian): both are UTF-16, not a NUL byte of a padded log."""
    status, answer = body_refusal("text/csv", _CSV.decode().encode(encoding), None, 10**6)
    assert status == 400
    assert answer["message"].startswith("EncodingError: the request body is UTF-16 "), answer


def test_a_ragged_row_under_a_header_of_two_columns_is_named():
    """Two columns are a table as any other (pandas would take the first field of a row
    of three as its index)."""
    status, answer = body_refusal("text/csv", b"t_s,vel_l\n1.0,2.0,3.0\n", None, 10**6)
    assert status == 400
    assert answer["message"] == ("RaggedRowError: a row of 3 fields under a header of 2 (a "
                                 "trailing comma, or a comma inside an unquoted value: the "
                                 "columns would shift) (file request, line 2)")
    assert body_refusal("text/csv", b"t_s\n1.0\n", None, 10**6) is None


def test_of_several_keys_given_twice_the_first_is_named():
    body = b'{"dataframe_records": [{"t_s": 1, "t_s": 2}, {"t_s": 3, "t_s": 4}]}'
    status, answer = body_refusal("application/json", body, None, 10**6)
    assert status == 400
    assert answer["message"].startswith('DataFormatError: record 0 (0-based) has the key '
                                        '"t_s" twice'), answer


@pytest.mark.parametrize("host", ["192.168.1.5", "10.0.0.1", "::", "example.org"])
def test_serve_refuses_every_address_that_is_not_loopback(tmp_path, capsys, host):
    """Not only the unspecified 0.0.0.0: any address off the machine (a LAN one) too."""
    from terrain.cli import main

    assert main(["serve", "--model", str(tmp_path / "model"), "--host", host]) == 2
    assert capsys.readouterr().err.strip() == (
        f"terrain serve: error: --host {host} is not a loopback address (use 127.0.0.1)")
