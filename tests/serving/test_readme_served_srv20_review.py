"""Review srv20: README's served-model example request, sent with one row moved back in
time, is answered word for word as README shows, as CSV and as ``dataframe_split`` JSON (the
row named is the one in the body as sent)."""

from __future__ import annotations

import io
import json
import re
from pathlib import Path

import pandas as pd
import pytest

import test_content_type_srv20_review as _types   # same folder
from test_served_fuzz_srv15_review import answer, encode

guarded = _types.guarded   # the wheel model behind the request guard (a fixture)

README = Path(__file__).resolve().parents[2] / "README.md"


def _section() -> str:
    text = README.read_text(encoding="utf-8")
    return text[text.index("### Served model (`terrain serve`)"):]


def _request() -> str:
    """README's ``request.csv``."""
    return re.search(r"```text\n(stream,t_s,vel_l.*?)```", _section(), re.S).group(1)


def _error_answer() -> dict:
    """README's answer to the request with one row moved back in time."""
    found = re.search(r"answers `HTTP 400`\s*```json\n(.*?)\n```", _section(), re.S)
    return json.loads(found.group(1))


@pytest.mark.parametrize("fmt", ["csv", "split", "crlf"])
def test_readmes_moved_row_example_is_answered_word_for_word(guarded, fmt):
    lines = _request().strip().split("\n")
    # the first sample moved back to after the fifth: data row 4 goes back in time
    moved = [lines[0], *lines[2:6], lines[1], *lines[6:]]
    body = "\n".join(moved) + "\n"
    if fmt == "crlf":
        data, content_type = ("\ufeff" + body.replace("\n", "\r\n")).encode(), "text/csv"
    elif fmt == "csv":
        data, content_type = body.encode(), "text/csv"
    else:
        data, content_type = encode(pd.read_csv(io.StringIO(body)), "split")
    status, doc = answer(guarded, data, content_type)
    assert status == 400
    assert doc == _error_answer()
