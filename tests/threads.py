"""Run one test body in threads started together (the concurrency reviews' one helper)."""

from __future__ import annotations

import threading


def at_once(n, target, timeout_s=None):
    """Run ``target(i)`` for ``i`` in ``range(n)``, in ``n`` threads started together.

    Parameters
    ----------
    n : int
        Threads.
    target : callable (int) -> object
        The body of thread ``i``.
    timeout_s : float or None
        Longest wait for the start barrier and for each thread to end, s (None: no limit).

    Returns
    -------
    list
        ``target(i)``'s result, or the exception it raised, per thread in order.

    Raises
    ------
    AssertionError
        A thread not ended within ``timeout_s``.
    """
    barrier = threading.Barrier(n)
    results: dict = {}

    def body(i):
        barrier.wait(timeout_s)
        try:
            results[i] = target(i)
        except BaseException as exc:  # noqa: B902 - reported by the test
            results[i] = exc

    threads = [threading.Thread(target=body, args=(i,), name=f"t{i}") for i in range(n)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout_s)
    assert len(results) == n, f"{n - len(results)} of {n} threads did not end"
    return [results[i] for i in range(n)]
