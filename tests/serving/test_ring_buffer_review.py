"""Review tests of the streaming service's ring buffer (:mod:`terrain.serving.buffers`):
dropping the newest samples across the wrap, and more of them than it holds."""

from __future__ import annotations

import numpy as np

from terrain.serving.buffers import RingBuffer


def _push(buf: RingBuffer, *stamps: float) -> None:
    t = np.array(stamps, dtype=float)
    buf.append(t, np.column_stack([t, -t]))


def test_dropping_the_newest_samples_across_the_wrap_keeps_the_rest_in_order():
    buf = RingBuffer(2, 4)
    _push(buf, 0, 1, 2, 3, 4, 5)            # wraps: keeps 2..5
    buf.drop_newest(1)
    assert buf.times().tolist() == [2.0, 3.0, 4.0] and (buf.first_t, buf.last_t) == (2.0, 4.0)
    _push(buf, 9)
    _push(buf, 10)                          # full again: 2 is pushed out
    t, v = buf.since(-np.inf)
    assert t.tolist() == [3.0, 4.0, 9.0, 10.0]
    np.testing.assert_array_equal(v, np.column_stack([t, -t]))


def test_dropping_more_than_the_buffer_holds_empties_it_and_it_fills_again():
    buf = RingBuffer(2, 4)
    _push(buf, 0, 1, 2, 3, 4, 5)
    buf.drop_newest(10)                     # all of them, as the docstring says
    assert len(buf) == 0 and buf.times().size == 0
    assert (buf.first_t, buf.last_t) == (np.inf, -np.inf)
    _push(buf, 7, 8)
    t, v = buf.since(-np.inf)
    assert t.tolist() == [7.0, 8.0] and len(buf) == 2
    np.testing.assert_array_equal(v, [[7.0, -7.0], [8.0, -8.0]])
