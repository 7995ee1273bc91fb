"""HTTP front of the served model: the request guard in front of MLflow's scoring app.

MLflow's scoring server answers some malformed requests itself (a body it cannot parse as
CSV, JSON or Parquet, a missing content type) with its own message, a ``stack_trace`` field
or a bare 500. :class:`RequestGuard`, an ASGI middleware, sits outside MLflow's handler and
gives every error answer the project's form: one line, ``<ErrorClass>: ...`` with the
:mod:`terrain.errors` class, no stack trace and no dump of the request; it also enforces the
body-size limit. ``terrain serve`` (:mod:`pipelines.serve`) adds it to the app.
"""

from __future__ import annotations

import json
import logging
import re
from typing import Any, Awaitable, Callable, MutableMapping

from terrain.errors import (DataFormatError, EmptyFileError, EncodingError,
                            ImplausibleValueError, RaggedRowError, TerrainError)

Scope = MutableMapping[str, Any]
Message = MutableMapping[str, Any]
Receive = Callable[[], Awaitable[Message]]
Send = Callable[[Message], Awaitable[None]]

#: request content types of MLflow's scoring server
CONTENT_TYPES = ("text/csv", "application/json", "application/vnd.apache.parquet")
#: longest message of an error answer, characters
MAX_MESSAGE = 500
_TYPED = re.compile(r"^([A-Z][A-Za-z]*Error): ")
_log = logging.getLogger(__name__)


def project_message(status: int, text: str) -> str:
    """One-line message of an error answer, in the project's ``<ErrorClass>: ...`` form.

    MLflow's own messages (a body it cannot parse as CSV, JSON or Parquet, an unsupported
    content type...) are turned into the matching :mod:`terrain.errors` message; the dump
    of the request MLflow puts in some of them is dropped. A message that already starts
    with an error class, and those of 5xx answers, are only made one line.

    Parameters
    ----------
    status : int
        HTTP status of the answer.
    text : str
        Message of the answer.

    Returns
    -------
    str
        At most :data:`MAX_MESSAGE` characters, one line.
    """
    text = re.sub(r"^Failed to predict data .*?\nError: ", "", text, flags=re.S)
    text = text.split("\nInput:")[0]  # MLflow echoes the whole body after a JSON error
    text = text.split("IMPORTANT: The MLflow Model scoring protocol")[0]  # MLflow 1 -> 2 notice
    if status < 500 and not _TYPED.match(text.strip()):
        text = _typed(_typed_error(status, text))
    text = " ".join(text.split())
    return text if len(text) <= MAX_MESSAGE else text[:MAX_MESSAGE - 3] + "..."


def _typed_error(status: int, text: str) -> TerrainError:
    """The project's error for one of MLflow's request-parsing messages."""
    found = re.search(r"Error: '(.*)'\s*$", text, flags=re.S)
    detail = " ".join((found.group(1) if found else text).split())
    where = "request"
    if "CSV-formatted" in text:
        ragged = re.search(r"Expected (\d+) fields in line (\d+), saw (\d+)", detail)
        if "No columns to parse" in detail:
            return EmptyFileError("the request body holds no CSV table (not even a header "
                                  "line)", where)
        if ragged:
            header, line, fields = ragged.groups()
            return RaggedRowError(f"a row of {fields} fields under a header of {header} "
                                  "(quote a field that holds a comma)", where,
                                  line=int(line))
        if "EOF inside string" in detail:
            return DataFormatError(f"unterminated quote in the CSV body ({detail})", where)
        return DataFormatError(f"the request body is not a readable CSV table ({detail})",
                               where)
    if "Parquet" in text and "Failed to parse" in text:
        return DataFormatError("the request body is not a readable Parquet table "
                               f"({detail[:200]})", where)
    if "valid JSON" in text:
        reason = re.search(r"JSONDecodeError\('(.*)'\)", detail)
        return DataFormatError("the request body is not valid JSON "
                               f"({reason.group(1) if reason else detail[:200]})", where)
    if "UTF-8" in text and "UnicodeDecodeError" in text:
        byte = re.search(r", (\d+), \d+, '([^']*)'\)", detail)
        return EncodingError("the request body is not UTF-8 text"
                             + (f" ({byte.group(2)} at byte {byte.group(1)})" if byte else ""),
                             where)
    if status == 415:
        return DataFormatError(f"unsupported request content type: {text.strip()}", where)
    return DataFormatError(re.sub(r"^Invalid input\.\s*", "", text.strip()), where)


def _error_body(status: int, body: bytes) -> dict:
    """An error answer's body as the project's JSON error: no ``stack_trace``, one line."""
    try:
        doc = json.loads(body)
    except ValueError:
        doc = None
    if isinstance(doc, dict):
        doc.pop("stack_trace", None)
        if "message" in doc:
            doc["message"] = project_message(status, str(doc["message"]))
        return doc
    code = {415: "BAD_REQUEST", 504: "DEADLINE_EXCEEDED"}.get(
        status, "BAD_REQUEST" if status < 500 else "INTERNAL_ERROR")
    return {"error_code": code,
            "message": project_message(status, body.decode("utf-8", "replace"))}


def _typed(error: TerrainError) -> str:
    """``<ErrorClass>: message`` of a project error."""
    return f"{type(error).__name__}: {error}"


def _failure(exc: Exception) -> tuple[int, dict]:
    """Answer to an exception that escaped MLflow's handler (it would be a bare 500)."""
    if isinstance(exc, RecursionError):
        return 400, {"error_code": "BAD_REQUEST", "message": _typed(DataFormatError(
            "the request body nests deeper than the JSON parser allows; send a "
            "dataframe_split table {\"columns\": [...], \"data\": [[...], ...]}",
            "request"))}
    if isinstance(exc, ValueError) and "integer string conversion" in str(exc):
        return 400, {"error_code": "BAD_REQUEST", "message": _typed(ImplausibleValueError(
            "the request body holds an integer of more than 4300 digits", "request"))}
    _log.error("request failed", exc_info=exc)
    return 500, {"error_code": "INTERNAL_ERROR",
                 "message": f"internal error ({type(exc).__name__}); see the server log"}


async def _send_json(send: Send, status: int, doc: dict) -> None:
    body = json.dumps(doc).encode()
    await send({"type": "http.response.start", "status": status,
                "headers": [(b"content-type", b"application/json"),
                            (b"content-length", str(len(body)).encode())]})
    await send({"type": "http.response.body", "body": body})


class RequestGuard:
    """ASGI middleware in front of MLflow's scoring server app.

    * a POST without ``Content-Length`` is answered 411, one over ``max_body_bytes`` 413,
      one without ``Content-Type`` 415 (MLflow's handler would fail on it with a 500);
    * every error answer (status >= 400) is rewritten to the project's JSON error: MLflow's
      ``stack_trace`` field is dropped and the message is one line, ``<ErrorClass>: ...``
      (:func:`project_message`); a plain-text answer (MLflow's 415, its 504 timeout)
      becomes JSON as well;
    * an exception that escapes MLflow's handler (a JSON body nested 100,000 deep raises
      ``RecursionError`` in the parser) is answered 400 when it is the request's fault,
      else 500 with one line (the traceback goes to the server log); the server keeps
      serving either way.

    Success answers pass through untouched and unbuffered.

    Parameters
    ----------
    app : ASGI app
        MLflow's scoring server app (or what wraps it).
    max_body_bytes : int
        Largest request body, bytes.
    """

    def __init__(self, app: Callable, max_body_bytes: int) -> None:
        self.app = app
        self.max_body_bytes = int(max_body_bytes)

    def refusal(self, path: str, headers: dict[bytes, bytes]) -> tuple[int, dict] | None:
        """Status and body refusing a POST from its path and headers alone, or None.

        Parameters
        ----------
        path : str
            Request path (the Content-Type is required on ``/invocations``).
        headers : dict
            Lower-case header name -> value (bytes, as ASGI gives them).

        Returns
        -------
        tuple of (int, dict) or None
        """
        size = headers.get(b"content-length")
        tail = "; send the streams in shorter pieces"
        if size is None:
            return 411, {"error_code": "REQUEST_LIMIT_EXCEEDED",
                         "message": "DataFormatError: request without Content-Length (a "
                                    "chunked body is not accepted); send the body with its "
                                    "length"}
        try:
            n = int(size)
        except ValueError:
            return 400, {"error_code": "BAD_REQUEST",
                         "message": "DataFormatError: Content-Length is not a number"}
        if n > self.max_body_bytes:
            return 413, {"error_code": "REQUEST_LIMIT_EXCEEDED",
                         "message": f"DataFormatError: request body of {n} bytes exceeds "
                                    f"the limit of {self.max_body_bytes}{tail}"}
        if path == "/invocations" and not headers.get(b"content-type", b"").strip():
            return 415, {"error_code": "BAD_REQUEST", "message": _typed(DataFormatError(
                f"request without Content-Type; send one of {', '.join(CONTENT_TYPES)} "
                "(JSON: a dataframe_split table)", "request"))}
        return None

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        if scope["method"] == "POST":
            refused = self.refusal(scope.get("path", ""), dict(scope["headers"]))
            if refused is not None:
                await _send_json(send, *refused)
                return
        held: dict = {"start": None, "parts": [], "sent": False}

        async def guarded_send(message: Message) -> None:
            if message["type"] == "http.response.start" and message["status"] >= 400:
                held["start"] = message  # an error answer: rewritten once complete
                return
            if message["type"] == "http.response.body" and held["start"] is not None:
                held["parts"].append(message.get("body", b""))
                if message.get("more_body", False):
                    return
                status = held["start"]["status"]
                held["sent"] = True
                await _send_json(send, status, _error_body(status, b"".join(held["parts"])))
                return
            held["sent"] = held["sent"] or message["type"] == "http.response.start"
            await send(message)

        try:
            await self.app(scope, receive, guarded_send)
        except Exception as exc:  # the server answers and keeps serving
            if held["sent"]:
                raise
            await _send_json(send, *_failure(exc))
