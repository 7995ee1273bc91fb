"""Review srv20 of the line numbers :func:`terrain.serving.body.body_refusal` gives a CSV
body's refusals: the line of the offending cell in the body as sent, whatever its line ends
(LF, CR LF, a lone CR), blank lines, byte-order mark or quoted fields holding a line break
(a free-text column the model ignores)."""

from __future__ import annotations

import re

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
import pytest

from terrain.serving.body import body_refusal

LIMIT = 1 << 20
HEADER = ["stream", "t_s", "vel_l", "vel_r", "note"]


@st.composite
def bodies(draw):
    """(body, 1-based line of the cell ``1e400``, column of it); the note, which may hold
    line breaks, before or after the number columns."""
    n = draw(st.integers(2, 6))
    bad_row = draw(st.integers(0, n - 1))
    bad_col = draw(st.sampled_from(["t_s", "vel_l", "vel_r"]))
    end = draw(st.sampled_from(["\n", "\r\n", "\r"]))
    quote_all = draw(st.booleans())
    header = draw(st.sampled_from([HEADER, ["stream", "note", "t_s", "vel_l", "vel_r"]]))
    text = "\ufeff" if draw(st.booleans()) else ""
    line = 1
    for _ in range(draw(st.integers(0, 2))):   # blank lines before the header, skipped too
        text += draw(st.sampled_from(["", " "])) + end
        line += 1
    text += ",".join(header) + end
    line += 1
    target = None
    for row in range(n):
        for _ in range(draw(st.integers(0, 2))):   # blank lines pandas skips
            text += draw(st.sampled_from(["", " ", "\t"])) + end
            line += 1
        note_breaks = draw(st.integers(0, 2)) if quote_all else 0
        note = "a" + "".join(draw(st.sampled_from(["\n", "\r\n"])) + "b"
                             for _ in range(note_breaks))
        cells = {"stream": "wheels", "t_s": f"{row * 0.2:.1f}", "vel_l": "0.1",
                 "vel_r": "0.2", "note": note}
        if row == bad_row:
            cells[bad_col] = "1e400"
            # the cell's own line: after the note's line breaks where the note comes first
            target = line + (note_breaks if header.index("note") < header.index(bad_col)
                             else 0)
        fields = [f'"{cells[c]}"' if quote_all else cells[c] for c in header]
        text += ",".join(fields) + end
        line += 1 + len(re.findall(r"\r\n|\r|\n", note))
    return text.encode(), target, bad_col


@pytest.mark.slow
@settings(max_examples=300, deadline=None, suppress_health_check=list(HealthCheck))
@given(bodies())
def test_a_number_beyond_the_float_range_is_named_with_the_line_of_its_cell(case):
    body, line, column = case
    status, answer = body_refusal("text/csv", body, None, LIMIT)
    assert status == 400
    message = answer["message"]
    assert message.startswith("ImplausibleValueError: number 1e400 beyond the float range")
    assert f"column '{column}', line {line})" in message, (body, message)


@settings(max_examples=200, deadline=None, suppress_health_check=list(HealthCheck))
@given(prefix=st.sampled_from(["", "\ufeff", "\n", " \r\n"]),
       end=st.sampled_from(["\n", "\r\n", "\r"]), breaks=st.integers(1, 3),
       short=st.booleans(), before=st.integers(0, 2))
def test_a_ragged_row_holding_a_quoted_line_break_is_named_with_its_first_line(
        prefix, end, breaks, short, before):
    """A row whose quoted note holds line breaks spans several lines; it was named with its
    last, a line holding only the note's tail."""
    good = '"wheels","0.0","0.1","0.2","a"'
    note = '"a' + "\nb" * breaks + '"'
    ragged = '"wheels","0.2","0.1",' + note if short else '"wheels","0.2","0.1","0.2",' \
        + note + ',"x"'
    lines = [",".join(HEADER), *[good] * before, ragged, good]
    body = (prefix + end.join(lines) + end).encode()
    line = prefix.count("\n") + prefix.count("\r") - prefix.count("\r\n") + 2 + before
    status, answer = body_refusal("text/csv", body, None, LIMIT)
    assert status == 400 and answer["message"].startswith("RaggedRowError"), answer
    assert answer["message"].endswith(f"(file request, line {line})"), (body, answer)
