"""Review of the service's input side at its bounds: when a decision is due, what the
intake counts and flags (hand mutants of intake.py, clocks.py and service.py)."""

from __future__ import annotations

import numpy as np

from terrain.run import IMU_CHANNELS, WHEEL_CHANNELS
from terrain.serving.buffers import RingBuffer
from terrain.serving.clocks import (AHEAD, DUPLICATE, DUPLICATE_TOL_S, TIME_RULE, HeldRun,
                                    first_long_step, in_a_gap, restart_shift,
                                    steps_ahead)
from terrain.serving.config import StreamConfig
from terrain.serving.intake import DecisionClock, StreamIntake
from terrain.serving.rules import DEFAULT_RULES
from test_intake import _chunk, _intake
from test_service import _two_stream_service


def _live(ti):
    live = 0.01 * np.sin(7.0 * ti)
    return {c: live for c in IMU_CHANNELS}, {"vel_l": 0.25, "vel_r": 0.25 + live,
                                             "cur_l": 1.0 + live, "cur_r": 1.0 - live}


def test_a_decision_comes_with_the_push_that_brings_every_stream_to_its_time():
    """A decision at ``t`` is due once every stream has reached ``t``: the wheel sample
    stamped exactly ``t`` (the IMU's came just before) returns it, not the next push."""
    svc = _two_stream_service(0.5)
    returned = {}
    for ti in np.arange(0, 48) * 0.125:                # binary-exact stamps, 8 Hz
        imu, wheels = _live(ti)
        for stream, values in (("imu", imu), ("wheels", wheels)):
            for d in svc.push(stream, ti, values):
                returned[d.t_s] = (stream, float(ti))
    assert sorted(returned) == [2.0, 2.5, 3.0, 3.5, 4.0, 4.5, 5.0, 5.5]
    assert all(returned[t] == ("wheels", t) for t in returned)


def test_a_decision_waiting_for_a_silent_stream_comes_with_the_push_stale_s_past_it():
    """With the IMU silent after 3 s, the decision at ``t`` is due once the wheels' newest
    push began ``stale_s`` (1 s) past it: with the wheel sample stamped ``t + 1``."""
    svc = _two_stream_service(0.5)
    returned = {}
    for ti in np.arange(0, 64) * 0.125:
        imu, wheels = _live(ti)
        if ti <= 3.0:
            for d in svc.push("imu", ti, imu):
                returned[d.t_s] = ("imu", float(ti))
        for d in svc.push("wheels", ti, wheels):
            returned[d.t_s] = ("wheels", float(ti))
    late = sorted(t for t in returned if t > 3.0)
    assert late == [3.5, 4.0, 4.5, 5.0, 5.5, 6.0, 6.5]
    assert all(returned[t] == ("wheels", t + 1.0) for t in late)


def test_the_first_decision_beside_a_silent_stream_comes_with_the_push_stale_s_past_it():
    """The IMU never sends: the first window (the wheels' first sample plus 2 s) is placed
    once the wheels' newest push began ``stale_s`` past it, with the sample stamped 3 s."""
    svc = _two_stream_service(0.5)
    returned = {}
    for ti in np.arange(0, 40) * 0.125:
        for d in svc.push("wheels", ti, _live(ti)[1]):
            returned[d.t_s] = float(ti)
    assert sorted(returned) == [2.0, 2.5, 3.0, 3.5]
    assert all(returned[t] == t + 1.0 for t in returned)


def test_a_late_sample_before_an_earlier_refusal_flags_the_windows_that_hold_it():
    """Two late samples of a reordering link, the second before the first: each flags the
    windows that hold it (the second was merged into the span of the first, which starts
    after it, so a window holding only the second was clean)."""
    intake, _ = _intake()
    t, v = _chunk(0.0, 30)                             # 0.0 .. 2.9 s
    intake.ingest("wheels", t, v)
    intake.ingest("wheels", np.array([2.55]), v[:1] + 0.1)
    intake.ingest("wheels", np.array([2.15]), v[:1] + 0.2)
    assert intake.refused == {("wheels", TIME_RULE): 2}

    def flagged(t_end):                                # the service's rule, window 2 s
        return any(first < t_end and last >= t_end - 2.0
                   for first, last, _ in intake.events["wheels"])
    assert flagged(2.5) and flagged(2.6) and not flagged(2.1)


def test_a_sample_repeated_inside_a_chunk_after_the_newest_is_a_duplicate():
    """A chunk that starts after the stream's newest sample but holds one sample twice (the
    same stamp and values): the repeat is a duplicate, not a late sample (flagged
    ``time_not_increasing``)."""
    intake, _ = _intake()
    t, v = _chunk(0.0, 10)
    intake.ingest("wheels", t, v)
    t2, v2 = _chunk(1.0, 5)
    intake.ingest("wheels", np.insert(t2, 3, t2[2]), np.insert(v2, 3, v2[2], axis=0))
    assert intake.refused == {("wheels", DUPLICATE): 1}
    assert len(intake.buffers["wheels"]) == 15 and not intake.events["wheels"]


def test_a_late_run_restarts_the_clock_once_it_spans_exactly_clock_restart_s():
    """A looped log (binary-exact 0.125 s steps): held late samples spanning 4.875 s are no
    clock yet; the one that makes them span ``clock_restart_s`` (5 s) restarts it."""
    intake, _ = _intake(buffer_samples=128)
    t, v = _chunk(0.0, 80, step=0.125)                 # 0 .. 9.875 s
    intake.ingest("wheels", t, v + 0.01 * np.arange(80)[:, None])
    intake.ingest("wheels", t[:40], v[:40])            # the log again from 0: 0 .. 4.875 s
    assert intake.restarts == 0 and intake.refused == {("wheels", TIME_RULE): 40}
    intake.ingest("wheels", t[40:41], v[40:41])        # 5.0 s
    assert intake.restarts == 1 and intake.refused == {}
    assert intake.buffers["wheels"].first_t == 0.0 and intake.buffers["wheels"].last_t == 5.0


def test_a_sample_at_the_newest_held_stamp_ahead_is_late_and_keeps_the_hold():
    """The wheels' clock steps ~98 s ahead of the IMU's and is held; a sample at the newest
    held stamp with other values (a reordering link, no re-send) is refused as late
    (``time_not_increasing``); it dropped the held run as a stray stamp ahead."""
    streams = {"imu": IMU_CHANNELS, "wheels": WHEEL_CHANNELS}
    intake = StreamIntake(streams, StreamConfig(streams=streams, buffer_samples=64),
                          DEFAULT_RULES, DecisionClock(window_s=2.0, rate_hz=10.0))
    t, w = _chunk(0.0, 20)
    imu = np.column_stack([np.zeros((20, 5)), np.full(20, 9.81)])
    intake.ingest("imu", t, imu)
    intake.ingest("wheels", t, w)
    intake.ingest("wheels", np.array([100.0, 100.1]), w[:2])
    assert intake.clocks["wheels"].held() == {AHEAD: 2}
    intake.ingest("wheels", np.array([100.1]), w[:1] + 0.3)
    assert intake.refused == {("wheels", TIME_RULE): 1}
    assert intake.clocks["wheels"].held() == {AHEAD: 2}


def test_the_decision_clock_starts_again_only_more_than_max_backlog_s_ahead():
    clock = DecisionClock(window_s=2.0, rate_hz=10.0)
    clock.next_t = 70.0
    clock.rewind(newest_s=10.0, max_backlog_s=60.0)   # exactly 60 s ahead: kept
    assert clock.next_t == 70.0
    clock.rewind(newest_s=9.0, max_backlog_s=60.0)     # 61 s ahead: again
    assert clock.next_t is None


def test_clock_rules_at_the_bounds_their_docstrings_draw():
    # a shift of exactly gap_factor steps is within a gap of the running clock: none
    assert restart_shift(8.75, 0.0, [10.0], [0.5], 3.0) == 0.0
    assert restart_shift(8.5, 0.0, [10.0], [0.5], 3.0) == 1.75
    # a hole of exactly max_backlog_s is one a backlog fills
    assert in_a_gap(np.array([0.0, 60.0, 60.5]), 1.0, 2.0, 60.0, [], 5.0)
    assert not in_a_gap(np.array([0.0, 60.5, 61.0]), 1.0, 2.0, 60.0, [], 5.0)
    # the sample after the hole on another stream's clock: that stream at it less step_s
    assert in_a_gap(np.array([0.0, 10.0]), 1.0, 2.0, 60.0, [5.0], 5.0)
    assert not in_a_gap(np.array([0.0, 10.0]), 1.0, 2.0, 60.0, [4.5], 5.0)
    # a stream's first sample exactly first_step_s from the others is on their clock
    assert not steps_ahead(65.0, -np.inf, [5.0], 5.0, 60.0)
    assert steps_ahead(65.5, -np.inf, [5.0], 5.0, 60.0)
    # a step of exactly max_step_s is an ordinary one
    assert first_long_step(np.array([0.0, 1.0, 3.0]), None, 1.0) == 2
    assert first_long_step(np.array([0.0, 1.0, 3.0]), -0.5, 1.0) == 2


def test_a_held_sample_exactly_the_stamp_tolerance_before_is_the_same_stamp():
    held = HeldRun(4)
    v = np.array([0.25, 8.0])
    held.begin(0.5, 0.0, {})
    held.append(0.5, v)
    assert held.repeats(0.5 + DUPLICATE_TOL_S, v)     # (0.5 + 1e-6) - 1e-6 == 0.5
    assert not held.repeats(0.5 + 2 * DUPLICATE_TOL_S, v)


def test_a_sample_into_a_buffer_with_room_pushes_nothing_out():
    buf = RingBuffer(1, 4)
    buf.append(np.array([0.0, 1.0, 2.0]), np.zeros((3, 1)))
    assert buf.evicted(np.array([3.0]), -np.inf) == 0
    buf.append(np.array([3.0]), np.zeros((1, 1)))
    assert buf.evicted(np.array([4.0]), -np.inf) == 1
    assert buf.evicted(np.array([4.0]), 0.5) == 0      # the oldest is no longer needed
    assert buf.evicted(np.array([4.0]), 0.0) == 1      # one at the look-back is needed
    np.testing.assert_array_equal(buf.evicted_times(np.array([4.0, 5.0]), 1.0), [1.0])
    # a window's samples, with the one just before its look-back (to interpolate from)
    np.testing.assert_array_equal(buf.since(1.5)[0], [1.0, 2.0, 3.0])
    assert buf.first_at_or_after(2.0) == 2.0 and buf.first_at_or_after(3.5) == np.inf
    steps = RingBuffer(1, 8)
    steps.append(np.array([0.0, 2.0, 3.0, 4.0, 8.0]), np.zeros((5, 1)))
    # up to the first sample at or past 4 s, that one included: steps 2, 1, 1
    assert steps.median_step(through_s=4.0) == 1.0


def test_a_step_ahead_shorter_than_clock_restart_s_is_a_lag_not_held():
    """The wheels 2.1 s ahead of the IMU (over ``stale_s``, under ``clock_restart_s``): a
    lag the config tolerates, taken, not held as a clock stepped ahead."""
    streams = {"imu": IMU_CHANNELS, "wheels": WHEEL_CHANNELS}
    intake = StreamIntake(streams, StreamConfig(streams=streams, buffer_samples=64),
                          DEFAULT_RULES, DecisionClock(window_s=2.0, rate_hz=10.0))
    t, w = _chunk(0.0, 20)
    intake.ingest("imu", t, np.column_stack([np.zeros((20, 5)), np.full(20, 9.81)]))
    intake.ingest("wheels", t, w)
    intake.ingest("wheels", np.array([4.0]), w[:1])
    assert intake.clocks["wheels"].held() == {} and intake.buffers["wheels"].last_t == 4.0
