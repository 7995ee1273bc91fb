"""Replay recorded runs as a live stream: every sample of every stream in timestamp order.

:func:`interleave` merges the streams of a run into one time-ordered sequence of chunks
(consecutive samples of the same stream form one chunk, so the service sees exactly what a
robot publishing each sample as it is measured would give it). :func:`replay_run` pushes
them through a :class:`~terrain.serving.service.StreamService`.
"""

from __future__ import annotations

from typing import Iterator, Sequence

import numpy as np

from terrain.errors import config_integer
from terrain.run import TIME, Run
from terrain.serving.decisions import Decision
from terrain.serving.service import StreamService


def interleave(run: Run, streams: Sequence[str], max_chunk: int = 1
               ) -> Iterator[tuple[str, np.ndarray, np.ndarray]]:
    """Samples of ``streams`` of ``run`` merged in timestamp order.

    Parameters
    ----------
    run : Run
        Recorded run.
    streams : sequence of str
        Streams to replay (those absent from the run are skipped).
    max_chunk : int
        Most consecutive samples of one stream yielded together (1: one by one).

    Yields
    ------
    stream : str
    t_s : numpy.ndarray
        ``(n,)`` timestamps, s.
    values : numpy.ndarray
        ``(n, n_channels)`` in the stream frame's channel order.

    Raises
    ------
    ConfigError
        ``max_chunk`` not an integer >= 1 (0 raised Python's ``range`` error, -1 replayed
        nothing without a word).
    """
    config_integer("max_chunk", max_chunk, 1)
    names = [s for s in streams if s in run.streams]
    times = [run.streams[s][TIME].to_numpy(dtype=float) for s in names]
    vals = [run.streams[s].drop(columns=TIME).to_numpy(dtype=float) for s in names]
    which = np.concatenate([np.full(len(t), i) for i, t in enumerate(times)])
    row = np.concatenate([np.arange(len(t)) for t in times])
    order = np.argsort(np.concatenate(times), kind="stable")
    which, row = which[order], row[order]
    cut = np.flatnonzero(np.diff(which)) + 1
    for a, b in zip(np.r_[0, cut], np.r_[cut, len(which)]):
        i = int(which[a])
        for c in range(a, b, max_chunk):
            r = row[c:min(b, c + max_chunk)]
            yield names[i], times[i][r], vals[i][r]


def replay_run(service: StreamService, run: Run, max_chunk: int = 1) -> list[Decision]:
    """Push a whole run through ``service`` in timestamp order.

    Parameters
    ----------
    service : StreamService
    run : Run
        Its stream frames' channel order must match the service's streams (it does for
        runs read by :mod:`terrain.io`).
    max_chunk : int
        See :func:`interleave`.

    Returns
    -------
    list of Decision

    Raises
    ------
    ConfigError
        ``max_chunk`` not an integer >= 1.
    """
    out: list[Decision] = []
    for stream, t, v in interleave(run, service.needed_streams, max_chunk):
        cols = [c for c in run.streams[stream].columns if c != TIME]
        out.extend(service.push(stream, t, dict(zip(cols, v.T))))
    return out
