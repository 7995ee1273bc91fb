"""``terrain serve``'s event loop gives every admitted request a thread of its own
(:func:`terrain.serving.http.run_server`), on a real uvicorn server on 127.0.0.1.

MLflow's scoring server decides each request in ``asyncio.to_thread``; Python's default
executor has ``min(32, CPUs + 4)`` threads, so requests blocked in a thread (a long one
waiting for its lane of the served model) kept later ones from starting. Here each request
blocks in ``asyncio.to_thread`` on a barrier that opens only when all of them are inside a
thread at once: more parties than any default executor has threads, so the test fails with
the default executor on any machine."""

from __future__ import annotations

import asyncio
import socket
import threading
import time
import urllib.request
from concurrent.futures import ThreadPoolExecutor

import pytest

from terrain.serving.http import run_server

PARTIES = 40   # above min(32, CPUs + 4), Python's default executor size on any machine


def _server(app, workers: int):
    import uvicorn

    sock = socket.socket()
    sock.bind(("127.0.0.1", 0))
    sock.listen(128)
    config = uvicorn.Config(app, log_level="warning", lifespan="off", backlog=128)
    srv = uvicorn.Server(config)
    thread = threading.Thread(target=run_server, args=(srv, [sock], workers), daemon=True)
    thread.start()
    deadline = time.monotonic() + 20
    while not srv.started:
        assert time.monotonic() < deadline, "uvicorn did not start"
        time.sleep(0.01)
    return srv, thread, sock


def _barrier_app(barrier: threading.Barrier):
    def wait() -> bytes:
        try:
            barrier.wait()
            return b"met"
        except threading.BrokenBarrierError:
            return b"broken"

    async def app(scope, receive, send):
        if scope["type"] != "http":
            return
        body = await asyncio.to_thread(wait)
        await send({"type": "http.response.start", "status": 200,
                    "headers": [(b"content-length", str(len(body)).encode())]})
        await send({"type": "http.response.body", "body": body})
    return app


def _get(url: str) -> bytes:
    with urllib.request.urlopen(url, timeout=30) as res:
        return res.read()


def test_every_admitted_request_gets_a_thread_of_its_own():
    barrier = threading.Barrier(PARTIES, timeout=15)
    srv, thread, sock = _server(_barrier_app(barrier), workers=PARTIES)
    try:
        url = f"http://127.0.0.1:{sock.getsockname()[1]}/"
        with ThreadPoolExecutor(PARTIES) as pool:
            answers = list(pool.map(_get, [url] * PARTIES))
    finally:
        srv.should_exit = True
        thread.join(10)
        sock.close()
    assert answers == [b"met"] * PARTIES
    assert not thread.is_alive()


@pytest.mark.slow
def test_fewer_threads_than_requests_blocked_at_once_starve_the_rest():
    """The control: with fewer threads than parties the barrier never opens (it breaks at
    its timeout), so the test above measures the executor, not the client."""
    barrier = threading.Barrier(4, timeout=1.5)
    srv, thread, sock = _server(_barrier_app(barrier), workers=3)
    try:
        url = f"http://127.0.0.1:{sock.getsockname()[1]}/"
        with ThreadPoolExecutor(4) as pool:
            answers = list(pool.map(_get, [url] * 4))
    finally:
        srv.should_exit = True
        thread.join(10)
        sock.close()
    assert b"met" not in answers


def test_run_server_refuses_no_threads():
    with pytest.raises(ValueError, match="workers must be at least 1"):
        run_server(None, [], 0)


def test_one_thread_is_enough():
    srv, thread, sock = _server(_barrier_app(threading.Barrier(1)), workers=1)
    try:
        assert _get(f"http://127.0.0.1:{sock.getsockname()[1]}/") == b"met"
    finally:
        srv.should_exit = True
        thread.join(10)
        sock.close()
