"""The request guard's in-flight count under concurrent and cancelled requests (review
svc26): every slot taken is given back, whatever ends the request."""

from __future__ import annotations

import asyncio
import json

import pytest

from terrain.serving.http import RequestGuard


def _scope(length=2):
    return {"type": "http", "method": "POST", "path": "/invocations",
            "headers": [(b"content-length", str(length).encode()),
                        (b"content-type", b"text/csv")]}


def _slow_app(started: list):
    async def app(scope, receive, send):
        while (await receive()).get("more_body"):
            pass
        started.append(1)
        await asyncio.sleep(3600)     # a prediction that does not end before the cancel
    return app


@pytest.mark.parametrize("where", ["body", "app"])
def test_cancelled_requests_give_their_slots_back(where):
    started: list = []
    guard = RequestGuard(_slow_app(started), max_body_bytes=100, max_in_flight=3)

    async def receive():
        if where == "body":
            await asyncio.sleep(3600)     # a client stalled half-way (its task cancelled)
        return {"type": "http.request", "body": b"ab", "more_body": False}

    async def send(message):
        pass

    async def run():
        tasks = [asyncio.ensure_future(guard(_scope(), receive, send)) for _ in range(3)]
        await asyncio.sleep(0.05)
        assert guard.in_flight == 3
        for t in tasks:
            t.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)

    asyncio.run(run())
    assert guard.in_flight == 0 and len(started) == (3 if where == "app" else 0)


def test_many_concurrent_requests_never_run_more_than_the_limit():
    running, most = [0], [0]

    async def app(scope, receive, send):
        while (await receive()).get("more_body"):
            pass
        running[0] += 1
        most[0] = max(most[0], running[0])
        await asyncio.sleep(0.01)
        running[0] -= 1
        await send({"type": "http.response.start", "status": 200, "headers": []})
        await send({"type": "http.response.body", "body": b"{}"})

    guard = RequestGuard(app, max_body_bytes=100, max_in_flight=4)
    statuses: list = []

    async def one(delay):
        await asyncio.sleep(delay)
        sent = []

        async def receive():
            await asyncio.sleep(0)
            return {"type": "http.request", "body": b"ab", "more_body": False}

        async def send(message):
            sent.append(message)

        await guard(_scope(), receive, send)
        statuses.append(sent[0]["status"])
        if sent[0]["status"] == 503:
            assert json.loads(sent[1]["body"])["error_code"] == "TEMPORARILY_UNAVAILABLE"

    async def run():
        await asyncio.gather(*(one(0.001 * (i % 20)) for i in range(200)))

    asyncio.run(run())
    assert len(statuses) == 200 and set(statuses) <= {200, 503} and 200 in statuses
    assert most[0] <= 4 and guard.in_flight == 0
