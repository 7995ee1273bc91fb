"""What the streaming service keeps of each stream, and the clock rules that decide it.

:class:`StreamIntake` takes the validated chunks that :meth:`StreamService.push
<terrain.serving.service.StreamService.push>` receives and keeps, per stream, a bounded
:class:`~terrain.serving.buffers.RingBuffer`, the per-sample rules' rejection events (for the
decision flags), a stuck-sensor watch and one :class:`~terrain.serving.clocks.StreamClock`:
its offset and the samples the clock rules hold. It applies the verdicts of the pure clock
rules of :mod:`terrain.serving.clocks` (a restarted clock, a forward step of one stream's
clock, a stream's first sample on another clock, a clock in ms, samples sent again) and
counts every sample it refuses, by stream and reason.

:class:`DecisionClock` is the one piece of state the intake shares with the service: the
service time of the next decision. The service advances it; the intake reads it (a sample
pushed out of its buffer before a decision could read it is counted as lost) and starts it
again when the clocks restart. Data flow: service -> intake -> buffers; the service reads
the buffers, events and stuck watches to decide.
"""

from __future__ import annotations

import math
from collections import Counter, deque
from typing import Sequence

import numpy as np

from terrain.serving.buffers import RingBuffer
from terrain.serving.clocks import (AHEAD, DUPLICATE, DUPLICATE_TOL_S, TIME_RULE, UNITS,
                                    UNITS_STEPS, HeldRun, StreamClock, ahead_shift,
                                    continues_run, first_long_step, in_a_gap,
                                    newest_on_ms_clock, resent_mask, resolve_hold,
                                    restart_shift, steps_ahead, went_on_live)
from terrain.serving.config import KNOWN_STREAMS, StreamConfig
from terrain.serving.rules import MAX_PLAUSIBLE_TIME_S, SampleRule, StuckWatch

#: Rejection spans remembered per stream (bounded, for the flags; :meth:`StreamIntake.note`).
MAX_EVENTS = 256
#: reason of a sample a chunk pushed out of its stream's buffer before any decision used it
#: (a chunk longer than the buffer, or a backlog while another stream lags)
OVERFLOW = "buffer_overflow"


class DecisionClock:
    """Service time of the next decision, shared by the service and its intake.

    Parameters
    ----------
    window_s : float
        The model's window, s.
    rate_hz : float
        The model's aligned clock, Hz (a window reads ``2 / rate_hz`` s before its start,
        to interpolate).

    Attributes
    ----------
    next_t : float or None
        Service time of the next decision, s; ``None`` until the first window can be placed
        (and after the clocks restart). Setting it places the clock there;
        :meth:`advance` moves it on by whole hops from that origin.
    """

    __slots__ = ("_origin", "_hops", "_next_t", "_window_s", "_rate_hz")

    def __init__(self, window_s: float, rate_hz: float) -> None:
        self._origin: float | None = None
        self._hops = 0
        self._next_t: float | None = None
        self._window_s, self._rate_hz = window_s, rate_hz

    @property
    def next_t(self) -> float | None:
        """Service time of the next decision, s (None: not placed)."""
        return self._next_t

    @next_t.setter
    def next_t(self, value: float | None) -> None:
        self._origin, self._hops, self._next_t = value, 0, value

    def advance(self, hops: int, hop_s: float) -> None:
        """Move the next decision on by ``hops`` hops of ``hop_s`` s.

        The time is the origin plus a whole number of hops, not a running sum: adding a
        0.3 s hop 20 000 times drifts 2e-9 s, past the 1e-9 s by which a window's end is
        told from a grid point (``StreamService._window``), so a window would read one
        sample more than the batch window of the same span.

        Parameters
        ----------
        hops : int
            Hops to move on (>= 1).
        hop_s : float
            The service's hop, s.
        """
        self._hops += hops
        self._next_t = self._origin + self._hops * hop_s

    @property
    def window_s(self) -> float:
        """The model's window, s."""
        return self._window_s

    def needed_since(self) -> float:
        """Oldest time a coming decision's window may still read.

        Returns
        -------
        float
            s; ``-inf`` before the first decision (every sample may be read).
        """
        if self.next_t is None:
            return -np.inf
        return self.next_t - self._window_s - 2.0 / self._rate_hz

    def reset(self) -> None:
        """Start again: the next decision is placed by the samples that come."""
        self.next_t = None

    def rewind(self, newest_s: float, max_backlog_s: float) -> None:
        """Start again when the clock ran more than ``max_backlog_s`` ahead of every stream
        (on a stamp far ahead, or a clock in ms, since taken back).

        Parameters
        ----------
        newest_s : float
            Newest buffered time of any stream, s.
        max_backlog_s : float
            ``StreamConfig.max_backlog_s``, s.
        """
        if self.next_t is not None and self.next_t > newest_s + max_backlog_s:
            self.next_t = None


class StreamIntake:
    """The buffers, events, stuck watches and clocks of a service's streams (module
    docstring).

    Parameters
    ----------
    streams : Mapping[str, tuple of str]
        The streams the model needs -> their channels.
    config : StreamConfig
        The service's settings (buffer size, clock tolerances, offsets).
    rules : sequence of SampleRule
        Per-sample plausibility rules.
    decisions : DecisionClock
        The service's decision clock.

    Attributes
    ----------
    buffers : dict of str to RingBuffer
        Accepted samples per stream (replaced when a clock restarts).
    events : dict of str to deque
        ``(t_first_s, t_last_s, reason)`` of the newest :data:`MAX_EVENTS` spans of
        rejections per stream (:meth:`note`): a window ``[t - window_s, t)`` holds a
        rejection of the span iff ``t_first_s < t`` and ``t_last_s >= t - window_s``.
    stuck : dict of str to StuckWatch
        Stuck-sensor watch per stream.
    clocks : dict of str to StreamClock
        Offset and held samples per stream.
    refused : collections.Counter
        Samples refused, by ``(stream, reason)``.
    restarts : int
        Clock restarts so far.
    unplaced : set of (str, str)
        ``(stream, reason)`` of samples refused without a stamp before any stream had one,
        or pushed out of their buffer (``buffer_overflow``) before the first decision was
        placed (flagged on the first window).
    """

    def __init__(self, streams: dict[str, tuple[str, ...]], config: StreamConfig,
                 rules: Sequence[SampleRule], decisions: DecisionClock) -> None:
        self.streams, self.config, self.rules = streams, config, rules
        self._decisions = decisions
        self.buffers = {s: self._new_buffer(s) for s in streams}
        self.events: dict[str, deque] = {s: deque(maxlen=MAX_EVENTS) for s in streams}
        self.stuck = {s: StuckWatch(s, ch) for s, ch in streams.items()}
        self.refused: Counter = Counter()
        self.restarts = 0
        # each stream's clock: offset, held samples, the timestamp_units rule (clocks.py);
        # the rule knows a stream's nominal rate range by its channels
        self.clocks = {s: StreamClock(config.buffer_samples,
                                      next((k for k, known in KNOWN_STREAMS.items()
                                            if set(ch) <= set(known)), None),
                                      config.clock_offsets_s.get(s, 0.0))
                       for s, ch in streams.items()}
        # runs held ahead so far (their order: StreamClock.ahead_rank)
        self._holds_begun = 0
        # a step ahead of the others by less than stale_s is a lag the config tolerates
        self._step_s = max(config.clock_restart_s, config.stale_s)
        self.unplaced: set[tuple[str, str]] = set()

    def note(self, stream: str, t_s: float, reason: str, until_s: float | None = None
             ) -> None:
        """Remember a rejection (or a restart) of ``stream`` at ``t_s`` for the flags.

        A rejection of the same reason as the stream's newest span, at most one window
        after its end, extends that span: no window ``[t - window_s, t)`` holds the span
        without holding one of its rejections, so the flags are those of every rejection
        kept one by one, while a chunk refused sample by sample no longer pushes the
        rejections of its first windows out of the bounded log (one 580-sample chunk with
        every other sample non-finite left its first 18 decisions unflagged).

        Parameters
        ----------
        stream : str
            A stream the model needs.
        t_s : float
            Service time of the rejection, s.
        reason : str
            Its flag.
        until_s : float or None
            Service time of the last of a run of rejections from ``t_s`` on, s (no step
            between them longer than a gap of the stream), noted as one span; None: the
            one rejection at ``t_s``.
        """
        last_s = t_s if until_s is None else max(t_s, until_s)
        log = self.events[stream]
        if log:
            first, last, kind = log[-1]
            if kind == reason and first <= t_s <= last + self._decisions.window_s:
                if last_s > last:
                    log[-1] = (first, last_s, reason)
                return
        log.append((t_s, last_s, reason))

    def ingest(self, stream: str, t: np.ndarray, v: np.ndarray, hold: bool = True,
               judged: bool = False) -> None:
        """Take a validated chunk of one stream: the rules, the clock rules, the buffer.

        Applies the sample rules, buffers what they keep, holds the samples of a forward
        step of the stream's clock alone (unless ``hold`` is false) and watches the samples
        refused as earlier than the stream's newest for a clock restart.

        Parameters
        ----------
        stream : str
            A stream the model needs (a key of :attr:`streams`).
        t : numpy.ndarray
            ``(n,)`` timestamps on the service clock (the stream's offset added), s.
        v : numpy.ndarray
            ``(n, n_channels)`` values in the stream's channel order, SI units.
        hold : bool
            Whether a forward step of the stream's clock may be held (false for a held run
            being released).
        judged : bool
            Samples held before, whose clock's units were judged when they came (the
            ``timestamp_units`` rule is not asked again).
        """
        channels, buf, clock = self.streams[stream], self.buffers[stream], self.clocks[stream]
        # a sample at or before the stream's newest, buffered or held ahead, may be one
        # sent again (checked only then: the usual increasing push costs two comparisons)
        ahead = clock.ahead
        if t[0] <= buf.last_t or (ahead is not None and t[0] <= ahead.last_t) or \
                (len(t) > 1 and not (t[1:] > t[:-1]).all()):
            resent = self._resent(stream, t, v)
            if resent.any():
                self.refused[(stream, DUPLICATE)] += int(resent.sum())
                t, v = t[~resent], v[~resent]
                if not len(t):   # all sent again: the kept samples have arrived
                    buf.mark_arrived()
                    return
        slowest = clock.ms_step_s
        if slowest is not None and not judged:   # rule timestamp_units
            taken = self._judge_units(stream, t, v, slowest)
            if taken is None:
                return
            t, v = taken
            buf = self.buffers[stream]   # (held samples taken meanwhile may restart)
        order = np.arange(len(t))  # arrival position of each sample still in play
        late: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        unstamped = []    # (arrival position, reason) of samples refused without a stamp
        for rule in self.rules:
            keep, reason = rule(channels, t, v, buf.last_t)
            if not keep.all():
                bad_t = t[~keep]
                self.refused[(stream, reason)] += len(bad_t)
                for bt, at in zip(bad_t.tolist(), order[~keep].tolist()):
                    if math.isfinite(bt):
                        self.note(stream, bt, reason)
                    else:
                        unstamped.append((at, reason))
                if reason == TIME_RULE:
                    late = (t[~keep], v[~keep], order[~keep])
                t, v, order = t[keep], v[keep], order[keep]
        if unstamped:
            self._note_unstamped(stream, unstamped, t, order)
        if not len(t):
            # a later push, refused whole (for its values, its stamp or a stamp going back),
            # still says the stream's kept samples have all arrived (as when they came one by
            # one): it lags no more
            buf.mark_arrived()
        # a step forward longer than clock_restart_s and stale_s, or a stream's first
        # samples (one comparison on the usual push)
        if hold and len(t) and (clock.ahead is not None or t[-1] - buf.last_t > self._step_s):
            t, v = self._hold_ahead(stream, t, v)
        if len(t):
            # samples the chunk pushes out of the buffer before a decision used them
            since = self._decisions.needed_since()
            lost = buf.evicted(t, since)
            if lost:
                self.refused[(stream, OVERFLOW)] += lost
                if since == -np.inf:   # no decision placed: the first window says so
                    self.unplaced.add((stream, OVERFLOW))
                else:   # the coming windows that would have read them
                    for lt in buf.evicted_times(t, since).tolist():
                        self.note(stream, lt, OVERFLOW)
            self.stuck[stream].update(t, v)
            clock.rejoining = False
        buf.append(t, v)
        self._watch_restart(stream, late, order, t, v)
        if any(c.ahead is not None for c in self.clocks.values()):
            self._resolve_ahead()

    def _note_unstamped(self, stream: str, unstamped: list[tuple[int, str]],
                        kept_t: np.ndarray, kept_order: np.ndarray) -> None:
        """Flag the samples of a chunk refused without a usable stamp (``(arrival
        position, reason)``) at the stream's newest time when each came: the stamp of the
        chunk's kept sample before it, else the stream's newest (the service's before the
        stream's first sample; the first window's start before any sample at all), as
        pushed one by one (flagged at the newest before the chunk, a NaN stamp flagged a
        window the same samples one by one left unflagged)."""
        buf = self.buffers[stream]
        before = buf.last_t if len(buf) else self.newest()
        for pos, reason in unstamped:
            i = int(np.searchsorted(kept_order, pos))
            at = float(kept_t[i - 1]) if i else before
            if at == -np.inf:
                self.unplaced.add((stream, reason))
            self.note(stream, at, reason)

    def _judge_units(self, stream: str, t: np.ndarray, v: np.ndarray, slowest: float
                     ) -> tuple[np.ndarray, np.ndarray] | None:
        """Rule ``timestamp_units`` on a chunk of ``stream``: the samples to take now, or
        None (refused, held until they can be judged, or taken here).

        A push whose mean step is over ``slowest`` (s: ten periods of the stream's slowest
        nominal rate; a stream's first push, over its own steps) opens a hold at its first
        step that long (the samples before it are taken): the chunks from it on are held
        until :data:`~terrain.serving.clocks.UNITS_STEPS` steps after it are known, then
        purged with what the stream gave in ms (counted) or taken chunk by chunk as they
        came. A clock that switches to ms thus never runs the decision clock; a dropout
        costs the stream a delay of that many samples. A sample back before the step ends
        the hold: one that continues the stream's old clock after a step longer than
        ``max_backlog_s`` (no dropout's backlog is that late) drops the held samples as a
        stray stamp ahead (``time_ahead``); otherwise they are taken as they came. A stream
        found in ms is judged at every push and its samples refused until its steps are in
        s again. The usual push costs one comparison."""
        clock = self.clocks[stream]
        held, prev = clock.unjudged, clock.newest_stamp_s
        # (a stamp the readers' rule implausible_time refuses opens no hold)
        suspect = abs(t[-1]) <= MAX_PLAUSIBLE_TIME_S and (
            t[-1] - prev > len(t) * slowest if prev is not None
            else t[-1] - t[0] > (len(t) - 1) * slowest)
        clock.remember(t)
        if clock.on_ms_clock or (suspect and not held):
            if self._in_ms(stream):   # its newest steps say so already
                self.refused[(stream, UNITS)] += len(t)
                self.note(stream, self.newest(), UNITS)
                return None
            if not suspect:
                return t, v
        if held:
            t0, last = held.t0_s, self.buffers[stream].last_t
            back = np.flatnonzero(t < t0)
            if len(back):   # back before the step: no clock from it
                i = int(back[0])
                if last < t[i] and t0 - last > self.config.max_backlog_s:
                    self.refused[(stream, AHEAD)] += len(held) + i
                    self.note(stream, self.newest(), AHEAD)
                    held.clear()
                    return t[i:], v[i:]
                self._release_unjudged(stream)
                return t, v
        elif not suspect:
            return t, v
        else:   # the hold begins at the chunk's first long step
            k = first_long_step(np.where(np.abs(t) <= MAX_PLAUSIBLE_TIME_S, t, np.nan), prev,
                                slowest)
            if k:
                self.ingest(stream, t[:k], v[:k], judged=True)
                t, v = t[k:], v[k:]
            last = self.buffers[stream].last_t
            # a long step from a late or stray stamp but not past the stream's newest taken
            # is no switch (a restarted clock goes on); a step ahead of every other stream
            # in step is held (and judged) as one
            if not t[0] - last > slowest or steps_ahead(
                    t[0], last, self._others_newest(stream).values(), self._step_s,
                    self._first_step_s(stream)):
                return t, v
        held.append(t, v)
        if held.n_finite <= UNITS_STEPS and len(held) < self.config.buffer_samples:
            return None
        if held.n_finite > UNITS_STEPS and self._in_ms(stream):   # purged with what is held
            self.note(stream, self.newest(), UNITS)
            return None
        self._release_unjudged(stream)   # a clock in s (a dropout)
        return None

    def _release_unjudged(self, stream: str) -> None:
        """Take the chunks of ``stream`` held for the ``timestamp_units`` rule, one by one
        as they came (their units judged)."""
        for t, v in self.clocks[stream].unjudged.take():
            self.ingest(stream, t, v, judged=True)

    def _hold_ahead(self, stream: str, t: np.ndarray, v: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray]:
        """Hold the samples of ``stream`` that step its clock ahead of every other stream's
        (:func:`~terrain.serving.clocks.steps_ahead`) and those that run on from them as a
        clock; return the samples to take now. A sample before the newest held one by no
        more than a clock's step (``clock_restart_s``, ``stale_s``) but itself ahead of
        every other stream (on the held clock, delivered out of order) is refused as
        ``time_not_increasing``, as a late sample on a clock taken is; one that
        breaks a held run otherwise (the stream going on on its old clock: the held ones
        were a stray stamp far ahead) drops the held ones, counted as ``time_ahead`` (one
        that repeats a held sample never comes here: :meth:`_resent`)."""
        buf, clock = self.buffers[stream], self.clocks[stream]
        held = clock.ahead
        first_jump = self._first_step_s(stream)
        max_step = self._gap_step_s(stream)
        max_step = max_step if np.isfinite(max_step) else self._step_s
        taken = np.ones(len(t), dtype=bool)
        prev = buf.last_t        # the stream's newest sample taken
        others = self._others_newest(stream)
        for i, ti in enumerate(t):
            if held is not None and continues_run(ti, held.last_t, max_step):
                if held.full:   # the hold is bounded: count the loss
                    self.refused[(stream, OVERFLOW)] += 1
                held.append(ti, v[i])
                taken[i] = False
                continue
            ahead = steps_ahead(ti, prev, others.values(), self._step_s, first_jump)
            if held is not None:
                # late on the held clock by less than a clock's step: out of order
                if ahead and 0.0 <= held.last_t - ti <= self._step_s:
                    self.refused[(stream, TIME_RULE)] += 1
                    self.note(stream, self.newest(), TIME_RULE)
                    taken[i] = False
                    continue
                self._drop_ahead(stream)
                held = None
            if ahead:
                held = clock.ahead = HeldRun(self.config.buffer_samples)
                clock.ahead_rank = self._holds_begun
                self._holds_begun += 1
                # the chunk arrived with its newest sample: the others' clock then is that
                # sample's, not the first held one's
                held.begin(ti, t[-1] - ti, others)
                held.append(ti, v[i])
                taken[i] = False
                continue
            prev = ti
        return t[taken], v[taken]

    def _first_step_s(self, stream: str) -> float:
        """How far a stream's first sample must be from every other stream's newest to be
        on another clock, s: more than a delivery lag could be (``max_backlog_s``), or,
        for a stream silent through a restart of the others' clock (its old clock is no
        longer theirs), more than a lag the config tolerates (``clock_restart_s``,
        ``stale_s``)."""
        if self.clocks[stream].rejoining:
            return self._step_s
        return max(self._step_s, self.config.max_backlog_s)

    def _others_newest(self, stream: str) -> dict[str, float]:
        """Newest buffered time of every other stream with samples and no run held ahead,
        s (the clocks a step of ``stream`` is judged against)."""
        return {s: b.last_t for s, b in self.buffers.items()
                if s != stream and len(b) and self.clocks[s].ahead is None}

    def _drop_ahead(self, stream: str) -> None:
        """Refuse the held run of ``stream`` (a stray stamp ahead), counted and flagged as
        ``time_ahead``."""
        self._refuse_ahead(stream, AHEAD)
        # flagged from the service's newest time on: the stream's own newest may be long
        # before every coming window (a clock in ms whose every sample steps ahead)
        self.note(stream, self.newest(), AHEAD)

    def _resolve_ahead(self) -> None:
        """Release the runs held ahead that :func:`~terrain.serving.clocks.resolve_hold`
        settles: as they are, or on the clock of the streams that went on."""
        for stream in self._holding_ahead():
            held = self.clocks[stream].ahead
            if held is None:   # released by a release before it
                continue
            at_start = held.others_newest_s
            running = resolve_hold(held.t0_s, held.last_t, at_start,
                                   {s: self.buffers[s].last_t for s in at_start},
                                   self.config.stale_s, self.config.clock_restart_s,
                                   self.config.max_backlog_s)
            if running is None:
                continue
            shift = 0.0 if not running else ahead_shift(
                held.t0_s, held.lead_s, [at_start[s] for s in running],
                [self.buffers[s].median_step() for s in running],
                self.buffers[stream].last_t, self.buffers[stream].median_step())
            self._release_ahead(stream, shift)

    def _release_ahead(self, stream: str, shift: float) -> None:
        """Ingest the held run of ``stream`` moved by ``shift`` (s; a shift is a restart of
        that stream's clock alone: offset, counter and flag). The oldest samples the bounded
        hold dropped (counted as ``buffer_overflow`` when dropped) flag the windows that
        would have read them, on the clock the run is put on, as samples pushed out of the
        stream's buffer do (:meth:`ingest`; the first window when no decision is placed)."""
        held = self._take_ahead(stream)
        t, v = held.arrays()
        if shift:
            self._move_clock(stream, t, shift)
        self.ingest(stream, t, v, hold=False, judged=True)
        if held.n_dropped:   # a run: no step in it longer than a gap of the stream
            if self._decisions.next_t is None:
                self.unplaced.add((stream, OVERFLOW))
            else:
                self.note(stream, held.t0_s + shift, OVERFLOW,
                          until_s=held.dropped_last_s + shift)
        if shift:
            self.note(stream, float(t[-1]), "clock_restart")

    def _resent(self, stream: str, t: np.ndarray, v: np.ndarray) -> np.ndarray:
        """``(n,)`` bool: the samples of a chunk that the stream already gave, buffered
        (:func:`~terrain.serving.clocks.resent_mask`) or held ahead
        (:meth:`~terrain.serving.clocks.HeldRun.repeats`)."""
        finite = t[np.isfinite(t)]
        if not len(finite):       # no stamp to match (the rules refuse them)
            return np.zeros(len(t), dtype=bool)
        buf, clock = self.buffers[stream], self.clocks[stream]
        bt, bv = buf.since(float(finite.min()) - DUPLICATE_TOL_S)
        out = resent_mask(t, v, bt, bv, buf.first_t, buf.last_t,
                          clock.late.last_t if len(clock.late) else None,
                          self._gap_step_s(stream))
        if clock.ahead is not None:   # a re-send while a step ahead is told
            out |= [clock.ahead.repeats(ti, vi) for ti, vi in zip(t, v)]
        return out

    def _refuse_ahead(self, stream: str, reason: str) -> None:
        """Refuse the run held ahead by ``stream``, counted under ``reason``: the samples
        held and the oldest ones its bound dropped (counted as ``buffer_overflow`` when
        dropped, now under the reason that drops the run: a sample counts once)."""
        held = self._take_ahead(stream)
        if held.n_dropped:
            self._uncount(stream, OVERFLOW, held.n_dropped)
        self.refused[(stream, reason)] += len(held) + held.n_dropped

    def _take_ahead(self, stream: str) -> HeldRun:
        """The run held ahead by ``stream``, which holds none after."""
        clock = self.clocks[stream]
        held, clock.ahead = clock.ahead, None
        return held

    def _holding_ahead(self) -> list[str]:
        """Streams holding a run ahead, in the order their runs began
        (:attr:`~terrain.serving.clocks.StreamClock.ahead_rank`)."""
        return [s for _, s in sorted((c.ahead_rank, s) for s, c in self.clocks.items()
                                     if c.ahead is not None)]

    def _new_buffer(self, stream: str) -> RingBuffer:
        """An empty buffer for ``stream`` (``buffer_samples`` of its channels)."""
        return RingBuffer(len(self.streams[stream]), self.config.buffer_samples)

    def _gap_step_s(self, stream: str) -> float:
        """Longest step of ``stream`` that is no gap, s: ``gap_factor`` times its usual
        (median) step, the readers' rule (``nan`` with fewer than 2 samples buffered)."""
        return self.config.gap_factor * self.buffers[stream].median_step()

    def _move_clock(self, stream: str, t: np.ndarray, shift: float) -> None:
        """Restart the clock of ``stream`` alone: its held stamps ``t`` (s) move by
        ``shift`` (s, in place), its offset changes by it and the restart is counted."""
        clock = self.clocks[stream]
        t += shift
        clock.offset_s += float(shift)
        clock.restamp(t)
        self.restarts += 1

    def newest(self) -> float:
        """Newest buffered time of any stream (the service's now).

        Returns
        -------
        float
            s; ``-inf`` before any sample.
        """
        return max(b.last_t for b in self.buffers.values())

    def _in_ms(self, stream: str) -> bool:
        """Rule ``timestamp_units`` live (:func:`~terrain.serving.clocks.clock_in_ms` on the
        stream's newest arrival stamps; asked only when a push's mean step may say so); a
        stream found in ms has its samples purged (counted) and stays refused until its
        steps are in s again."""
        in_ms, switched = self.clocks[stream].judge_ms()
        if switched:
            self._purge(stream)
        return in_ms

    def _purge(self, stream: str) -> None:
        """Refuse the samples of ``stream`` buffered on its ms clock (the newest ones, each
        a step over ten nominal periods after the one before; those before the switch were
        good and stay) and those it holds, counted as ``timestamp_units`` (the late ones
        held for a restart move there from ``time_not_increasing``); the decision clock
        starts again when it ran ahead of every other stream on their stamps."""
        buf, clock = self.buffers[stream], self.clocks[stream]
        k = newest_on_ms_clock(buf.times(), clock.ms_step_s)
        if len(clock.late):   # counted when refused as late (held_samples says so)
            self._uncount(stream, TIME_RULE, len(clock.late))
        n = k + len(clock.late) + len(clock.unjudged)
        if n:
            self.refused[(stream, UNITS)] += n
        if clock.ahead is not None:
            self._refuse_ahead(stream, UNITS)
        buf.drop_newest(k)
        self.stuck[stream] = StuckWatch(stream, self.streams[stream])
        clock.late.clear()
        clock.unjudged.clear()
        self._decisions.rewind(self.newest(), self.config.max_backlog_s)

    def _uncount(self, stream: str, reason: str, n: int) -> None:
        """Take back ``n`` refusals of ``stream`` for ``reason`` (held samples used after
        all)."""
        self.refused[(stream, reason)] -= n
        if self.refused[(stream, reason)] <= 0:
            del self.refused[(stream, reason)]

    def _watch_restart(self, stream: str, late, kept_order: np.ndarray,
                       kept_t: np.ndarray, kept_v: np.ndarray) -> None:
        """Hold the samples of ``stream`` refused as not increasing since its last accepted
        one; once they run as a clock over ``clock_restart_s``, restart (all streams, or
        ``stream`` alone when others went on meanwhile), unless they fill a hole of its
        buffer (:func:`~terrain.serving.clocks.in_a_gap`). A held run that the stream's
        accepted samples continue (its clock stepped back by less than ``clock_restart_s``
        and ran on past its old newest) is a restart of that stream alone too, once it
        spans ``stale_s``; ``kept_t``, ``kept_v``: the chunk's samples taken (``kept_order``
        their arrival positions)."""
        held = self.clocks[stream].late
        if late is None or (len(kept_order) and kept_order[-1] > late[2][-1]):
            if late is not None:   # this chunk's late samples before its last taken one
                self._extend_late(stream, late[0], late[1])
            if len(kept_order) == len(kept_t) > 0 and len(held):
                after = kept_order > (late[2][-1] if late is not None else -1)
                if after.any() and self._stepped_back(stream, kept_t[after][0]):
                    shift = self._restart_alone(stream, self._running(stream))
                    self.ingest(stream, kept_t[after] + shift, kept_v[after], judged=True)
                    return
            if len(kept_order) or late is not None:
                held.clear()   # the stream goes on on its clock: a stray late sample
            return
        lt, lv, lo = late
        if len(kept_order):       # only those after the last accepted sample count
            after = lo > kept_order[-1]
            lt, lv = lt[after], lv[after]
        self._extend_late(stream, lt, lv)
        if not (len(held) and held.last_t - held.t0_s >= self.config.clock_restart_s):
            return
        if self._in_own_gap(stream):
            held.clear()   # a late backlog of the stream's own gap: no new clock
            return
        # streams that went on accepting samples on the old clock meanwhile
        running = self._running(stream)
        if not running:
            self._restart()
        elif self._went_on_beside(stream, running):   # (else a backlog sent at once)
            self._restart_alone(stream, running)

    def _extend_late(self, stream: str, t: np.ndarray, v: np.ndarray) -> None:
        """Hold late samples of ``stream`` as a possible new clock: it runs as the old one
        did, increasing, with no step longer than a gap (the readers' rule against the
        stream's usual step); anything else starts the run again."""
        self.clocks[stream].late.extend_clock(
            t, v, self._gap_step_s(stream),
            {s: b.last_t for s, b in self.buffers.items() if s != stream and len(b)})

    def _went_on_beside(self, stream: str, running: list[str]) -> bool:
        """Whether one of the ``running`` streams went on live beside the late run held by
        ``stream`` (:func:`~terrain.serving.clocks.went_on_live`; else the run came at
        once: a backlog or a re-send, no clock)."""
        held = self.clocks[stream].late
        return any(went_on_live(held.last_t - held.t0_s,
                                self.buffers[s].last_t - held.others_newest_s[s])
                   for s in running)

    def _in_own_gap(self, stream: str) -> bool:
        """Whether the late run held by ``stream`` fills a hole of its buffer
        (:func:`~terrain.serving.clocks.in_a_gap`)."""
        held = self.clocks[stream].late
        return in_a_gap(self.buffers[stream].since(held.t0_s)[0], held.t0_s, held.last_t,
                        self.config.max_backlog_s,
                        [b.last_t for s, b in self.buffers.items() if s != stream],
                        self._step_s)

    def _running(self, stream: str) -> list[str]:
        """Streams that went on accepting samples on the old clock while ``stream``'s late
        run was held."""
        held = self.clocks[stream].late
        return [s for s, last in held.others_newest_s.items()
                if not self.clocks[s].late and self.buffers[s].last_t > last]

    def _stepped_back(self, stream: str, next_t: float) -> bool:
        """Whether the late run held by ``stream`` is its clock stepped back by less than
        ``clock_restart_s``: ``next_t`` (s, its first sample taken after the run)
        continues it, it spans at least ``stale_s`` (a shorter step is a lag the config
        tolerates), fills no hole of its buffer and another stream went on live beside
        it."""
        held = self.clocks[stream].late
        max_step = self._gap_step_s(stream)
        if not (held.last_t - held.t0_s >= self.config.stale_s and
                continues_run(next_t, held.last_t, max_step)) or self._in_own_gap(stream):
            return False
        return self._went_on_beside(stream, self._running(stream))

    def _restart(self) -> None:
        """Restart on new clocks: empty every buffer and the decision clock, then ingest
        the samples each stream sent on its new clock (the forward filter is kept)."""
        held = {s: c.late.arrays() for s, c in self.clocks.items() if len(c.late)}
        for s, clock in self.clocks.items():
            # streams that sent nothing on the new clocks: their next sample may still be
            # on the old one
            clock.rejoining = bool(len(self.buffers[s])) and s not in held
            clock.late.clear()
        for s in self._holding_ahead():   # a run held ahead of the old clocks
            self._drop_ahead(s)
        for s, (t, _) in held.items():  # counted as refused when they came; used now
            self._uncount(s, TIME_RULE, len(t))
        self.buffers = {s: self._new_buffer(s) for s in self.streams}
        self.stuck = {s: StuckWatch(s, ch) for s, ch in self.streams.items()}
        self._decisions.reset()
        self.restarts += 1
        for s in self.streams:
            self.events[s].clear()
        for s, (t, v) in held.items():
            self.note(s, float(t[0]), "clock_restart")
            self.ingest(s, t, v, judged=True)

    def _restart_alone(self, stream: str, running: list[str]) -> float:
        """Put the held samples of ``stream`` on the clock of the ``running`` streams
        (:func:`~terrain.serving.clocks.restart_shift`): its buffer starts again, its
        offset changes by the shift, which is returned (s)."""
        clock = self.clocks[stream]
        held = clock.late
        t, v = held.arrays()
        held.clear()
        shift = restart_shift(held.t0_s, held.lead_s,
                              [held.others_newest_s[s] for s in running],
                              [self.buffers[s].median_step() for s in running],
                              self.config.gap_factor)
        self._uncount(stream, TIME_RULE, len(t))
        self.buffers[stream] = self._new_buffer(stream)
        self.stuck[stream] = StuckWatch(stream, self.streams[stream])
        self.events[stream].clear()
        self._move_clock(stream, t, shift)
        self.ingest(stream, t, v, judged=True)
        self._decisions.rewind(self.newest(), self.config.max_backlog_s)
        # the windows that hold the restart carry it: from the first held sample when the
        # decision clock starts again, else from the newest (those before are emitted)
        self.note(stream, float(t[0] if self._decisions.next_t is None else t[-1]),
                  "clock_restart")
        return float(shift)
