"""Checks of a request body before MLflow's scoring server parses it.

MLflow reads a CSV body with pandas, a JSON body with its own ``dataframe_split`` /
``dataframe_records`` readers and a Parquet body with pyarrow. Each of them accepts some
malformed bodies silently (pandas renames a repeated column ``cur_r.1``, fills a short row
with NaN, turns a row one field longer than the header into an index column, reads
``1e400`` as infinity; ``json`` keeps the last value of a key given twice) and refuses
others with its own wording (``Error tokenizing data. C error: EOF inside string``, ``6
columns passed, passed data had 8 columns``).
:func:`body_refusal` finds these cases on the raw bytes first and answers them with the
project's typed message, naming the line, row and column. Used by
:class:`terrain.serving.http.RequestGuard`.
"""

from __future__ import annotations

import csv
import io
import json
import math
import re
from typing import Any

from terrain.errors import (DataFormatError, EncodingError, ImplausibleValueError,
                            RaggedRowError, TerrainError, duplicated, listed)

#: line ends of a CSV body: pandas (MLflow's CSV parser) reads CR LF, LF and a lone CR
LINE_END = re.compile(rb"\r\n|\r|\n")
_TEXT_LINE_END = re.compile(r"\r\n|\r|\n")
#: what pandas skips as a blank line (``skip_blank_lines``): spaces and tabs only; a line of
#: other white space (a vertical tab, a form feed, a no-break space) is a row of one field
BLANK = " \t"
#: the blank lines pandas skips before a CSV body's header line
_LEADING_BLANK_LINES = re.compile(rb"(?:[ \t]*+(?:\r\n|\r|\n))*+")
#: largest uncompressed size of a Parquet body, as a multiple of the body-size limit (a
#: small compressed body can decode to gigabytes)
PARQUET_EXPANSION = 16
#: the JSON shapes of a table that the served model takes
JSON_TABLES = ("dataframe_split", "dataframe_records")
#: digits in a row from which a number without a 3-digit exponent is parsed to be sure
#: (beyond the float range it needs 309 digits with no exponent, 210 with one of 99)
_LONG_DIGIT_RUN = 100
#: a number written beyond the float range has a decimal exponent of 100 or more, or
#: :data:`_LONG_DIGIT_RUN` or more digits before the point: only such tokens are parsed to
#: be sure. Possessive quantifiers: with plain ones a run of 40,000 digits backtracked for
#: 22 s (quadratic in its length) while the event loop waited
_HUGE_NUMBER = re.compile(
    r"(?<![\w.])[-+]?(?:(?:\d++(?:\.\d*+)?|\.\d++)[eE]\+?\d{3,}+"
    rf"|\d{{{_LONG_DIGIT_RUN},}}+(?:\.\d*+)?(?:[eE][-+]?\d++)?)(?![\w.])")
#: cheap first passes over the raw bytes for such tokens (the precise pattern above takes
#: ~0.4 s on an 8 MB body, these ~0.06 s): a 3-digit exponent, or a long run of digits
_EXPONENT_3 = re.compile(rb"[eE]\+?\d\d\d")
_DIGITS_AS_ZERO = bytes.maketrans(b"123456789", b"000000000")
#: a CSV field as pandas and the csv module read it: a quote opens a quoted field only at
#: the field's start (inside, ``""`` is a quote and a single ``"`` closes it; what follows
#: up to the next comma is kept as written); anywhere else a quote is a literal character
#: (``tire 13"``)
_CSV_FIELD = rb'(?:"(?:[^"]|"")*+"[^,\r\n]*+|(?:[^",\r\n][^,\r\n]*+)?+)'
#: a CSV body's longest prefix of whole fields: it stops at a quote that opens a field and
#: is never closed (possessive, so one pass: 0.2 s on an 8 MB body of quoted fields)
_CSV_WHOLE_FIELDS = re.compile(rb"(?:" + _CSV_FIELD + rb"(?:,|\r\n|\r|\n))*+" + _CSV_FIELD)
_JSON_FORM = ('send {"dataframe_split": {"columns": [...], "data": [[...], ...]}} or '
              '{"dataframe_records": [{...}, ...]}')
_WHERE = "request"


def _refusal(error: TerrainError, status: int = 400,
             code: str = "BAD_REQUEST") -> tuple[int, dict]:
    """Status and JSON answer of a refused body (``<ErrorClass>: message``)."""
    return status, {"error_code": code, "message": f"{type(error).__name__}: {error}"}


class _HugeFloat(float):
    """A JSON number literal beyond the float range (``json`` reads it as infinity); keeps
    its text so the refusal can show it."""

    text = ""


def _json_float(text: str) -> float:
    """``parse_float`` of :func:`json.loads`: a float, or a :class:`_HugeFloat` for a
    literal beyond the float range."""
    value = float(text)
    if math.isinf(value):
        value = _HugeFloat(value)
        value.text = text
    return value


def _json_type(value: Any) -> str:
    """JSON's name of a parsed value's type (``null``, ``a number``...), not Python's."""
    if value is None:
        return "null"
    for kind, name in ((bool, "a boolean"), ((int, float), "a number"), (str, "a string"),
                       (list, "an array"), (dict, "an object")):
        if isinstance(value, kind):
            return name
    return type(value).__name__


def _short_text(text: str, limit: int = 24) -> str:
    return text if len(text) <= limit else f"{text[:limit - 3]}... ({len(text)} characters)"


def _listed(names: list, limit: int = 5) -> str:
    """``names`` (the request's columns or keys) as a message lists them: the first
    ``limit``, each cut by :func:`_short_text`, and a count of the others (a repeated
    5,000-name header listed every name: a 70 kB message)."""
    return listed(names, limit, lambda n: _short_text(str(n)))


def _huge_number(value: str, column: str | None, row: int | None = None,
                 line: int | None = None) -> ImplausibleValueError:
    """The refusal of a number beyond the float range (``value`` as written)."""
    return ImplausibleValueError(
        f"number {_short_text(value)} beyond the float range (|x| < "
        f"{1.7976931348623157e308:.4g}); no logger writes it", _WHERE, column, row, line)


def _looks_utf16(head: bytes) -> bool:
    """Whether ``head`` (a body's first bytes) is UTF-16: a byte-order mark, or NUL bytes in
    most of its even or of its odd positions (ASCII text in UTF-16)."""
    if head[:2] in (b"\xff\xfe", b"\xfe\xff"):
        return True
    half = len(head) // 2
    return half > 0 and max(head[0::2].count(0), head[1::2].count(0)) > half // 2


def _encoding_refusal(body: bytes) -> tuple[int, dict] | None:
    """A text body (CSV, JSON) that is not UTF-8: UTF-16 (its byte-order mark, or NUL bytes
    in every other position), a NUL byte (a log padded after a power cut), or a byte
    sequence UTF-8 cannot hold, named with its offset."""
    if _looks_utf16(body[:4096]):
        return _refusal(EncodingError("the request body is UTF-16 (a byte-order mark or NUL "
                                      "bytes in every other position); send UTF-8 text",
                                      _WHERE))
    nul = body.find(b"\x00")
    if nul >= 0:
        line = len(LINE_END.findall(body, 0, nul)) + 1
        return _refusal(EncodingError(
            f"the request body holds a NUL byte (0x00) at byte {nul} (a log padded with "
            "zeros, e.g. after a power cut?); send text only", _WHERE, line=line))
    try:
        body.decode("utf-8")
    except UnicodeDecodeError as exc:
        return _refusal(EncodingError(
            f"the request body is not UTF-8 text (byte 0x{body[exc.start]:02x} at byte "
            f"{exc.start}); send UTF-8 text", _WHERE))
    return None


def _header_start(body: bytes) -> tuple[int, int]:
    """(byte offset of the header line, blank lines before it) of a CSV body: pandas skips a
    UTF-8 byte-order mark and the blank lines (:data:`BLANK` only) before its header."""
    start = 3 if body.startswith(b"\xef\xbb\xbf") else 0
    end = _LEADING_BLANK_LINES.match(body, start).end()
    return end, len(LINE_END.findall(body, start, end))


def csv_header(body: bytes) -> list[str]:
    """Column names of a CSV body's header line (ended by CR LF, LF or a lone CR, as pandas
    reads it; quoted names unquoted, a UTF-8 byte-order mark and blank lines before it
    dropped, as pandas skips them).

    Parameters
    ----------
    body : bytes
        The request body, UTF-8.

    Returns
    -------
    list of str
        Names as pandas would read them before de-duplicating (stripped of spaces).

    Raises
    ------
    csv.Error
        A field beyond the csv module's size limit.
    """
    body = body[_header_start(body)[0]:]
    head = LINE_END.split(body, 1)[0]
    if b'"' in head:  # a quoted name may hold a line break: the csv module reads it whole
        head = body
    text = head.decode("utf-8", "replace")   # (one mark at the start: _header_start)
    return [c.strip() for c in next(csv.reader(io.StringIO(text, newline="")), [])]


def _ragged_csv_row(body: bytes, n_columns: int) -> tuple[int, int] | None:
    """(1-based line, fields) of the first CSV data row whose number of fields differs from
    the header's ``n_columns``, or None. pandas would fill a short row's missing fields with
    NaN, which the served model cannot tell from a cell left empty on purpose, and would
    take the first field of rows one field longer than the header as an index, shifting
    every column; blank lines are skipped as pandas skips them. A body with quotes is
    split by :mod:`csv` (a quoted field may hold a comma or a line break: the line is the
    one the row starts on), any other by its
    commas; a body with an unterminated quote is refused before this is asked. The blank
    lines before the header are skipped as pandas skips them (counted in the line)."""
    start, skipped = _header_start(body)
    body = body[start:]
    if b'"' in body:  # newline="": the csv module then takes any of the line ends
        reader = csv.reader(io.StringIO(body.decode("utf-8", "replace"), newline=""))
        next(reader, None)  # the header
        first = reader.line_num + 1   # the line a row starts on (a quoted field may hold
        for row in reader:            # line breaks: the row then ends lines later)
            # pandas skips a line of spaces and tabs only
            blank = len(row) == 1 and not row[0].strip(BLANK)
            if row and not blank and len(row) != n_columns:
                return first + skipped, len(row)
            first = reader.line_num + 1
        return None
    for number, line in enumerate(LINE_END.split(body)[1:], start=2 + skipped):
        if line.strip(BLANK.encode()) and line.count(b",") + 1 != n_columns:
            return number, line.count(b",") + 1
    return None


def _may_hold_huge_number(body: bytes) -> bool:
    """Whether ``body`` holds a 3-digit decimal exponent or :data:`_LONG_DIGIT_RUN` digits
    in a row, without which no number in it is beyond the float range."""
    return (_EXPONENT_3.search(body) is not None
            or b"0" * _LONG_DIGIT_RUN in body.translate(_DIGITS_AS_ZERO))


def _unterminated_quote(body: bytes) -> int | None:
    """Byte offset of the quote opening a CSV field that is never closed, or None (see
    :data:`_CSV_FIELD` for where a quote opens a field)."""
    end = _CSV_WHOLE_FIELDS.match(body).end()
    return None if end == len(body) else end


def _csv_refusal(body: bytes) -> tuple[int, dict] | None:
    """Refusal of a CSV body (see :func:`body_refusal`), or None."""
    if body.lstrip(b"\xef\xbb\xbf \t\r\n")[:1] in (b"{", b"["):
        # read as CSV, a JSON table's first line is a header of fragments: "duplicated
        # column name(s) ['-0.0236220472440944', ...]" or a missing stream
        try:
            json.loads(body)
        except (ValueError, RecursionError):
            pass   # a CSV header that opens with a brace
        else:
            return _refusal(DataFormatError("the CSV body is a JSON document; send it with "
                                            "Content-Type application/json", _WHERE))
    opening = _unterminated_quote(body) if b'"' in body else None
    if opening is not None:
        line = len(LINE_END.findall(body, 0, opening)) + 1
        return _refusal(DataFormatError("unterminated quote: the quoted field opened here "
                                        "runs to the end of the body", _WHERE, line=line))
    try:
        header = csv_header(body)
        refused = _names_refusal(header)
        if refused is not None:
            return refused
        ragged = _ragged_csv_row(body, len(header)) if len(header) > 1 else None
        # the scan below splits quoted rows with csv as well: under a one-column header,
        # where the ragged scan does not run, it met a field over csv's limit first
        huge = (_huge_csv_field(body.decode("utf-8"), header)
                if ragged is None and _may_hold_huge_number(body) else None)
    except csv.Error as exc:  # a field over csv's 131 072 characters: a 500 before
        limit = re.search(r"\((\d+)\)", str(exc))
        return _refusal(DataFormatError(
            "unreadable CSV: a field longer than "
            f"{limit.group(1) if limit else 'the CSV reader allows'} characters; a channel "
            "value or name is a number or a short name", _WHERE))
    if ragged is not None:
        line, fields = ragged
        hint = ("write an empty field for a missing value: the row would be filled with NaN"
                if fields < len(header) else
                "a trailing comma, or a comma inside an unquoted value: the columns would "
                "shift")
        return _refusal(RaggedRowError(f"a row of {fields} fields under a header of "
                                       f"{len(header)} ({hint})", _WHERE, line=line))
    if huge is None:
        return None
    value, column, line = huge
    return _refusal(_huge_number(value, column, line=line))


def _huge_csv_field(text: str, header: list[str]) -> tuple[str, str | None, int] | None:
    """(number as written, its column, 1-based line) of the first CSV field beyond the
    float range, or None. Without quotes a field is found by counting commas; with quotes
    the csv module splits the rows (a quoted field may hold a comma or a line break: the
    line is the row's first plus the line breaks in the fields before it)."""
    if '"' not in text:
        for found in _HUGE_NUMBER.finditer(text):
            if math.isinf(float(found.group())):
                start = found.start()
                line = len(_TEXT_LINE_END.findall(text, 0, start)) + 1
                line_start = max(text.rfind("\n", 0, start), text.rfind("\r", 0, start)) + 1
                field = text.count(",", line_start, start)
                return (found.group(), header[field] if field < len(header) else None, line)
        return None
    reader = csv.reader(io.StringIO(text, newline=""))
    next(reader, None)  # the header
    first = reader.line_num + 1   # the line each row starts on
    for row in reader:
        for field, value in enumerate(row):
            value = value.strip()
            if _HUGE_NUMBER.fullmatch(value) and math.isinf(float(value)):
                line = first + sum(len(_TEXT_LINE_END.findall(v)) for v in row[:field])
                return (value, header[field] if field < len(header) else None, line)
        first = reader.line_num + 1
    return None


class _ObjectsWithRepeatedKeys:
    """``object_pairs_hook`` of :func:`json.loads` that notes a key given twice in one
    object (``json`` and MLflow keep the last value and drop the other silently): the
    first such key and the object's place among the objects closed so far (a
    ``dataframe_records`` record closes before the next one opens, so for a table of flat
    records that place is the record's index)."""

    def __init__(self) -> None:
        self.closed = 0
        self.repeated: tuple[str, int] | None = None

    def __call__(self, pairs: list[tuple[str, Any]]) -> dict:
        obj = dict(pairs)
        if len(obj) != len(pairs) and self.repeated is None:
            seen: set[str] = set()
            for key, _ in pairs:
                if key in seen:
                    self.repeated = (key, self.closed)
                    break
                seen.add(key)
        self.closed += 1
        return obj


def _repeated_key_refusal(doc: Any, key: str, place: int) -> tuple[int, dict]:
    """Refusal of a JSON body with ``key`` twice in one object, the ``place``-th closed."""
    records = doc.get("dataframe_records") if isinstance(doc, dict) else None
    if isinstance(records, list) and place < len(records) and isinstance(
            records[place], dict) and key in records[place]:
        return _refusal(DataFormatError(f"record {place} (0-based) has the key "
                                        f"{json.dumps(key)[:40]} twice (a JSON reader keeps "
                                        "the last value and drops the other); send each "
                                        "key once", _WHERE))
    return _refusal(DataFormatError(f"the JSON body has the key {json.dumps(key)[:40]} twice "
                                    "in one object (a JSON reader keeps the last value and "
                                    "drops the other); send each key once", _WHERE))


def _json_refusal(body: bytes) -> tuple[int, dict] | None:
    """Refusal of a JSON body (see :func:`body_refusal`), or None."""
    hook = _ObjectsWithRepeatedKeys()
    try:
        # parse_float costs a Python call per number: only where a huge one may be (None:
        # json's own float)
        huge = _may_hold_huge_number(body)
        doc = json.loads(body, parse_float=_json_float if huge else None,
                         object_pairs_hook=hook)
    except (ValueError, RecursionError):
        return None  # MLflow's parser refuses it; its message is rewritten by the guard
    if hook.repeated is not None:
        return _repeated_key_refusal(doc, *hook.repeated)
    if not isinstance(doc, dict):
        return _refusal(DataFormatError(f"the JSON body is {_json_type(doc)}, not an "
                                        f"object; {_JSON_FORM}", _WHERE))
    if "inputs" in doc or "instances" in doc:
        return None  # the served model answers MLflow's tensor formats itself
    tables = [k for k in doc if k in JSON_TABLES]
    if "params" in doc:   # MLflow's inference parameters: nothing in the served model reads them
        return _refusal(DataFormatError("the served model takes no 'params' (its settings "
                                        "are fixed when it is served); send the table alone",
                                        _WHERE))
    if len(tables) != 1 or len(doc) != 1:
        return _refusal(DataFormatError(f"the JSON body has the key(s) {_listed(sorted(doc))}; "
                                        f"{_JSON_FORM}", _WHERE))
    if tables[0] == "dataframe_split":
        return _split_refusal(doc["dataframe_split"], huge)
    return _records_refusal(doc["dataframe_records"], huge)


def _names_refusal(columns: list) -> tuple[int, dict] | None:
    """Refusal of column names that are not text or appear twice (CSV header, JSON table,
    Parquet schema), or None."""
    odd = [c for c in columns if not isinstance(c, str)]
    if odd:
        return _refusal(DataFormatError(f"column names must be text, got "
                                        f"{json.dumps(odd[0])[:40]}", _WHERE))
    dup = duplicated(columns)
    if dup:
        return _refusal(DataFormatError(f"duplicated column name(s) {_listed(dup)}; send each "
                                        "column once", _WHERE))
    return None


def _split_refusal(split: Any, huge: bool) -> tuple[int, dict] | None:
    """Refusal of a ``dataframe_split`` table: its shape, names, rows and (``huge``: the
    body may hold one) numbers beyond the float range."""
    if not isinstance(split, dict) or not {"columns", "data"} <= set(split) \
            or not set(split) <= {"columns", "data", "index"}:
        keys = sorted(split) if isinstance(split, dict) else _json_type(split)
        return _refusal(DataFormatError(f"dataframe_split must be an object with 'columns' "
                                        f"and 'data' (and optionally 'index'), got {keys}; "
                                        f"{_JSON_FORM}", _WHERE))
    columns, data = split["columns"], split["data"]
    if not isinstance(columns, list):
        return _refusal(DataFormatError("dataframe_split 'columns' must be a list of column "
                                        f"names, got {_json_type(columns)}", _WHERE))
    refused = _names_refusal(columns)
    if refused is not None:
        return refused
    if not isinstance(data, list):
        return _refusal(DataFormatError("dataframe_split 'data' must be a list of rows, got "
                                        f"{_json_type(data)}", _WHERE))
    index = split.get("index")
    if index is not None and not (isinstance(index, list) and len(index) == len(data)):
        size = len(index) if isinstance(index, list) else _json_type(index)
        return _refusal(DataFormatError(f"dataframe_split 'index' has {size} entries for "
                                        f"{len(data)} data rows (leave it out)", _WHERE))
    for number, row in enumerate(data):
        if not isinstance(row, list):
            return _refusal(DataFormatError(f"a data row is {_json_type(row)}, not an "
                                            "array of values", _WHERE, row=number))
        if len(row) != len(columns):
            hint = ("send null for a missing value: the row would be filled with NaN"
                    if len(row) < len(columns) else "one value per column")
            return _refusal(RaggedRowError(f"data row {number} (0-based) holds {len(row)} "
                                           f"values for {len(columns)} columns ({hint})",
                                           _WHERE))
        for column, value in zip(columns, row) if huge else ():
            if isinstance(value, _HugeFloat):
                return _refusal(_huge_number(value.text, column, number))
    return None


def _records_refusal(records: Any, huge: bool) -> tuple[int, dict] | None:
    """Refusal of a ``dataframe_records`` table: every record an object with the same keys
    (pandas would fill a missing key with NaN, as a short CSV row), and (``huge``: the body
    may hold one) its numbers beyond the float range."""
    if not isinstance(records, list):
        return _refusal(DataFormatError(f"dataframe_records must be a list of objects, got "
                                        f"{_json_type(records)}", _WHERE))
    keys = None
    for number, record in enumerate(records):
        if not isinstance(record, dict):
            return _refusal(DataFormatError(f"a record is {_json_type(record)}, not an "
                                            "object of column: value", _WHERE, row=number))
        if keys is None:
            keys = list(record)
        elif set(record) != set(keys):
            missing = [k for k in keys if k not in record]
            extra = [k for k in record if k not in keys]
            what = (f"lacks {_listed(missing)} (send null for a missing value: it would be "
                    "filled with NaN)" if missing else
                    f"has key(s) {_listed(extra)} that record 0 lacks")
            return _refusal(RaggedRowError(f"record {number} (0-based) {what}", _WHERE))
        for column, value in record.items() if huge else ():
            if isinstance(value, _HugeFloat):
                return _refusal(_huge_number(value.text, column, number))
    return None


def _parquet_refusal(body: bytes, max_rows: int | None,
                     max_body_bytes: int) -> tuple[int, dict] | None:
    """Refusal of a Parquet body from its metadata (see :func:`body_refusal`), or None."""
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
        meta = pq.ParquetFile(pa.BufferReader(body)).metadata
    except Exception:  # not Parquet: MLflow's parser answers with its own message
        return None
    refused = _names_refusal(meta.schema.names)
    if refused is not None:
        return refused
    # decoded, every cell takes at least 8 bytes (a float; text more); the metadata's own
    # sizes are of the encoded pages (a dictionary-encoded column is a few bytes)
    size = int(meta.num_rows) * int(meta.num_columns) * 8
    if max_rows is not None and meta.num_rows > max_rows:
        return _refusal(DataFormatError(f"request of {meta.num_rows} rows exceeds the limit "
                                        f"of {max_rows}; send the streams in shorter pieces",
                                        _WHERE))
    if size > PARQUET_EXPANSION * max_body_bytes:
        return _refusal(DataFormatError(
            f"Parquet body decodes to at least {size} bytes, over {PARQUET_EXPANSION} x the "
            f"body limit of {max_body_bytes}; send the streams in shorter pieces", _WHERE),
            413, "REQUEST_LIMIT_EXCEEDED")
    return None


def body_refusal(content_type: str, body: bytes, max_rows: int | None,
                 max_body_bytes: int) -> tuple[int, dict] | None:
    """Status and answer refusing a request body before MLflow parses it, or None.

    * a CSV or JSON body that is not UTF-8 (UTF-16 included), named with the byte;
    * column names that are not text or appear twice (a CSV header, quoted or not, a
      ``dataframe_split`` table or a Parquet schema): pandas renames a repeated column and
      MLflow would shift the channels after it;
    * a CSV row with a number of fields other than the header's, a ``dataframe_split``
      data row with another number of values than columns, a ``dataframe_records`` record
      with other keys than the first: pandas would fill the missing fields with NaN
      silently, or shift the columns;
    * a JSON key given twice in one object (a record's column, a table's ``columns``):
      ``json`` keeps the last value and drops the other silently; named with the record;
    * an unterminated quote in a CSV body, named with the line where it opens;
    * a CSV body that is a JSON document (a JSON table sent as ``text/csv``);
    * a JSON body that is not one ``dataframe_split`` or ``dataframe_records`` table of the
      right shape (MLflow's ``inputs`` / ``instances`` are left to the served model, which
      refuses them with its own message);
    * a number beyond the float range, which pandas and ``json`` read as infinity: in CSV
      ``1e400`` or 400 digits, in JSON a literal with a fraction or an exponent (``1e400``;
      ``json`` reads a JSON integer of 400 digits exactly, and the served model's check of
      its column refuses it): refused with its line or row and column;
    * a NUL byte (a log padded with zeros), named with its offset and line;
    * a Parquet body whose metadata announce more than ``max_rows`` rows, or rows x columns
      x 8 bytes (the least it decodes to) over :data:`PARQUET_EXPANSION` x
      ``max_body_bytes`` (a small compressed body can decode to gigabytes before the served
      model could count its rows).

    Parameters
    ----------
    content_type : str
        The request's Content-Type (parameters such as ``charset`` ignored).
    body : bytes
        The whole body.
    max_rows : int or None
        Largest request the served model accepts, rows (None: not checked here).
    max_body_bytes : int
        The body-size limit, bytes.

    Returns
    -------
    tuple of (int, dict) or None
        HTTP status and ``{"error_code", "message"}`` of the refusal; None to pass the body
        on to MLflow.
    """
    kind = content_type.split(";")[0].strip().lower()
    if kind in ("text/csv", "application/json"):
        refused = _encoding_refusal(body)
        if refused is not None:
            return refused
        return _csv_refusal(body) if kind == "text/csv" else _json_refusal(body)
    if kind == "application/vnd.apache.parquet":
        return _parquet_refusal(body, max_rows, max_body_bytes)
    return None
