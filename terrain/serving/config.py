"""Settings of the streaming service: :class:`StreamConfig`, the known streams, the hop check.

:class:`StreamConfig` is read by the service (:mod:`terrain.serving.service`: decisions) and
by its intake (:mod:`terrain.serving.intake`: buffers and clocks); it lives here so that
neither imports the other for it.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from types import MappingProxyType
from typing import Mapping

import numpy as np

from terrain.errors import (ConfigError, config_integer, config_numbers, config_positive,
                            config_probability, duplicated)
from terrain.io.align import check_gap_factor
from terrain.run import IMU_CHANNELS, WHEEL_CHANNELS
from terrain.serving.smoothing import SmoothingConfig

#: Stream name -> channels, as the readers name them (``terrain.io.measured``).
KNOWN_STREAMS: Mapping[str, tuple[str, ...]] = MappingProxyType(
    {"imu": IMU_CHANNELS, "wheels": WHEEL_CHANNELS})
#: Largest ``StreamConfig.buffer_samples``: 10 000 s at 100 Hz, ~110 MB per 6-channel
#: stream (the buffer stores every sample twice); 10**9 asked NumPy for 60 GB at the first
#: buffer
MAX_BUFFER_SAMPLES = 1_000_000


@dataclass(frozen=True)
class StreamConfig:
    """Settings of the streaming service.

    Parameters
    ----------
    hop_s : float
        Time between decisions, s (finite, > 0).
    stale_s : float
        A stream whose newest sample is older than the decision time by more than this is
        stale, s (> 0). A decision waits for a lagging stream until the newest push of
        another began this far past it (a chunk's samples arrive together: a chunk longer
        than ``stale_s`` makes no decision early; :mod:`terrain.serving.service`).
    min_confidence : float
        Smoothed probability below which the fallback target is used, in [0, 1].
    buffer_samples : int
        Capacity of each stream's ring buffer, samples (must hold ``window_s`` of the
        fastest stream; 4096 is 40 s at 100 Hz).
    gap_factor : float
        A step longer than this many median steps is a gap (as in the readers).
    streams : Mapping[str, tuple of str]
        Stream name -> its channels (kept as a read-only copy, the channels as tuples: a
        dict changed after the checks does not change the config).
    clock_offsets_s : Mapping[str, float]
        Per-stream offset added to its timestamps to put them on the service clock, s (kept
        as a read-only copy).
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
        A ``hop_s``, ``stale_s``, ``max_backlog_s`` or ``clock_restart_s`` that is not a
        finite number > 0, a
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
        # an infinite stale_s waits for ever for a silent stream (no decision at all); an
        # infinite hop was refused only by the service built on it (check_hop)
        for name in ("hop_s", "stale_s", "max_backlog_s", "clock_restart_s"):
            if not 0 < getattr(self, name) < np.inf:
                raise ConfigError(f"{name} must be a finite number of seconds > 0, got "
                                  f"{getattr(self, name)}")
        config_probability("StreamConfig", min_confidence=self.min_confidence)
        config_integer("buffer_samples", self.buffer_samples, 2, MAX_BUFFER_SAMPLES)
        check_gap_factor("StreamConfig", self.gap_factor)
        unknown = [s for s in self.clock_offsets_s if s not in self.streams]
        bad = {s: o for s, o in self.clock_offsets_s.items() if not np.isfinite(o)}
        if unknown or bad:
            raise ConfigError(f"clock_offsets_s must be finite offsets of configured streams "
                              f"{list(self.streams)}; got unknown stream(s) {unknown}, "
                              f"non-finite {bad}")
        # read-only copies of what was checked: the caller's dicts changed afterwards (a
        # channel named twice, a NaN offset) changed this frozen config unchecked
        object.__setattr__(self, "streams", MappingProxyType(
            {s: tuple(ch) for s, ch in self.streams.items()}))
        object.__setattr__(self, "clock_offsets_s", MappingProxyType(dict(self.clock_offsets_s)))

    def __reduce__(self):
        """Copies and pickles rebuild the config from plain dicts (a read-only mapping proxy
        cannot be pickled: ``copy.deepcopy`` of the default config, and of every service,
        raised TypeError)."""
        return type(self), tuple(dict(v) if isinstance(v, MappingProxyType) else v
                                 for v in (getattr(self, f.name) for f in fields(self)))


def _check_streams(streams) -> None:
    """Refuse a ``StreamConfig.streams`` that is not stream name -> distinct channel names
    (a channel named twice, in one stream or two, would be read from one place only)."""
    if not isinstance(streams, Mapping) or not streams:
        raise ConfigError("StreamConfig.streams must be a non-empty mapping of stream name -> "
                          f"channel names, got {type(streams).__name__} {streams!r:.60}")
    names = []
    for stream, channels in streams.items():
        try:   # a number or None is not iterable: Python's own TypeError before
            given = None if isinstance(channels, (str, bytes)) else tuple(channels)
        except TypeError:
            given = None
        if not isinstance(stream, str) or not given or not all(
                isinstance(c, str) for c in given):
            raise ConfigError("StreamConfig.streams must map stream names (text) to "
                              f"non-empty sequences of channel names, got {stream!r}: "
                              f"{channels!r:.60}")
        names.extend(given)
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
        ``hop_s`` or ``rate_hz`` not a real number (text, None, a boolean), ``rate_hz`` not
        finite and > 0, or ``hop_s`` not finite or below ``1 / rate_hz``.
    """
    # before the division: 0 Hz raised ZeroDivisionError, text or None Python's own error,
    # and a negative rate gave a negative period that every hop passed
    config_numbers("check_hop", hop_s=hop_s)
    config_positive("check_hop", rate_hz=rate_hz)
    period = 1.0 / float(rate_hz)
    hop = float(hop_s)
    if not (np.isfinite(hop) and hop >= period):
        raise ConfigError(f"hop_s {hop:g} s is shorter than one period of the model's "
                          f"{float(rate_hz):g} Hz clock ({period:g} s) or not finite; "
                          "decisions that often would decide on no new sample")
    return hop
