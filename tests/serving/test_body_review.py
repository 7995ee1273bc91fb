"""Review of :func:`terrain.serving.body.body_refusal` on bodies built here (no server)."""

from __future__ import annotations

import json

import pytest

from terrain.serving.body import body_refusal

LIMIT = 1 << 20


def _json(doc) -> tuple[int, dict] | None:
    return body_refusal("application/json", json.dumps(doc).encode(), None, LIMIT)


def test_a_record_with_a_key_record_0_lacks_is_refused_naming_the_key():
    # pandas would add the column and fill it with NaN in every other record
    records = [{"t_s": 0.0, "vel_l": 0.1}, {"t_s": 0.1, "vel_l": 0.1},
               {"t_s": 0.2, "vel_l": 0.1, "cur_l": 5.0}]
    status, answer = _json({"dataframe_records": records})
    assert status == 400
    assert answer["message"].startswith("RaggedRowError: record 2 (0-based) has key(s) "
                                        "['cur_l'] that record 0 lacks")


def test_a_quote_opened_in_the_last_byte_is_named_with_its_line():
    # the quote opens a field and the body ends: pandas would answer "EOF inside string"
    body = b"stream,t_s\nwheels,0.0\nwheels,\""
    status, answer = body_refusal("text/csv", body, None, LIMIT)
    assert status == 400
    assert answer["message"].startswith("DataFormatError: unterminated quote")
    assert "line 3" in answer["message"]


def test_a_record_that_is_no_object_is_named_by_its_place():
    status, answer = _json({"dataframe_records": [{"t_s": 0.0}, {"t_s": 0.1}, [0.2]]})
    assert status == 400 and answer["message"].startswith("DataFormatError: a record is an "
                                                          "array, not an object")
    assert "data row 2 (0-based)" in answer["message"]


def test_seven_repeated_column_names_are_five_named_and_two_counted():
    names = [f"c{i}" for i in range(7)]
    body = (",".join(names * 2) + "\n" + ",".join(["1"] * 14) + "\n").encode()
    status, answer = body_refusal("text/csv", body, None, LIMIT)
    assert status == 400
    assert ("duplicated column name(s) ['c0', 'c1', 'c2', 'c3', 'c4'] and 2 more; send each "
            "column once") in answer["message"]


def test_a_huge_number_after_a_space_in_a_quoted_body_is_refused_with_its_column():
    # pandas reads " 1e400" as infinity; the quote elsewhere sends the body through the
    # csv module, whose fields keep their spaces
    body = b'stream,t_s,vel_l\n"wheels",0.0, 1e400\n'
    status, answer = body_refusal("text/csv", body, None, LIMIT)
    assert status == 400 and answer["message"].startswith("ImplausibleValueError: number "
                                                          "1e400 beyond the float range")
    assert "column 'vel_l'" in answer["message"] and "line 2" in answer["message"]


def test_mlflow_s_tensor_formats_are_left_to_the_served_model():
    # the served model refuses "inputs" and "instances" in its own words (expected a table)
    for key in ("inputs", "instances"):
        assert _json({key: [[0.0, 1.0]]}) is None


@pytest.mark.parametrize("row, fields", [(b"1", 1), (b"1,2,3", 3)])
def test_a_two_column_csv_body_is_checked_for_ragged_rows(row, fields):
    """The smallest table the row check reads (one column cannot be ragged but for a
    comma, and is refused for its missing channels anyway): a short or long row of a
    two-column body is named with its line."""
    body = b"t_s,cur_l\n0,1\n" + row + b"\n2,3\n"
    status, answer = body_refusal("text/csv", body, None, 10**6)
    assert status == 400 and answer["message"].startswith(
        f"RaggedRowError: a row of {fields} fields under a header of 2")
    assert answer["message"].endswith("line 3)")


@pytest.mark.parametrize("kind", ["text/csv", "application/json"])
def test_a_nul_byte_at_the_very_start_is_named(kind):
    """A log padded with zeros from its first byte on is refused for its NUL byte at byte
    0 (the check 'nul > 0' survived: the body then went on to the parsers)."""
    body = b"\x00" + b"stream,t_s,vel_l\nwheels,0,0.1\n"
    status, answer = body_refusal(kind, body, None, LIMIT)
    assert status == 400 and answer["message"].startswith(
        "EncodingError: the request body holds a NUL byte (0x00) at byte 0")
    assert answer["message"].endswith("line 1)")


def test_a_field_over_the_csv_readers_limit_is_refused_under_a_one_column_header():
    """Under a header of one column the ragged-row scan (which catches the csv module's
    field limit) does not run; the scan for numbers beyond the float range then hit it:
    csv.Error escaped body_refusal and the server answered uvicorn's plain-text 500."""
    body = b'a\n"' + b"x" * 200_000 + b'"\n1e400\n'
    status, answer = body_refusal("text/csv", body, None, 10**8)
    assert status == 400, answer
    assert answer["message"].startswith("DataFormatError: unreadable CSV: a field longer "
                                        "than 131072 characters")


def test_a_record_with_as_many_keys_as_record_0_but_another_one_is_refused():
    # the same count of keys is not the same keys: pandas would add the column 'vel_r',
    # NaN in record 0, and fill 'vel_l' with NaN in record 1
    records = [{"t_s": 0.0, "vel_l": 0.1}, {"t_s": 0.1, "vel_r": 0.1}]
    status, answer = _json({"dataframe_records": records})
    assert status == 400
    assert answer["message"].startswith("RaggedRowError: record 1 (0-based) lacks ['vel_l']")


@pytest.mark.parametrize("table", ["dataframe_split", "dataframe_records"])
def test_a_json_body_sent_as_csv_is_told_to_be_sent_as_json(table):
    """A JSON table sent with Content-Type text/csv was read as a CSV header of JSON
    fragments: "duplicated column name(s) ['-0.0236220472440944', ...]" or a missing
    stream; the answer now says what the body is and which Content-Type to send."""
    columns = ["stream", "t_s", "vel_l", "vel_r", "cur_l", "cur_r"]
    data = [["wheels", 0.154 * i, -0.02, -0.02, 1.0, 1.0] for i in range(3)]
    doc = ({"dataframe_split": {"columns": columns, "data": data}}
           if table == "dataframe_split" else
           {"dataframe_records": [dict(zip(columns, row)) for row in data]})
    body = b" \r\n" + json.dumps(doc, indent=1).encode()
    status, answer = body_refusal("text/csv", body, None, LIMIT)
    assert status == 400
    assert answer["message"].startswith("DataFormatError: the CSV body is a JSON document; "
                                        "send it with Content-Type application/json"), answer


def test_a_csv_header_that_opens_with_a_brace_is_still_csv():
    assert body_refusal("text/csv", b"{a},t_s\n1,2\n", None, LIMIT) is None
