"""In-process streaming terrain service: samples in, smoothed terrain + slip targets out.

Samples of each stream arrive one by one or in chunks, each stream at its own rate and on
its own clock (an optional per-stream offset maps it onto the service clock). Each stream
keeps a bounded :class:`~terrain.serving.buffers.RingBuffer`, so memory is fixed for an
unbounded stream. A chunk longer than half the buffer is taken in pieces, deciding after
each; a sample pushed out of its buffer before any decision could read it (a backlog of one
stream while another lags) is counted as ``buffer_overflow`` in
:attr:`StreamService.refused_samples` and flags the windows after it. Every ``hop_s`` of
service time the service

1. takes the samples of every needed stream around ``[t - window_s, t)``,
2. aligns the last window of the model's length with the project's NumPy alignment core
   (:func:`terrain.io.align.overlap_grid_tail`, the window's end of ``overlap_grid``, and
   :func:`terrain.io.align.align_arrays`, the step the batch readers' :func:`~terrain.io.align.align_streams` runs) and adds the
   derived wheel channels (:func:`features.windows.derived_wheel_arrays`); the whole
   per-decision path works on arrays, no data frame,
3. classifies it with the fitted pipeline (the model's own feature code),
4. folds the probabilities into the forward filter (:mod:`terrain.serving.smoothing`),
5. asks the injected :class:`~terrain.serving.targets.TargetProvider` for the slip
   targets, passing ``terrain=None`` (the conservative fallback) below ``min_confidence``.

A decision is due at service time ``t`` once every needed stream has reached ``t``, or once
some stream is ``stale_s`` past ``t`` while another lags (the decision is then flagged
``stale`` and rests on the data that did arrive; its ``window_age_s`` says how old).

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
sent again (refused as ``duplicate``). The service keeps one
:class:`~terrain.serving.clocks.StreamClock` per stream (its offset and the samples the
rules hold, bounded) and applies the rules' verdicts.

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
a model whose metadata names a vehicle of :data:`terrain.io.plausibility.VEHICLE_LIMITS`
and that uses the wheel speeds), ``clock_restart``, ``low_confidence`` (fallback target).
"""

from __future__ import annotations

import math
from collections import Counter, deque
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Mapping, Sequence

import numpy as np

from features.calculators import quantile_sorted
from features.windows import DERIVED_WHEEL_CHANNELS, derived_wheel_arrays
from terrain.errors import ConfigError, config_integer, config_numbers, duplicated
from terrain.io.align import align_arrays, overlap_grid_tail
from terrain.io.plausibility import (VEHICLE_LIMITS, accel_in_g, stuck_flag,
                                     wheel_speed_in_kmh)
from terrain.run import IMU_CHANNELS, WHEEL_CHANNELS
from terrain.serving.buffers import RingBuffer
from terrain.serving.clocks import (AHEAD, DUPLICATE, DUPLICATE_TOL_S, TIME_RULE, UNITS,
                                    UNITS_STEPS, HeldRun, StreamClock, ahead_shift,
                                    continues_run, first_long_step, in_a_gap,
                                    newest_on_ms_clock, resent_mask, resolve_hold,
                                    restart_shift, steps_ahead, went_on_live)
from terrain.serving.decisions import Decision
from terrain.serving.inputs import check_same_index, chunk_values, real_array
from terrain.serving.model import StreamModel
from terrain.serving.rules import (DEFAULT_RULES, MAX_PLAUSIBLE_TIME_S, SampleRule,
                                   StuckWatch)
from terrain.serving.smoothing import ForwardFilter, SmoothingConfig
from terrain.serving.targets import TargetProvider

#: Stream name -> channels, as the readers name them (``terrain.io.measured``).
KNOWN_STREAMS: Mapping[str, tuple[str, ...]] = MappingProxyType(
    {"imu": IMU_CHANNELS, "wheels": WHEEL_CHANNELS})
#: Rejection events remembered per stream (bounded, for the flags).
MAX_EVENTS = 256
#: Largest ``StreamConfig.buffer_samples``: 10 000 s at 100 Hz, ~110 MB per 6-channel
#: stream (the buffer stores every sample twice); 10**9 asked NumPy for 60 GB at the first
#: buffer
MAX_BUFFER_SAMPLES = 1_000_000
#: reason of a sample a chunk pushed out of its stream's buffer before any decision used it
#: (a chunk longer than the buffer, or a backlog while another stream lags)
OVERFLOW = "buffer_overflow"

@dataclass(frozen=True)
class StreamConfig:
    """Settings of the streaming service.

    Parameters
    ----------
    hop_s : float
        Time between decisions, s (> 0).
    stale_s : float
        A stream whose newest sample is older than the decision time by more than this is
        stale, s (> 0).
    min_confidence : float
        Smoothed probability below which the fallback target is used, in [0, 1].
    buffer_samples : int
        Capacity of each stream's ring buffer, samples (must hold ``window_s`` of the
        fastest stream; 4096 is 40 s at 100 Hz).
    gap_factor : float
        A step longer than this many median steps is a gap (as in the readers).
    streams : Mapping[str, tuple of str]
        Stream name -> its channels.
    clock_offsets_s : Mapping[str, float]
        Per-stream offset added to its timestamps to put them on the service clock, s.
    smoothing : SmoothingConfig
    max_backlog_s : float
        Decisions of a silent stretch (no sample of any stream in their window) due more
        than this before the newest sample are skipped and counted, s (finite, > 0; module
        docstring).
    clock_restart_s : float
        A stream whose samples keep arriving earlier than its newest accepted one,
        increasing among themselves with no gap over this span of their own time, has
        restarted its clock: the service restarts on the new clocks
        (:mod:`terrain.serving.clocks`), s (finite, > 0).

    Raises
    ------
    ConfigError
        A non-positive ``hop_s``, ``stale_s``, ``max_backlog_s`` or ``clock_restart_s``, a
        non-finite ``stale_s``, ``max_backlog_s`` or ``clock_restart_s``, a
        ``min_confidence`` outside [0, 1], ``buffer_samples`` not an integer >= 2,
        ``gap_factor`` not a finite number > 1, or a clock offset that is not finite or
        names no configured stream; a number field given as text, a boolean, a list or
        ``None``; ``buffer_samples`` above :data:`MAX_BUFFER_SAMPLES`; ``streams`` that is
        not a mapping of names to channel names, or names a channel twice; ``smoothing``
        that is not a :class:`SmoothingConfig`.
    """

    hop_s: float = 0.5
    stale_s: float = 1.0
    min_confidence: float = 0.5
    buffer_samples: int = 4096
    gap_factor: float = 3.0
    streams: Mapping[str, tuple[str, ...]] = field(default_factory=lambda: KNOWN_STREAMS)
    clock_offsets_s: Mapping[str, float] = field(default_factory=lambda: MappingProxyType({}))
    smoothing: SmoothingConfig = field(default_factory=SmoothingConfig)
    max_backlog_s: float = 60.0
    clock_restart_s: float = 5.0

    def __post_init__(self) -> None:
        config_numbers("StreamConfig", hop_s=self.hop_s, stale_s=self.stale_s,
                       min_confidence=self.min_confidence, gap_factor=self.gap_factor,
                       max_backlog_s=self.max_backlog_s, clock_restart_s=self.clock_restart_s)
        _check_streams(self.streams)
        if not isinstance(self.clock_offsets_s, Mapping):
            raise ConfigError("StreamConfig.clock_offsets_s must be a mapping of stream name "
                              f"-> offset in s, got {type(self.clock_offsets_s).__name__}")
        offsets = {str(k): v for k, v in self.clock_offsets_s.items()}
        config_numbers("StreamConfig.clock_offsets_s", **offsets)
        if not isinstance(self.smoothing, SmoothingConfig):
            raise ConfigError("StreamConfig.smoothing must be a SmoothingConfig, got "
                              f"{type(self.smoothing).__name__}")
        if not self.hop_s > 0:
            raise ConfigError(f"hop_s must be > 0, got {self.hop_s}")
        # an infinite stale_s waits for ever for a silent stream (no decision at all)
        for name in ("stale_s", "max_backlog_s", "clock_restart_s"):
            if not 0 < getattr(self, name) < np.inf:
                raise ConfigError(f"{name} must be a finite number of seconds > 0, got "
                                  f"{getattr(self, name)}")
        if not 0 <= self.min_confidence <= 1:
            raise ConfigError(f"min_confidence must be in [0, 1], got {self.min_confidence}")
        config_integer("buffer_samples", self.buffer_samples, 2, MAX_BUFFER_SAMPLES)
        # a factor <= 1 calls half of all steps a gap (every window dropped); NaN none
        if not 1 < self.gap_factor < np.inf:
            raise ConfigError(f"gap_factor must be a finite number > 1, got {self.gap_factor}")
        unknown = [s for s in self.clock_offsets_s if s not in self.streams]
        bad = {s: o for s, o in self.clock_offsets_s.items() if not np.isfinite(o)}
        if unknown or bad:
            raise ConfigError(f"clock_offsets_s must be finite offsets of configured streams "
                              f"{list(self.streams)}; got unknown stream(s) {unknown}, "
                              f"non-finite {bad}")


def _check_streams(streams) -> None:
    """Refuse a ``StreamConfig.streams`` that is not stream name -> distinct channel names
    (a channel named twice, in one stream or two, would be read from one place only)."""
    if not isinstance(streams, Mapping) or not streams:
        raise ConfigError("StreamConfig.streams must be a non-empty mapping of stream name -> "
                          f"channel names, got {type(streams).__name__} {streams!r:.60}")
    names = []
    for stream, channels in streams.items():
        if not isinstance(stream, str) or isinstance(channels, str) or not all(
                isinstance(c, str) for c in channels) or not channels:
            raise ConfigError("StreamConfig.streams must map stream names (text) to "
                              f"non-empty sequences of channel names, got {stream!r}: "
                              f"{channels!r:.60}")
        names.extend(channels)
    dup = duplicated(names)
    if dup:
        raise ConfigError(f"StreamConfig.streams names channel(s) {dup} more than once; each "
                          "channel belongs to one stream, once")


def check_hop(hop_s: float, rate_hz: float) -> float:
    """Refuse a decision hop shorter than one period of the model's clock.

    Deciding more often than the model's clock gives no new aligned sample to decide on,
    and a tiny hop makes a replay of minutes cost hours (one decision per hop).

    Parameters
    ----------
    hop_s : float
        Time between decisions, s.
    rate_hz : float
        The model's aligned clock, Hz.

    Returns
    -------
    float
        ``hop_s``.

    Raises
    ------
    ConfigError
        ``hop_s`` not finite or below ``1 / rate_hz``.
    """
    period = 1.0 / float(rate_hz)
    hop = float(hop_s)
    if not (np.isfinite(hop) and hop >= period):
        raise ConfigError(f"hop_s {hop:g} s is shorter than one period of the model's "
                          f"{float(rate_hz):g} Hz clock ({period:g} s) or not finite; "
                          "decisions that often would decide on no new sample")
    return hop


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
        Per-sample plausibility rules (default: the readers' rules).

    Raises
    ------
    ConfigError
        ``model``, ``config``, ``targets`` or ``rules`` of the wrong kind (e.g. ``None``),
        a channel the model needs is in none of the configured streams, the hop is
        shorter than one period of the model's clock (:func:`check_hop`), or
        ``buffer_samples`` cannot hold one window of the model (plus 2 samples).
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
        rules = given
        check_hop(config.hop_s, model.window.rate_hz)
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
        self._buffers = {s: RingBuffer(len(ch), config.buffer_samples)
                         for s, ch in self.streams.items()}
        self._events: dict[str, deque] = {s: deque(maxlen=MAX_EVENTS) for s in self.streams}
        self._stuck = {s: StuckWatch(s, ch) for s, ch in self.streams.items()}
        self._refused: Counter = Counter()
        self._skipped = 0
        self._clock_restarts = 0
        # each stream's clock: offset, held samples, the timestamp_units rule (clocks.py);
        # the rule knows a stream's nominal rate range by its channels
        self._clocks = {s: StreamClock(config.buffer_samples,
                                       next((k for k, known in KNOWN_STREAMS.items()
                                             if set(ch) <= set(known)), None),
                                       config.clock_offsets_s.get(s, 0.0))
                        for s, ch in self.streams.items()}
        # runs held ahead so far (their order: StreamClock.ahead_rank)
        self._holds_begun = 0
        # a step ahead of the others by less than stale_s is a lag the config tolerates
        self._step_s = max(config.clock_restart_s, config.stale_s)
        # (stream, reason) of samples refused without a stamp before any stream had one
        self._unplaced: set[tuple[str, str]] = set()
        self._filter = ForwardFilter(len(model.classes), config.hop_s, config.smoothing)
        self._next_t: float | None = None
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
        self._speed_limits = VEHICLE_LIMITS.get(str(model.metadata.get("vehicle", "")))
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
        return dict(self._refused)

    @property
    def held_samples(self) -> dict[tuple[str, str], int]:
        """Samples held at this moment and counted nowhere yet, by ``(stream, reason)``:
        ``time_ahead`` (a run ahead of every other stream's clock) and ``timestamp_units``
        (samples after a long step, awaiting the units rule) (:mod:`terrain.serving.clocks`).
        They reach the decisions, or ``refused_samples``, once their clock is told; at the
        end of a replay they are what the last decisions never saw. (Late samples held as a
        possible restarted clock are in ``refused_samples`` until a restart uses them.)"""
        return {(s, reason): n for s, clock in self._clocks.items()
                for reason, n in clock.held().items()}

    @property
    def clock_restarts(self) -> int:
        """Clock restarts since the service started (:mod:`terrain.serving.clocks`,
        ``StreamConfig.clock_restart_s``)."""
        return self._clock_restarts

    @property
    def clock_offsets_s(self) -> dict[str, float]:
        """Offset added to each stream's timestamps, s: ``StreamConfig.clock_offsets_s``
        plus the shift of every restart of that stream's clock alone
        (:mod:`terrain.serving.clocks`)."""
        return {s: clock.offset_s for s, clock in self._clocks.items()}

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
        """
        if not isinstance(stream, str) or stream not in self.config.streams:
            raise ConfigError(f"unknown stream {stream!r:.60}; configured: "
                              f"{list(self.config.streams)}")
        if stream not in self.streams:
            return []
        channels = self.streams[stream]
        if not isinstance(values, np.ndarray):   # the usual push: nothing read by index
            check_same_index(t_s, values, stream)
        t = real_array(t_s, stream, "t_s") + self._clocks[stream].offset_s
        v = chunk_values(values, t, channels, stream)
        if not len(t):
            return []
        # a chunk longer than half the buffer goes in pieces, deciding after each: in one
        # piece the buffer would keep only its newest samples and the rest be lost
        piece = max(1, self.config.buffer_samples // 2)
        if len(t) <= piece:
            self._ingest(stream, t, v)
            return self._emit()
        out = []
        for i in range(0, len(t), piece):
            self._ingest(stream, t[i:i + piece], v[i:i + piece])
            out.extend(self._emit())
        return out

    def _ingest(self, stream: str, t: np.ndarray, v: np.ndarray, hold: bool = True,
                judged: bool = False) -> None:
        """Apply the rules to a validated chunk, buffer what they keep, hold the samples
        of a forward step of the stream's clock alone (unless ``hold`` is false) and watch
        the samples refused as earlier than the stream's newest for a clock restart.
        ``judged``: samples held before, whose clock's units were judged when they came."""
        channels, buf, clock = self.streams[stream], self._buffers[stream], self._clocks[stream]
        # a sample at or before the stream's newest, buffered or held ahead, may be one
        # sent again (checked only then: the usual increasing push costs two comparisons)
        ahead = clock.ahead
        if t[0] <= buf.last_t or (ahead is not None and t[0] <= ahead.last_t) or \
                (len(t) > 1 and not (t[1:] > t[:-1]).all()):
            resent = self._resent(stream, t, v)
            if resent.any():
                self._refused[(stream, DUPLICATE)] += int(resent.sum())
                t, v = t[~resent], v[~resent]
                if not len(t):
                    return
        slowest = clock.ms_step_s
        if slowest is not None and not judged:   # rule timestamp_units
            taken = self._judge_units(stream, t, v, slowest)
            if taken is None:
                return
            t, v = taken
            buf = self._buffers[stream]   # (held samples taken meanwhile may restart)
        order = np.arange(len(t))  # arrival position of each sample still in play
        late: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        for rule in self.rules:
            keep, reason = rule(channels, t, v, buf.last_t)
            if not keep.all():
                bad_t = t[~keep]
                self._refused[(stream, reason)] += len(bad_t)
                # a sample without a usable stamp is flagged at the stream's newest time
                # (the service's before the stream's first sample; the first window's
                # start before any sample at all)
                at = buf.last_t if len(buf) else self._newest()
                if not np.isfinite(bad_t).all() and at == -np.inf:
                    self._unplaced.add((stream, reason))
                self._events[stream].extend(
                    (bt if np.isfinite(bt) else at, reason) for bt in bad_t)
                if reason == TIME_RULE:
                    late = (t[~keep], v[~keep], order[~keep])
                t, v, order = t[keep], v[keep], order[keep]
        # a step forward longer than clock_restart_s and stale_s, or a stream's first
        # samples (one comparison on the usual push)
        if hold and len(t) and (clock.ahead is not None or t[-1] - buf.last_t > self._step_s):
            t, v = self._hold_ahead(stream, t, v)
        if len(t):
            # samples the chunk pushes out of the buffer before a decision used them
            lost = buf.evicted(t, self._needed_since())
            if lost:
                self._refused[(stream, OVERFLOW)] += lost
                self._events[stream].append((float(t[0]), OVERFLOW))
            self._stuck[stream].update(t, v)
            clock.rejoining = False
        buf.append(t, v)
        self._watch_restart(stream, late, order, t, v)
        if any(c.ahead is not None for c in self._clocks.values()):
            self._resolve_ahead()

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
        clock = self._clocks[stream]
        held, prev = clock.unjudged, clock.newest_stamp_s
        # (a stamp the readers' rule implausible_time refuses opens no hold)
        suspect = abs(t[-1]) <= MAX_PLAUSIBLE_TIME_S and (
            t[-1] - prev > len(t) * slowest if prev is not None
            else t[-1] - t[0] > (len(t) - 1) * slowest)
        clock.remember(t)
        if clock.on_ms_clock or (suspect and not held):
            if self._in_ms(stream):   # its newest steps say so already
                self._refused[(stream, UNITS)] += len(t)
                self._events[stream].append((self._newest(), UNITS))
                return None
            if not suspect:
                return t, v
        if held:
            t0, last = held.t0_s, self._buffers[stream].last_t
            back = np.flatnonzero(t < t0)
            if len(back):   # back before the step: no clock from it
                i = int(back[0])
                if last < t[i] and t0 - last > self.config.max_backlog_s:
                    self._refused[(stream, AHEAD)] += len(held) + i
                    self._events[stream].append((self._newest(), AHEAD))
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
                self._ingest(stream, t[:k], v[:k], judged=True)
                t, v = t[k:], v[k:]
            last = self._buffers[stream].last_t
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
            self._events[stream].append((self._newest(), UNITS))
            return None
        self._release_unjudged(stream)   # a clock in s (a dropout)
        return None

    def _release_unjudged(self, stream: str) -> None:
        """Take the chunks of ``stream`` held for the ``timestamp_units`` rule, one by one
        as they came (their units judged)."""
        for t, v in self._clocks[stream].unjudged.take():
            self._ingest(stream, t, v, judged=True)

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
        buf, clock = self._buffers[stream], self._clocks[stream]
        held = clock.ahead
        first_jump = self._first_step_s(stream)
        step = buf.median_step()
        max_step = self.config.gap_factor * step if np.isfinite(step) else self._step_s
        taken = np.ones(len(t), dtype=bool)
        prev = buf.last_t        # the stream's newest sample taken
        others = self._others_newest(stream)
        for i, ti in enumerate(t):
            if held is not None and continues_run(ti, held.last_t, max_step):
                if held.full:   # the hold is bounded: count the loss
                    self._refused[(stream, OVERFLOW)] += 1
                held.append(ti, v[i])
                taken[i] = False
                continue
            ahead = steps_ahead(ti, prev, others.values(), self._step_s, first_jump)
            if held is not None:
                # late on the held clock by less than a clock's step: out of order
                if ahead and 0.0 <= held.last_t - ti <= self._step_s:
                    self._refused[(stream, TIME_RULE)] += 1
                    self._events[stream].append((self._newest(), TIME_RULE))
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
        if self._clocks[stream].rejoining:
            return self._step_s
        return max(self._step_s, self.config.max_backlog_s)

    def _others_newest(self, stream: str) -> dict[str, float]:
        """Newest buffered time of every other stream with samples and no run held ahead,
        s (the clocks a step of ``stream`` is judged against)."""
        return {s: b.last_t for s, b in self._buffers.items()
                if s != stream and len(b) and self._clocks[s].ahead is None}

    def _drop_ahead(self, stream: str) -> None:
        """Refuse the held run of ``stream`` (a stray stamp ahead), counted and flagged as
        ``time_ahead``."""
        self._refused[(stream, AHEAD)] += len(self._take_ahead(stream))
        # flagged from the service's newest time on: the stream's own newest may be long
        # before every coming window (a clock in ms whose every sample steps ahead)
        self._events[stream].append((self._newest(), AHEAD))

    def _resolve_ahead(self) -> None:
        """Release the runs held ahead that :func:`~terrain.serving.clocks.resolve_hold`
        settles: as they are, or on the clock of the streams that went on."""
        holding = sorted((c.ahead_rank, s) for s, c in self._clocks.items()
                         if c.ahead is not None)
        for _, stream in holding:
            held = self._clocks[stream].ahead
            if held is None:   # released by a release before it
                continue
            at_start = held.others_newest_s
            running = resolve_hold(held.t0_s, held.last_t, at_start,
                                   {s: self._buffers[s].last_t for s in at_start},
                                   self.config.stale_s, self.config.clock_restart_s,
                                   self.config.max_backlog_s)
            if running is None:
                continue
            shift = 0.0 if not running else ahead_shift(
                held.t0_s, held.lead_s, [at_start[s] for s in running],
                [self._buffers[s].median_step() for s in running],
                self._buffers[stream].last_t, self._buffers[stream].median_step())
            self._release_ahead(stream, shift)

    def _release_ahead(self, stream: str, shift: float) -> None:
        """Ingest the held run of ``stream`` moved by ``shift`` (s; a shift is a restart of
        that stream's clock alone: offset, counter and flag)."""
        t, v = self._take_ahead(stream).arrays()
        t += shift
        if shift:
            self._clocks[stream].offset_s += shift
            self._clock_restarts += 1
            self._clocks[stream].restamp(t)
        self._ingest(stream, t, v, hold=False, judged=True)
        if shift:
            self._events[stream].append((float(t[-1]), "clock_restart"))

    def _resent(self, stream: str, t: np.ndarray, v: np.ndarray) -> np.ndarray:
        """``(n,)`` bool: the samples of a chunk that the stream already gave, buffered
        (:func:`~terrain.serving.clocks.resent_mask`) or held ahead
        (:meth:`~terrain.serving.clocks.HeldRun.repeats`)."""
        finite = t[np.isfinite(t)]
        if not len(finite):       # no stamp to match (the rules refuse them)
            return np.zeros(len(t), dtype=bool)
        buf, clock = self._buffers[stream], self._clocks[stream]
        bt, bv = buf.since(float(finite.min()) - DUPLICATE_TOL_S)
        out = resent_mask(t, v, bt, bv, buf.first_t, buf.last_t,
                          clock.late.last_t if len(clock.late) else None,
                          self.config.gap_factor * buf.median_step())
        if clock.ahead is not None:   # a re-send while a step ahead is told
            out |= [clock.ahead.repeats(ti, vi) for ti, vi in zip(t, v)]
        return out

    def _take_ahead(self, stream: str) -> HeldRun:
        """The run held ahead by ``stream``, which holds none after."""
        clock = self._clocks[stream]
        held, clock.ahead = clock.ahead, None
        return held

    def _newest(self) -> float:
        """Newest buffered time of any stream, s (the service's now)."""
        return max(b.last_t for b in self._buffers.values())

    def _in_ms(self, stream: str) -> bool:
        """Rule ``timestamp_units`` live (:func:`~terrain.serving.clocks.clock_in_ms` on the
        stream's newest arrival stamps; asked only when a push's mean step may say so); a
        stream found in ms has its samples purged (counted) and stays refused until its
        steps are in s again."""
        in_ms, switched = self._clocks[stream].judge_ms()
        if switched:
            self._purge(stream)
        return in_ms

    def _purge(self, stream: str) -> None:
        """Refuse the samples of ``stream`` buffered on its ms clock (the newest ones, each
        a step over ten nominal periods after the one before; those before the switch were
        good and stay) and those it holds, counted as ``timestamp_units``; the decision
        clock starts again when it ran ahead of every other stream on their stamps."""
        buf, clock = self._buffers[stream], self._clocks[stream]
        k = newest_on_ms_clock(buf.times(), clock.ms_step_s)
        n = k + len(clock.late) + len(clock.unjudged) + \
            (len(self._take_ahead(stream)) if clock.ahead is not None else 0)
        if n:
            self._refused[(stream, UNITS)] += n
        buf.drop_newest(k)
        self._stuck[stream] = StuckWatch(stream, self.streams[stream])
        clock.late.clear()
        clock.unjudged.clear()
        self._rewind_decision_clock()

    def _rewind_decision_clock(self) -> None:
        """Start the decision clock again when it ran more than ``max_backlog_s`` ahead of
        every stream (on a stamp far ahead, or a clock in ms, since taken back)."""
        if self._next_t is not None and \
                self._next_t > self._newest() + self.config.max_backlog_s:
            self._next_t = None

    def _uncount(self, stream: str, reason: str, n: int) -> None:
        """Take back ``n`` refusals of ``stream`` for ``reason`` (held samples used after
        all)."""
        self._refused[(stream, reason)] -= n
        if self._refused[(stream, reason)] <= 0:
            del self._refused[(stream, reason)]

    def _needed_since(self) -> float:
        """Oldest time a coming decision's window may still read, s (``-inf`` before the
        first decision: every sample may be)."""
        if self._next_t is None:
            return -np.inf
        w = self.model.window
        return self._next_t - w.window_s - 2.0 / w.rate_hz

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
        held = self._clocks[stream].late
        if late is None or (len(kept_order) and kept_order[-1] > late[2][-1]):
            if late is not None:   # this chunk's late samples before its last taken one
                self._extend_late(stream, late[0], late[1])
            if len(kept_order) == len(kept_t) > 0 and len(held):
                after = kept_order > (late[2][-1] if late is not None else -1)
                if after.any() and self._stepped_back(stream, kept_t[after][0]):
                    shift = self._restart_alone(stream, self._running(stream))
                    self._ingest(stream, kept_t[after] + shift, kept_v[after], judged=True)
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
        self._clocks[stream].late.extend_clock(
            t, v, self.config.gap_factor * self._buffers[stream].median_step(),
            {s: b.last_t for s, b in self._buffers.items() if s != stream and len(b)})

    def _went_on_beside(self, stream: str, running: list[str]) -> bool:
        """Whether one of the ``running`` streams went on live beside the late run held by
        ``stream`` (:func:`~terrain.serving.clocks.went_on_live`; else the run came at
        once: a backlog or a re-send, no clock)."""
        held = self._clocks[stream].late
        return any(went_on_live(held.last_t - held.t0_s,
                                self._buffers[s].last_t - held.others_newest_s[s])
                   for s in running)

    def _in_own_gap(self, stream: str) -> bool:
        """Whether the late run held by ``stream`` fills a hole of its buffer
        (:func:`~terrain.serving.clocks.in_a_gap`)."""
        held = self._clocks[stream].late
        return in_a_gap(self._buffers[stream].since(held.t0_s)[0], held.t0_s, held.last_t,
                        self.config.max_backlog_s,
                        [b.last_t for s, b in self._buffers.items() if s != stream],
                        self._step_s)

    def _running(self, stream: str) -> list[str]:
        """Streams that went on accepting samples on the old clock while ``stream``'s late
        run was held."""
        held = self._clocks[stream].late
        return [s for s, last in held.others_newest_s.items()
                if not self._clocks[s].late and self._buffers[s].last_t > last]

    def _stepped_back(self, stream: str, next_t: float) -> bool:
        """Whether the late run held by ``stream`` is its clock stepped back by less than
        ``clock_restart_s``: ``next_t`` (s, its first sample taken after the run)
        continues it, it spans at least ``stale_s`` (a shorter step is a lag the config
        tolerates), fills no hole of its buffer and another stream went on live beside
        it."""
        held = self._clocks[stream].late
        max_step = self.config.gap_factor * self._buffers[stream].median_step()
        if not (held.last_t - held.t0_s >= self.config.stale_s and
                continues_run(next_t, held.last_t, max_step)) or self._in_own_gap(stream):
            return False
        return self._went_on_beside(stream, self._running(stream))

    def _restart(self) -> None:
        """Restart on new clocks: empty every buffer and the decision clock, then ingest
        the samples each stream sent on its new clock (the forward filter is kept)."""
        held = {s: c.late.arrays() for s, c in self._clocks.items() if len(c.late)}
        for s, clock in self._clocks.items():
            # streams that sent nothing on the new clocks: their next sample may still be
            # on the old one
            clock.rejoining = bool(len(self._buffers[s])) and s not in held
            clock.late.clear()
        for _, s in sorted((c.ahead_rank, s) for s, c in self._clocks.items()
                           if c.ahead is not None):   # a run held ahead of the old clocks
            self._drop_ahead(s)
        for s, (t, _) in held.items():  # counted as refused when they came; used now
            self._uncount(s, TIME_RULE, len(t))
        self._buffers = {s: RingBuffer(len(ch), self.config.buffer_samples)
                         for s, ch in self.streams.items()}
        self._stuck = {s: StuckWatch(s, ch) for s, ch in self.streams.items()}
        self._next_t = None
        self._clock_restarts += 1
        for s in self.streams:
            self._events[s].clear()
        for s, (t, v) in held.items():
            self._events[s].append((float(t[0]), "clock_restart"))
            self._ingest(s, t, v, judged=True)

    def _restart_alone(self, stream: str, running: list[str]) -> float:
        """Put the held samples of ``stream`` on the clock of the ``running`` streams
        (:func:`~terrain.serving.clocks.restart_shift`): its buffer starts again, its
        offset changes by the shift, which is returned (s)."""
        clock = self._clocks[stream]
        held = clock.late
        t, v = held.arrays()
        held.clear()
        shift = restart_shift(held.t0_s, held.lead_s,
                              [held.others_newest_s[s] for s in running],
                              [self._buffers[s].median_step() for s in running],
                              self.config.gap_factor)
        self._uncount(stream, TIME_RULE, len(t))
        clock.offset_s += float(shift)
        self._buffers[stream] = RingBuffer(len(self.streams[stream]), self.config.buffer_samples)
        self._stuck[stream] = StuckWatch(stream, self.streams[stream])
        self._events[stream].clear()
        self._clock_restarts += 1
        t += shift
        clock.restamp(t)
        self._ingest(stream, t, v, judged=True)
        self._rewind_decision_clock()
        # the windows that hold the restart carry it: from the first held sample when the
        # decision clock starts again, else from the newest (those before are emitted)
        self._events[stream].append((float(t[0] if self._next_t is None else t[-1]),
                                     "clock_restart"))
        return float(shift)

    def _emit(self) -> list[Decision]:
        last = [b.last_t for b in self._buffers.values()]
        newest = max(last)
        if self._next_t is None:
            filled = [b for b in self._buffers.values() if len(b)]
            if not filled:
                return []
            start = max(b.first_t for b in filled)
            if len(filled) < len(self._buffers) and \
                    newest < start + self.model.window.window_s + self.config.stale_s:
                return []  # wait for the silent stream(s) for a while
            self._next_t = start + self.model.window.window_s
            for stream, reason in self._unplaced:   # refused before any sample
                self._events[stream].append((start, reason))
            self._unplaced.clear()
        out = []
        while min(last) >= self._next_t or newest >= self._next_t + self.config.stale_s:
            if newest - self._next_t > self.config.max_backlog_s:
                skip = self._silent_hops(newest)
                if skip:
                    self._filter.skip(skip)
                    self._skipped += skip
                    self._next_t += skip * self.config.hop_s
                    continue
            out.append(self._decide(self._next_t))
            self._next_t += self.config.hop_s
        return out

    def _silent_hops(self, newest: float) -> int:
        """Hops from the next due time over which no stream has a sample in the window
        (``_window``'s look-back), up to ``max_backlog_s`` before ``newest``; 0 if the next
        window holds a sample."""
        w = self.model.window
        t = self._next_t
        resume = min(b.first_at_or_after(t - w.window_s - 2.0 / w.rate_hz)
                     for b in self._buffers.values())
        if resume <= t:
            return 0
        until = min(resume, newest - self.config.max_backlog_s)
        return max(0, int(np.ceil((until - t) / self.config.hop_s)))

    def _window(self, t: float) -> tuple[np.ndarray | None, float, set[str]]:
        """Aligned window ending at or before ``t``: (X (1, ch, n) or None, age, flags)."""
        w = self.model.window
        lo = t - w.window_s - 2.0 / w.rate_hz
        times, values, steps, gap = [], [], [], False
        for buf in self._buffers.values():
            ts, vs = buf.since(lo)
            cut = int(np.searchsorted(ts, t, side="right")) + 1  # one sample past t
            ts, vs = ts[:cut], vs[:cut]
            if len(ts) < 2:
                return None, np.inf, {"short"}
            # a gap is judged against the stream's usual step (the readers' rule), not the
            # few samples of one window, which a long gap would dominate
            steps.append(buf.median_step())
            if (np.diff(ts) > self.config.gap_factor * steps[-1]).any():
                gap = True
            times.append(ts)
            values.append(vs)
        # the window covers [t - window_s, t), as the batch windows [t_start_s, t_end_s):
        # the last n points of the streams' common grid before t (only those are built, so
        # a window inside a long timestamp gap costs no more than any other)
        tail, end = overlap_grid_tail(times, w.rate_hz, t - 1e-9, self._n)
        if end == 0:  # streams do not overlap inside the window
            return None, np.inf, {"short"}
        age = t - float(tail[-1]) - 1.0 / w.rate_hz
        # the grid's rounding leaves ~1e-17 s on a fresh window: report it as 0 (1 ns is far
        # below any clock period)
        age = age if age > 1e-9 else 0.0
        if end < self._n:
            return None, age, {"short"}
        aligned = align_arrays(times, values, tail, w.rate_hz, self.config.gap_factor,
                               steps).T
        if self._wheel_cols is not None:
            derived = derived_wheel_arrays(*aligned[self._wheel_cols])
            aligned = np.concatenate([aligned, np.stack(list(derived.values()))])
        X = aligned[self._x_cols][None]
        if gap or not np.isfinite(X).all():
            return None, age, {"gap"}
        if self._accel_cols is not None:  # the readers' rule on the window's median |a|
            acc = aligned[self._accel_cols]
            sq = np.einsum("ij,ij->j", acc, acc)    # 5 us; np.median of the norm took 31
            if accel_in_g(math.sqrt(float(np.partition(sq, len(sq) // 2)[len(sq) // 2]))):
                return None, age, {"accel_units"}
        if self._speed_cols is not None and wheel_speed_in_kmh(quantile_sorted(
                np.sort(np.abs(aligned[self._speed_cols]), axis=None), 0.99),
                self._speed_limits):
            return None, age, {"wheel_speed_units"}
        return X, age, set()

    def _decide(self, t: float) -> Decision:
        X, age, flags = self._window(t)
        stale = any(t - b.last_t > self.config.stale_s for b in self._buffers.values())
        if stale:
            flags.add("stale")
        t_lo = t - self.model.window.window_s
        for ev in self._events.values():
            flags.update(reason for et, reason in ev if t_lo <= et < t)
        stuck = [key for watch in self._stuck.values() for key in watch.stuck_between(t_lo, t)]
        if stuck:   # one flag, as the readers write it
            flags.add(stuck_flag(stuck))
        q = None
        if X is not None:
            raw = self.model.pipeline.predict_proba(X)[0]
            q = np.array([raw[i] if i >= 0 else 0.0 for i in self._pipe_cols])
        decided, p = self._filter.update(q)
        terrain = None if decided is None else self.model.classes[decided]
        conf = 0.0 if decided is None else float(p[decided])
        trusted = terrain if conf >= self.config.min_confidence else None
        if terrain is not None and trusted is None:
            flags.add("low_confidence")
        traction, braking, steady = self.targets.target_for(trusted, conf, stale)
        return Decision(float(t), terrain, conf, p, float(traction), float(braking),
                        float(steady), float(age), "|".join(sorted(flags)))

