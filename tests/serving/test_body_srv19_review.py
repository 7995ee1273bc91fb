"""Review srv19 of :func:`terrain.serving.body.body_refusal`'s CSV checks against what
pandas (MLflow's CSV parser) reads: blank lines before the header, and lines of white space
that pandas does not take as blank."""

from __future__ import annotations

import io

import pandas as pd
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from terrain.serving.body import body_refusal, csv_header

LIMIT = 1 << 20
HEADER = "stream,t_s,vel_l,vel_r"
ROWS = ["wheels,0.0,0.1,0.2", "wheels,0.1,0.1,0.2", "wheels,0.2,0.1,0.2"]


def _csv(text: str):
    return body_refusal("text/csv", text.encode(), None, LIMIT)


@pytest.mark.parametrize("prefix", ["\n", "\r\n", " \n", "\t\r", "\n \n\t\n", "\ufeff\n"])
def test_a_repeated_column_after_leading_blank_lines_is_refused(prefix):
    """pandas skips blank lines before the header; the check read the blank first line as
    a header of no column, so ``vel_l`` twice passed and pandas renamed the second
    ``vel_l.1`` (answered as an ignored column the client never sent)."""
    body = prefix + "stream,t_s,vel_l,vel_l\n" + "\n".join(ROWS) + "\n"
    assert list(pd.read_csv(io.StringIO(body)).columns)[-1] == "vel_l.1"
    status, answer = _csv(body)
    assert status == 400
    assert answer["message"].startswith("DataFormatError: duplicated column name(s) "
                                        "['vel_l']")


@pytest.mark.parametrize("quoted", [False, True])
def test_a_short_row_after_leading_blank_lines_is_refused_with_its_line(quoted):
    """The short row (line 5 of the body, with two blank lines first) was filled with NaN
    by pandas, unsaid."""
    rows = list(ROWS)
    rows[1] = "wheels,0.1,0.1"
    if quoted:
        rows[0] = '"wheels",0.0,0.1,0.2'
    body = "\n \n" + HEADER + "\n" + "\n".join(rows) + "\n"
    assert pd.read_csv(io.StringIO(body)).isna().sum().sum() == 1
    status, answer = _csv(body)
    assert status == 400
    assert answer["message"].startswith("RaggedRowError: a row of 3 fields under a header "
                                        "of 4")
    assert "line 5" in answer["message"]


def test_the_header_is_the_first_line_that_is_not_blank():
    assert csv_header(b"\n \t\r\n" + HEADER.encode() + b"\n") == HEADER.split(",")
    assert csv_header(b"\xef\xbb\xbf\n" + HEADER.encode()) == HEADER.split(",")


@pytest.mark.parametrize("space", ["\x0b", "\x0c", "\u00a0"])
@pytest.mark.parametrize("quoted", [False, True])
def test_a_line_of_other_white_space_is_a_short_row(space, quoted):
    """pandas skips a line of spaces and tabs only; a vertical tab, a form feed or a
    no-break space is a field, so the line is a row of one field filled with NaN."""
    first = '"wheels",0.0,0.1,0.2' if quoted else ROWS[0]
    body = "\n".join([HEADER, first, space, *ROWS[1:]]) + "\n"
    assert len(pd.read_csv(io.StringIO(body))) == 4   # three rows and the one-field one
    status, answer = _csv(body)
    assert status == 400 and answer["message"].startswith("RaggedRowError: a row of 1 field")
    assert "line 3" in answer["message"]


_PIECES = st.sampled_from([",", '"', "\n", "\r", "\r\n", "a", "b", "1", " ", "\t", ".", "#",
                           "\x0b", "\ufeff"])


@pytest.mark.slow
@settings(max_examples=400, deadline=None, suppress_health_check=list(HealthCheck))
@given(st.lists(_PIECES, min_size=1, max_size=24))
@example(["\ufeff", "\ufeff", ",", "a", "\n", ","])
def test_a_csv_body_passed_on_is_read_by_pandas_as_checked(pieces):
    """A body the checks pass is read by pandas with the header :func:`csv_header` names
    (no column renamed ``.1``) and no row longer or shorter than it (none filled with NaN
    nor turned into an index). A second byte-order mark is part of the first name, as
    pandas reads it (csv_header stripped every mark: a local Hypothesis draw, stop 92)."""
    text = "".join(pieces)
    if body_refusal("text/csv", text.encode(), None, LIMIT) is not None:
        return
    try:
        frame = pd.read_csv(io.StringIO(text))
    except Exception:   # pandas refuses it: MLflow's message, rewritten by the guard
        return
    if frame.shape[1] < 2 or not len(frame):
        return   # a one-column body is refused by the served model for its columns
    header = csv_header(text.encode())
    # a name of white space only is '' to csv_header (stripped), kept or "Unnamed: i" by
    # pandas
    read = [str(c).strip() for c in frame.columns]
    assert len(read) == len(header), text
    assert all(r == h or (not h and r in ("", f"Unnamed: {i}"))
               for i, (r, h) in enumerate(zip(read, header))), text
    assert isinstance(frame.index, pd.RangeIndex), text


@settings(max_examples=200, deadline=None, suppress_health_check=list(HealthCheck))
@given(st.lists(st.sampled_from(["\n", "\r\n", "\r", " ", "\t"]), min_size=1, max_size=6)
       .map("".join).map(lambda p: p if p.endswith(("\n", "\r")) else p + "\n"),
       st.lists(_PIECES, min_size=1, max_size=24).map("".join))
def test_blank_lines_before_the_header_change_nothing_but_the_line_numbers(prefix, text):
    """pandas skips them: the body is refused, or passed on, as without them."""
    if text.lstrip(" \t\r\n\ufeff") != text:
        return
    alone, prefixed = _csv(text), _csv(prefix + text)
    assert (alone is None) == (prefixed is None), (prefix, text, alone, prefixed)
    if alone is not None:
        assert alone[0] == prefixed[0]
        assert alone[1]["message"].split(":")[0] == prefixed[1]["message"].split(":")[0]


_NAMES = st.sampled_from(["t_s", "vel_l", "stream", "", "a b", "1"])
_VALUES = st.one_of(st.floats(allow_nan=False, allow_infinity=False, width=32),
                    st.integers(-5, 5), st.sampled_from(["wheels", "", None, True]))


@pytest.mark.slow
@settings(max_examples=300, deadline=None, suppress_health_check=list(HealthCheck))
@given(st.lists(_NAMES, max_size=4), st.lists(st.lists(_VALUES, max_size=5), max_size=4),
       st.booleans(), st.one_of(st.none(), st.lists(st.integers(0, 3), max_size=5)))
def test_a_json_table_passed_on_is_read_by_mlflow_cell_for_cell(columns, data, records, index):
    """A ``dataframe_split`` or ``dataframe_records`` body the checks pass is read by
    MLflow's own JSON reader with every column once and every value given (none filled
    with NaN, none dropped)."""
    import json

    from mlflow.utils.proto_json_utils import dataframe_from_parsed_json

    if records:
        key, doc = "dataframe_records", [dict(zip(columns, row)) for row in data]
        given_cells = sum(v is not None for row in doc for v in row.values())
        n_cells = sum(len(row) for row in doc)
    else:
        key, doc = "dataframe_split", {"columns": columns, "data": data}
        if index is not None:
            doc["index"] = index
        given_cells = sum(v is not None for row in data for v in row)
        n_cells = sum(len(row) for row in data)
    body = json.dumps({key: doc}).encode()
    if body_refusal("application/json", body, None, LIMIT) is not None:
        return
    frame = dataframe_from_parsed_json(json.loads(body)[key],
                                       "records" if records else "split")
    assert frame.size == n_cells, body   # no cell added (NaN) for a missing value
    assert int(frame.notna().sum().sum()) == given_cells, body
    assert len(set(frame.columns)) == len(frame.columns), body
