"""Clock rules of the streaming service: on which clock a stream's samples are.

Each stream arrives on its own clock, and clocks misbehave: a driver restarts, a log loops,
one computer's clock steps forward, a publisher re-sends its buffer, a clock runs in ms. The
rules below tell these apart from the arrival order and the stamps alone. They are pure
functions over the times the service gives them, plus the records of what the service knows
of one stream's clock (:class:`StreamClock`: its offset, the samples it holds while their
clock is told, :class:`HeldRun` and :class:`HeldChunks`, and the units rule's stamps); the
service's intake (:class:`terrain.serving.intake.StreamIntake`) keeps the buffers and applies
the verdicts (which samples it refuses, holds, moves or takes).

**Restarts.** A stream whose samples keep arriving earlier than its newest accepted one (a
looped log, a restarted driver or simulator) would have every later sample refused as
``time_not_increasing``, and the service would decide nothing again. Such samples are held
(the newest ``buffer_samples``, a :class:`HeldRun`); once they run as a clock over
``clock_restart_s`` (increasing, no step longer than ``gap_factor`` of the stream's usual
step, :func:`continues_run`) the clock has restarted: every buffer and the decision clock
start again and the held samples of every stream are ingested
(:attr:`~terrain.serving.service.StreamService.clock_restarts` counts it, the windows that
cover the restart carry ``clock_restart``). A single late sample is still refused, and so
is a late run inside one hole of its stream's buffer no longer than ``max_backlog_s``
(:func:`in_a_gap`: the backlog of a dropout sent after the live samples by a
store-and-forward link: on the stream's own clock, it cannot be put back in order, and it
is no new clock), when the sample after the hole is on another stream's clock or followed
by more. A clock stepped back by less than ``clock_restart_s`` never ran that long
before its samples passed the stream's old newest and were taken, the stream left behind the
others by the step for good: a held run that the stream's next accepted sample continues,
spanning ``stale_s`` (a shorter step is a lag the config tolerates) beside another stream
that went on live, is a restart of that stream alone as well.

**A restart of one stream alone.** Streams on one clock restart together. When one stream
restarts alone (a restarted IMU driver whose device clock starts again while the wheel
stream goes on), the others are the time reference (:func:`restart_shift`): the restarted
stream's first held sample is placed half a step after the newest sample the streams still
running had when it arrived (arrival order is the only link between two clocks, so the
offset is good to half their step), unless its new clock already agrees with theirs within
a gap (then it is not moved: a stamp far ahead followed by samples on the true clock); that
stream's buffer starts again, its offset is kept for its later samples and reported in
:attr:`~terrain.serving.service.StreamService.clock_offsets_s`, and the decision clock goes
on (it starts again only when it ran ahead of every stream). A run sent faster than the
others went on meanwhile (none :func:`went_on_live`: they advanced by less than half its
span; a reconnecting publisher re-sending more than the buffer holds) is no live clock: it
stays refused and moves nothing (such a re-send moved the stream by its length for good).

**A forward step of one clock.** A stream whose clock steps forward alone (an NTP step on
the computer of one sensor) puts its samples ahead of every other stream, which never catch
up: every later decision was short and stale. A sample more than ``clock_restart_s`` (and
``stale_s``: a lag the config tolerates is never a clock) after its stream's newest and
ahead of every other stream's newest by as much, those streams not having been behind it
just before (a dead or lagging stream is no clock to judge by; :func:`steps_ahead`), is held
(a step inside a pushed chunk too; bounded, counted as ``buffer_overflow`` beyond
``buffer_samples``). The held run (:func:`resolve_hold`) is taken as it is once another
stream catches up with it, to within ``stale_s`` (the others lagged, or every stream was
silent, a paused robot),
put on the others' clock once it has run as a clock for ``clock_restart_s`` while they went
on (:func:`ahead_shift`: one usual step after the stream's last sample before the step, kept
inside the step of the others in which it arrived, a chunk arriving with its newest sample;
offset, counter and ``clock_restart`` as for a restart alone), and taken as it is after
``max_backlog_s`` with the others silent. A sample before the newest held one by no more
than ``clock_restart_s`` and ``stale_s`` but itself ahead of every other stream is late on
the held clock (a link that reorders): it is refused as ``time_not_increasing``, as on a
clock taken (it broke the run, refused as a stray: a reordered wheel stream on another
clock from its start lost 574 of 580 samples). A sample that breaks the held run otherwise
(the stream going on on its old clock: the held ones were a stray stamp ahead) drops it,
counted and flagged as ``time_ahead``. One stream alone, or a chunk holding more than
``max_backlog_s`` after the step, is taken as it is (the service skips silent decisions). A
stream's first sample more than ``max_backlog_s`` from every other stream's newest, ahead or behind
(two computers whose clocks were never synchronised; a stream delivered late is never that
late; for a stream silent through a restart of every other clock, more than
``clock_restart_s`` and ``stale_s``: its old clock is no longer theirs), is held the same
way and put on the clock of the streams that came first (the middle of the step in which
it arrived); a run sent faster than the others go on (a
backlog: they advanced by less than half its span) is never moved.

**A clock in ms.** A stream whose clock is in ms (or us, ns; the readers' rule
``timestamp_units``, :func:`clock_in_ms` on the median of its newest finite
:data:`UNITS_STEPS` steps, judged only when a step may say so) has what it gave on that clock purged
(:func:`newest_on_ms_clock`; the samples before a switch stay) and every sample refused as
``timestamp_units`` (counted, flagged from the service's newest time on) until its steps
are in s again: an IMU in ms beside wheels in s made every 0.5 "s" of its clock a decision.
A step over ten periods of the stream's slowest nominal rate (a switch to ms, or a
dropout; :func:`first_long_step`) that no hold ahead takes (no other stream in step to
judge it by: one stream, every stream switching, the others lagging) opens a hold
(bounded): the chunks from it on are held until :data:`UNITS_STEPS` steps after it are
known, then purged or taken as they came, so the rule never judges across the switch and
no sample on a clock in ms reaches the decision clock (a stream switching to ms, or in ms
from its first sample, ran it to 1000 times its time first, and back again after the
purge); a dropout costs that many samples of delay. A sample back before the step ends
the hold: on the stream's old clock after a step longer than ``max_backlog_s`` (no
dropout's backlog is that late) the held samples were a stray stamp ahead, refused as
``time_ahead``; otherwise they are taken as they came.

**Re-sent samples.** A late sample that repeats one the stream already gave (the same stamp
and values: a reconnecting publisher re-sending its buffer) is counted as ``duplicate`` and
dropped without a flag, never held for a restart, unless it is the stream's oldest buffered
sample or continues a held run (a log played again from its start is a loop;
:func:`resent_mask`). A sample that repeats one of a run held ahead is counted the same way
and the run goes on (:meth:`HeldRun.repeats`; before, such a re-send broke the run, which
was refused as a stray stamp ahead).
"""

from __future__ import annotations

import math
from collections import deque
from typing import Iterable, Mapping, Sequence

import numpy as np

from terrain.io.plausibility import NOMINAL_RATE_HZ, implied_rate_hz, timestamp_unit
from terrain.serving.inputs import same_values

#: reason of the rule whose refusals may announce a clock restart
#: (:func:`terrain.serving.rules.time_increasing`)
TIME_RULE = "time_not_increasing"
#: reason of a sample sent again: the stamp (within :data:`DUPLICATE_TOL_S`) and values
#: (to float32 precision) of a sample the stream already gave (a reconnecting publisher
#: re-sending its buffer); refused without a flag, the decisions already had it
DUPLICATE = "duplicate"
#: reason of samples of one stream stamped far ahead of every other stream's clock that
#: then did not run on as a clock (a stray stamp ahead; module docstring)
AHEAD = "time_ahead"
#: reason of the samples of a stream whose clock is in ms, us or ns (the readers' rule
#: ``timestamp_units``, :func:`terrain.io.plausibility.timestamp_unit`)
UNITS = "timestamp_units"
#: time steps the ``timestamp_units`` rule judges a live stream on (its newest ones)
UNITS_STEPS = 8
#: stamps this close are one stamp when telling a re-sent sample, s (1 us: far below the
#: 0.5 ms period of a 2 kHz IMU, above the rounding of a stamp sent as float32 seconds of
#: a clock from 0 over a few s only; stamps are mostly re-sent exactly)
DUPLICATE_TOL_S = 1e-6


class HeldRun:
    """Samples of one stream held while their clock is told, and where the run began.

    Bounded: beyond ``capacity`` samples the oldest are dropped (the run's start time
    stays; :attr:`n_dropped` and :attr:`dropped_last_s` say what was lost).

    Parameters
    ----------
    capacity : int
        Samples kept (> 0; the service's ``buffer_samples``).

    Attributes
    ----------
    t0_s : float
        Stamp of the run's first sample, s (NaN before a run begins).
    lead_s : float
        How far the newest sample of the chunk the run began in is past ``t0_s``, s (the
        chunk arrived with its newest sample).
    others_newest_s : dict of str to float
        Newest buffered time of every other stream when the run began, s (the reference
        of a move onto their clock).
    n_dropped : int
        Samples dropped by the bound since the run began (its oldest ones: stamps from
        ``t0_s`` to :attr:`dropped_last_s`).
    dropped_last_s : float
        Stamp of the newest sample dropped, s (NaN when none was).
    """

    __slots__ = ("_samples", "t0_s", "lead_s", "others_newest_s", "n_dropped",
                 "dropped_last_s")

    def __init__(self, capacity: int) -> None:
        self._samples: deque = deque(maxlen=int(capacity))
        self.t0_s = float("nan")
        self.lead_s = 0.0
        self.others_newest_s: dict[str, float] = {}
        self.n_dropped = 0
        self.dropped_last_s = float("nan")

    def __len__(self) -> int:
        return len(self._samples)

    @property
    def full(self) -> bool:
        """Whether the next sample drops the oldest one."""
        return len(self._samples) == self._samples.maxlen

    @property
    def last_t(self) -> float:
        """Stamp of the newest held sample, s (``-inf`` when empty)."""
        return self._samples[-1][0] if self._samples else -np.inf

    def begin(self, t0_s: float, lead_s: float, others_newest_s: Mapping[str, float]
              ) -> None:
        """Drop what is held and start a run.

        Parameters
        ----------
        t0_s : float
            Stamp of the run's first sample, s.
        lead_s : float
            How far the newest sample of its chunk is past ``t0_s``, s.
        others_newest_s : Mapping[str, float]
            Newest buffered time of every other stream now, s (copied).
        """
        self.clear()
        self.t0_s, self.lead_s = float(t0_s), float(lead_s)
        self.others_newest_s = dict(others_newest_s)

    def append(self, t_s: float, values: np.ndarray) -> None:
        """Hold one sample (the oldest is dropped when :attr:`full`, and counted in
        :attr:`n_dropped`).

        Parameters
        ----------
        t_s : float
            Its stamp, s.
        values : numpy.ndarray
            ``(n_channels,)`` its values, copied (a robot may reuse the array it pushed).
        """
        if self.full:
            self.n_dropped += 1
            self.dropped_last_s = self._samples[0][0]
        self._samples.append((float(t_s), np.array(values, dtype=float)))

    def repeats(self, t_s: float, values: np.ndarray) -> bool:
        """Whether a sample repeats a held one: its stamp within :data:`DUPLICATE_TOL_S`
        and the same values (:func:`~terrain.serving.inputs.same_values`; a publisher
        re-sending its buffer while the run is held).

        Parameters
        ----------
        t_s : float
            The sample's stamp, s.
        values : numpy.ndarray
            ``(n_channels,)`` its values.

        Returns
        -------
        bool
        """
        for held_t, held_v in reversed(self._samples):   # increasing: newest first
            if held_t < t_s - DUPLICATE_TOL_S:
                return False
            if held_t <= t_s + DUPLICATE_TOL_S and same_values(held_v, values):
                return True
        return False

    def extend_clock(self, t_s: np.ndarray, values: np.ndarray, max_step_s: float,
                     others_newest_s: Mapping[str, float]) -> None:
        """Hold samples that run as a clock: a sample that does not continue the run
        (:func:`continues_run`) begins a new one.

        Parameters
        ----------
        t_s : numpy.ndarray
            ``(n,)`` stamps, s.
        values : numpy.ndarray
            ``(n, n_channels)`` values.
        max_step_s : float
            Longest step of a run, s (``gap_factor`` times the stream's usual step).
        others_newest_s : Mapping[str, float]
            Newest buffered time of every other stream, s, recorded when a run begins.
        """
        for ti, vi in zip(t_s, values):
            if self._samples and not continues_run(ti, self.last_t, max_step_s):
                self._samples.clear()
            if not self._samples:   # the chunk arrived with its newest sample
                self.begin(ti, t_s[-1] - ti, others_newest_s)
            self.append(ti, vi)

    def clear(self) -> None:
        """Drop every held sample (and forget those the bound dropped)."""
        self._samples.clear()
        self.n_dropped = 0
        self.dropped_last_s = float("nan")

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """The held samples as arrays.

        Returns
        -------
        t_s : numpy.ndarray
            ``(n,)`` stamps, s (a new array).
        values : numpy.ndarray
            ``(n, n_channels)`` values (``(0, 0)`` when none is held).
        """
        if not self._samples:
            return np.empty(0), np.empty((0, 0))
        return (np.array([ti for ti, _ in self._samples], dtype=float),
                np.array([vi for _, vi in self._samples]).reshape(len(self._samples), -1))


class HeldChunks:
    """Chunks of one stream held whole, as they came, until the ``timestamp_units`` rule
    can judge the long step they start at (module docstring, "A clock in ms").

    Attributes
    ----------
    t0_s : float
        Stamp of the long step's sample, s (``-inf`` when the first chunk has no finite
        stamp).
    n_samples, n_finite : int
        Held samples, and those with a finite stamp.
    """

    __slots__ = ("_chunks", "t0_s", "n_samples", "n_finite")

    def __init__(self) -> None:
        self._chunks: list[tuple[np.ndarray, np.ndarray]] = []
        self.t0_s = -np.inf
        self.n_samples = self.n_finite = 0

    def __len__(self) -> int:
        return self.n_samples

    def append(self, t_s: np.ndarray, values: np.ndarray) -> None:
        """Hold one chunk (copied: a robot may reuse the arrays it pushed); the first one
        sets :attr:`t0_s`.

        Parameters
        ----------
        t_s : numpy.ndarray
            ``(n,)`` stamps of the chunk as pushed (NaN ones included), s.
        values : numpy.ndarray
            ``(n, n_channels)`` its values.
        """
        finite = np.isfinite(t_s)
        if not self._chunks:
            self.t0_s = float(t_s[finite][0]) if finite.any() else -np.inf
        self._chunks.append((t_s.copy(), values.copy()))
        self.n_samples += len(t_s)
        self.n_finite += int(finite.sum())

    def take(self) -> list[tuple[np.ndarray, np.ndarray]]:
        """The held chunks in the order they came; the hold is empty after.

        Returns
        -------
        list of (numpy.ndarray, numpy.ndarray)
            ``(n,)`` stamps (s) and ``(n, n_channels)`` values of each chunk.
        """
        chunks = self._chunks
        self.clear()
        return chunks

    def clear(self) -> None:
        """Drop every held chunk."""
        self._chunks = []
        self.n_samples = self.n_finite = 0


class StreamClock:
    """What the service knows of one stream's clock: its offset, the samples it holds while
    the clock is told, and the ``timestamp_units`` rule's state (module docstring).

    Parameters
    ----------
    capacity : int
        Samples a held run keeps (> 0; the service's ``buffer_samples``).
    rate_kind : str or None
        Key of :data:`terrain.io.plausibility.NOMINAL_RATE_HZ` whose channels the stream
        carries (``"imu"``, ``"wheels"``); None: no nominal rate, no ``timestamp_units``
        rule.
    offset_s : float, default 0.0
        Offset added to the stream's stamps, s (the configured one).

    Attributes
    ----------
    offset_s : float
        Offset added to the stream's stamps, s: the configured one plus the shift of every
        restart of this clock alone.
    ms_step_s : float or None
        Longest step of a clock in s, s: ten periods of the slowest nominal rate of
        ``rate_kind`` (1 s for an IMU; a step that long may be a switch to ms); None
        without ``rate_kind``.
    late : HeldRun
        Samples refused as earlier than the stream's newest, held as a possible restarted
        clock.
    ahead : HeldRun or None
        The run held since the clock stepped ahead of every other stream's; None when none
        is held.
    ahead_rank : int
        Order in which the run held ahead began among the streams' (they are resolved in
        that order).
    unjudged : HeldChunks
        Chunks from a step long enough to be a switch to ms, held until the steps after it
        are enough to judge.
    on_ms_clock : bool
        Whether the stream was found on a clock in ms (its samples refused until its
        steps are in s again).
    rejoining : bool
        Whether the stream was silent through a restart of every other clock and has sent
        nothing since (its next sample may still be on the old clock).
    """

    __slots__ = ("offset_s", "rate_kind", "ms_step_s", "late", "ahead", "ahead_rank",
                 "unjudged", "on_ms_clock", "rejoining", "_recent_t")

    def __init__(self, capacity: int, rate_kind: str | None, offset_s: float = 0.0) -> None:
        self.offset_s = float(offset_s)
        self.rate_kind = rate_kind
        self.ms_step_s = None if rate_kind is None else 10.0 / NOMINAL_RATE_HZ[rate_kind][0]
        self.late = HeldRun(capacity)
        self.ahead: HeldRun | None = None
        self.ahead_rank = 0
        self.unjudged = HeldChunks()
        self.on_ms_clock = False
        self.rejoining = False
        self._recent_t: deque = deque(maxlen=UNITS_STEPS + 1)

    @property
    def newest_stamp_s(self) -> float | None:
        """The newest arrival stamp the ``timestamp_units`` rule remembers, s (None before
        any)."""
        return self._recent_t[-1] if self._recent_t else None

    def remember(self, t_s: np.ndarray) -> None:
        """Remember a chunk's newest finite stamps for the ``timestamp_units`` rule (a NaN
        stamp leaves too few steps to judge; one float for the usual one-sample push).

        Parameters
        ----------
        t_s : numpy.ndarray
            ``(n,)`` stamps of the chunk as it arrived, s.
        """
        recent = self._recent_t
        if len(t_s) == 1:
            if math.isfinite(t_s[0]):
                recent.append(float(t_s[0]))
        else:
            recent.extend(t_s[np.isfinite(t_s)][-recent.maxlen:].tolist())

    def restamp(self, t_s: np.ndarray) -> None:
        """The remembered stamps become ``t_s`` (held samples moved onto another clock with
        a new offset): later samples come with that offset, and a step from the stamps
        before the move would look like a clock in ms.

        Parameters
        ----------
        t_s : numpy.ndarray
            ``(n,)`` the moved stamps, s.
        """
        self._recent_t.clear()
        self.remember(t_s)

    def judge_ms(self) -> tuple[bool, bool]:
        """The ``timestamp_units`` rule on the remembered stamps (:func:`clock_in_ms`),
        updating :attr:`on_ms_clock`.

        Returns
        -------
        in_ms : bool
            Whether the clock is in ms now (as before when too little to judge).
        switched : bool
            Whether this judgement found it in ms, and it was not before.
        """
        if self.rate_kind is None:
            return False, False
        in_ms = clock_in_ms(np.array(self._recent_t), self.rate_kind)
        if in_ms is None:
            return self.on_ms_clock, False
        switched = in_ms and not self.on_ms_clock
        self.on_ms_clock = in_ms
        return in_ms, switched

    def held(self) -> dict[str, int]:
        """Samples held and counted nowhere yet, by reason: :data:`AHEAD` (a run ahead of
        every other clock) and :data:`UNITS` (awaiting the units rule).

        Returns
        -------
        dict of str to int
            Only the reasons with held samples.
        """
        out = {}
        if self.ahead is not None:
            out[AHEAD] = len(self.ahead)
        if self.unjudged:
            out[UNITS] = len(self.unjudged)
        return out


def continues_run(t_s: float, last_t_s: float, max_step_s: float) -> bool:
    """Whether a sample continues a run as a clock would.

    Parameters
    ----------
    t_s : float
        The sample's stamp, s.
    last_t_s : float
        Stamp of the run's newest sample, s.
    max_step_s : float
        Longest step of the run, s (``gap_factor`` times the stream's usual step).

    Returns
    -------
    bool
        Later than ``last_t_s`` by at most ``max_step_s`` (a NaN step continues nothing).
    """
    return 0 < t_s - last_t_s <= max_step_s


def steps_ahead(t_s: float, prev_t_s: float, others_newest_s: Iterable[float],
                step_s: float, first_step_s: float) -> bool:
    """Whether a sample steps its stream's clock ahead of every other stream's (module
    docstring, "A forward step of one clock").

    Parameters
    ----------
    t_s : float
        The sample's stamp, s.
    prev_t_s : float
        The stream's newest sample taken, s (``-inf`` before its first).
    others_newest_s : iterable of float
        Newest buffered time of every other stream not itself held ahead, s.
    step_s : float
        Shortest step that is a clock's, s (``max(clock_restart_s, stale_s)``).
    first_step_s : float
        Shortest distance of a stream's first sample from every other stream that is
        another clock, s (``max(step_s, max_backlog_s)``; ``step_s`` for a stream silent
        through a restart of the others' clock).

    Returns
    -------
    bool
        More than ``step_s`` past ``prev_t_s`` and past every other stream, those not having
        been behind ``prev_t_s`` by more than ``step_s``; for the stream's first sample,
        more than ``first_step_s`` from every other stream, ahead or behind. False with no
        other stream.
    """
    others = list(others_newest_s)
    if not others or not t_s - prev_t_s > step_s:
        return False
    if prev_t_s > -np.inf:
        return min(t_s - o for o in others) > step_s and \
            max(prev_t_s - o for o in others) <= step_s
    return min(abs(t_s - o) for o in others) > first_step_s


def resolve_hold(t0_s: float, t1_s: float, newest_at_start_s: Mapping[str, float],
                 newest_now_s: Mapping[str, float], lag_s: float, clock_restart_s: float,
                 max_backlog_s: float) -> list[str] | None:
    """What becomes of a run held ahead of the other streams (module docstring, "A forward
    step of one clock").

    Parameters
    ----------
    t0_s, t1_s : float
        First and newest held stamp, s.
    newest_at_start_s, newest_now_s : Mapping[str, float]
        Newest buffered time of each other stream when the hold began and now, s (same
        keys).
    lag_s : float
        Delivery lag of two clocks that meet, s (``stale_s``: the lag the config
        tolerates; a clock's step of 5 to 10 s, the shortest step told, was taken for a
        lag once the others came within 5 s of it).
    clock_restart_s : float
        Run length that makes a clock, s.
    max_backlog_s : float
        Run length after which a hold with the others silent is taken as it is, s.

    Returns
    -------
    list of str or None
        None: keep holding. Empty: take the run as it is (another stream caught up with
        it, or it ran ``max_backlog_s`` with the others silent). Otherwise the streams that
        went on live meanwhile (by at least half the held span: a backlog sent at once runs
        faster), onto whose clock the run is put.
    """
    span = t1_s - t0_s
    if any(last >= t0_s - lag_s and t1_s >= last - lag_s for last in newest_now_s.values()):
        return []   # the clocks meet (one of them lagged)
    went_on = [s for s, at in newest_at_start_s.items()
               if went_on_live(span, newest_now_s[s] - at)]
    if went_on and span >= clock_restart_s:
        return went_on
    if span >= max_backlog_s:
        return []
    return None


def went_on_live(span_s: float, advance_s: float) -> bool:
    """Whether another stream went on live beside a held run: it advanced, by at least
    half the run's span while the run came. A run that every other stream fell that far
    behind came faster than live (a backlog or a re-send sent at once: a 60 s re-send sent
    in 6 s) and is no live clock (module docstring).

    Parameters
    ----------
    span_s : float
        Time the held run's stamps span, s.
    advance_s : float
        How far the other stream's newest sample advanced while the run came, s.

    Returns
    -------
    bool
    """
    return advance_s > 0 and advance_s >= 0.5 * span_s


def ahead_shift(t0_s: float, lead_s: float, running_newest_s: Sequence[float],
                running_steps_s: Sequence[float], last_t_s: float, step_s: float) -> float:
    """Shift that puts a run held ahead on the clock of the streams that went on, s.

    One usual step after the stream's last sample before its clock stepped, kept between
    the newest sample the running streams had when the run arrived and their next one
    (arrival order, as for :func:`restart_shift`); the middle of that step for the
    stream's first sample.

    Parameters
    ----------
    t0_s : float
        First held stamp, s.
    lead_s : float
        How far its chunk's newest sample was past it, s.
    running_newest_s, running_steps_s : sequence of float
        Newest time when the hold began and usual step (NaN if unknown) of each running
        stream, s.
    last_t_s : float
        The stream's newest buffered sample, s (``-inf`` when it has none).
    step_s : float
        The stream's usual step, s (NaN if unknown).

    Returns
    -------
    float
        Shift to add to the held stamps, s.
    """
    lower = max(running_newest_s) - lead_s
    upper = max(lower, min(at + np.nan_to_num(step) for at, step
                           in zip(running_newest_s, running_steps_s)) - lead_s)
    if last_t_s == -np.inf:   # its first sample: no step of its own, the middle
        return float(0.5 * (lower + upper) - t0_s)
    step = np.nan_to_num(step_s)
    first = max(min(max(last_t_s + step, lower), upper), last_t_s + 0.5 * step)
    return float(first - t0_s)


def restart_shift(t0_s: float, lead_s: float, running_newest_s: Sequence[float],
                  running_steps_s: Sequence[float], gap_factor: float) -> float:
    """Shift that puts the run of a stream whose clock restarted alone on the clock of the
    streams still running, s (module docstring, "A restart of one stream alone").

    The run's first sample arrived (with its chunk's newest, ``lead_s`` later) after the
    newest sample of the running streams and before their next one: it is put half a step
    after it, unbiased for a uniform phase; a shift within a gap of their clock is none.

    Parameters
    ----------
    t0_s, lead_s, running_newest_s, running_steps_s
        As for :func:`ahead_shift`: the run's first stamp, its chunk's lead past it, and
        the newest times when the run began and usual steps of the running streams, s.
    gap_factor : float
        A step longer than this many usual steps is a gap (the readers' rule).

    Returns
    -------
    float
        Shift to add to the held stamps, s (0.0 when within a gap).
    """
    steps = list(running_steps_s)
    reference = max(at + 0.5 * np.nan_to_num(step)
                    for at, step in zip(running_newest_s, steps)) - lead_s
    shift = reference - t0_s
    if abs(shift) <= gap_factor * float(np.nanmax(steps + [0.0])):
        return 0.0
    return float(shift)


def in_a_gap(buffered_t_s: np.ndarray, t_first_s: float, t_last_s: float,
             max_backlog_s: float, others_newest_s: Iterable[float], step_s: float) -> bool:
    """Whether a late run ``[t_first_s, t_last_s]`` falls inside one hole of its stream's
    buffer no longer than ``max_backlog_s``: the backlog of a dropout, refused, never a
    restart (module docstring, "Restarts").

    Parameters
    ----------
    buffered_t_s : numpy.ndarray
        ``(n,)`` buffered stamps of the stream from the last one before ``t_first_s`` on,
        s (the ring buffer's ``since(t_first_s)``).
    t_first_s, t_last_s : float
        First and newest stamp of the late run, s.
    max_backlog_s : float
        Longest hole a backlog fills, s.
    others_newest_s : iterable of float
        Newest buffered time of every other stream, s.
    step_s : float
        Shortest step that is a clock's, s.

    Returns
    -------
    bool
        Buffered samples before and after the run and none within, the hole no longer than
        ``max_backlog_s``, and the sample after it followed by more or on the clock of
        another stream (one stray stamp ahead makes no dropout).
    """
    ts = buffered_t_s
    if not (len(ts) >= 2 and ts[0] < t_first_s and ts[1] > t_last_s
            and ts[1] - ts[0] <= max_backlog_s):
        return False
    return len(ts) >= 3 or any(last >= ts[1] - step_s for last in others_newest_s)


def resent_mask(t_s: np.ndarray, values: np.ndarray, buffered_t_s: np.ndarray,
                buffered_values: np.ndarray, oldest_t_s: float, newest_t_s: float,
                last_held_t_s: float | None, max_step_s: float) -> np.ndarray:
    """Which samples of a chunk the stream already gave and start no new clock (module
    docstring, "Re-sent samples").

    Parameters
    ----------
    t_s : numpy.ndarray
        ``(n,)`` stamps of the chunk, s.
    values : numpy.ndarray
        ``(n, n_channels)`` values of the chunk.
    buffered_t_s, buffered_values : numpy.ndarray
        ``(m,)`` stamps (s) and ``(m, n_channels)`` values of the stream's buffer from
        :data:`DUPLICATE_TOL_S` before the chunk's earliest finite stamp on.
    oldest_t_s, newest_t_s : float
        The buffer's oldest (``inf`` when empty) and newest (``-inf`` when empty) stamp, s.
    last_held_t_s : float or None
        Newest stamp of the stream's held late run, s (None when none is held).
    max_step_s : float
        Longest step of a run, s.

    Returns
    -------
    numpy.ndarray
        ``(n,)`` bool: a sample at or before the stream's newest with the stamp (within
        :data:`DUPLICATE_TOL_S`) and values of a buffered sample or of an earlier one of the
        chunk, unless that is the buffer's oldest sample (or, with an empty buffer, the
        chunk's first: a loop starts) or the sample continues a held run.
    """
    out = np.zeros(len(t_s), dtype=bool)
    empty = newest_t_s == -np.inf
    newest, last_held = newest_t_s, last_held_t_s
    for i, ti in enumerate(t_s):
        if not ti <= newest:               # increasing (or not finite): the rules judge
            newest = ti if ti > newest else newest
            continue
        if last_held is not None and continues_run(ti, last_held, max_step_s):
            last_held = ti                 # continues a held run (a loop or a restart)
            continue
        same = range(int(np.searchsorted(buffered_t_s, ti - DUPLICATE_TOL_S)),
                     int(np.searchsorted(buffered_t_s, ti + DUPLICATE_TOL_S, side="right")))
        earlier = np.flatnonzero(np.abs(t_s[:i] - ti) <= DUPLICATE_TOL_S)
        in_buffer = [k for k in same if same_values(buffered_values[k], values[i])]
        in_chunk = [k for k in earlier if same_values(values[k], values[i])]
        # the stream's oldest sample again: a loop starts (not a re-send)
        loop = (bool(in_buffer) and buffered_t_s[in_buffer[0]] == oldest_t_s) or \
            (empty and bool(in_chunk) and in_chunk[0] == 0)
        if (in_buffer or in_chunk) and not loop:
            out[i] = True
        else:
            last_held = ti                 # late and held: a possible new clock
    return out


def first_long_step(t_s: np.ndarray, prev_t_s: float | None, max_step_s: float) -> int:
    """Where in a chunk a stream's clock first steps by more than ``max_step_s``.

    Parameters
    ----------
    t_s : numpy.ndarray
        ``(n,)`` stamps of the chunk, s (NaN ones are skipped: a step runs from the finite
        stamp before).
    prev_t_s : float or None
        The stream's newest stamp before the chunk, s (None: its first chunk, whose first
        sample has no step).
    max_step_s : float
        Longest ordinary step, s.

    Returns
    -------
    int
        Index of the first sample more than ``max_step_s`` after the finite stamp before
        it; 0 when none is.
    """
    finite = np.flatnonzero(np.isfinite(t_s))
    stamps = t_s[finite]
    before = np.concatenate([[np.nan if prev_t_s is None else prev_t_s], stamps[:-1]])
    long = np.flatnonzero(stamps - before > max_step_s)
    return int(finite[long[0]]) if len(long) else 0


def clock_in_ms(stamps_s: np.ndarray, rate_kind: str) -> bool | None:
    """The readers' rule ``timestamp_units`` on a live stream's newest stamps.

    Parameters
    ----------
    stamps_s : numpy.ndarray
        ``(n,)`` newest finite arrival stamps of the stream, "s".
    rate_kind : str
        Key of :data:`terrain.io.plausibility.NOMINAL_RATE_HZ` (``"imu"``, ``"wheels"``).

    Returns
    -------
    bool or None
        Whether the median step says the clock is in ms, us or ns
        (:func:`terrain.io.plausibility.timestamp_unit`, the readers' rule itself: a wheel
        clock in us ran 5561 decisions and skipped 176 million over 88 s of a wheel-only
        replay, taken as s); None with fewer than :data:`UNITS_STEPS` steps or a median
        step that is not positive (too little to judge).
    """
    steps = np.diff(stamps_s)
    if len(steps) < UNITS_STEPS or not np.median(steps) > 0:
        return None
    return timestamp_unit(implied_rate_hz(stamps_s), rate_kind) is not None


def newest_on_ms_clock(times_s: np.ndarray, ms_step_s: float) -> int:
    """How many of a stream's newest buffered samples are on its clock in ms: the newest
    ones each a step over ``ms_step_s`` (s, ten nominal periods of its slowest rate) after
    the one before; all of them when no step is on a clock in s.

    Parameters
    ----------
    times_s : numpy.ndarray
        ``(n,)`` buffered stamps, oldest first, "s".
    ms_step_s : float
        Longest step of a clock in s, s.

    Returns
    -------
    int
        Samples to drop from the newest end (0 to n).
    """
    slow = np.diff(times_s) > ms_step_s
    if not (~slow).any():   # no step on a clock in s at all: nothing is known good
        return len(times_s)
    return len(slow) - int(np.flatnonzero(~slow)[-1]) - 1
