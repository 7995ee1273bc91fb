"""Replay recorded runs as a live stream: every sample of every stream in timestamp order.

:func:`interleave` merges the streams of a run into one time-ordered sequence of chunks
(consecutive samples of the same stream form one chunk, so the service sees exactly what a
robot publishing each sample as it is measured would give it). :func:`replay_run` pushes
them through a :class:`~terrain.serving.service.StreamService`; :func:`replay_recorded`
does so for ``terrain stream`` and keeps what a user is told of the replay
(:class:`RunReplay`).
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator, Sequence

import numpy as np
import pandas as pd

from terrain.errors import ConfigError, DataFormatError, config_integer
from terrain.io.report import InputReport, input_report
from terrain.run import TIME, Run
from terrain.serving.decisions import Decision, decisions_frame, with_run_stuck_flags
from terrain.serving.service import StreamService


def interleave(run: Run, streams: Sequence[str], max_chunk: int = 1
               ) -> Iterator[tuple[str, np.ndarray, np.ndarray]]:
    """Samples of ``streams`` of ``run`` merged in timestamp order (samples of two streams
    at the same time in the order of ``streams``).

    Parameters
    ----------
    run : Run
        Recorded run.
    streams : sequence of str
        Streams to replay (those absent from the run are skipped).
    max_chunk : int
        Most consecutive samples of one stream yielded together (1: one by one). The last
        sample of a run of one stream (before another stream's sample, or the end) is
        yielded alone: the service judges a lagging stream stale from the first sample of
        the newest push, so a run ending inside a longer chunk would leave the decisions
        it makes due sample by sample undecided (a 6.5 Hz wheel stream outlasting the IMU
        by 4.8 s in one 32-sample chunk: 7 decisions instead of 14, the rest of the
        wheels' samples reaching none, without a word).

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
    if not sum(len(t) for t in times):
        return  # no sample of the named streams (none present, or all empty)
    which = np.concatenate([np.full(len(t), i) for i, t in enumerate(times)])
    row = np.concatenate([np.arange(len(t)) for t in times])
    order = np.argsort(np.concatenate(times), kind="stable")
    which, row = which[order], row[order]
    cut = np.flatnonzero(np.diff(which)) + 1
    for a, b in zip(np.r_[0, cut], np.r_[cut, len(which)]):
        i = int(which[a])
        # the run's last sample alone (docstring): its chunks cover [a, b - 1), then b - 1
        edges = [*range(a, b - 1, max_chunk), b - 1, b] if b - a > 1 else [a, b]
        for c, d in zip(edges[:-1], edges[1:]):
            r = row[c:d]
            yield names[i], times[i][r], vals[i][r]


def replay_run(service: StreamService, run: Run, max_chunk: int = 1) -> list[Decision]:
    """Push a whole run through ``service`` in timestamp order.

    Parameters
    ----------
    service : StreamService
    run : Run
        Its stream frames must hold every channel of the service's streams; they are read
        by name, in any column order (runs read by :mod:`terrain.io` do).
    max_chunk : int
        See :func:`interleave`.

    Returns
    -------
    list of Decision

    Raises
    ------
    ConfigError
        ``max_chunk`` not an integer >= 1.
    MissingColumnError
        A stream frame lacks a channel of its stream (named;
        :meth:`StreamService.push <terrain.serving.service.StreamService.push>`).
    """
    out: list[Decision] = []
    for stream, t, v in interleave(run, service.needed_streams, max_chunk):
        cols = [c for c in run.streams[stream].columns if c != TIME]
        out.extend(service.push(stream, t, dict(zip(cols, v.T))))
    return out


@dataclass(frozen=True)
class RunReplay:
    """The decisions of one recorded run replayed as a live stream, and what the service
    did with its samples (:func:`replay_recorded`).

    Attributes
    ----------
    run : Run
        The replayed run.
    frame : pandas.DataFrame
        Decisions (:func:`~terrain.serving.decisions.decisions_frame` columns), whose
        ``flags`` carry the readers' stuck-sensor flags of the run's ``meta`` as the batch
        windows do.
    n_stuck : int
        Decisions flagged for a stuck sensor.
    overlap_s : float
        Time span covered by every stream the model needs, s (0 when they do not
        overlap).
    window_s, hop_s, max_backlog_s : float
        The model's window length, the time between decisions and the service's silent
        stretch (decisions skipped beyond it), s.
    streams : tuple of str
        Streams the model needs.
    refused, held : dict of (str, str) to int
        Samples refused, and those still held at the end, by ``(stream, reason)``
        (:attr:`StreamService.refused_samples`, :attr:`StreamService.held_samples`).
    skipped : int
        Decisions skipped in silent stretches.
    first_decision_s, last_common_s : float
        When the service's first decision is due (the latest first sample of the needed
        streams plus ``window_s``, as its clock computes it) and the earliest last sample of
        those streams, s (NaN where a needed stream is empty).
    """

    run: Run
    frame: pd.DataFrame
    n_stuck: int
    overlap_s: float
    window_s: float
    hop_s: float
    max_backlog_s: float
    streams: tuple
    refused: dict
    held: dict
    skipped: int
    first_decision_s: float
    last_common_s: float

    @property
    def too_short(self) -> bool:
        """Whether the needed streams share less than one window (the run is refused even
        where the service emitted flagged decisions from the longer stream alone): the
        first decision is due after the earliest last sample, the service's own rule
        (``overlap_s < window_s`` refused runs the service decides on, where the span's
        subtraction rounds below the window: 2.3 - 0.3 s is 1.9999999999999998 s)."""
        return not self.first_decision_s <= self.last_common_s

    def input_report(self) -> InputReport:
        """The readers' report of the run (what they repaired and found), with its window
        counts as ``terrain predict`` gives them.

        Returns
        -------
        InputReport
        """
        run_id = self.run.run_id
        counts = {"per_run": {} if self.too_short else {run_id: {
            "windows": len(self.frame), "dropped_gap": 0, "dropped_unsteady": 0}},
            "too_short_runs": [run_id] if self.too_short else [],
            "streams": list(self.streams)}
        return input_report([self.run], counts, self.window_s, {run_id: self.n_stuck})

    def check(self, path: str | Path) -> None:
        """Refuse a replay that gave no decision.

        Parameters
        ----------
        path : str or pathlib.Path
            The run's folder, named in the error.

        Raises
        ------
        DataFormatError
            The needed streams overlap for less than one window, or the service's
            per-sample rules refused the samples it needed (the message counts them per
            stream and reason).
        """
        run_id, streams = self.run.run_id, list(self.streams)
        if self.too_short:
            raise DataFormatError(f"no decision from run {run_id}: its streams {streams} "
                                  f"overlap for {self.overlap_s:.2f} s, shorter than the "
                                  f"model's {self.window_s:g} s window", path)
        if not len(self.frame):
            refused = ", ".join(f"{n} of stream {s} ({r})"
                                for (s, r), n in sorted(self.refused.items()))
            raise DataFormatError(f"no decision from run {run_id}: its streams {streams} "
                                  f"overlap for {self.overlap_s:.2f} s (window "
                                  f"{self.window_s:g} s), but the service's input rules "
                                  f"left too few samples; refused: {refused or 'none'}",
                                  path)

    def summary(self, out: str | Path) -> str:
        """What a user is told of the replay: decisions, flags by kind, decisions skipped,
        samples refused (by stream and reason), samples still held, where they were
        written, and the share decided as the run's label.

        Parameters
        ----------
        out : str or pathlib.Path
            The decisions file written.

        Returns
        -------
        str
            One line, plus one more when the run's label is a class of the model.
        """
        frame = self.frame
        kinds = Counter(k.split(":")[0] for f in frame["flags"] if f for k in f.split("|"))
        flagged = int((frame["flags"] != "").sum())
        detail = f" ({', '.join(f'{k} {n}' for k, n in sorted(kinds.items()))})" \
            if kinds else ""
        skipped = (f"; {self.skipped} skipped in silent stretches (no sample of any stream "
                   f"for over {self.max_backlog_s:g} s)" if self.skipped else "")
        if self.refused:   # counted per sample (a re-sent one flags no decision)
            skipped += "; refused " + ", ".join(
                f"{n}{(' sample' + 's' * (n != 1)) if i == 0 else ''} of stream {s} ({r})"
                for i, ((s, r), n) in enumerate(sorted(self.refused.items())))
        if self.held:
            skipped += "; " + ", ".join(f"{n} samples of stream {s} still held at the end "
                                        f"({r}: their clock not yet told)"
                                        for (s, r), n in sorted(self.held.items()))
        plural = "" if len(frame) == 1 else "s"
        text = (f"{self.run.run_id}: {len(frame)} decision{plural} every {self.hop_s} s from "
                f"streams {list(self.streams)}; {flagged} flagged{detail}{skipped}; "
                f"written to {out}")
        classes = [c[len("proba_"):] for c in frame.columns if c.startswith("proba_")]
        if len(frame) and self.run.terrain in classes:
            acc = float((frame["terrain"] == self.run.terrain).mean())
            text += (f"\n  decided {self.run.terrain} (the folder's label) in {acc:.3f} of "
                     "the decisions")
        return text


def replay_recorded(service: StreamService, run: Run) -> RunReplay:
    """Replay a recorded run through ``service`` as ``terrain stream`` does.

    Every sample is pushed one by one in timestamp order (:func:`replay_run`); the
    decisions carry the readers' stuck-sensor flags of the run.

    Parameters
    ----------
    service : StreamService
        A fresh service (its counters are reported as the replay's).
    run : Run
        Recorded run, read by :mod:`terrain.io`.

    Returns
    -------
    RunReplay

    Raises
    ------
    ConfigError
        ``run`` lacks a stream the model needs.
    """
    streams = service.needed_streams
    missing = [s for s in streams if s not in run.streams]
    if missing:
        raise ConfigError(f"the model needs stream(s) {missing}, absent from run {run.run_id}")
    model = service.model
    frame = decisions_frame(replay_run(service, run), model.classes)
    window_s = model.window.window_s
    frame["flags"], n_stuck = with_run_stuck_flags(frame, dict(run.meta.get("stuck", {})),
                                                   window_s)
    needed = [run.streams[s] for s in streams]
    start_s, end_s = _common_span_s(needed)
    return RunReplay(run, frame, n_stuck, _overlap_s(needed), window_s,
                     service.config.hop_s, service.config.max_backlog_s, streams,
                     service.refused_samples, service.held_samples,
                     service.skipped_decisions, start_s + window_s, end_s)


def _common_span_s(streams: list[pd.DataFrame]) -> tuple[float, float]:
    """Latest first sample and earliest last sample of ``streams``, s (NaN, NaN where one
    is empty)."""
    if not all(len(f) for f in streams):
        return math.nan, math.nan
    return (max(float(f[TIME].iloc[0]) for f in streams),
            min(float(f[TIME].iloc[-1]) for f in streams))


def _overlap_s(streams: list[pd.DataFrame]) -> float:
    """Time span covered by every one of ``streams``, s (0 when they do not overlap)."""
    start_s, end_s = _common_span_s(streams)
    return end_s - start_s if end_s >= start_s else 0.0     # NaN: an empty stream
