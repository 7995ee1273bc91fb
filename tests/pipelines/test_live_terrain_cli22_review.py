"""Boundaries of :class:`pipelines.live_terrain.LiveClassifier`'s decision look-up: a
decision is available from the loop time it was emitted at (inclusive), the history keeps
the last :data:`MAX_DECISIONS` (cli22 review)."""

from __future__ import annotations

from collections import deque

import numpy as np

from pipelines.live_terrain import MAX_DECISIONS, LiveClassifier


def _live(times, label="ICE"):
    """A LiveClassifier holding decisions emitted at ``times`` (no model: the look-up only)."""
    live = object.__new__(LiveClassifier)
    live._decisions = deque(maxlen=MAX_DECISIONS)
    for t in times:
        live._decisions.append((float(t), label, 0.9))
    return live


def test_a_decision_is_available_from_its_own_time_not_one_step_before():
    t0 = 1.7e9 + 0.5                           # an epoch clock: the same rule
    live = _live([t0])
    assert live(t0) == ("ICE", 0.9, t0)
    assert live(np.nextafter(t0, np.inf)) == ("ICE", 0.9, t0)
    assert live(t0 - 0.02) == (None, 0.0)      # one 50 Hz control step before it


def test_the_latest_decision_wins_at_a_shared_time():
    live = _live([1.0])
    live._decisions.append((1.0, "SNOW", 0.7))
    assert live(1.0) == ("SNOW", 0.7, 1.0)


def test_a_full_history_evicts_the_oldest_decision_only():
    times = 0.5 * np.arange(1, MAX_DECISIONS + 2)       # one more than it keeps
    live = _live(times)
    assert len(live._decisions) == MAX_DECISIONS
    assert live(times[0]) == (None, 0.0)                 # evicted: before the oldest kept
    assert live(times[1]) == ("ICE", 0.9, times[1])       # the oldest kept
    assert live(times[-1] + 100) == ("ICE", 0.9, times[-1])
