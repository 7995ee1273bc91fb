"""HTTP front of the served model: the request guard in front of MLflow's scoring app.

MLflow's scoring server answers some malformed requests itself (a body it cannot parse as
CSV, JSON or Parquet, a missing content type) with its own message, a ``stack_trace`` field
or a bare 500. :class:`RequestGuard`, an ASGI middleware, sits outside MLflow's handler and
gives every error answer the project's form: one line, no stack trace and no dump of the
request; a 4xx's message is ``<ErrorClass>: ...`` with the :mod:`terrain.errors` class (an
unexpected failure's or MLflow's 5xx says what failed, e.g. ``internal error (KeyError); see
the server log`` or MLflow's timeout). It also enforces the body-size limit. ``terrain
serve`` (:mod:`pipelines.serve`) adds it to the app.
"""

from __future__ import annotations

import asyncio
import json
import logging
import math
import re
from concurrent.futures import ThreadPoolExecutor
from typing import Any, Awaitable, Callable, MutableMapping

from terrain.errors import (ConfigError, DataFormatError, EmptyFileError, EncodingError,
                            ImplausibleValueError, MethodNotAllowedError, RaggedRowError,
                            ServiceBusyError, TerrainError, UnknownEndpointError,
                            config_integer)
from terrain.serving.body import body_refusal

Scope = MutableMapping[str, Any]
Message = MutableMapping[str, Any]
Receive = Callable[[], Awaitable[Message]]
Send = Callable[[Message], Awaitable[None]]

#: request content types of MLflow's scoring server
CONTENT_TYPES = ("text/csv", "application/json", "application/vnd.apache.parquet")
#: longest message of an error answer, characters
MAX_MESSAGE = 500
#: default of the requests to ``/invocations`` answered at once; more are told 503 at once
#: instead of queueing behind slow ones (MLflow's timeout answers 504 but cannot stop a
#: prediction that runs on, so a queue would grow unbounded)
MAX_IN_FLIGHT = 8
#: seconds a client has, from its headers, to send the whole body of ``/invocations``: a
#: client that stalls half-way would otherwise hold one of the ``MAX_IN_FLIGHT`` slots for
#: ever (8 stalled clients would keep every other one out); 8 MB at 10 Mbit/s take 6.4 s
BODY_TIMEOUT_S = 30.0
#: seconds a connection may go without starting a request while none is in progress, before
#: it is answered 408 and closed: uvicorn times out no connection before its first request,
#: nor one stalled inside a request's headers (its keep-alive timer stops at the first byte)
HEADER_TIMEOUT_S = 30.0
#: default of the connections ``terrain serve`` keeps open: beyond, the oldest one idle for
#: :data:`MIN_IDLE_S` is closed, or the new one is answered 503. Measured: 1,100 connections
#: that never sent a byte took a served model down under the common 1,024 open-file limit
#: (``accept`` failed with EMFILE, /ping timed out, 83,150 lines of tracebacks on stderr),
#: uvicorn having no timeout before the first request
MAX_CONNECTIONS = 256
#: seconds a connection must have gone without a byte in, no request of it in progress, before
#: it may be closed for a new one beyond the bound; also the longest a connection refused
#: beyond the bound is kept open after its 503, reading (and dropping) its client's request so
#: that the client reads the answer instead of a reset. A just-accepted connection whose bytes
#: are not read yet is not idle: closing it reset 41 of 90 requests of 40 clients at a bound
#: of 20 (100 of 120 in tests/serving/test_header_timeout.py)
MIN_IDLE_S = 1.0
#: open files ``terrain serve`` keeps for itself beside its connections (model files,
#: MLflow, logs) when checking ``--max-connections`` against the open-file limit
RESERVED_FILES = 64
#: the served model's endpoints; any other path is answered 404 here (FastAPI would serve its
#: ``/docs`` and ``/openapi.json`` pages, and redirect ``/invocations/`` with an empty 307)
ENDPOINTS = ("/invocations", "/ping", "/health", "/version")
#: endpoints answered to GET (and so to HEAD, without the body)
READ_ENDPOINTS = ("/ping", "/health", "/version")
#: error codes that MLflow's classification tables lack, classified as another: a request
#: that ran out of time (MLflow's 504) is, like a busy server, to be retried
CLASSIFIED_AS = {"DEADLINE_EXCEEDED": "TEMPORARILY_UNAVAILABLE"}
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
            return DataFormatError("unterminated quote in the CSV body", where)
        return DataFormatError("the request body is not a readable CSV table", where)
    if "Parquet" in text and "Failed to parse" in text:
        # pyarrow's reason is a schema dump or a C++ status line, not the user's words
        return DataFormatError("the request body is not a readable Parquet table (send a "
                               "file written by pandas.DataFrame.to_parquet or pyarrow)",
                               where)
    # before the JSON branch: MLflow's JSON parse error of a non-UTF-8 body holds the
    # UnicodeDecodeError's repr, with the request's bytes in it
    if "UnicodeDecodeError" in text and ("UTF-8" in text or "valid JSON" in text):
        byte = re.search(r", (\d+), \d+, '([^']*)'\)", detail)
        return EncodingError("the request body is not UTF-8 text"
                             + (f" ({byte.group(2)} at byte {byte.group(1)})" if byte else ""),
                             where)
    if "valid JSON" in text:
        # the repr quotes a reason holding a quote with double quotes
        reason = re.search(r"JSONDecodeError\((['\"])(.*)\1\)", detail)
        return DataFormatError("the request body is not valid JSON "
                               f"({reason.group(2) if reason else detail[:200]})", where)
    if status == 415:
        return DataFormatError(f"unsupported request content type: {text.strip()}", where)
    text = re.sub(r"<class '([\w.]+)'>", r"\1", text.strip())  # Python type reprs
    if re.search(r"DataFrame constructor|must be called with a collection|Got type|"
                 r"unexpected input type|Failed to parse input|not a valid dataframe|"
                 r"must be a dictionary|must have 'data'|exactly one of the input fields",
                 text):
        # MLflow's and pandas's own words (constructor calls, Python types) say nothing
        # to the client: say what the served model takes
        return DataFormatError("the JSON body is not a table of samples; send "
                               "{\"dataframe_split\": {\"columns\": [...], \"data\": [[...], "
                               "...]}} or {\"dataframe_records\": [{...}, ...]}", where)
    text = re.sub(r"^Invalid input\.\s*", "", text)
    if text.count("'") % 2:  # MLflow's "... Got {'columns'}.'" ends on a stray quote
        text = re.sub(r"'$", "", text)
    return DataFormatError(text, where)


def _error_body(status: int, body: bytes) -> dict:
    """An error answer's body as the project's JSON error: no ``stack_trace``, one line."""
    try:
        doc = json.loads(body)
    except ValueError:
        doc = None
    if isinstance(doc, dict) and "message" not in doc and status in (404, 405):
        return _endpoint_error(status, str(doc.get("detail", "no such endpoint")))
    if isinstance(doc, dict):
        doc.pop("stack_trace", None)
        if "message" in doc:
            doc["message"] = project_message(status, str(doc["message"]))
        return doc
    code = {415: "BAD_REQUEST", 504: "DEADLINE_EXCEEDED"}.get(
        status, "BAD_REQUEST" if status < 500 else "INTERNAL_ERROR")
    return {"error_code": code,
            "message": project_message(status, body.decode("utf-8", "replace"))}


def _endpoint_error(status: int, detail: str) -> dict:
    """The JSON error of a request to an unknown endpoint (404: ``ENDPOINT_NOT_FOUND``,
    :class:`UnknownEndpointError`) or with a wrong method (405: ``BAD_REQUEST``, MLflow's
    codes having none for it, :class:`MethodNotAllowedError`)."""
    error = UnknownEndpointError if status == 404 else MethodNotAllowedError
    return {"error_code": "ENDPOINT_NOT_FOUND" if status == 404 else "BAD_REQUEST",
            "message": _typed(error(
                f"{detail}: the served model answers POST /invocations (the streams) and "
                "GET /ping, /health, /version"))}


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


def classified(doc: dict) -> dict:
    """An error answer with MLflow's ``sqlstate`` and ``error_class`` beside its
    ``error_code``, as MLflow's own answers carry them, so every error has one form.

    Parameters
    ----------
    doc : dict
        ``{"error_code", "message", ...}``; fields already set are kept.

    Returns
    -------
    dict
        ``doc`` with ``sqlstate`` and ``error_class`` derived from ``error_code`` by MLflow's
        own tables (:mod:`mlflow.error_classification`: the client table, else the server
        one, e.g. ``REQUEST_LIMIT_EXCEEDED``; a code in neither as :data:`CLASSIFIED_AS`
        says).
    """
    from mlflow.error_classification import ErrorClass, SqlState

    code = str(doc.get("error_code", "BAD_REQUEST"))
    code = CLASSIFIED_AS.get(code, code)
    doc.setdefault("sqlstate", SqlState.from_client_error_code(code)
                   or SqlState.from_cp_error_code(code))
    doc.setdefault("error_class", ErrorClass.from_client_error_code(code)
                   or ErrorClass.from_cp_error_code(code))
    return doc


async def _send_json(send: Send, status: int, doc: dict,
                     headers: tuple[tuple[bytes, bytes], ...] = ()) -> None:
    """Send ``doc`` as a JSON answer (an error classified, :func:`classified`, its message
    one line of at most :data:`MAX_MESSAGE` characters, :func:`project_message`) with the
    extra ``headers``."""
    if status >= 400 and "message" in doc:
        doc = {**doc, "message": project_message(status, str(doc["message"]))}
    body = json.dumps(classified(doc) if status >= 400 else doc).encode()
    await send({"type": "http.response.start", "status": status,
                "headers": [(b"content-type", b"application/json"),
                            (b"content-length", str(len(body)).encode()), *headers]})
    await send({"type": "http.response.body", "body": body})


class _BodyTooLarge(Exception):
    """The body sent is longer than its Content-Length or the limit."""


class _BodyTimeout(Exception):
    """The body did not arrive whole within the time allowed."""


class RequestGuard:
    """ASGI middleware in front of MLflow's scoring server app.

    * a path other than :data:`ENDPOINTS` is answered 404 (``/invocations/`` included: a
      redirect would lose the body of a client that does not follow it);
    * a POST to ``/invocations`` without ``Content-Length`` is answered 411, one with
      ``Transfer-Encoding`` as well 400 (the two disagree on where the body ends), one over
      ``max_body_bytes`` 413, one without ``Content-Type`` 415 (MLflow's handler would fail
      on it with a 500), one with a ``Content-Encoding`` 415 (its bytes would be read as
      text), one with two different Content-Type headers 400 (compared as
      :func:`normalised_content_type` writes them); the Content-Type is handed on so
      written (media types, parameter names and the charset are case-insensitive; MLflow
      compares them as written); a POST elsewhere is MLflow's to answer (405);
    * ``HEAD`` on ``/ping``, ``/health`` and ``/version`` is run as ``GET`` (the server
      sends no body for it);
    * the body of ``/invocations`` is read here, counting its bytes (longer than announced
      or than the limit: 413), checked by :func:`terrain.serving.body.body_refusal`
      (encoding, column names, ragged rows, the JSON table's shape, numbers beyond the
      float range, a Parquet body that decodes past the limits) and then handed to MLflow;
    * a body that has not arrived whole ``body_timeout_s`` after the headers is answered
      408 and its slot freed (a client stalled half-way would hold it for ever);
    * at most ``max_in_flight`` requests to ``/invocations`` are answered at once; one more
      is answered 503 at once;
    * every error answer (status >= 400) is rewritten to the project's JSON error: MLflow's
      ``stack_trace`` field is dropped and the message is one line, ``<ErrorClass>: ...``
      for a 4xx (MLflow's 5xx is only made one line, :func:`project_message`), with
      ``sqlstate`` and ``error_class`` (:func:`classified`) and a 405's ``Allow`` header
      kept; a plain-text answer (MLflow's 415, its 504
      timeout) becomes JSON as well;
    * an exception that escapes MLflow's handler (a JSON body nested 100,000 deep raises
      ``RecursionError`` in the parser) or the guard's own body checks is answered 400
      when it is the request's fault, else 500 with one line (the traceback goes to the
      server log); the server keeps serving either way.

    Success answers pass through untouched and unbuffered.

    Parameters
    ----------
    app : ASGI app
        MLflow's scoring server app (or what wraps it).
    max_body_bytes : int
        Largest request body, bytes.
    max_rows : int or None
        Largest request of the served model, rows (checked here on Parquet metadata).
    max_in_flight : int
        Requests to ``/invocations`` answered at once.
    body_timeout_s : float
        Seconds from the headers to the last byte of an ``/invocations`` body.
    """

    def __init__(self, app: Callable, max_body_bytes: int, max_rows: int | None = None,
                 max_in_flight: int = MAX_IN_FLIGHT,
                 body_timeout_s: float = BODY_TIMEOUT_S) -> None:
        self.app = app
        self.max_body_bytes = int(max_body_bytes)
        self.max_rows = None if max_rows is None else int(max_rows)
        self.max_in_flight = int(max_in_flight)
        self.body_timeout_s = float(body_timeout_s)
        self.in_flight = 0

    def refusal(self, path: str, raw_headers: list[tuple[bytes, bytes]]
                ) -> tuple[int, dict] | None:
        """Status and body refusing a POST from its path and headers alone, or None.

        Parameters
        ----------
        path : str
            Request path (the Content-Type is required on ``/invocations``).
        raw_headers : list of (bytes, bytes)
            Lower-case header name and value, as ASGI gives them (a name may repeat).

        Returns
        -------
        tuple of (int, dict) or None
        """
        headers = dict(raw_headers)
        size = headers.get(b"content-length")
        # the same type written twice in other case or quoting is one type (RFC 9110)
        types = {normalised_content_type(v) for k, v in raw_headers if k == b"content-type"}
        if len(types) > 1:
            return 400, {"error_code": "BAD_REQUEST", "message": _typed(DataFormatError(
                f"request with {len(types)} different Content-Type headers; send one",
                "request"))}
        # every Content-Encoding header counts (RFC 9110 lists their codings in the order
        # applied): ``gzip`` then ``identity`` is a gzip body, not the last header's text
        encodings = [v.strip().lower() for k, v in raw_headers if k == b"content-encoding"]
        encoding = next((e for e in encodings if e not in (b"", b"identity")), None)
        if encoding is not None:
            return 415, {"error_code": "BAD_REQUEST", "message": _typed(DataFormatError(
                f"Content-Encoding {encoding.decode('latin-1')[:20]!r} is not accepted; "
                "send the body uncompressed", "request"))}
        tail = "; send the streams in shorter pieces"
        if size is not None and b"transfer-encoding" in headers:
            return 400, {"error_code": "BAD_REQUEST",
                         "message": "DataFormatError: request with both Content-Length and "
                                    "Transfer-Encoding; send the body with its length only"}
        if size is None:
            return 411, {"error_code": "REQUEST_LIMIT_EXCEEDED",
                         "message": "DataFormatError: request without Content-Length (a "
                                    "chunked body is not accepted); send the body with its "
                                    "length"}
        # 1*DIGIT (RFC 9110, 8.6): int() also read "-5" (answered 413), "+2" and "2_0" (20)
        if not size.strip().isdigit():
            return 400, {"error_code": "BAD_REQUEST",
                         "message": "DataFormatError: Content-Length is not a number"}
        n = int(size)
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
        path = scope.get("path", "")
        if path not in ENDPOINTS:
            detail = (f"no endpoint {_short_path(path)}"
                      + (" (send it without the trailing slash)"
                         if path.rstrip("/") in ENDPOINTS else ""))
            await _send_json(send, 404, _endpoint_error(404, detail))
            return
        if scope["method"] == "HEAD" and path in READ_ENDPOINTS:
            # HEAD is GET without the body (RFC 9110); the server, which keeps its own scope,
            # sends no body for it
            scope = {**scope, "method": "GET"}
        invocation = scope["method"] == "POST" and path == "/invocations"
        if invocation:  # a POST elsewhere is MLflow's to answer: 405, whatever its length
            refused = self.refusal(path, scope["headers"])
            headers = dict(scope["headers"])
            if refused is None and invocation:
                scope = {**scope, "headers": _content_type_normalised(scope["headers"])}
            if refused is None and invocation and self.in_flight >= self.max_in_flight:
                refused = 503, {"error_code": "TEMPORARILY_UNAVAILABLE",
                                "message": _typed(ServiceBusyError(
                                    f"server busy with {self.in_flight} requests; retry "
                                    "shortly"))}
            if refused is None and invocation:
                self.in_flight += 1
                try:
                    try:
                        body = await self._read_body(receive, int(headers[b"content-length"]))
                    except _BodyTooLarge as exc:
                        await _send_json(send, 413, {"error_code": "REQUEST_LIMIT_EXCEEDED",
                                                     "message": f"DataFormatError: {exc}"})
                        return
                    except _BodyTimeout as exc:
                        await _send_json(send, 408, {"error_code": "BAD_REQUEST",
                                                     "message": f"DataFormatError: {exc}"})
                        return
                    if body is None:  # the client went away
                        return
                    try:
                        # under a Content-Type MLflow refuses (415), whatever the body
                        refused = body_refusal(headers.get(b"content-type", b"").decode(
                            "latin-1"), body, self.max_rows, self.max_body_bytes) \
                            if mlflow_takes_parameters(headers.get(b"content-type", b"")) \
                            else None
                    except Exception as exc:  # past the guard, Starlette's plain-text 500
                        refused = _failure(exc)
                    if refused is None:
                        await self._answer(scope, _replay(body, receive), send)
                        return
                finally:
                    self.in_flight -= 1
            if refused is not None:
                await _send_json(send, *refused)
                return
        await self._answer(scope, receive, send)

    async def _read_body(self, receive: Receive, length: int) -> bytes | None:
        """The whole request body, or None when the client disconnected; raises
        :class:`_BodyTooLarge` as soon as more bytes arrive than announced or allowed, and
        :class:`_BodyTimeout` when the body is not whole ``body_timeout_s`` after the
        headers."""
        limit = min(length, self.max_body_bytes)
        parts, total = [], 0
        loop = asyncio.get_running_loop()
        deadline = loop.time() + self.body_timeout_s
        while True:
            try:
                message = await asyncio.wait_for(receive(), max(0.0, deadline - loop.time()))
            except asyncio.TimeoutError:
                raise _BodyTimeout(f"request body incomplete after {self.body_timeout_s:g} s "
                                   f"({total} of {length} bytes); send the whole body at "
                                   "once") from None
            if message["type"] == "http.disconnect":
                return None
            chunk = message.get("body", b"")
            total += len(chunk)
            if total > limit:
                raise _BodyTooLarge(f"request body longer than its Content-Length of {length} "
                                    f"bytes or the limit of {self.max_body_bytes}; send the "
                                    "streams in shorter pieces")
            parts.append(chunk)
            if not message.get("more_body", False):
                return b"".join(parts)

    async def _answer(self, scope: Scope, receive: Receive, send: Send) -> None:
        """Run MLflow's app, rewriting its error answers (see the class docstring)."""
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
                # a 405's Allow header says which methods the endpoint takes
                kept = tuple((k, v) for k, v in held["start"].get("headers", [])
                             if k.lower() == b"allow")
                await _send_json(send, status, _error_body(status, b"".join(held["parts"])),
                                 kept)
                return
            held["sent"] = held["sent"] or message["type"] == "http.response.start"
            await send(message)

        try:
            await self.app(scope, receive, guarded_send)
        except Exception as exc:  # the server answers and keeps serving
            if held["sent"]:
                raise
            await _send_json(send, *_failure(exc))


def run_server(server, sockets: list, workers: int) -> None:
    """Run a uvicorn server until it stops, with ``workers`` threads for MLflow's predictions.

    MLflow's scoring server decides every request in a thread of the event loop's default
    executor (``asyncio.to_thread``), whose size Python sets to ``min(32, CPUs + 4)``: 6 on
    a 2-core robot computer, fewer than the default :data:`MAX_IN_FLIGHT` requests the
    server admits. A long request waiting for its lane of the served model
    (:class:`terrain.serving.served.ServedStreamModel`) holds its thread, so with six bulk
    logs admitted a robot's short requests queued for a thread, not for the model: up to
    3.8 s behind seven 5.8-7.5 MB logs, 0.11-0.17 s with a thread each (measured,
    docs/streaming.md, "Served model under load"). Here every admitted request has a thread
    of its own.

    Parameters
    ----------
    server : uvicorn.Server
        The configured server (its ``config`` gives the event loop factory).
    sockets : list of socket.socket
        Bound, listening sockets handed to ``server.serve``.
    workers : int
        Threads of the default executor, at least the requests admitted at once
        (``max_in_flight``; ``terrain serve`` gives twice that, since a request MLflow
        answered 504 frees its slot while its prediction still runs in its thread).

    Raises
    ------
    ValueError
        ``workers`` is below 1.
    """
    if workers < 1:
        raise ValueError(f"workers must be at least 1, got {workers}")

    async def serve() -> None:
        executor = ThreadPoolExecutor(max_workers=workers, thread_name_prefix="terrain-serve")
        asyncio.get_running_loop().set_default_executor(executor)
        await server.serve(sockets=sockets)

    with asyncio.Runner(loop_factory=server.config.get_loop_factory()) as runner:
        runner.run(serve())


def normalised_content_type(value: bytes) -> bytes:
    """A Content-Type as MLflow's scoring server compares it: the media type and the
    parameter names in lower case, quoted parameter values unquoted, the charset's value in
    lower case, ``; `` between the parts (RFC 9110, 8.3: media types, parameter names and
    the charset are case-insensitive, and a value may be quoted). MLflow compares them as
    written: ``TEXT/CSV`` and ``Charset=UTF-8`` were a 415, ``charset="utf-8"`` a 415 saying
    "only supports UTF-8".

    Parameters
    ----------
    value : bytes
        The Content-Type header's value.

    Returns
    -------
    bytes
    """
    kind, *params = value.split(b";")
    parts = [kind.strip().lower()]
    for param in params:
        name, sep, text = param.partition(b"=")
        name, text = name.strip().lower(), text.strip()
        if len(text) >= 2 and text[:1] == text[-1:] == b'"':
            text = re.sub(rb"\\(.)", rb"\1", text[1:-1])
        if name == b"charset":
            text = text.lower()
        if name or text:
            parts.append(name + sep + text)
    return b"; ".join(parts)


def mlflow_takes_parameters(value: bytes) -> bool:
    """Whether MLflow's scoring server takes a Content-Type's parameters: none, or a charset
    of UTF-8 (compared as :func:`normalised_content_type` writes it). Under any other (a
    charset such as ``latin-1``, a parameter such as ``header=present`` or MLflow 1's
    ``format=pandas-split``) it answers 415 whatever the body, so the guard's body checks
    are not asked: one header, one verdict.

    Parameters
    ----------
    value : bytes
        The Content-Type header's value, as sent.

    Returns
    -------
    bool
    """
    if b";" not in value:   # the usual request: no parameter
        return True
    return all(param == b"charset=utf-8"
               for param in normalised_content_type(value).split(b"; ")[1:])


def _content_type_normalised(raw_headers: list[tuple[bytes, bytes]]
                             ) -> list[tuple[bytes, bytes]]:
    """The headers with the Content-Type :func:`normalised_content_type`."""
    return [(k, normalised_content_type(v) if k == b"content-type" else v)
            for k, v in raw_headers]


def _short_path(path: str, limit: int = 60) -> str:
    """``path`` quoted for a message, cut at ``limit`` characters (printable ASCII kept)."""
    text = "".join(c if " " <= c <= "~" else "?" for c in path)
    return repr(text if len(text) <= limit else text[:limit] + "...")


def _replay(body: bytes, receive: Receive) -> Receive:
    """An ASGI ``receive`` that gives the body already read, then waits on the client."""
    given = False

    async def replay() -> Message:
        nonlocal given
        if not given:
            given = True
            return {"type": "http.request", "body": body, "more_body": False}
        return await receive()

    return replay


def bounded_connections_protocol(max_connections: int = MAX_CONNECTIONS,
                                 header_timeout_s: float = HEADER_TIMEOUT_S,
                                 min_idle_s: float = MIN_IDLE_S) -> type:
    """uvicorn HTTP protocol class keeping at most ``max_connections`` connections open and
    timing out connections that start no request.

    uvicorn accepts every connection and times none out before its first request, so
    connections that never send a byte (a leaking client, a port scanner holding sockets)
    pile up until ``accept`` fails for lack of file descriptors and the server answers
    nobody. With this class, a new connection beyond the bound closes the oldest *idle*
    one (no request in progress and no byte received for ``min_idle_s``, nor a response
    sent); when there is none (every other one is mid-request, or was just accepted and its
    request not read yet), the new one is answered ``503`` with the project's JSON error
    (``ServiceBusyError``, ``TEMPORARILY_UNAVAILABLE``) and closed once its client closes, or
    after ``min_idle_s``, its request read and dropped meanwhile (closed at once with bytes
    unread, its client would see a reset, not the answer). At most ``max_connections`` such
    refused connections are kept so; beyond, the oldest is closed at once. A request in
    progress, or a connection just accepted, is never cut.

    A connection that starts no request for ``header_timeout_s`` while none of its requests
    is in progress (it never sent a byte, or it stalled inside a request line or headers,
    which stops uvicorn's keep-alive timer) is answered ``408`` with the project's JSON
    error and closed, like a web server's client-header timeout; it is checked every
    ``header_timeout_s``, so such a connection lives between one and two timeouts. A
    stalled *body* is :class:`RequestGuard`'s to time out. Bytes uvicorn's parser refuses (a
    garbage request line, a non-numeric Content-Length, bad chunk framing) are answered
    ``400`` in the same JSON form instead of uvicorn's plain text.

    Parameters
    ----------
    max_connections : int
        Connections kept open at most (>= 1).
    header_timeout_s : float
        Seconds without a new request, none in progress, before a connection is closed
        (finite, > 0).
    min_idle_s : float
        Seconds without a byte in, no request in progress, before a connection may be
        closed for a new one beyond the bound (finite, > 0).

    Returns
    -------
    type
        A subclass of uvicorn's default HTTP protocol, for ``uvicorn.Config(http=...)``;
        its ``closed`` attribute counts the idle connections it closed beyond the bound,
        ``refused`` the new ones it answered 503, ``timed_out`` those closed by the header
        timeout, ``limit`` is ``max_connections``, ``header_timeout_s`` the timeout and
        ``min_idle_s`` the idle time.

    Raises
    ------
    ConfigError
        ``max_connections`` below 1, or ``header_timeout_s`` or ``min_idle_s`` not a finite
        number > 0.
    """
    from collections import OrderedDict

    from uvicorn.protocols.http.auto import AutoHTTPProtocol

    config_integer("max_connections", max_connections, 1)
    for name, value in (("header_timeout_s", header_timeout_s), ("min_idle_s", min_idle_s)):
        if isinstance(value, bool) or not (
                isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
            raise ConfigError(f"{name} must be a finite number of seconds > 0, got {value!r}")
    opened: OrderedDict = OrderedDict()   # open connections, oldest first
    refusing: OrderedDict = OrderedDict()   # connections answered 503 -> their closing timer
    busy_answer = _closing_answer(b"503 Service Unavailable", _typed(ServiceBusyError(
        f"server holds its {max_connections} connections, none idle for {min_idle_s:g} s; "
        "retry shortly")), "TEMPORARILY_UNAVAILABLE")
    timeout_answer = _closing_answer(b"408 Request Timeout", (
        f"DataFormatError: no complete request within {header_timeout_s:g} s; send the "
        "request line and headers at once"))
    bad_http_answer = _closing_answer(b"400 Bad Request", (
        "DataFormatError: malformed HTTP request (its request line, a header, its "
        "Content-Length or its chunk framing is not HTTP/1.1); send a well-formed HTTP/1.1 "
        "request"))

    class BoundedConnections(AutoHTTPProtocol):  # type: ignore[misc, valid-type]
        closed = 0
        refused = 0
        timed_out = 0
        limit = max_connections

        def connection_made(self, transport) -> None:
            super().connection_made(transport)
            self._refused = False
            self._active = self.loop.time()   # a byte in, a response out, or the accept
            opened[self] = None
            self._watch_requests(None, True)
            if len(opened) <= max_connections:
                return
            if BoundedConnections.closed + BoundedConnections.refused == 0:
                _log.warning("more than %d connections open: closing the oldest one idle "
                             "for %g s for each new one, else answering the new one 503 "
                             "(counted; said once)", max_connections, min_idle_s)
            now = self.loop.time()
            idle = next((c for c in opened if c is not self and _is_idle(c)
                         and now - c._active >= min_idle_s), None)
            if idle is None:
                self._refuse()
                return
            opened.pop(idle, None)
            BoundedConnections.closed += 1
            idle.transport.close()

        def _refuse(self) -> None:
            """Answer this new connection 503 and close it once its client has read it."""
            BoundedConnections.refused += 1
            opened.pop(self, None)
            self._refused = True
            self._header_timer.cancel()
            self.transport.write(busy_answer)
            if self.transport.can_write_eof():
                self.transport.write_eof()
            refusing[self] = self.loop.call_later(min_idle_s, self.transport.close)
            while len(refusing) > max_connections:   # a flood: the oldest goes at once
                oldest, timer = refusing.popitem(last=False)
                timer.cancel()
                oldest.transport.close()

        def data_received(self, data: bytes) -> None:
            if self._refused:   # answered 503 already: the request is read and dropped
                return
            self._active = self.loop.time()
            super().data_received(data)

        def on_response_complete(self) -> None:
            self._active = self.loop.time()
            super().on_response_complete()

        def connection_lost(self, exc) -> None:
            opened.pop(self, None)
            timer = refusing.pop(self, None)
            if timer is not None:
                timer.cancel()
            self._header_timer.cancel()
            super().connection_lost(exc)

        def send_400_response(self, msg: str) -> None:
            """uvicorn's answer to bytes its parser refuses, in the project's JSON form
            (uvicorn's own is a plain-text ``Invalid HTTP request received.``)."""
            self.transport.write(bad_http_answer)
            self.transport.close()

        def _watch_requests(self, seen, idle: bool = True) -> None:
            """Look again in ``header_timeout_s``: ``seen`` is the request-response cycle
            current now (None before the first request), ``idle`` whether none runs."""
            self._header_timer = self.loop.call_later(
                header_timeout_s, self._header_timeout, seen, idle)

        def _header_timeout(self, seen, was_idle: bool) -> None:
            if self.transport.is_closing():
                return
            idle = _is_idle(self)
            if not (was_idle and idle and self.cycle is seen):
                self._watch_requests(self.cycle, idle)  # a request began or ran meanwhile
                return
            BoundedConnections.timed_out += 1   # idle for a whole timeout: no request began
            opened.pop(self, None)
            self.transport.write(timeout_answer)
            self.transport.close()

    # set here: inside the class body the name would not see this function's argument
    BoundedConnections.header_timeout_s = header_timeout_s
    BoundedConnections.min_idle_s = min_idle_s
    return BoundedConnections


def _closing_answer(status: bytes, message: str, code: str = "BAD_REQUEST") -> bytes:
    """A whole HTTP/1.1 answer written straight to a connection that is then closed (no
    ASGI cycle runs): ``status`` line, the project's JSON error with ``message`` and the
    error code ``code``."""
    body = json.dumps(classified({"error_code": code, "message": message})).encode()
    return (b"HTTP/1.1 %s\r\ncontent-type: application/json\r\nconnection: close\r\n"
            b"content-length: %d\r\n\r\n" % (status, len(body)) + body)


def _is_idle(connection) -> bool:
    """Whether a uvicorn HTTP connection has no request in progress."""
    cycle = getattr(connection, "cycle", None)
    return cycle is None or bool(getattr(cycle, "response_complete", True))
