"""Bounded ring buffer of one stream's samples: timestamps and channel values.

Memory is fixed at construction (``capacity`` rows), so an unbounded stream never grows it:
the oldest samples are overwritten. Every sample is stored twice, at its slot and at slot +
``capacity`` (a mirrored ring), so the kept samples are always one contiguous slice: reading
a window is a binary search and a slice, with no gather over the whole buffer.
"""

from __future__ import annotations

import numpy as np

from terrain.errors import config_integer
from terrain.io.align import median_step

#: Known steps below which a stream's usual step is its smallest, not its median
#: (:meth:`RingBuffer.usual_step`): the median of a few steps is the holes among them.
FEW_STEPS = 8


class RingBuffer:
    """Fixed-capacity FIFO of ``(t_s, values)`` samples of one stream.

    Parameters
    ----------
    n_channels : int
        Channels per sample (> 0).
    capacity : int
        Samples kept (> 0); older ones are overwritten.

    Raises
    ------
    ConfigError
        ``n_channels`` or ``capacity`` not an integer > 0 (a boolean, a float such as 4.7
        included: ``True`` made a buffer of one sample).
    """

    def __init__(self, n_channels: int, capacity: int) -> None:
        config_integer("RingBuffer.n_channels", n_channels, 1)
        config_integer("RingBuffer.capacity", capacity, 1)
        self.capacity = int(capacity)
        self._t = np.empty(2 * self.capacity)
        self._v = np.empty((2 * self.capacity, n_channels))
        self._next = 0  # slot the next sample goes to
        self._size = 0
        self._batch_t = -np.inf  # first timestamp of the newest appended batch

    def __len__(self) -> int:
        return self._size

    @property
    def last_t(self) -> float:
        """Timestamp of the newest sample, s (``-inf`` when empty)."""
        return float(self._t[self._next - 1 + self.capacity]) if self._size else -np.inf

    @property
    def first_t(self) -> float:
        """Timestamp of the oldest kept sample, s (``inf`` when empty)."""
        return float(self._t[self._next - self._size + self.capacity]) if self._size \
            else np.inf

    @property
    def batch_first_t(self) -> float:
        """Timestamp of the first sample of the newest batch appended, s, at most
        :attr:`last_t` (``-inf`` when empty): the time the stream had reached when its
        newest samples arrived together (:attr:`last_t` for samples appended one by one)."""
        return min(self._batch_t, self.last_t)

    def mark_arrived(self) -> None:
        """Say that every kept sample has arrived: :attr:`batch_first_t` becomes
        :attr:`last_t`, as after a push of the newest sample alone (a later push whose
        samples were all refused still shows the stream went on)."""
        self._batch_t = np.inf

    def append(self, t_s: np.ndarray, values: np.ndarray) -> None:
        """Append samples (already validated, in increasing time).

        Parameters
        ----------
        t_s : numpy.ndarray
            ``(n,)`` timestamps, s.
        values : numpy.ndarray
            ``(n, n_channels)`` values, SI units.
        """
        n = len(t_s)
        if n:
            self._batch_t = float(t_s[0])
        if n == 1:  # the usual push: one sample, no index arrays
            i = self._next
            self._t[i] = self._t[i + self.capacity] = t_s[0]
            self._v[i] = self._v[i + self.capacity] = values[0]
            self._next = (i + 1) % self.capacity
            self._size = min(self.capacity, self._size + 1)
            return
        if n >= self.capacity:  # only the newest ``capacity`` samples survive
            t_s, values, n = t_s[-self.capacity:], values[-self.capacity:], self.capacity
        idx = (self._next + np.arange(n)) % self.capacity
        self._t[idx] = t_s
        self._v[idx] = values
        self._t[idx + self.capacity] = t_s
        self._v[idx + self.capacity] = values
        self._next = (self._next + n) % self.capacity
        self._size = min(self.capacity, self._size + n)

    def drop_newest(self, n: int) -> None:
        """Forget the newest ``n`` samples (all of them when ``n`` exceeds the size).

        Parameters
        ----------
        n : int
            Samples to drop (>= 0).
        """
        n = min(max(int(n), 0), self._size)
        self._next = (self._next - n) % self.capacity
        self._size -= n

    def times(self) -> np.ndarray:
        """Timestamps of the kept samples, oldest first, s (a view: read, do not keep).

        Returns
        -------
        numpy.ndarray
            ``(len(self),)``.
        """
        end = self._next + self.capacity
        return self._t[end - self._size:end]

    def evicted(self, t_s: np.ndarray, since_s: float) -> int:
        """Samples that appending ``t_s`` would push out (the oldest held ones, then the
        chunk's own first ones when it is longer than the buffer) with a time at or after
        ``since_s``.

        Parameters
        ----------
        t_s : numpy.ndarray
            ``(n,)`` timestamps about to be appended, s.
        since_s : float
            Samples before this time are no longer needed, s (``-inf``: all are).

        Returns
        -------
        int
        """
        k = self._size + len(t_s) - self.capacity
        if k <= 0:
            return 0
        if len(t_s) == 1:  # the usual push on a full buffer: its oldest sample goes
            return int(self.first_t >= since_s)
        return len(self.evicted_times(t_s, since_s))

    def evicted_times(self, t_s: np.ndarray, since_s: float) -> np.ndarray:
        """Timestamps of the samples :meth:`evicted` counts, oldest first.

        Parameters
        ----------
        t_s : numpy.ndarray
            ``(n,)`` timestamps about to be appended, s.
        since_s : float
            Samples before this time are no longer needed, s (``-inf``: all are).

        Returns
        -------
        numpy.ndarray
            ``(m,)`` timestamps, s (``m`` is :meth:`evicted`).
        """
        k = self._size + len(t_s) - self.capacity
        if k <= 0:
            return np.empty(0)
        end = self._next + self.capacity
        held = self._t[end - self._size:end][:k]
        own = t_s[:max(0, k - self._size)]
        lost = np.concatenate([held, own])
        return lost[lost >= since_s]

    def first_at_or_after(self, t_s: float) -> float:
        """Timestamp of the oldest kept sample at or after ``t_s``, s (``inf`` if none).

        Parameters
        ----------
        t_s : float
            Time, s.

        Returns
        -------
        float
        """
        end = self._next + self.capacity
        t = self._t[end - self._size:end]
        i = int(np.searchsorted(t, t_s, side="left"))
        return float(t[i]) if i < len(t) else np.inf

    def since(self, t_min_s: float) -> tuple[np.ndarray, np.ndarray]:
        """Samples with ``t >= t_min_s``, oldest first, plus the one just before (if kept).

        The sample preceding ``t_min_s`` is included so that interpolation onto a grid
        starting at ``t_min_s`` needs no extrapolation.

        Parameters
        ----------
        t_min_s : float
            Earliest time wanted, s.

        Returns
        -------
        t_s : numpy.ndarray
            ``(m,)`` timestamps, s (copies).
        values : numpy.ndarray
            ``(m, n_channels)``.
        """
        end = self._next + self.capacity
        t = self._t[end - self._size:end]
        start = max(0, int(np.searchsorted(t, t_min_s, side="left")) - 1)
        return t[start:].copy(), self._v[end - self._size + start:end].copy()

    def median_step(self, last: int = 64, through_s: float | None = None) -> float:
        """Median time step of the newest ``last`` samples, s (``nan`` with < 2 samples).

        Parameters
        ----------
        last : int
            Samples looked at.
        through_s : float or None
            Only the samples up to the first one at or after this time count, s (a
            window's step, whatever arrived after it); ``None``: all kept samples.

        Returns
        -------
        float
            Median of the differences of their timestamps, s; ``nan`` with fewer than 2.
        """
        t = self._newest_through(through_s, last)
        if len(t) < 2:
            return float("nan")
        return median_step(t)

    def usual_step(self, through_s: float | None = None, last: int = 64,
                   few: int = FEW_STEPS, prior_s: float | None = None) -> float:
        """Usual time step of the stream, the one a gap is judged against, s.

        The median of the steps between the newest ``last`` samples (``last - 1`` steps;
        :meth:`median_step`, the readers' rule), but the smallest of them while fewer than
        ``few`` steps are known: two holes in a
        stream's first four steps (samples at 0, 0.615, 1.69, 1.846 and 2 s of a 6.5 Hz
        stream) made the median 0.385 s, and neither hole, of 4 and 7 usual steps, was a
        gap. The smallest step errs the other way (a jittered short step makes a longer one
        a gap), which flags a window the filter then only predicts over: the conservative
        side. The steps known may all be holes (samples at 0 and 0.615 s, then none until
        2 s): a ``prior_s`` (the training runs' step of the stream,
        :func:`terrain.serving.model.training_steps_s`) caps the smallest while few are
        known.

        Parameters
        ----------
        through_s : float or None
            Only the samples up to the first one at or after this time count, s (as
            :meth:`median_step`); ``None``: all kept samples.
        last : int
            Samples looked at.
        few : int
            Below this many known steps (through ``through_s``) the smallest step is taken.
        prior_s : float or None
            Step expected before any is known, s: below ``few`` known steps the usual step
            is the smaller of it and the smallest known; None: no expectation.

        Returns
        -------
        float
            The usual step, s; ``nan`` with fewer than 2 samples.
        """
        t = self._newest_through(through_s, last)
        if len(t) < 2:
            return float("nan")
        if len(t) - 1 < few:
            smallest = float(np.diff(t).min())
            return smallest if prior_s is None else min(smallest, prior_s)
        return median_step(t)

    def _newest_through(self, through_s: float | None, last: int) -> np.ndarray:
        """The newest ``last`` kept timestamps up to the first at or after ``through_s``
        (all kept with ``None``), s (a view)."""
        end = self._next + self.capacity
        size = self._size
        if through_s is not None:
            t = self._t[end - size:end]
            size = min(size, int(np.searchsorted(t, through_s, side="left")) + 1)
            end -= self._size - size
        m = min(size, last)
        return self._t[end - m:end]
