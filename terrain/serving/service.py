"""In-process streaming terrain service: samples in, smoothed terrain + slip targets out.

Samples of each stream arrive one by one or in chunks, each stream at its own rate and on
its own clock (an optional per-stream offset maps it onto the service clock). Each stream
keeps a bounded :class:`~terrain.serving.buffers.RingBuffer`, so memory is fixed for an
unbounded stream. A chunk longer than half the buffer, or than the room its buffer has
beside the samples a coming decision may read, is taken in pieces, deciding after each; a
sample pushed out of its buffer before any decision could read it (a backlog of one
stream while another lags) is counted as ``buffer_overflow`` in
:attr:`StreamService.refused_samples` and flags the windows that would have read it (the
first window, when it was lost before any decision was placed), as is a sample dropped from
a full run held ahead of the other streams' clock (flagged once the run is taken, on the
clock it is put on). Every ``hop_s`` of service time the service

1. takes the samples of every needed stream around ``[t - window_s, t)``,
2. aligns the last window of the model's length with the project's NumPy alignment core
   (:func:`terrain.io.align.anchored_grid_tail`, the window's end of a grid through the
   newest sample of the fastest stream at the grid's rate, or the decision clock, and
   :func:`terrain.io.align.align_arrays`, the step the batch readers'
   :func:`~terrain.io.align.align_streams` runs) and adds the
   derived wheel channels (:func:`features.windows.derived_wheel_arrays`, with the
   model's track width, :func:`terrain.serving.model.model_track_m`); the whole
   per-decision path works on arrays, no data frame,
3. classifies it with the fitted pipeline (the model's own feature code),
4. folds the probabilities into the forward filter (:mod:`terrain.serving.smoothing`),
5. asks the injected :class:`~terrain.serving.targets.TargetProvider` for the slip
   targets, passing ``terrain=None`` (the conservative fallback) below ``min_confidence``.

A decision is due at service time ``t`` once every needed stream has reached ``t``, or once
some stream had gone ``stale_s`` past ``t`` when its newest push came while another lags
(the decision is then flagged ``stale`` when the lagging stream's newest sample is over
``stale_s`` before ``t``, and rests on the data that did arrive; its ``window_age_s`` says
how old). The samples of a chunk arrive together, so the other streams' samples of its span
may still be on their way: a stream's staleness is judged from the first sample of its
newest push, not its last, and a chunk longer than ``stale_s`` makes no decision early
(one by one, as before; a stream silent for good is judged stale one chunk later). A later
push whose samples were all refused (values, stamps) still shows the stream went on: its
kept samples count as arrived one by one.

A sample that arrives after every stream has been silent for long (a paused robot, a
clock jump) makes every hop of the silent stretch due at once. Decisions due more than
``max_backlog_s`` before the newest sample whose window holds no sample of any stream are
skipped rather than emitted (the forward filter still takes their prediction steps, in
closed form, :meth:`~terrain.serving.smoothing.ForwardFilter.skip`); they are counted in
:attr:`StreamService.skipped_decisions`. Without that, one sample a day late would cost
172,800 decisions at a 0.5 s hop before the next one.

The streams' clocks are judged by the rules of :mod:`terrain.serving.clocks`: a clock that
restarts (all streams together, or one alone: its offset is reported in
:attr:`StreamService.clock_offsets_s`), a forward step of one stream's clock, a stream's
first sample on another clock, a clock in ms (refused as ``timestamp_units``) and samples
sent again (refused as ``duplicate``). What the service keeps of each stream (its buffer,
rejection events, stuck watch and :class:`~terrain.serving.clocks.StreamClock`: offset and
the samples the rules hold, bounded) is its :class:`~terrain.serving.intake.StreamIntake`,
which applies the rules' verdicts; this module decides on what the intake keeps.

``flags`` (``|``-separated, empty when clean): ``stale``, ``gap`` (the window holds a
timestamp gap, so it was not classified), ``short`` (not enough aligned history),
``non_finite`` / ``time_not_increasing`` / ``implausible_rate`` / ``implausible_value`` /
``implausible_time`` (samples rejected by the rules of :mod:`terrain.serving.rules` inside
the window), ``time_ahead`` (a stray stamp ahead of the other streams refused),
``timestamp_units`` (a stream on a clock in ms refused),
``accel_units`` (the window's median specific force says the accelerometer is in g, the
readers' rule :func:`terrain.io.plausibility.check_accel_units`: not
classified), ``wheel_speed_units`` (the 99th percentile of the window's wheel speeds is
over twice the top speed of the model's vehicle, so they are in km/h: the readers' rule
:func:`terrain.io.plausibility.wheel_speed_in_kmh` on one window; not classified; only for
a model whose metadata names a vehicle of :data:`terrain.io.plausibility.VEHICLE_LIMITS`,
directly or through its shipped dataset (:func:`terrain.serving.model.model_vehicle`), and
that uses the wheel speeds), ``non_finite_proba`` (the model's probabilities for the window
hold a NaN or inf: no evidence, the filter takes a prediction-only step; no terrain before
the first window taken as evidence, with the filter as without), ``clock_restart``,
``low_confidence`` (fallback target).
"""

from __future__ import annotations

import copy
import math
from typing import Mapping, Sequence

import numpy as np

from features.calculators import quantile_sorted
from features.windows import DERIVED_WHEEL_CHANNELS, derived_wheel_arrays
from terrain.errors import ConfigError
from terrain.io.align import align_arrays, anchored_grid_tail, gap_steps
from terrain.io.plausibility import (VEHICLE_LIMITS, accel_in_g, stuck_flag,
                                     wheel_speed_in_kmh)
from terrain.run import WHEEL_CHANNELS, clock_slack
from terrain.serving.config import StreamConfig, check_hop
from terrain.serving.decisions import Decision
from terrain.serving.inputs import check_same_index, chunk_values, real_array
from terrain.serving.intake import DecisionClock, StreamIntake
from terrain.serving.model import (StreamModel, model_channel_steps_s, model_track_m,
                                   model_vehicle)
from terrain.serving.rules import DEFAULT_RULES, SampleRule, time_increasing
from terrain.serving.smoothing import ForwardFilter
from terrain.serving.targets import TargetProvider, check_provider

# StreamConfig is the service's settings (terrain.serving.config), imported from here too
__all__ = ["StreamService", "StreamConfig", "UNCLASSIFIED_FLAGS"]

#: Flags of a window the service does not classify (the filter takes a prediction-only
#: step there; see the module docstring).
UNCLASSIFIED_FLAGS: frozenset[str] = frozenset({"gap", "short", "accel_units",
                                                "wheel_speed_units", "non_finite_proba"})


def _same_time_s(t_s: float) -> float:
    """How close a stamp is to ``t_s`` (s) when the two are one time, s: 1 ns (far below
    any clock period), or 8 units of the float64 resolution at ``t_s`` when coarser (an
    epoch clock, 1.7e9 s, resolves 2.4e-7 s: a grid point at a decision's time, rounded 1
    ulp below it, was read as before it, and the window ``[t - window_s, t)`` read the
    sample at ``t``, one grid point late; 1.2e-4 s at
    :data:`~terrain.serving.rules.MAX_PLAUSIBLE_TIME_S`, below half the period of a 2 kHz
    IMU)."""
    return max(1e-9, 8.0 * math.ulp(t_s))


#: How much longer than the grid's step a stream's usual step may be for the window's grid
#: to stay on its samples (:func:`_grid_anchor`): a clock's drift (1e-4 for a 100.01 Hz
#: IMU) and its stamps' jitter in the median step, far below a slower stream's (a 40 Hz
#: stream on a 50 Hz grid is 25 % slower).
GRID_STREAM_SLACK = 0.01


def _grid_anchor(times: list[np.ndarray], steps: list[float], t: float, rate_hz: float,
                 slack: float) -> float:
    """The last point of the grid of the window decided at ``t``, s.

    The batch windows lie on a run's grid at ``rate_hz`` (:func:`terrain.io.align.
    overlap_grid`) and a window ending at ``t`` has its last point at ``t - 1 / rate_hz``.
    Where a stream is sampled at the grid's rate or faster (the IMU; its usual step within
    :data:`GRID_STREAM_SLACK` of the grid's step or shorter), the last point is its newest
    sample at or before ``t - 1 / rate_hz`` (within ``slack``, the clock's rounding:
    :func:`terrain.run.clock_slack`), so the grid stays on that stream's samples
    wherever its clock drifts or a new piece of stream starts; among several such
    streams, the fastest (the first listed at equal steps). Where none is (wheel-only
    models), the last point is ``t - 1 / rate_hz`` itself, on the decision clock, which
    is the batch grid's for a stream on the model's clock from its first sample.
    Measured against one grid per stream: docs/streaming.md, "One grid per stream".

    Parameters
    ----------
    times : list of numpy.ndarray
        ``(m_i,)`` increasing stamps of each stream read for the window, s.
    steps : list of float
        Each stream's usual step, s.
    t : float
        Decision time, s.
    rate_hz : float
        Grid rate, Hz.
    slack : float
        Rounding slack of a stamp compared with a time, s.

    Returns
    -------
    float
        The anchor, s (``t - 1 / rate_hz`` when the fastest stream has no sample at or
        before it less than one grid step back).
    """
    end = t - 1.0 / rate_hz
    fast = [i for i, step in enumerate(steps) if step <= (1.0 + GRID_STREAM_SLACK) / rate_hz]
    if not fast:
        return end
    ts = times[min(fast, key=lambda i: steps[i])]
    k = int(np.searchsorted(ts, end + slack, side="right")) - 1
    # a sample less than one grid step back; none there (the stream lags or holds a gap at
    # the window's end): the decision clock, so the window still ends where it should and
    # the gap or staleness is seen, not stepped around
    return float(ts[k]) if k >= 0 and end - ts[k] < 1.0 / rate_hz else end


def _median_norm(sq: np.ndarray) -> float:
    """``numpy.median`` of the norms whose squares are ``sq`` (``(n,)``, n >= 1), by
    partition: the middle norm, or the mean of the two middle ones for an even ``n``, as the
    readers' rule takes the median (:func:`terrain.io.plausibility.check_accel_units`); the
    upper middle one alone read a window half at 2.0 and half at 3.9 m/s^2 (median 2.95, in
    g) as 3.9."""
    k = len(sq) // 2
    if len(sq) % 2:
        return math.sqrt(float(np.partition(sq, k)[k]))
    mid = np.partition(sq, (k - 1, k))
    return 0.5 * (math.sqrt(float(mid[k - 1])) + math.sqrt(float(mid[k])))


class StreamService:
    """Streaming terrain classifier with bounded memory (see module docstring).

    Parameters
    ----------
    model : StreamModel
        Fitted classifier and its window settings.
    targets : TargetProvider
        Desired-slip lookup.
    config : StreamConfig
    rules : sequence of SampleRule
        Per-sample plausibility rules (default: the readers' rules);
        :func:`~terrain.serving.rules.time_increasing` is added last when missing (the
        buffers keep samples in increasing time).

    Raises
    ------
    ConfigError
        ``model``, ``config``, ``targets`` or ``rules`` of the wrong kind (e.g. ``None``),
        a channel the model needs is in none of the configured streams, the hop is
        shorter than one period of the model's clock (:func:`check_hop`), or
        ``buffer_samples`` cannot hold one window of the model (plus 2 samples), or a
        provider whose own threshold is above ``config.min_confidence`` or which lacks a
        class of the model (:func:`~terrain.serving.targets.check_provider`).
    """

    def __init__(self, model: StreamModel, targets: TargetProvider,
                 config: StreamConfig = StreamConfig(),
                 rules: Sequence[SampleRule] = DEFAULT_RULES) -> None:
        for name, value, kind in (("model", model, StreamModel),
                                  ("config", config, StreamConfig)):
            if not isinstance(value, kind):
                raise ConfigError(f"StreamService {name} must be a {kind.__name__}, got "
                                  f"{type(value).__name__}")
        if not callable(getattr(targets, "target_for", None)):
            raise ConfigError("StreamService targets must be a TargetProvider (e.g. "
                              f"TableTargets), got {type(targets).__name__}")
        try:
            given = None if isinstance(rules, (str, bytes)) else tuple(rules)
        except TypeError:   # not iterable (None)
            given = None
        if given is None or not all(callable(r) for r in given):
            raise ConfigError("StreamService rules must be a sequence of SampleRule "
                              f"functions, got {type(rules).__name__} {rules!r:.60}")
        # the buffers keep samples in increasing time (read by binary search): that rule is
        # applied whatever the rules given (a robot's own in place of the defaults let a
        # chunk going back in time into a buffer, unsorted, nothing refused)
        rules = given if time_increasing in given else given + (time_increasing,)
        check_hop(config.hop_s, model.window.rate_hz)
        check_provider(targets, model.classes, config.min_confidence)
        if config.buffer_samples < model.window.n_samples + 2:
            raise ConfigError(f"buffer_samples {config.buffer_samples} cannot hold one "
                              f"{model.window.window_s:g} s window of the model "
                              f"({model.window.n_samples} samples at "
                              f"{model.window.rate_hz:g} Hz, plus 2 to interpolate): every "
                              "window would be short")
        self.model, self.targets, self.config, self.rules = model, targets, config, rules
        need = set(model.raw_channels)
        self.streams = {s: tuple(ch) for s, ch in config.streams.items() if need & set(ch)}
        covered = {c for ch in self.streams.values() for c in ch}
        if need - covered:
            raise ConfigError(f"model channels {sorted(need - covered)} are in none of the "
                              f"streams {dict(config.streams)}")
        self._clock = DecisionClock(model.window.window_s, model.window.rate_hz)
        self._intake = StreamIntake(self.streams, config, rules, self._clock)
        self._skipped = 0
        self._filter = ForwardFilter(len(model.classes), config.hop_s, config.smoothing)
        self._n = model.window.n_samples
        self._pipe_cols = [list(model.pipeline.classes_).index(c)
                           if c in list(model.pipeline.classes_) else -1
                           for c in model.classes]
        # aligned columns: every stream's channels in order, then the derived wheel channels
        flat = [c for ch in self.streams.values() for c in ch]
        self._wheel_cols = [flat.index(c) for c in WHEEL_CHANNELS] \
            if set(WHEEL_CHANNELS) <= set(flat) else None
        if self._wheel_cols is not None:
            flat += list(DERIVED_WHEEL_CHANNELS)
        self._track_m = model_track_m(model.metadata)   # as the training windows derived
        # a stream's step in the training runs (its channels' smallest) judges its first
        # steps, which may all be holes (RingBuffer.usual_step)
        trained = model_channel_steps_s(model.metadata)
        self._prior_steps = {s: min(trained[c] for c in ch if c in trained)
                             for s, ch in self.streams.items() if set(ch) & set(trained)}
        self._x_cols = np.array([flat.index(c) for c in model.channels])
        accel = ("ax", "ay", "az")
        # the accelerometer-units rule needs all three axes; it matters when one is used
        self._accel_cols = None
        if set(accel) <= set(flat) and set(accel) & set(model.raw_channels):
            cols = [flat.index(c) for c in accel]     # a slice (no copy) when adjacent
            self._accel_cols = slice(cols[0], cols[0] + 3) \
                if cols == list(range(cols[0], cols[0] + 3)) else cols
        # the wheel-speed-units rule needs the vehicle's top speed (the model's metadata)
        # and matters when the model uses the wheel speeds, directly or derived
        self._speed_limits = VEHICLE_LIMITS.get(str(model_vehicle(model.metadata)))
        self._speed_cols = None
        if self._speed_limits is not None and {"vel_l", "vel_r"} <= set(flat) and \
                {"vel_l", "vel_r"} & set(model.raw_channels):
            self._speed_cols = [flat.index("vel_l"), flat.index("vel_r")]

    @property
    def needed_streams(self) -> tuple[str, ...]:
        """Streams the model needs (others pushed to the service are ignored)."""
        return tuple(self.streams)

    @property
    def refused_samples(self) -> dict[tuple[str, str], int]:
        """Samples refused since the service started, by ``(stream, reason)``: the reason
        is the flag the per-sample rule raises, ``buffer_overflow``, ``duplicate`` (a
        sample sent again), ``time_ahead`` (a stray stamp ahead of the other streams) or
        ``timestamp_units`` (a clock in ms; :mod:`terrain.serving.clocks`); bounded by the
        number of streams and reasons."""
        return dict(self._intake.refused)

    @property
    def held_samples(self) -> dict[tuple[str, str], int]:
        """Samples held at this moment and counted nowhere yet, by ``(stream, reason)``:
        ``time_ahead`` (a run ahead of every other stream's clock) and ``timestamp_units``
        (samples after a long step, awaiting the units rule) (:mod:`terrain.serving.clocks`).
        They reach the decisions, or ``refused_samples``, once their clock is told; at the
        end of a replay they are what the last decisions never saw. (Late samples held as a
        possible restarted clock are in ``refused_samples`` until a restart uses them.)"""
        return {(s, reason): n for s, clock in self._intake.clocks.items()
                for reason, n in clock.held().items()}

    @property
    def clock_restarts(self) -> int:
        """Clock restarts since the service started (:mod:`terrain.serving.clocks`,
        ``StreamConfig.clock_restart_s``)."""
        return self._intake.restarts

    @property
    def clock_offsets_s(self) -> dict[str, float]:
        """Offset added to each stream's timestamps, s: ``StreamConfig.clock_offsets_s``
        plus the shift of every restart of that stream's clock alone
        (:mod:`terrain.serving.clocks`)."""
        return {s: clock.offset_s for s, clock in self._intake.clocks.items()}

    @property
    def skipped_decisions(self) -> int:
        """Decisions skipped in silent stretches since the service started (module
        docstring, ``StreamConfig.max_backlog_s``)."""
        return self._skipped

    def push(self, stream: str, t_s: np.ndarray | float,
             values: Mapping[str, np.ndarray] | np.ndarray) -> list[Decision]:
        """Feed samples of one stream; returns the decisions that became due.

        Parameters
        ----------
        stream : str
            Stream name (a key of ``config.streams``).
        t_s : float or numpy.ndarray
            ``(n,)`` timestamps on the stream's own clock, s.
        values : Mapping[str, array], pandas.DataFrame or numpy.ndarray
            Channel -> ``(n,)`` values (a DataFrame is read by its column names, a Series
            as one sample), or ``(n, n_channels)`` in the stream's channel order (one
            sample may be a 1-D row, one channel a 1-D column); SI units. Masked values
            are missing (NaN).

        Returns
        -------
        list of Decision
            Possibly empty.

        Raises
        ------
        ConfigError
            Unknown stream name.
        MissingColumnError
            A channel of the stream is missing from ``values``.
        DataFormatError
            ``values`` of any other shape (a transposed chunk included), a channel's values
            and the timestamps of different lengths, or a timestamp or value that is not a
            real number (text, complex, booleans, NumPy datetime or timedelta, an integer
            beyond the float range, ragged lists), or pandas timestamps and values whose
            indexes differ (:func:`~terrain.serving.inputs.check_same_index`).
        Exception
            Whatever the model's pipeline or the targets provider raises at a decision: the
            samples stay taken and the forward filter is as before that decision, which the
            next push makes again (decisions made before it in the same push are lost).
        """
        if not isinstance(stream, str) or stream not in self.config.streams:
            raise ConfigError(f"unknown stream {stream!r:.60}; configured: "
                              f"{list(self.config.streams)}")
        if stream not in self.streams:
            return []
        channels = self.streams[stream]
        if not isinstance(values, np.ndarray):   # the usual push: nothing read by index
            check_same_index(t_s, values, stream)
        clock = self._intake.clocks[stream]
        raw = real_array(t_s, stream, "t_s")
        t = raw + clock.offset_s
        v = chunk_values(values, t, channels, stream)
        if not len(t):
            return []
        # a chunk longer than half the buffer, or than the room its buffer has beside the
        # samples a coming decision may read, goes in pieces, deciding after each: in one
        # piece the buffer would keep only its newest samples and the rest be lost
        piece = self._piece(stream, len(t))
        if len(t) <= piece:
            self._intake.ingest(stream, t, v)
            return self._emit()
        out, i = [], 0
        while i < len(t):
            # each piece with the stream's offset now, as a next push: a piece before may
            # have moved its clock (a restart of it alone, a run held ahead put back)
            self._intake.ingest(stream, raw[i:i + piece] + clock.offset_s, v[i:i + piece])
            out.extend(self._emit())
            i += piece
            piece = self._piece(stream, len(t) - i)
        return out

    def _piece(self, stream: str, n: int) -> int:
        """Samples of a chunk of ``n`` to take before deciding: at most half the buffer,
        and no more than the buffer holds beside the samples a coming decision may still
        read (down to one), so that a backlog pushed at once loses none of them where the
        same samples pushed one by one lose none (a 0.08 s wheel step, a 24-sample buffer:
        4 samples were counted ``buffer_overflow``). Where the buffer is full of such
        samples (another stream lags), half the buffer: one by one would lose them too."""
        half = max(1, self.config.buffer_samples // 2)
        if n <= 1:      # one sample is one piece whatever the room (a robot's usual push)
            return half
        buf = self._intake.buffers[stream]
        if len(buf) + min(n, half) <= buf.capacity:   # nothing pushed out
            return half
        since = self._clock.needed_since()
        if since == -np.inf:
            return half
        needed = len(buf) - int(np.searchsorted(buf.times(), since, side="left"))
        room = buf.capacity - needed
        return half if room < 1 else min(half, room)

    def _emit(self) -> list[Decision]:
        buffers, clock = self._intake.buffers, self._clock
        last = [b.last_t for b in buffers.values()]
        newest = max(last)
        # a lagging stream is stale once another had gone stale_s past the decision when
        # its newest samples came: a chunk's samples arrive together, so the other
        # streams' samples of its span may be on their way (module docstring)
        arrived = max(b.batch_first_t for b in buffers.values())
        if clock.next_t is None:
            filled = [b for b in buffers.values() if len(b)]
            if not filled:
                return []
            start = max(b.first_t for b in filled)
            if len(filled) < len(buffers) and \
                    arrived < start + self.model.window.window_s + self.config.stale_s:
                return []  # wait for the silent stream(s) for a while
            clock.next_t = start + self.model.window.window_s
            unplaced = self._intake.unplaced
            for stream, reason in unplaced:   # refused before any sample
                self._intake.note(stream, start, reason)
            unplaced.clear()
        out = []
        while min(last) >= clock.next_t or arrived >= clock.next_t + self.config.stale_s:
            if newest - clock.next_t > self.config.max_backlog_s:
                skip = self._silent_hops(newest)
                if skip:
                    self._filter.skip(skip)
                    self._skipped += skip
                    clock.advance(skip, self.config.hop_s)
                    continue
            out.append(self._decide(clock.next_t))
            clock.advance(1, self.config.hop_s)
        return out

    def _silent_hops(self, newest: float) -> int:
        """Hops from the next due time over which no stream has a sample in the window
        (``_window``'s look-back), up to ``max_backlog_s`` before ``newest``; 0 if the next
        window holds a sample."""
        w = self.model.window
        t = self._clock.next_t
        resume = min(b.first_at_or_after(t - w.window_s - 2.0 / w.rate_hz)
                     for b in self._intake.buffers.values())
        if resume <= t:
            return 0
        # the hops before it; a hop at it (within the clock's rounding: 8.6 s beside a
        # newest sample at 12.8 s and max_backlog_s 4.2 s) is decided
        until = min(resume, newest - self.config.max_backlog_s) - _same_time_s(newest)
        return max(0, int(np.ceil((until - t) / self.config.hop_s)))

    def _holds_gap(self, ts: np.ndarray, step: float, first: float) -> bool:
        """Whether a stream's samples ``ts`` read for a window whose first grid point is
        ``first`` hold a gap: a step ending after ``first`` over ``gap_factor`` x the
        stream's usual ``step`` (the readers' rule, :func:`terrain.io.align.gap_steps`).
        Past a stream's first samples the median of its one or two known steps is the gap
        itself: the smallest step read stands for the usual one when fewer than three are
        read, and two samples read (one before the window, one after it: none in it) are
        one gap."""
        if len(ts) == 2:
            return True
        steps = np.diff(ts)
        if len(steps) < 3:
            step = min(step, float(steps.min()))
        return bool(gap_steps(steps[ts[1:] > first], step, self.config.gap_factor).any())

    def _window(self, t: float) -> tuple[np.ndarray | None, float, set[str]]:
        """Aligned window ending at or before ``t``: (X (1, ch, n) or None, age, flags)."""
        w = self.model.window
        # stamps are compared with times within the clock's rounding (clock_slack): a
        # sample on the look-back bound (read as the one just before it) or at t (the
        # decision clock and a 100 Hz IMU share a lattice) is on it whichever way the
        # floats round, so a shift of every clock reads the same samples
        slack = float(clock_slack(t))
        lo = t - w.window_s - 2.0 / w.rate_hz + slack
        times, values, steps = [], [], []
        for name, buf in self._intake.buffers.items():
            ts, vs = buf.since(lo)
            # up to the first sample at or past t, whatever came after it: the IMU's
            # anti-alias filter runs both ways over what is read, so one more sample would
            # move the window's values with the chunking of the pushes
            cut = int(np.searchsorted(ts, t - slack, side="left")) + 1
            ts, vs = ts[:cut], vs[:cut]
            if len(ts) < 2:
                return None, np.inf, {"short"}
            # a gap is judged against the stream's usual step (the readers' rule), not the
            # few samples of one window, which a long gap would dominate; its step up to the
            # window's last sample read (later arrivals would move it with the chunking),
            # the smallest while few are known (holes would make the median)
            steps.append(buf.usual_step(through_s=t, prior_s=self._prior_steps.get(name)))
            times.append(ts)
            values.append(vs)
        # the window covers [t - window_s, t), as the batch windows [t_start_s, t_end_s):
        # the last n points of a grid ending at t - 1 / rate (only those are built, so a
        # window inside a long timestamp gap costs no more than any other), moved back onto
        # the newest sample there of the fastest stream at the grid's rate or faster
        # (_grid_anchor)
        tol = _same_time_s(t)
        tail, end = anchored_grid_tail(times, w.rate_hz,
                                       _grid_anchor(times, steps, t, w.rate_hz, slack),
                                       self._n)
        if end == 0:  # streams do not overlap inside the window
            return None, np.inf, {"short"}
        age = t - float(tail[-1]) - 1.0 / w.rate_hz
        # the grid's rounding leaves ~1e-17 s on a fresh window (~1e-7 s on an epoch
        # clock): report it as 0
        age = age if age > tol else 0.0
        if end < self._n:
            return None, age, {"short"}
        # a gap counts where it holds a grid point of the window: a step that ends at or
        # before the first point (read for the look-back margin) leaves the window whole
        gap = any(self._holds_gap(ts, step, tail[0] + slack)
                  for ts, step in zip(times, steps))
        aligned = align_arrays(times, values, tail, w.rate_hz, self.config.gap_factor,
                               steps).T
        if self._wheel_cols is not None:
            derived = derived_wheel_arrays(*aligned[self._wheel_cols], self._track_m)
            aligned = np.concatenate([aligned, np.stack(list(derived.values()))])
        X = aligned[self._x_cols][None]
        if gap or not np.isfinite(X).all():
            return None, age, {"gap"}
        if self._accel_cols is not None:  # the readers' rule on the window's median |a|
            acc = aligned[self._accel_cols]
            sq = np.einsum("ij,ij->j", acc, acc)    # 5 us; np.median of the norm took 31
            if accel_in_g(_median_norm(sq)):
                return None, age, {"accel_units"}
        if self._speed_cols is not None and wheel_speed_in_kmh(quantile_sorted(
                np.sort(np.abs(aligned[self._speed_cols]), axis=None), 0.99),
                self._speed_limits):
            return None, age, {"wheel_speed_units"}
        return X, age, set()

    def _decide(self, t: float) -> Decision:
        """The decision at ``t``; the forward filter as before it when the model or the
        provider raises (the next push decides ``t`` again: the window was folded in
        twice, 0.964 for 0.941)."""
        saved = copy.copy(self._filter)   # update replaces its arrays, never writes into them
        try:
            return self._decision(t)
        except BaseException:
            self._filter = saved
            raise

    def _decision(self, t: float) -> Decision:
        X, age, flags = self._window(t)
        intake = self._intake
        # the window [t - window_s, t) with both edges moved by the clock's rounding, as
        # its grid (_window): a rejection stamped at t (1.7 s, beside a decision time of
        # 1.7000000000000002) is in the next window, not this one; a stream exactly
        # stale_s old is not stale (1.8 - 1.5 s is 0.30000000000000004)
        tol = _same_time_s(t)
        stale = any(t - b.last_t > self.config.stale_s + tol
                    for b in intake.buffers.values())
        if stale:
            flags.add("stale")
        t_lo, t_hi = t - self.model.window.window_s - tol, t - tol
        for ev in intake.events.values():
            flags.update(reason for first, last, reason in ev
                         if first < t_hi and last >= t_lo)
        stuck = [key for watch in intake.stuck.values()
                 for key in watch.stuck_between(t_lo, t_hi)]
        if stuck:   # one flag, as the readers write it
            flags.add(stuck_flag(stuck))
        q = None
        if X is not None:
            raw = self.model.pipeline.predict_proba(X)[0]
            q = np.array([raw[i] if i >= 0 else 0.0 for i in self._pipe_cols])
        decided, p = self._filter.update(q)
        if q is not None and not self._filter.evidence:   # a NaN or inf: no evidence
            flags.add("non_finite_proba")
        terrain = None if decided is None else self.model.classes[decided]
        conf = 0.0 if decided is None else float(p[decided])
        trusted = terrain if conf >= self.config.min_confidence else None
        if terrain is not None and trusted is None:
            flags.add("low_confidence")
        if not self._filter.evidence and self.config.smoothing.dwell_s is None:
            # without the filter's memory an unclassified window (flagged for its reason)
            # is no evidence: its uniform 1/K (0.5 of two classes) is no confidence
            trusted = None
        traction, braking, steady = self.targets.target_for(trusted, conf, stale)
        return Decision(float(t), terrain, conf, p, float(traction), float(braking),
                        float(steady), float(age), "|".join(sorted(flags)))
