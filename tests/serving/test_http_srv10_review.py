"""Review srv10 of :class:`terrain.serving.http.RequestGuard`'s reading of Content-Length
and of the body's edges (driven directly as an ASGI app, no server)."""

from __future__ import annotations

import asyncio
import json

import pytest

from terrain.serving.http import RequestGuard
from test_request_guard import _echo_app  # same folder (pytest's default prepend import)


def _guard_answer(length: bytes, chunks: list[bytes], max_body_bytes: int = 1000):
    """(status, JSON answer, bodies the app saw) of one POST /invocations."""
    app, seen = _echo_app()
    sent = []
    queue = list(chunks)

    async def receive():
        if queue:
            body = queue.pop(0)
            return {"type": "http.request", "body": body, "more_body": bool(queue)}
        await asyncio.sleep(3600)

    async def send(message):
        sent.append(message)

    scope = {"type": "http", "method": "POST", "path": "/invocations",
             "headers": [(b"content-length", length), (b"content-type", b"text/csv")]}
    asyncio.run(RequestGuard(app, max_body_bytes=max_body_bytes)(scope, receive, send))
    start = next(m for m in sent if m["type"] == "http.response.start")
    body = b"".join(m.get("body", b"") for m in sent if m["type"] == "http.response.body")
    return start["status"], json.loads(body), seen


@pytest.mark.parametrize("length", [b"-5", b"+2", b"2_0", b"0x2", b"2.0", b"", b" "])
def test_a_content_length_that_is_not_digits_is_a_400_and_the_app_never_runs(length):
    """RFC 9110, 8.6: Content-Length is 1*DIGIT. Python's int() read ``-5`` (answered 413
    'longer than its Content-Length of -5 bytes'), ``+2`` and ``2_0`` (= 20: a 2-byte body
    handed on as if whole)."""
    status, answer, seen = _guard_answer(length, [b"ab"])
    assert status == 400 and seen == [], (length, answer)
    assert answer["message"] == "DataFormatError: Content-Length is not a number"


def test_a_content_length_of_digits_is_read_as_before():
    assert _guard_answer(b"2", [b"ab"])[:2] == (200, {"n": 2})
    assert _guard_answer(b" 2 ", [b"ab"])[:2] == (200, {"n": 2})   # optional whitespace
    assert _guard_answer(b"0", [b""])[:2] == (200, {"n": 0})
    status, answer, seen = _guard_answer(b"1001", [b"a" * 1001])
    assert status == 413 and seen == [] and "1001 bytes exceeds the limit of 1000" \
        in answer["message"]
    # exactly the limit passes
    assert _guard_answer(b"1000", [b"a" * 1000])[0] == 200
